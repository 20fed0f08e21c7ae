//! `Sim` = one simulation's log + its world; `Registry` = the simulations of a data directory.
//!
//! Every tool call on a simulation goes through `Sim::change` (decide → check → apply →
//! commit → reply) or `Sim::read` (compute → buffer the event → reply). A refusal is logged
//! and changes nothing. On start, `Registry::open` locks the data directory and recovers every
//! simulation from its nearest snapshot on the head's chain plus the events after it, checking
//! every recorded state hash.

pub mod apply;
pub mod budget;
pub mod dynamics_reads;
pub mod geometry_reads;
pub mod cluster;
pub mod reads;
pub mod queue;
pub mod sampled_step;
pub mod save_load;
pub mod sweep;
pub mod sweep_across;
pub mod sweep_worker;
pub mod timeline;

use crate::log::EventLog;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use serde::Serialize;

use crate::command::{Command, NoBlobs};
use crate::log::fold::{self, Verify};
use crate::limits::Limits;
use crate::outputs::{DamagedSimulation, Message, Outcome, SimulationList, SimulationSummary};
use crate::sim::reads::ReadContext;
use crate::log::sqlite::{data_dir, Event, Kind, Log, StoreError, SyncMode};
pub(crate) use crate::log::sqlite::data_dir::remove_log_files;
use crate::value::{Args, Refusal};
use crate::files::Sandbox;
use crate::world::World;

/// A snapshot is taken once this much simulation work (steps × bodies) has been done since
/// the last one — about half a second for a 1000-body pile — so rebuilding any recent state
/// (undo, fork, restart) costs at most that much re-simulation, whatever the world's size…
pub const SNAPSHOT_EVERY_BODY_STEPS: u64 = 100_000;
/// …or after this many state-changing events since the last one (`snapshot_every_changes`).
pub const SNAPSHOT_EVERY_CHANGES: u32 = 64;

/// The state-changing events after which a snapshot is due in a world of `objects` objects:
/// `SNAPSHOT_EVERY_CHANGES`, or a quarter of the objects if that is more. A snapshot costs time
/// and disk in proportion to the world, so a big world takes one after proportionally more
/// changes: each change's share of the snapshot cost is the same at any size (adding the
/// 10,000th box costs what adding the 100th does), and rebuilding from the last snapshot folds
/// at most a quarter as many one-object changes as the snapshot restores objects.
pub fn snapshot_every_changes(objects: usize) -> u32 {
    SNAPSHOT_EVERY_CHANGES.max(u32::try_from(objects / 4).unwrap_or(u32::MAX))
}

/// Snapshots on a chain kept unconditionally, newest first.
pub const SNAPSHOTS_KEPT_RECENT: usize = 100;

/// Which of a chain's snapshots (seqs, newest first) to delete when the head is at `head`:
/// keep the newest `SNAPSHOTS_KEPT_RECENT`; older ones are bucketed by the doubling of their
/// age in events (`head - seq` in [2^k, 2^(k+1))) and only the newest of each bucket stays;
/// the oldest (the root's) always stays and claims its bucket. Ages in events are stable, so
/// thinning twice at the same head deletes nothing more.
pub fn snapshots_to_thin(newest_first: &[u64], head: u64) -> Vec<u64> {
    let bucket = |seq: u64| u64::BITS - head.saturating_sub(seq).max(1).leading_zeros();
    let Some(&oldest) = newest_first.last() else {
        return Vec::new();
    };
    let mut taken = std::collections::BTreeSet::from([bucket(oldest)]);
    let mut doomed = Vec::new();
    for (i, seq) in newest_first.iter().enumerate() {
        if i < SNAPSHOTS_KEPT_RECENT || *seq == oldest {
            continue;
        }
        if !taken.insert(bucket(*seq)) {
            doomed.push(*seq);
        }
    }
    doomed
}

/// The standard "simulation not found" sentence (docs/tools.md).
pub fn sim_not_found(id: &str) -> Refusal {
    format!("Simulation {id} not found")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_recent_snapshots_then_one_per_doubling() {
        let chain: Vec<u64> = (1..=5000u64).rev().collect(); // newest first
        let doomed = snapshots_to_thin(&chain, 5000);
        let kept: Vec<u64> = chain.iter().copied().filter(|s| !doomed.contains(s)).collect();
        assert!(kept.starts_with(&chain[..SNAPSHOTS_KEPT_RECENT]));
        assert_eq!(kept.last(), chain.last(), "the root's snapshot stays");
        let bound = SNAPSHOTS_KEPT_RECENT + (5000f64).log2().ceil() as usize;
        assert!(kept.len() <= bound, "{} kept, bound {bound}", kept.len());
        // Thinning what is already thin removes nothing more.
        assert!(snapshots_to_thin(&kept, 5000).is_empty());
    }
}

