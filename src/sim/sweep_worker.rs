//! A cluster node's sweepers: one thread per core, each pulling one sweep variant at a time
//! from the cluster's sweep queue (`cluster::sweeps`) and running it exactly as a sweep on one
//! node runs it (`Registry::fork_and_run`: fork at the sweep's seq, the calls as a batch, the
//! steps). The swept simulation's state at that seq comes from its log: the sweeping node lends
//! its own, other nodes materialize the simulation's subject into a temporary file — once per
//! (simulation, seq), shared by the node's sweepers, deleted once the sweeps that used it are
//! over. A kept fork is published as a simulation of the node that ran it; it stays only if the
//! sweep's verdict names it (the sweeping node accepted its result and kept it), and is
//! destroyed otherwise. A result with no answer is never given up while the sweeping node's
//! lease lives: the worker asks again (a repeat of an attempt is answered as the first was),
//! and follows the verdict once there is one.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, MutexGuard, OnceLock, Weak};
use std::time::{Duration, Instant};

use crate::cluster::sweeps::{Answer, Delivery, Over, Report, SweepQueue, Verdict, WorkItem};
use crate::outputs::SweptVariant;
use crate::sim::sweep::{discard, fork_arguments, Control, Planner, Ran};
use crate::sim::timeline::ForkSource;
use crate::sim::{remove_log_files, Registry, Sim};
use crate::value::Refusal;

/// A materialized state no sweep has used for this long is deleted (its sweeping node died
/// before saying the sweep was over).
const SOURCE_IDLE: Duration = Duration::from_secs(60);

/// How long a node remembers that a sweep is over (its items may still be delivered again).
const OVER_KEPT: Duration = Duration::from_secs(600);

/// How often a worker without an answer looks at the verdict and the sweeping node's lease,
/// and how often kept forks awaiting a verdict are looked at.
const UNANSWERED_PAUSE: Duration = Duration::from_millis(300);

/// A kept fork whose result was accepted, waiting for its sweep's verdict.
struct Pending {
    item: WorkItem,
    fork: String,
}

/// What a worker learned of its result.
enum Learned {
    /// Accepted (the first attempt for its variant, or a repeat of it): the verdict decides.
    Accepted,
    /// Another attempt's result counted.
    Unwanted,
    /// The sweep's verdict (written by the sweeping node, or "abandoned" once its lease was gone).
    Decided(Verdict),
    /// This node is shutting down.
    Stopped,
}

/// A swept state as this node's sweepers share it.
type Made = Arc<OnceLock<Result<Arc<ForkSource>, Refusal>>>;

/// One (simulation, seq) state on this node.
struct Source {
    made: Made,
    /// The temporary copy of the simulation's log it is read from (None: lent by the sweeping
    /// node, from the simulation itself).
    file: Option<PathBuf>,
    /// Sweepers using it now.
    users: usize,
    /// Sweeps that used it and are not over.
    sweeps: BTreeSet<String>,
    last_used: Instant,
}

