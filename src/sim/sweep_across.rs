//! run_sweep on a cluster node: the variants go to every node's sweepers through the cluster's
//! sweep queue (`cluster::sweeps`) instead of this node's threads. Their results come back by
//! variant index — the first for each counts, a later one (an item run again after a node
//! died) is unwanted — and are decided as a sweep run on one node decides them
//! (`sweep::conclude`), so the reply and the read logged on the swept simulation are a single
//! node's, bit for bit.

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::cluster::sweeps::{Heard, Verdict, WorkItem};
use crate::outputs::Swept;
use crate::sim::sweep::{Control, Observe, Ran, VariantFork};
use crate::sim::sweep_worker::NodeSweeps;
use crate::sim::timeline::ForkSource;
use crate::sim::{Registry, Slot};
use crate::value::Refusal;

/// How often the sweeping node looks at its request's cancellation while it waits.
const POLL: Duration = Duration::from_millis(100);

/// Progress messages a whole sweep sends, about (as many as a request's progress notifications).
const PROGRESS_MESSAGES: u64 = 100;

/// How often the sweeping node checks, while it waits, that it still holds the swept simulation.
const LEASE_CHECK: Duration = Duration::from_secs(1);

/// How long a refused kept sweep waits for live nodes to destroy the forks they kept.
const GONE_WAIT: Duration = Duration::from_secs(3);

/// What every variant of a sweep shares, as the nodes get it.
pub(crate) struct Across {
    /// Each variant's calls as the client sent them.
    pub sent: Vec<Value>,
    /// Steps after the calls.
    pub steps: u64,
    /// What to report.
    pub observe: Observe,
    /// Keep the forks.
    pub keep: bool,
}

/// A kept variant's fork, on the node that ran it (which owns it).
pub(super) struct RemoteFork {
    id: String,
    sweep: String,
}

impl VariantFork for RemoteFork {
    fn fork_id(&self) -> String {
        self.id.clone()
    }

    fn discard_all(reg: &Registry, forks: Vec<RemoteFork>) {
        reg.discard_across(forks);
    }

    /// Already simulations of the nodes that ran them (published before they reported); the
    /// slots reserved here only kept --max-sims honest meanwhile. The sweep's verdict names
    /// them before the reply does — unless its workers wrote first that they gave it up (this
    /// node's lease lapsed meanwhile), and then the sweep is refused: those forks are going.
    fn keep_all(reg: &Registry, swept: Swept, forks: Vec<RemoteFork>, slots: Vec<Slot<'_>>) -> Result<Swept, Refusal> {
        drop(slots);
        let (Some(nodes), Some(first)) = (reg.sweepers(), forks.first()) else { return Ok(swept) };
        let kept: Vec<String> = forks.iter().map(|f| f.id.clone()).collect();
        match nodes.queue.decide(&first.sweep, &Verdict { kept: kept.clone(), abandoned: false }) {
            Ok(v) if v.kept == kept && !v.abandoned => Ok(swept),
            Ok(_) => Err("the sweep's variants were given up by the nodes that ran them (this node stopped answering past its lease); nothing was kept: call again".to_string()),
            Err(why) => {
                RemoteFork::discard_all(reg, forks);
                Err(format!("the sweep's kept variants could not be recorded ({why}); nothing was kept"))
            }
        }
    }
}