/// One simulation: its log and the world the log folds to.
pub struct Sim {
    pub(crate) world: World,
    pub(crate) log: Log,
    sync: SyncMode,
    /// The world's state hash, recomputed only when the world changes (reads and refusals
    /// record it without paying O(bodies) again).
    pub(crate) state_hash: String,
    /// Undone events that redo re-applies, the next one last (rebuilt from the log's move
    /// events on recovery; emptied by any new state-changing call).
    pub(crate) redo: Vec<u64>,
    pub(crate) work_since_snapshot: u64,
    pub(crate) changes_since_snapshot: u32,
    /// Set by destroy_simulation, under the lock, before the files are deleted: a request that
    /// took this simulation's handle earlier then finds it gone and writes nothing.
    destroyed: bool,
    /// Why the world can no longer be trusted (its log failed to fold again after a failed
    /// commit): every call is then refused with `Simulation {id} is damaged: {reason}`.
    damaged: Option<String>,
    /// Snapshot writes slower than [`stall_ms`] since the MCP layer last took them, as
    /// sentences for logging sessions (an operator wants to know the disk is slow).
    pub(crate) stalls: Vec<String>,
    /// Its place in a cluster (cluster mode): the ownership it is served under (checked by
    /// every call, `fenced`) and its index entry's writes.
    pub(crate) cluster: Option<cluster::Seat>,
}

/// A snapshot (serialise, hash, commit) slower than this many milliseconds is a stall worth a
/// `warning` to logging sessions.
pub const STALL_MS: u64 = 1000;

/// The stall threshold: [`STALL_MS`], or `PHYSICS_MCP_STALL_MS` (tests set 0 to see one).
pub fn stall_ms() -> u64 {
    static MS: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *MS.get_or_init(|| std::env::var("PHYSICS_MCP_STALL_MS").ok().and_then(|v| v.parse().ok()).unwrap_or(STALL_MS))
}

/// The standard "simulation damaged" sentence: its log could not be folded back, so nothing
/// of it is served.
pub fn sim_damaged(id: &str, reason: &str) -> Refusal {
    format!("Simulation {id} is damaged: {reason}")
}

impl Sim {
    /// Creates a simulation from a root command, committing the root event and a snapshot
    /// under a partial name first, so a kill before the root commits leaves nothing that a
    /// restart would serve or call damaged.
    pub fn create(
        path: &Path,
        tool: &str,
        root: Command,
        args: &Args,
        sync: SyncMode,
    ) -> Result<(Sim, Outcome), String> {
        let (sim, result) = Sim::create_unpublished(&crate::log::sqlite::partial_path(path), tool, root, args, sync)?;
        crate::crash_point!("create_before_publish");
        Ok((sim.publish(path)?, result))
    }

    /// Gives a simulation built at a partial path (create, load) its final name, once
    /// everything it needs has committed; on failure the partial files are removed.
    pub(crate) fn publish(self, final_path: &Path) -> Result<Sim, String> {
        let Sim { world, log, sync, state_hash, redo, work_since_snapshot, changes_since_snapshot, .. } = self;
        let partial = log.path().to_path_buf();
        let published = log.publish(final_path, sync).and_then(|()| Log::open(final_path, sync));
        match published {
            Ok(log) => Ok(Sim {
                world,
                log,
                sync,
                state_hash,
                redo,
                work_since_snapshot,
                changes_since_snapshot,
                destroyed: false,
                damaged: None,
                stalls: Vec::new(),
                cluster: None,
            }),
            Err(e) => {
                remove_log_files(&partial);
                Err(format!("The simulation could not be recorded: {e}"))
            }
        }
    }

    /// `create` at `path` itself, which stays a partial log until `publish`.
    pub(crate) fn create_unpublished(
        path: &Path,
        tool: &str,
        root: Command,
        args: &Args,
        sync: SyncMode,
    ) -> Result<(Sim, Outcome), String> {
        let (world, result) = World::create(&root).ok_or("not a root command")?;
        let mut log = Log::create(path, world.simulation_id(), sync).map_err(|e| e.to_string())?;
        let result = result.land(log.next_seq(), world.current_time());
        let args_json = log.store_arguments(serde_json::to_string(args).unwrap_or_default());
        let result_json = result.to_value().to_string();
        let snapshot = world.snapshot();
        let snap_hash = crate::digest::content_hash(&snapshot);
        let event = Event::root(log.next_seq(), None, tool, args_json, &root, result_json, &world.state_hash())?;
        let state_hash = event.state_hash.clone();
        let head = event.seq;
        if let Err(e) = log.append(std::slice::from_ref(&event), head, &[(head, &snapshot, &snap_hash)]) {
            drop(log);
            remove_log_files(path);
            return Err(format!("The simulation could not be recorded: {e}"));
        }
        Ok((
            Sim {
                world,
                log,
                sync,
                state_hash,
                redo: Vec::new(),
                work_since_snapshot: 0,
                changes_since_snapshot: 0,
                destroyed: false,
                damaged: None,
                stalls: Vec::new(),
                cluster: None,
            },
            result,
        ))
    }