/// This node's share of the cluster's sweeps: its end of the queue, how it decides a variant's
/// calls, the swept states it holds, and the sweeps it knows are over.
pub(crate) struct NodeSweeps {
    pub(super) queue: SweepQueue,
    plan: Planner,
    /// The registry the sweepers work for (weak: they stop when it is gone).
    pub(super) reg: Weak<Registry>,
    sources: Mutex<BTreeMap<(String, u64), Source>>,
    over: Mutex<BTreeMap<String, Instant>>,
    /// Kept forks whose results were accepted, until their sweeps' verdicts are known.
    pending: Mutex<Vec<Pending>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Registry {
    /// Starts this node's sweepers (a cluster node; nothing otherwise): as many threads as
    /// the machine has cores pull variants of any node's sweeps until shutdown. `plan` decides
    /// a variant's calls from the JSON a client sent.
    pub fn start_sweepers(self: &Arc<Self>, plan: Planner) -> anyhow::Result<()> {
        let Some(cluster) = &self.cluster else { return Ok(()) };
        let queue = SweepQueue::open(cluster).map_err(|e| anyhow::anyhow!("the cluster's sweep queue: {e}"))?;
        let reg = Arc::downgrade(self);
        let nodes = Arc::new(NodeSweeps { queue, plan, reg, sources: Mutex::default(), over: Mutex::default(), pending: Mutex::default() });
        if self.sweeps.set(nodes.clone()).is_err() {
            anyhow::bail!("this node's sweepers are already running");
        }
        let heard = nodes.clone();
        nodes.queue.on_over(move |sweep, over| heard.sweep_over(sweep, over)).map_err(anyhow::Error::msg)?;
        for k in 0..std::thread::available_parallelism().map_or(1, |n| n.get()) {
            let nodes = nodes.clone();
            std::thread::Builder::new().name(format!("sweeper-{k}")).spawn(move || nodes.pull())?;
        }
        let settler = nodes.clone();
        std::thread::Builder::new().name("sweep-verdicts".into()).spawn(move || settler.settle_pending())?;
        Ok(())
    }

    /// This node's sweepers, when it runs them (then its sweeps go across the cluster).
    pub(super) fn sweepers(&self) -> Option<Arc<NodeSweeps>> {
        self.sweeps.get().cloned()
    }

    /// `parent`'s state at `at` from its subject, materialized at `file` (removed on failure).
    fn materialized(&self, parent: &str, at: u64, file: &std::path::Path) -> Result<Arc<ForkSource>, Refusal> {
        let cluster = self.cluster.as_ref().ok_or("this server is not a cluster node")?;
        remove_log_files(file);
        let made = cluster
            .materialize(parent, file, self.config().sync)
            .and_then(|_| ForkSource::of_file(file, at))
            .map(Arc::new);
        if made.is_err() {
            remove_log_files(file);
        }
        made
    }
}

impl NodeSweeps {
    /// A sweeper's loop: one variant at a time, until shutdown (a variant pulled as it begins
    /// is given back at once).
    fn pull(self: &Arc<Self>) {
        while !crate::shutdown::requested() {
            match self.queue.next() {
                Ok(Some(d)) => match self.reg.upgrade() {
                    Some(reg) if !crate::shutdown::requested() => self.work_on(&reg, d),
                    _ => return d.release(),
                },
                Ok(None) => self.forget_idle(),
                Err(e) => {
                    tracing::warn!("a sweeper could not pull from the cluster: {e}");
                    std::thread::sleep(Duration::from_secs(1));
                }
            }
        }
    }

    /// Runs one delivered variant and reports it. An item of a sweep that is over (its
    /// verdict written, or its sweeping node's lease gone) is dropped; one stopped by this
    /// node's shutdown is given back.
    fn work_on(self: &Arc<Self>, reg: &Registry, mut d: Delivery<'_>) {
        let item = d.item().clone();
        if item.engine != crate::engine::ENGINE_BUILD {
            return d.decline();
        }
        d.heartbeat();
        if self.is_over(&item.sweep_id) || self.gone(&item) {
            return d.finish();
        }
        let ran = self.run(reg, &item);
        // Stopped by this node's shutdown (run again elsewhere) or by the sweep's end: no result.
        if ran.1.is_err() && (crate::shutdown::requested() || self.is_over(&item.sweep_id)) {
            discard(ran.0);
            return if crate::shutdown::requested() { d.release() } else { d.finish() };
        }
        tracing::info!(target: "physics_mcp::sweep", "variant {} of sweep {} ran on node {}", item.index, item.sweep_id, self.queue.node());
        let (fork, outcome) = settle(reg, item.keep, item.index, ran);
        let attempt = uuid::Uuid::new_v4().to_string();
        let report = Report { index: item.index, attempt, node: self.queue.node().to_string(), fork: fork.clone(), outcome };
        match (self.learn(&item, &report), fork) {
            (Learned::Stopped, _) => return d.release(),
            (Learned::Accepted, Some(fork)) => self.wait_for_verdict(item, fork),
            (Learned::Unwanted, Some(fork)) => destroy_fork(reg, &fork),
            (Learned::Decided(v), Some(fork)) if !v.kept.contains(&fork) => destroy_fork(reg, &fork),
            _ => {}
        }
        d.finish()
    }