impl Registry {
    /// Runs a sweep's variants on the cluster's sweepers (this node's among them, forking from
    /// `source` itself) and collects their outcomes by index; `controls` are the request's,
    /// one per variant. A cancelled request (or a shutdown) stops every variant still running.
    pub(super) fn sweep_across(&self, nodes: &NodeSweeps, sweep: &str, source: ForkSource, across: Across, mut controls: Vec<Control>) -> Vec<Ran<RemoteFork>> {
        let Across { sent, steps, observe, keep } = across;
        let n = sent.len();
        let sweep = sweep.to_string();
        let (from, token) = nodes.queue.signature();
        let (parent, at) = (source.parent_id().to_string(), source.at());
        let report_every = (n as u64).saturating_mul(steps) / PROGRESS_MESSAGES;
        let items: Vec<WorkItem> = sent
            .into_iter()
            .enumerate()
            .map(|(index, calls)| WorkItem {
                sweep_id: sweep.clone(),
                parent_id: parent.clone(),
                at,
                index,
                calls,
                steps,
                observe: observe.clone(),
                keep,
                report_every: report_every.max(1),
                engine: crate::engine::ENGINE_BUILD.to_string(),
                from: from.clone(),
                token: token.clone(),
            })
            .collect();
        nodes.lend(&parent, at, &sweep, Arc::new(source));
        let started = Instant::now();
        let mut call = match nodes.queue.begin(&sweep) {
            Ok(call) => call,
            Err(why) => {
                nodes.over_here(&sweep);
                return not_sent(n, &why);
            }
        };
        if let Err(why) = call.send(&items) {
            call.end();
            nodes.over_here(&sweep);
            return not_sent(n, &why);
        }
        let mut done: Vec<Option<Ran<RemoteFork>>> = (0..n).map(|_| None).collect();
        // The attempt whose result counts, per variant: its repeats are accepted again.
        let mut counted: Vec<Option<String>> = vec![None; n];
        let (mut left, mut seen, mut looked, mut lease_checked) = (n, vec![0u64; n], Instant::now(), Instant::now());
        let mut going = true;
        while left > 0 && going {
            match call.next(POLL) {
                Some(Heard::Progress(i, taken)) if i < n && taken > seen[i] => {
                    seen[i] = taken;
                    going = controls[i](taken);
                }
                Some(Heard::Report(report, reply)) if report.index < n => {
                    let i = report.index;
                    match &counted[i] {
                        None => {
                            call.answer(reply, true);
                            left -= 1;
                            counted[i] = Some(report.attempt.clone());
                            let fork = report.fork.map(|id| RemoteFork { id, sweep: sweep.clone() });
                            done[i] = Some((fork, report.outcome));
                        }
                        Some(attempt) => call.answer(reply, *attempt == report.attempt),
                    }
                }
                _ => {}
            }
            if going && looked.elapsed() >= POLL {
                looked = Instant::now();
                going = controls[0](seen[0]);
                // A node that lost the swept simulation (a pause past its lease) stops waiting:
                // its workers give its items up, and the sweep is refused when it concludes.
                if going && lease_checked.elapsed() >= LEASE_CHECK {
                    lease_checked = Instant::now();
                    going = self.cluster.as_ref().is_none_or(|c| c.owns(&parent));
                }
            }
        }
        call.end();
        nodes.over_here(&sweep);
        tracing::debug!("sweep {sweep} of {parent}: {n} variants across the cluster in {:?}", started.elapsed());
        let cancelled = |i: usize| (None, Err(format!("variants[{i}]: the sweep was cancelled")));
        done.into_iter().enumerate().map(|(i, d)| d.unwrap_or_else(|| cancelled(i))).collect()
    }

    /// Destroys kept forks on whichever nodes hold them (a sweep refused or cancelled after
    /// they were kept): every node is told, and the sweep waits (up to [`GONE_WAIT`]) until the
    /// cluster lists none of them, as a single node's refused sweep leaves none behind. A fork
    /// whose node died meanwhile is taken over once its lease lapses, then destroyed — on a
    /// thread of its own (for at most three lease times): the swept simulation is locked here,
    /// and a takeover is never waited for under a simulation's lock.
    fn discard_across(&self, forks: Vec<RemoteFork>) {
        let (Some(nodes), Some(cluster), Some(first)) = (self.sweepers(), self.cluster.clone(), forks.first()) else { return };
        // The verdict first: a worker that never heard its answer destroys its fork by it.
        if let Err(why) = nodes.queue.decide(&first.sweep, &Verdict::default()) {
            tracing::warn!("sweep {}'s verdict could not be written: {why}", first.sweep);
        }
        let mut left: Vec<String> = forks.iter().map(|f| f.id.clone()).collect();
        nodes.queue.tell_over(&first.sweep, left.clone());
        let waiting = Instant::now();
        loop {
            left.retain(|id| !matches!(cluster.index_get(id), Ok(None)));
            if left.is_empty() || waiting.elapsed() > GONE_WAIT {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        if left.is_empty() {
            return;
        }
        let reg = nodes.reg.clone();
        std::thread::spawn(move || {
            let deadline = Instant::now() + cluster.config().lease * 3;
            for id in left {
                while !crate::shutdown::requested() {
                    let Some(reg) = reg.upgrade() else { return };
                    if matches!(cluster.index_get(&id), Ok(None)) || reg.destroy(&id).is_ok() {
                        break;
                    }
                    if Instant::now() > deadline {
                        tracing::warn!("kept sweep variant {id} could not be destroyed; destroy_simulation removes it");
                        break;
                    }
                    drop(reg);
                    std::thread::sleep(Duration::from_millis(200));
                }
            }
        });
    }
}

/// Every variant refused because the sweep could not be put on the cluster's queue.
fn not_sent(n: usize, why: &str) -> Vec<Ran<RemoteFork>> {
    (0..n).map(|i| (None, Err(format!("variants[{i}] could not be sent to the cluster's nodes: {why}")))).collect()
}