    /// Reopens a simulation from its log: nearest snapshot on the head's chain, then the
    /// chain's later events, verifying every snapshot and state hash on the way.
    pub fn recover(path: &Path, sync: SyncMode) -> Result<Sim, StoreError> {
        let log = Log::open(path, sync)?;
        let id = log.simulation_id()?;
        if let Some(expected) = log.head_by_events()? {
            if expected != log.head_seq() {
                return Err(StoreError::Corrupt(format!(
                    "the stored head is event {} but the last change or move left event {expected}",
                    log.head_seq()
                )));
            }
        }
        let rebuilt = rebuild_at(&log, &id, log.head_seq(), true)?;
        let redo = redo_stack(&log)?;
        let state_hash = rebuilt.world.state_hash();
        Ok(Sim {
            world: rebuilt.world,
            log,
            sync,
            state_hash,
            redo,
            work_since_snapshot: rebuilt.work_since_snapshot,
            changes_since_snapshot: rebuilt.changes_since_snapshot,
            destroyed: false,
            damaged: None,
            stalls: Vec::new(),
            cluster: None,
        })
    }

    /// Refuses every call on a destroyed simulation with the standard sentence, before
    /// anything is computed or logged.
    pub(crate) fn ensure_live(&self) -> Result<(), Refusal> {
        self.fenced()?;
        if self.destroyed {
            Err(sim_not_found(self.id()))
        } else if let Some(why) = &self.damaged {
            Err(sim_damaged(self.id(), why))
        } else if self.log.is_stale() {
            Err(format!(
                "Simulation {} is being rebuilt from the cluster's log (this node's copy may be behind it); call again",
                self.id()
            ))
        } else {
            Ok(())
        }
    }

    /// Why this simulation is damaged, if it is.
    pub fn damaged(&self) -> Option<&str> {
        self.damaged.as_deref()
    }

    /// Marks the simulation destroyed and closes its log (dropping buffered events), so its
    /// files can be deleted and nothing recreates them.
    fn mark_destroyed(&mut self) {
        self.destroyed = true;
        self.log.close_for_deletion();
    }

    /// Deletes a simulation that is given up (a sweep's variant, a failed load): its log is
    /// closed first, waiting for a background checkpoint still writing it, so removing the
    /// files cannot make that checkpoint fail.
    pub(crate) fn delete(mut self) {
        self.log.close_for_deletion();
        let path = self.log.path().to_path_buf();
        drop(self);
        remove_log_files(&path);
    }

    /// The simulation id.
    pub fn id(&self) -> &str {
        self.world.simulation_id()
    }

    /// The world (read-only).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The current state hash (cached; equal to `world().state_hash()`).
    pub fn state_hash(&self) -> &str {
        &self.state_hash
    }

    /// The log (read-only).
    pub fn log(&self) -> &dyn EventLog {
        &self.log
    }

    /// The log's SQLite backend itself, for what only it has (file sizes, checkpoints):
    /// benchmarks and storage tests. Everything else uses `log`.
    pub fn storage(&self) -> &Log {
        &self.log
    }

    pub(crate) fn event(&mut self, kind: Kind, tool: &str, args: &Args) -> Event {
        let raw = serde_json::to_string(args).unwrap_or_default();
        let arguments = self.log.store_arguments(raw);
        Event::blank(self.log.next_seq(), kind, tool, arguments)
    }

    /// Records a refusal (nothing changes) and hands the sentence back.
    pub fn refuse(&mut self, tool: &str, args: &Args, why: Refusal) -> Refusal {
        if let Err(gone) = self.ensure_live() {
            return gone;
        }
        let mut e = self.event(Kind::Refused, tool, args);
        e.result = Some(why.clone());
        e.state_hash = self.state_hash.clone();
        if let Err(err) = self.log.append_lazy(e) {
            tracing::warn!("could not record a refused call: {err}");
        }
        why
    }

    /// The snapshot stalls since the last call, oldest first (taken: each is told once).
    pub fn take_stalls(&mut self) -> Vec<String> {
        std::mem::take(&mut self.stalls)
    }

    /// A read-only call: computes the answer from the world and records the event.
    pub fn read<T: Serialize>(
        &mut self,
        tool: &str,
        args: &Args,
        f: impl FnOnce(&Sim) -> Result<T, Refusal>,
    ) -> Result<T, Refusal> {
        self.read_within(tool, args, usize::MAX, f)
    }

    /// `read`, refusing an answer whose reply could not fit `budget` bytes
    /// (`--max-reply-bytes`): the refusal is logged as refused, as any other, rather than
    /// the read being logged as answered and the reply dropped later.
    pub fn read_within<T: Serialize>(
        &mut self,
        tool: &str,
        args: &Args,
        budget: usize,
        f: impl FnOnce(&Sim) -> Result<T, Refusal>,
    ) -> Result<T, Refusal> {
        self.read_replying(tool, args, budget, f, |_, json| {
            // Measured exactly only when anywhere near the budget: most reads are a few
            // hundred bytes, and the text copy at most doubles them.
            if json.len().saturating_mul(3).saturating_add(8192) <= budget {
                return 0;
            }
            crate::sim::budget::reply_bytes(tool, serde_json::from_str(json).unwrap_or_default())
        })
    }