    /// Whether `item`'s sweep is over: decided, or its sweeping node's lease is gone.
    fn gone(&self, item: &WorkItem) -> bool {
        matches!(self.queue.verdict(&item.sweep_id), Ok(Some(_))) || !self.queue.sweeping_node_alive(item)
    }

    /// Reports a run's result until the sweeping node answers — or, without an answer, until
    /// the sweep's verdict is there or the sweeping node's lease is gone (then this worker
    /// writes the verdict "abandoned", unless the sweeping node wrote one first). "Nobody
    /// listens" alone decides nothing: a node reconnecting to another NATS server looks so
    /// for a moment.
    fn learn(&self, item: &WorkItem, report: &Report) -> Learned {
        let sweep = &item.sweep_id;
        let mut packed = None;
        loop {
            if crate::shutdown::requested() {
                return Learned::Stopped;
            }
            if packed.is_none() {
                packed = self.queue.packed(report).inspect_err(|why| tracing::warn!("the result of variant {} of sweep {sweep} could not be sent yet: {why}", report.index)).ok();
            }
            match packed.as_deref().map(|p| self.queue.report(sweep, p)) {
                Some(Answer::Accepted) => return Learned::Accepted,
                Some(Answer::Unwanted) => return Learned::Unwanted,
                _ => {}
            }
            if let Ok(Some(v)) = self.queue.verdict(sweep) {
                return Learned::Decided(v);
            }
            if !self.queue.sweeping_node_alive(item) {
                if let Ok(v) = self.queue.decide(sweep, &Verdict { kept: Vec::new(), abandoned: true }) {
                    return Learned::Decided(v);
                }
            }
            std::thread::sleep(UNANSWERED_PAUSE);
        }
    }

    /// Keeps an accepted kept fork until its sweep's verdict says whether it stays.
    fn wait_for_verdict(&self, item: WorkItem, fork: String) {
        lock(&self.pending).push(Pending { item, fork });
    }

    /// The verdict thread: kept forks awaiting their sweeps' verdicts stay if named, and are
    /// destroyed otherwise; a sweep whose node's lease is gone before it decided is abandoned.
    fn settle_pending(self: &Arc<Self>) {
        while !crate::shutdown::requested() {
            std::thread::sleep(UNANSWERED_PAUSE);
            let Some(reg) = self.reg.upgrade() else { return };
            let sweeps: BTreeSet<String> = lock(&self.pending).iter().map(|p| p.item.sweep_id.clone()).collect();
            for sweep in sweeps {
                let Some(item) = lock(&self.pending).iter().find(|p| p.item.sweep_id == sweep).map(|p| p.item.clone()) else { continue };
                let verdict = match self.queue.verdict(&sweep) {
                    Ok(Some(v)) => v,
                    Ok(None) if !self.queue.sweeping_node_alive(&item) => match self.queue.decide(&sweep, &Verdict { kept: Vec::new(), abandoned: true }) {
                        Ok(v) => v,
                        Err(_) => continue,
                    },
                    _ => continue,
                };
                let settled: Vec<Pending> = {
                    let mut pending = lock(&self.pending);
                    let (mine, rest) = std::mem::take(&mut *pending).into_iter().partition(|p| p.item.sweep_id == sweep);
                    *pending = rest;
                    mine
                };
                for p in settled.into_iter().filter(|p| !verdict.kept.contains(&p.fork)) {
                    destroy_fork(&reg, &p.fork);
                }
            }
        }
    }