    /// A read whose reply is not simply its recorded result (a summary with a file's path, an
    /// image beside it): `reply_bytes` measures the reply as it will be sent, and the read is
    /// logged only once it is known to fit `budget` — so the logged outcome is what the
    /// client gets. The recorded result hash is the answer's own (what replay recomputes).
    pub fn read_replying<T: Serialize>(
        &mut self,
        tool: &str,
        args: &Args,
        budget: usize,
        f: impl FnOnce(&Sim) -> Result<T, Refusal>,
        reply_bytes: impl FnOnce(&T, &str) -> usize,
    ) -> Result<T, Refusal> {
        self.ensure_live()?;
        match f(self) {
            Ok(out) => {
                let value = serde_json::to_value(&out).unwrap_or_default();
                let json = value.to_string();
                if budget != usize::MAX {
                    let bytes = reply_bytes(&out, &json);
                    if bytes > budget {
                        let why = crate::sim::budget::over_budget(tool, bytes as u64, budget);
                        return Err(self.refuse(tool, args, why));
                    }
                }
                // Hashed as a JSON value (sorted keys), like every recorded result, so replay
                // can recompute it from `reads.rs`.
                let mut e = self.event(Kind::Read, tool, args);
                e.result_hash = Some(crate::digest::result_hash(&json));
                e.state_hash = self.state_hash.clone();
                e.summary = Some(crate::log::summary::one_line(&value));
                if let Err(err) = self.log.append_lazy(e) {
                    tracing::warn!("could not record a read: {err}");
                }
                Ok(out)
            }
            Err(why) => Err(self.refuse(tool, args, why)),
        }
    }

    /// Where the log stands, for the read-only tools (`reads.rs`).
    pub fn read_context(&self) -> ReadContext<'_> {
        ReadContext {
            world: &self.world,
            head_seq: self.log.head_seq(),
            last_seq: self.log.last_seq(),
            state_hash: &self.state_hash,
            rules: crate::command::EVENT_VERSION,
        }
    }

    /// Keeps the snapshots on the head's chain bounded: all of the newest
    /// `SNAPSHOTS_KEPT_RECENT`, then at most one per doubling of age, and always the oldest
    /// (the root's), so any recent point costs at most one snapshot interval to rebuild and
    /// the count grows only logarithmically with history.
    pub(crate) fn thin_snapshots(&mut self) {
        let head = self.log.head_seq();
        let seqs = match self.log.chain_snapshot_seqs(head) {
            Ok(s) => s,
            Err(e) => return tracing::warn!("could not list snapshots: {e}"),
        };
        let doomed = snapshots_to_thin(&seqs, head);
        if let Err(e) = self.log.delete_snapshots(&doomed) {
            tracing::warn!("could not thin snapshots: {e}");
        }
    }

    /// Rebuilds this simulation's world from its log (after a failed commit or a panic
    /// mid-call), so the world never holds a change the log does not. Reads the open log and
    /// writes nothing (a full disk cannot stop it); if the log no longer folds, the
    /// simulation is marked damaged and refuses every call.
    pub(crate) fn reload(&mut self) {
        if self.destroyed {
            return; // its files are gone on purpose
        }
        let id = self.id().to_string();
        let rebuilt = rebuild_at(&self.log, &id, self.log.head_seq(), true)
            .and_then(|r| Ok((r, redo_stack(&self.log)?)));
        match rebuilt {
            Ok((r, redo)) => {
                self.state_hash = r.world.state_hash();
                self.world = r.world;
                self.redo = redo;
                self.work_since_snapshot = r.work_since_snapshot;
                self.changes_since_snapshot = r.changes_since_snapshot;
            }
            Err(e) => {
                tracing::error!("could not reload simulation {id}: {e}");
                self.damaged = Some(e.to_string());
            }
        }
    }

    /// Commits buffered read/refused events (on shutdown).
    pub fn flush(&mut self) {
        if let Err(e) = self.log.flush() {
            tracing::warn!("could not flush simulation {}: {e}", self.id());
        }
    }
}

/// The world's snapshot bytes and their content hash, as a log stores them.
pub(crate) fn snapshot_with_hash(world: &World) -> (Vec<u8>, String) {
    let bytes = world.snapshot();
    let hash = crate::digest::content_hash(&bytes);
    (bytes, hash)
}

/// A world rebuilt at some event, with how far it is from the snapshot it started from.
pub(crate) struct Rebuilt {
    pub(crate) world: World,
    pub(crate) work_since_snapshot: u64,
    pub(crate) changes_since_snapshot: u32,
}

/// The world at state-changing event `target`: the nearest snapshot on its chain (hash
/// verified), then the chain's later events folded, each checked against its recorded hash.
/// This bounds undo, fork and recovery to one snapshot interval of re-simulation.
/// With `verify_each`, every event's recorded hash is checked (recovery); otherwise only the
/// target's (undo: the fold is deterministic, and the target's hash proves it).
pub(crate) fn rebuild_at(
    log: &dyn EventLog,
    id: &str,
    target: u64,
    verify_each: bool,
) -> Result<Rebuilt, StoreError> {
    let (chain, start) = fold::chain_from_snapshot(log, target, target)?;
    let first = chain.first().ok_or_else(|| StoreError::Corrupt("the chain is empty".into()))?;
    // The gui flag is this simulation's own root's (the latest root of the chain otherwise).
    let own_root = match log.own_root_command()? {
        Some(text) => serde_json::from_str::<Command>(&text).ok(),
        None => chain.iter().rev().find(|e| e.kind == Kind::Root).and_then(|e| fold::decode(e, &NoBlobs).ok().flatten()),
    };
    let (gui, name) = own_root.as_ref().and_then(fold::root_identity).map_or((false, None), |(_, gui, name)| (gui, name));
    let world = match start {
        Some(bytes) => World::restore(id, gui, &bytes).map_err(StoreError::Corrupt)?,
        None => fold::create_root(first, log)?.0.with_identity(id, gui),
    };
    let mut world = world.with_name(name);
    fold::check_hash(&world, first)?;
    let verify = if verify_each { Verify::Each } else { Verify::Only(target) };
    let folded = fold::fold(&mut world, &chain[1..], log, &Limits::unbounded(), verify, &mut |_, _, _| Ok(()))?;
    Ok(Rebuilt {
        world,
        work_since_snapshot: folded.work,
        changes_since_snapshot: folded.changes,
    })
}

/// What a move (undo/redo) event records, so redo stacks can be rebuilt from the log.
#[derive(serde::Serialize, serde::Deserialize, Debug, Clone)]
pub(crate) struct MoveRecord {
    /// "undo" or "redo".
    pub(crate) op: String,
    /// Head before the move.
    pub(crate) from: u64,
    /// Head after the move.
    pub(crate) to: u64,
    /// The events undone (most recent first) or redone (oldest first).
    pub(crate) seqs: Vec<u64>,
}

/// Replays the log's own (non-inherited) changes and moves to rebuild the redo stack.
fn redo_stack(log: &dyn EventLog) -> Result<Vec<u64>, StoreError> {
    let mut stack = Vec::new();
    for e in log.all_events()?.iter().filter(|e| !e.inherited) {
        match e.kind {
            Kind::Root | Kind::Change => stack.clear(),
            Kind::Move => {
                let m: MoveRecord = serde_json::from_str(e.command.as_deref().unwrap_or(""))
                    .map_err(|err| StoreError::Corrupt(format!("move {} does not decode: {err}", e.seq)))?;
                if m.op == "undo" {
                    stack.extend(m.seqs.iter().copied());
                } else {
                    for _ in &m.seqs {
                        stack.pop();
                    }
                }
            }
            Kind::Read | Kind::Refused => {}
        }
    }
    Ok(stack)
}

/// Locks a simulation. If an earlier call panicked while holding it, the world is first
/// rebuilt from the log, so a half-applied change is never served.
pub fn lock_sim(sim: &SharedSim) -> MutexGuard<'_, Sim> {
    match sim.lock() {
        Ok(g) => g,
        Err(poisoned) => {
            let mut g = poisoned.into_inner();
            g.reload();
            sim.clear_poison();
            g
        }
    }
}

/// Where a server keeps things and how much it allows.
#[derive(Clone, Debug)]
pub struct Config {
    /// Directory of simulation logs (one SQLite file each) and the MAC key.
    pub data_dir: PathBuf,
    /// Directory user files (URDF, saves) are confined to.
    pub workspace: PathBuf,
    /// Request limits.
    pub limits: Limits,
    /// Commit durability.
    pub sync: SyncMode,
}

/// A simulation shared between requests; one call at a time.
pub type SharedSim = Arc<Mutex<Sim>>;

/// All simulations of a data directory, which this process holds an exclusive lock on.
///
/// # Lock order
/// Two kinds of lock, taken in one order: a simulation's lock (`SharedSim`, held for a whole
/// call, commits included) may be held while the table lock is taken, never the reverse. The
/// table lock ([`Table`]) guards map operations only: it is never held across I/O and nothing
/// is locked under it, so it can never be part of a wait cycle. Creating, forking, loading and
/// keeping a simulation reserve a slot under the table lock, do their I/O without it, then
/// fill or release the slot ([`Slot`]); flush and shutdown copy the list of simulations out
/// of the table before locking any of them.
pub struct Registry {
    table: Mutex<Table>,

    /// Simulations whose logs failed to open or fold at start: id (the file's name) → why.
    /// Never served; every call on them answers `Simulation {id} is damaged: {reason}`.
    damaged: BTreeMap<String, String>,
    config: Config,
    sandbox: Sandbox,
    mac_key: [u8; 32],
    /// The cluster this node is part of (`serve --cluster`); None: embedded mode.
    cluster: Option<Arc<crate::cluster::Cluster>>,
    /// This node's sweepers, once started (a cluster node's sweeps then run across the cluster).
    sweeps: std::sync::OnceLock<Arc<sweep_worker::NodeSweeps>>,
    /// Calls waiting for busy simulations, bounded per simulation (`queue.rs`).
    queues: queue::Queues,
    /// What was last seen of each simulation, for listing one that is busy without waiting
    /// for it (a long step must not hold up list_simulations or a viewer link).
    listings: Mutex<BTreeMap<String, Listing>>,
    _lock: std::fs::File,
}