    /// Writes the verdict of a sweep this node ran, if none is there (a kept sweep wrote its
    /// own): workers still without an answer stop waiting, and destroy their forks.
    pub(super) fn decided(&self, sweep: &str) {
        if let Err(why) = self.queue.decide(sweep, &Verdict::default()) {
            tracing::warn!("sweep {sweep}'s verdict could not be written: {why}");
        }
    }

    /// Forks the swept state and runs the variant on the fork.
    fn run(self: &Arc<Self>, reg: &Registry, item: &WorkItem) -> Ran<Sim> {
        let index = item.index;
        let ran = match self.source(reg, &item.parent_id, item.at, &item.sweep_id) {
            Err(why) => (None, Err(format!("variants[{index}] could not be forked: {why}"))),
            Ok(source) => match (self.plan)(reg.sandbox(), &item.parent_id, &item.calls) {
                Err(why) => (None, Err(format!("variants[{index}]: {why}"))),
                Ok(calls) => {
                    let fork_args = fork_arguments(&item.parent_id, item.at);
                    reg.fork_and_run(&source, &fork_args, (index, calls, self.control(item)), item.steps, &item.observe)
                }
            },
        };
        self.give_back(&item.parent_id, item.at);
        ran
    }

    /// A variant's step control: its steps reported about every `report_every`; false (stop)
    /// once the sweep is over or this node is shutting down.
    fn control(self: &Arc<Self>, item: &WorkItem) -> Control {
        let (nodes, sweep, index, every) = (self.clone(), item.sweep_id.clone(), item.index, item.report_every);
        let (mut total, mut mine, mut told) = (0u64, 0u64, 0u64);
        Box::new(move |now| {
            // Each step command counts from zero again; the total goes on.
            if now < mine {
                mine = 0;
            }
            total += now - mine;
            mine = now;
            if total - told >= every {
                told = total;
                nodes.queue.progress(&sweep, index, total);
            }
            !nodes.is_over(&sweep) && !crate::shutdown::requested()
        })
    }

    /// The state `parent` had at `at`, for sweep `sweep`: lent, already materialized here, or
    /// materialized now (by the first sweeper to ask; the others wait for it).
    fn source(&self, reg: &Registry, parent: &str, at: u64, sweep: &str) -> Result<Arc<ForkSource>, Refusal> {
        let (made, file) = {
            let mut sources = lock(&self.sources);
            let s = sources.entry((parent.to_string(), at)).or_insert_with(|| Source {
                made: Made::default(),
                // A name of its own: the file of an earlier copy may still be being deleted.
                file: Some(crate::log::sqlite::partial_path(&reg.path_for(&format!("{parent}.at{at}.{}", uuid::Uuid::new_v4().simple())))),
                users: 0,
                sweeps: BTreeSet::new(),
                last_used: Instant::now(),
            });
            s.users += 1;
            s.sweeps.insert(sweep.to_string());
            (s.made.clone(), s.file.clone())
        };
        made.get_or_init(|| match &file {
            Some(file) => reg.materialized(parent, at, file),
            None => Err("the sweeping node's state is gone".into()),
        })
        .clone()
    }

    /// Done with a state for one variant; deleted when nothing else needs it (or it failed).
    fn give_back(&self, parent: &str, at: u64) {
        let key = (parent.to_string(), at);
        let mut sources = lock(&self.sources);
        let Some(s) = sources.get_mut(&key) else { return };
        s.users -= 1;
        s.last_used = Instant::now();
        let failed = s.made.get().is_some_and(Result::is_err);
        if s.users == 0 && (failed || s.sweeps.is_empty()) {
            let file = sources.remove(&key).and_then(|s| s.file);
            drop(sources);
            file.iter().for_each(|f| remove_log_files(f));
        }
    }

    /// Lends the sweeping node's own state of `parent` at `at` to its sweepers for `sweep`.
    pub(super) fn lend(&self, parent: &str, at: u64, sweep: &str, source: Arc<ForkSource>) {
        let mut sources = lock(&self.sources);
        let s = sources.entry((parent.to_string(), at)).or_insert_with(|| Source {
            made: Arc::new(OnceLock::from(Ok(source))),
            file: None,
            users: 0,
            sweeps: BTreeSet::new(),
            last_used: Instant::now(),
        });
        s.sweeps.insert(sweep.to_string());
    }