impl Registry {
    /// Locks the data directory and recovers every simulation in it. A corrupt log is
    /// reported on stderr and skipped (left on disk, not served).
    pub fn open(config: Config) -> anyhow::Result<Registry> {
        Self::open_with(config, None)
    }

    /// `open` as a node of `cluster` (when given): the data directory is then only a cache
    /// of the cluster's logs, emptied at start, and the saved-file key is the cluster's.
    pub fn open_with(mut config: Config, cluster: Option<Arc<crate::cluster::Cluster>>) -> anyhow::Result<Registry> {
        config.data_dir = data_dir::prepare_dir("--data", &config.data_dir, true)?;
        config.workspace = data_dir::prepare_dir("--workspace", &config.workspace, false)?;
        let lock = data_dir::lock(&config.data_dir)?;
        data_dir::remove_partial_logs(&config.data_dir);
        let mut sims = BTreeMap::new();
        let mut damaged = BTreeMap::new();
        data_dir::claim_for(&config.data_dir, cluster.is_some())?;
        if cluster.is_some() {
            for path in data_dir::logs(&config.data_dir)? {
                remove_log_files(&path);
            }
        }
        for path in data_dir::logs(&config.data_dir)? {
            let started = std::time::Instant::now();
            let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            // A panic while folding a hostile file is damage too, not a failed start.
            let recovered = std::panic::catch_unwind(|| Sim::recover(&path, config.sync))
                .unwrap_or_else(|_| Err(StoreError::Corrupt("folding it panicked".into())));
            match recovered {
                Ok(sim) if sim.id() == name => {
                    tracing::info!("recovered simulation {} in {:?}", sim.id(), started.elapsed());
                    sims.insert(sim.id().to_string(), Arc::new(Mutex::new(sim)));
                }
                Ok(sim) => {
                    let why = format!("the file {} holds simulation {}", path.display(), sim.id());
                    eprintln!("physics-mcp: warning: skipping {}: {why} (the file is left as it is)", path.display());
                    damaged.insert(name, why);
                }
                Err(e) => {
                    eprintln!(
                        "physics-mcp: warning: skipping {}: {e} (the file is left as it is)",
                        path.display()
                    );
                    damaged.insert(name, e.to_string());
                }
            }
        }
        let sandbox = Sandbox {
            workspace: config.workspace.clone(),
            data_dir: config.data_dir.clone(),
        };
        let mut mac_key = data_dir::mac_key(&config.data_dir)?;
        if let Some(cluster) = &cluster {
            mac_key = cluster.shared_mac_key(mac_key)?;
        }
        Ok(Registry {
            table: Mutex::new(Table { sims, reserved: 0 }),
            damaged,
            config,
            sandbox,
            mac_key,
            cluster,
            sweeps: std::sync::OnceLock::new(),
            queues: queue::Queues::default(),
            listings: Mutex::new(BTreeMap::new()),
            _lock: lock,
        })
    }

    /// The simulations skipped as damaged at start, with why (for the operator's log
    /// messages; list_simulations shows them too).
    pub fn damaged_at_start(&self) -> impl Iterator<Item = (&str, &str)> {
        self.damaged.iter().map(|(id, why)| (id.as_str(), why.as_str()))
    }

    /// The server's configuration (resolved directories).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The workspace sandbox for user file paths.
    pub fn sandbox(&self) -> &Sandbox {
        &self.sandbox
    }

    /// The key saved files' snapshots are MAC'd with.
    pub fn mac_key(&self) -> &[u8; 32] {
        &self.mac_key
    }

    /// The limits in force.
    pub fn limits(&self) -> &Limits {
        &self.config.limits
    }

    /// Notes what `sim` now is, for listing it while a later call holds it.
    pub(crate) fn listed(&self, sim: &Sim) {
        self.listings.lock().unwrap_or_else(|p| p.into_inner()).insert(sim.id().to_string(), Listing::of(sim));
    }

    /// Whether simulation `id` was made with `gui` (from its listing when it is busy).
    pub fn gui_of(&self, id: &str) -> bool {
        self.listing(id).is_some_and(|l| l.gui)
    }

    /// What is known of simulation `id` without waiting for it: the simulation itself when it
    /// is free, else what was last seen of it, else (it was never seen free) whatever the call
    /// holding it leaves.
    fn listing(&self, id: &str) -> Option<Listing> {
        let sim = self.lookup(id)?;
        Some(self.listing_of(id, &sim))
    }

    fn listing_of(&self, id: &str, sim: &SharedSim) -> Listing {
        if let Ok(guard) = sim.try_lock() {
            let l = Listing::of(&guard);
            drop(guard);
            self.listings.lock().unwrap_or_else(|p| p.into_inner()).insert(id.to_string(), l.clone());
            return l;
        }
        if let Some(l) = self.listings.lock().unwrap_or_else(|p| p.into_inner()).get(id) {
            return l.clone();
        }
        let l = Listing::of(&lock_sim(sim));
        self.listings.lock().unwrap_or_else(|p| p.into_inner()).insert(id.to_string(), l.clone());
        l
    }

    /// The queues of calls waiting for busy simulations: a call takes its simulation's turn
    /// here before it locks it (`queue.rs`).
    pub fn queues(&self) -> &queue::Queues {
        &self.queues
    }

    /// The table, for a map operation (see the lock order on [`Registry`]).
    fn table(&self) -> MutexGuard<'_, Table> {
        self.table.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Every live simulation, copied out of the table (so none is locked under it).
    pub(crate) fn all(&self) -> Vec<SharedSim> {
        self.table().sims.values().cloned().collect()
    }

    /// Reserves room for one new simulation (create, fork, load, a kept sweep variant),
    /// refused at --max-sims. The slot counts until it is filled or dropped.
    pub(crate) fn reserve(&self) -> Result<Slot<'_>, Refusal> {
        self.reserve_many(1).map(|mut slots| slots.pop().expect("one slot"))
    }

    /// Reserves room for `n` new simulations at once, all or none.
    pub(crate) fn reserve_many(&self, n: usize) -> Result<Vec<Slot<'_>>, Refusal> {
        let in_cluster = self.cluster_count()?;
        let mut t = self.table();
        let live = in_cluster.unwrap_or(t.sims.len()) + t.reserved;
        let max = self.config.limits.max_sims;
        if live + n > max {
            return Err(if n == 1 {
                format!("Simulation limit reached: {max} simulations (--max-sims)")
            } else {
                format!("{n} new simulations would be over --max-sims ({max}) beside the {live} there are")
            });
        }
        t.reserved += n;
        drop(t);
        Ok((0..n).map(|_| Slot { reg: self, filled: false }).collect())
    }

    pub(crate) fn path_for(&self, id: &str) -> PathBuf {
        self.config.data_dir.join(format!("{id}.sqlite"))
    }

    /// Creates a simulation from a root command whose id the caller generated: a slot is
    /// reserved, the log written and committed without the table lock, then listed.
    pub fn create(&self, root: Command, args: &Args) -> Result<Outcome, Refusal> {
        let Command::CreateSimulation { simulation_id, .. } = &root else {
            return Err("not a root command".into());
        };
        let id = simulation_id.clone();
        let slot = self.reserve()?;
        let partial = crate::log::sqlite::partial_path(&self.path_for(&id));
        let (sim, result) = Sim::create_unpublished(&partial, "create_simulation", root, args, self.config.sync)?;
        crate::crash_point!("create_before_publish");
        slot.fill(self.publish_sim(sim)?);
        Ok(result)
    }

    /// The simulation with this id (refused with the reason when it is damaged).
    pub fn get(&self, id: &str) -> Result<SharedSim, Refusal> {
        if let Some(why) = self.damaged.get(id) {
            return Err(sim_damaged(id, why));
        }
        if let Some(cluster) = &self.cluster {
            return self.get_in_cluster(cluster, id);
        }
        self.lookup(id).ok_or_else(|| sim_not_found(id))
    }

    /// The cluster this registry is a node of, if any.
    pub fn cluster(&self) -> Option<&Arc<crate::cluster::Cluster>> {
        self.cluster.as_ref()
    }

    /// Whether this registry is a cluster node (its `get` may then wait on the cluster).
    pub fn in_cluster(&self) -> bool {
        self.cluster.is_some()
    }

    /// The simulation if this process has it in memory, without asking the cluster (for
    /// what only concerns a simulation already here: stalls, the viewer link).
    pub fn get_local(&self, id: &str) -> Option<SharedSim> {
        self.lookup(id)
    }

    /// The simulation with this id if this process has it in memory.
    fn lookup(&self, id: &str) -> Option<SharedSim> {
        self.table().sims.get(id).cloned()
    }

    /// Drops a simulation from memory (cluster mode: its lease is gone, or it was destroyed),
    /// with the viewer's answers of it: another node may change or destroy it from now on.
    fn evict(&self, id: &str) {
        self.table().sims.remove(id);
        crate::seeing::viewer::forget(id);
    }

    /// Lists a simulation taken over from another node.
    fn insert(&self, id: &str, sim: SharedSim) {
        self.table().sims.insert(id.to_string(), sim);
    }

    /// Drops what this process keeps about a destroyed simulation besides the simulation
    /// itself: the viewer's cached answers, its waiting queue, its last listing.
    fn forget_local(&self, id: &str) {
        crate::seeing::viewer::forget(id);
        self.queues.forget(id);
        self.listings.lock().unwrap_or_else(|p| p.into_inner()).remove(id);
    }

    /// Removes a simulation and deletes its log.
    pub fn destroy(&self, id: &str) -> Result<Message, Refusal> {
        if let Some(why) = self.damaged.get(id) {
            return Err(sim_damaged(id, why));
        }
        if let Some(cluster) = &self.cluster {
            self.destroy_in_cluster(cluster, id)?;
            self.forget_local(id);
            return Ok(Message::new(format!("Simulation {id} destroyed")));
        }
        let sim = self.table().sims.remove(id).ok_or_else(|| sim_not_found(id))?;
        // Wait for any call in flight; then, still under the lock, mark it destroyed and close
        // its log before deleting the files, so a request that took the handle earlier finds
        // it gone instead of writing to (or recreating) deleted files.
        let path = {
            let mut guard = lock_sim(&sim);
            guard.mark_destroyed();
            guard.log.path().to_path_buf()
        };
        remove_log_files(&path);
        self.forget_local(id);
        Ok(Message::new(format!("Simulation {id} destroyed")))
    }

    /// list_simulations.
    pub fn list(&self) -> SimulationList {
        let sims: Vec<(String, SharedSim)> = self.table().sims.iter().map(|(id, s)| (id.clone(), s.clone())).collect();
        let mut damaged: Vec<DamagedSimulation> = self
            .damaged
            .iter()
            .map(|(id, why)| DamagedSimulation { simulation_id: id.clone(), reason: why.clone() })
            .collect();
        let mut simulations = Vec::new();
        for (id, s) in &sims {
            match self.listing_of(id, s) {
                Listing { damaged: Some(why), .. } => damaged.push(DamagedSimulation { simulation_id: id.clone(), reason: why }),
                Listing { summary, .. } => simulations.push(summary),
            }
        }
        let here: Vec<String> = simulations.iter().map(|s| s.simulation_id.clone()).collect();
        for (id, entry) in self.listed_elsewhere(&here) {
            simulations.push(SimulationSummary {
                simulation_id: id,
                name: entry.name,
                objects: entry.objects,
                simulation_time: entry.simulation_time,
            });
        }
        damaged.sort_by(|a, b| a.simulation_id.cmp(&b.simulation_id));
        SimulationList { simulations, damaged }
    }

    /// Commits the buffered reads of every simulation that was idle since the last call (its
    /// last seq is what `seen` held then), so a report or an export made beside a running
    /// server sees the reads after the last change within a tick. A busy simulation is
    /// skipped (`try_lock`): its next write commits them anyway.
    pub fn flush_idle(&self, seen: &mut std::collections::HashMap<String, u64>) {
        let mut now = std::collections::HashMap::new();
        for sim in self.all() {
            let Ok(mut s) = sim.try_lock() else { continue };
            let (id, last) = (s.id().to_string(), s.log().last_seq());
            if seen.get(&id) == Some(&last) {
                s.flush();
            }
            now.insert(id, last);
        }
        *seen = now;
    }

    /// Commits every simulation's buffered events at shutdown. The list is copied out of the
    /// table first, so a call holding a simulation that waits for the table (fork, keep)
    /// finishes instead of waiting for this. A simulation still busy at `deadline` is left:
    /// a change commits its own buffered events with its event, but a long read (verify,
    /// history, save) does not, so its simulation's buffered reads may be lost (the documented durability allows
    /// losing reads to a kill; running steps and re-simulations stop at the signal, so in
    /// practice only a read already past its last check is still busy). Returns how many
    /// were left.
    pub fn flush_all_until(&self, deadline: std::time::Instant) -> usize {
        let mut busy = 0;
        for sim in self.all() {
            loop {
                match sim.try_lock() {
                    Ok(mut s) => break s.flush(),
                    // A call panicked holding it: its buffered events are still whole.
                    Err(std::sync::TryLockError::Poisoned(p)) => break p.into_inner().flush(),
                    Err(std::sync::TryLockError::WouldBlock) if std::time::Instant::now() >= deadline => {
                        busy += 1;
                        break;
                    }
                    Err(std::sync::TryLockError::WouldBlock) => std::thread::sleep(std::time::Duration::from_millis(5)),
                }
            }
        }
        busy
    }
}