    /// Whether this node knows `sweep` is over.
    fn is_over(&self, sweep: &str) -> bool {
        lock(&self.over).contains_key(sweep)
    }

    /// Marks `sweep` over here and lets go of the states only it used (the sweeping node calls
    /// this itself; every node hears it from `sweep_over` too). Returns their files.
    fn mark_over(&self, sweep: &str) -> Vec<PathBuf> {
        {
            let mut over = lock(&self.over);
            over.retain(|_, at| at.elapsed() < OVER_KEPT);
            over.insert(sweep.to_string(), Instant::now());
        }
        self.drop_sources(|s| {
            s.sweeps.remove(sweep);
            s.users == 0 && s.sweeps.is_empty()
        })
    }

    /// `mark_over` on the sweeping node, deleting the files at once.
    pub(super) fn over_here(&self, sweep: &str) {
        self.mark_over(sweep).iter().for_each(|f| remove_log_files(f));
    }

    /// A sweep is over (heard from the cluster, on its runtime: the file work and the
    /// destruction of discarded kept forks are done on a thread of their own).
    fn sweep_over(&self, sweep: String, over: Over) {
        let files = self.mark_over(&sweep);
        if files.is_empty() && over.discard.is_empty() {
            return;
        }
        let reg = self.reg.clone();
        std::thread::spawn(move || {
            files.iter().for_each(|f| remove_log_files(f));
            let Some(reg) = reg.upgrade() else { return };
            for id in over.discard.iter().filter(|id| reg.get_local(id).is_some()) {
                if let Err(why) = reg.destroy(id) {
                    tracing::warn!("discarded kept sweep variant {id} could not be destroyed: {why}");
                }
            }
        });
    }

    /// Deletes the states no sweeper has used for [`SOURCE_IDLE`].
    fn forget_idle(&self) {
        self.drop_sources(|s| s.users == 0 && s.last_used.elapsed() > SOURCE_IDLE)
            .iter()
            .for_each(|f| remove_log_files(f));
    }

    /// Removes the states `doomed` picks; returns their files (to delete outside the lock).
    fn drop_sources(&self, mut doomed: impl FnMut(&mut Source) -> bool) -> Vec<PathBuf> {
        let mut sources = lock(&self.sources);
        let keys: Vec<(String, u64)> = sources.iter_mut().filter_map(|(k, s)| doomed(s).then(|| k.clone())).collect();
        keys.into_iter().filter_map(|k| sources.remove(&k).and_then(|s| s.file)).collect()
    }
}

/// Destroys a kept fork the sweep did not keep.
fn destroy_fork(reg: &Registry, id: &str) {
    if reg.get_local(id).is_none() && !reg.cluster().is_some_and(|c| matches!(c.index_get(id), Ok(Some(_)))) {
        return; // gone already (the sweep's end told this node first)
    }
    if let Err(why) = reg.destroy(id) {
        tracing::warn!("a kept sweep variant the sweep did not keep, {id}, could not be destroyed: {why}");
    }
}

/// A variant's fork once it ran: with keep and a result, published as this node's simulation
/// (its id reported); otherwise deleted.
fn settle(reg: &Registry, keep: bool, index: usize, ran: Ran<Sim>) -> (Option<String>, Result<SweptVariant, Refusal>) {
    match ran {
        (Some(sim), Ok(v)) if keep => {
            let id = sim.id().to_string();
            match reg.publish_sim(sim) {
                Ok(sim) => {
                    reg.insert(&id, Arc::new(Mutex::new(sim)));
                    (Some(id), Ok(v))
                }
                Err(why) => (None, Err(format!("variants[{index}] could not be kept ({why})"))),
            }
        }
        (fork, outcome) => {
            discard(fork);
            (None, outcome)
        }
    }
}