/// What list_simulations (and a viewer link) shows of a simulation.
#[derive(Clone)]
struct Listing {
    summary: SimulationSummary,
    gui: bool,
    /// Why it is damaged, when it is.
    damaged: Option<String>,
}

impl Listing {
    fn of(s: &Sim) -> Listing {
        Listing {
            summary: SimulationSummary {
                simulation_id: s.id().to_string(),
                name: s.world().name().map(str::to_string),
                objects: s.world().object_count(),
                simulation_time: s.world().current_time(),
            },
            gui: s.world().gui(),
            damaged: s.damaged().map(str::to_string),
        }
    }
}

/// The simulations of a registry and the slots reserved for ones being made.
struct Table {
    sims: BTreeMap<String, SharedSim>,
    /// Simulations being created, forked, loaded or kept: counted against --max-sims while
    /// their files are written without the table lock.
    reserved: usize,
}

/// Room for one new simulation, reserved by [`Registry::reserve`]: filled with the
/// simulation once its log is complete, or released when dropped unfilled.
pub(crate) struct Slot<'a> {
    reg: &'a Registry,
    filled: bool,
}

impl Slot<'_> {
    /// Lists `sim` in the slot reserved for it.
    pub(crate) fn fill(mut self, sim: Sim) {
        self.reg.listed(&sim);
        let shared = Arc::new(Mutex::new(sim));
        let id = lock_sim(&shared).id().to_string();
        let mut t = self.reg.table();
        t.reserved -= 1;
        t.sims.insert(id, shared);
        self.filled = true;
    }
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        if !self.filled {
            self.reg.table().reserved -= 1;
        }
    }
}
