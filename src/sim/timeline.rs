//! The time machine: undo, redo, history, verification and forks — all operations on the
//! log, never on the world directly. Undo rebuilds the world at an ancestor (the nearest
//! snapshot, then a refold); redo re-applies the undone events' own commands and checks their
//! hashes; a fork copies the chain into a new log. Every move is an event committed before
//! the reply.

use crate::log::EventLog;
use serde_json::Value;

use crate::command::{BlobSource, Command};
use crate::outputs::{
    Divergence, EventRef, Forked, History, HistoryEvent, Redone, Undone, Verified,
};
use crate::log::fold::{self, FoldError, Verify};
use crate::limits::Limits;
use crate::sim::{lock_sim, rebuild_at, MoveRecord, Registry, Sim};
use crate::log::sqlite::{Event, Kind, Log, StoreError};
use crate::value::{Args, Refusal};
use crate::world::World;

/// Most events one get_history page returns.
pub const HISTORY_MAX_LIMIT: usize = 1000;

pub(crate) fn store_err(e: StoreError) -> Refusal {
    format!("The simulation's log could not be read: {e}")
}

/// Deepest nesting of recorded arguments that get_history echoes as JSON; deeper parts are
/// shown as their compact JSON text. A request nested just under a client's parser limit
/// (serde_json's is 128) would otherwise come back deeper than it, inside the reply's own
/// envelope, and the client could not read the reply at all.
pub const ARGUMENTS_DEPTH: usize = 32;

/// `v` with everything nested deeper than `depth` levels replaced by its compact JSON text.
pub fn shallow(v: Value, depth: usize) -> Value {
    match v {
        Value::Array(_) | Value::Object(_) if depth == 0 => Value::String(v.to_string()),
        Value::Array(items) => Value::Array(items.into_iter().map(|x| shallow(x, depth - 1)).collect()),
        Value::Object(map) => Value::Object(map.into_iter().map(|(k, x)| (k, shallow(x, depth - 1))).collect()),
        other => other,
    }
}

/// The seq a fork's or load's own root takes: the event after the last one it inherits (None
/// for an empty chain). Its result says so before the root is written.
pub(crate) fn root_seq_after(chain: &[Event]) -> Option<u64> {
    chain.last().map(|e| e.seq + 1)
}

/// Compact JSON bytes over which a field of a recorded result is shown by its size in
/// get_history's default (compact) answer; with detail "full", fields up to the size of
/// arguments kept inline (64 KB) are shown whole.
pub const SUMMARY_FIELD_BYTES: usize = 256;

/// Characters of a refusal sentence get_history shows by default (all of it with "full").
const REFUSAL_CHARS: usize = 160;

/// `v` with every field whose compact JSON is over `max` bytes shown by its size instead
/// (`"[4000 items]"`, `"{12 fields}"`, a long string cut): a recorded result may be large (a
/// model's whole body list), a history event stays small.
fn bounded(v: Value, max: usize) -> Value {
    let shown = |x: Value| -> Value {
        if x.to_string().len() <= max {
            return x;
        }
        match x {
            Value::Array(items) => Value::String(format!("[{} items]", items.len())),
            Value::Object(m) => Value::String(format!("{{{} fields}}", m.len())),
            Value::String(text) => Value::String(crate::log::summary::cut(&text, max / 2)),
            other => other,
        }
    };
    match v {
        Value::Object(m) => Value::Object(m.into_iter().map(|(k, x)| (k, shown(x))).collect()),
        other => shown(other),
    }
}

/// What an event did, for get_history: a change's or root's recorded result as JSON (just
/// its message when that is all it says), "refused: why", or a read's one-line summary.
/// Compact unless `full`: see `HistoryEvent::summary`.
fn summary(e: &Event, full: bool) -> Value {
    let field_max = if full { crate::log::sqlite::INLINE_ARGS_MAX } else { SUMMARY_FIELD_BYTES };
    match (e.kind, e.result.as_deref()) {
        (Kind::Refused, why) => {
            let text = format!("refused: {}", why.unwrap_or_default());
            Value::String(if full { text } else { crate::log::summary::cut(&text, REFUSAL_CHARS) })
        }
        (Kind::Read, _) => Value::String(e.summary.clone().unwrap_or_else(|| "read".to_string())),
        (_, Some(result)) => match serde_json::from_str::<Value>(result) {
            Ok(Value::Object(m)) if m.len() == 1 && m.get("message").is_some_and(Value::is_string) => {
                m.into_iter().next().map(|(_, msg)| msg).unwrap_or_default()
            }
            Ok(Value::Object(mut m)) if !full => {
                // Compact: the simulation a change was made in is the one asked about (a root
                // keeps it: an inherited root names its ancestor), and a hash by its short form.
                if e.kind != Kind::Root {
                    m.remove("simulation_id");
                }
                // Where a change landed is the event's own seq, shown beside it already.
                if m.get("head_seq").and_then(Value::as_u64) == Some(e.seq) {
                    m.remove("head_seq");
                }
                for v in m.values_mut() {
                    if let Value::String(text) = v {
                        if let Some(short) = crate::log::summary::short_hash(text) {
                            *text = short.to_string();
                        }
                    }
                }
                shallow(bounded(Value::Object(m), field_max), ARGUMENTS_DEPTH)
            }
            Ok(v) => shallow(bounded(v, field_max), ARGUMENTS_DEPTH),
            Err(_) => Value::String(result.to_string()),
        },
        (_, None) => Value::Null,
    }
}

/// The arguments as get_history echoes them: as recorded with "full"; otherwise without
/// `sim_id`, which names the simulation being asked about (or, on an inherited event, its
/// ancestor).
fn echoed_arguments(recorded: &str, full: bool) -> Value {
    let mut v = serde_json::from_str(recorded).unwrap_or(Value::Null);
    if !full {
        if let Value::Object(m) = &mut v {
            m.remove("sim_id");
        }
    }
    shallow(v, ARGUMENTS_DEPTH)
}

impl Sim {
    /// Index in `chain` of this simulation's own root (undo never goes past it).
    fn own_root_index(chain: &[Event]) -> usize {
        chain.iter().rposition(|e| e.kind == Kind::Root).unwrap_or(0)
    }

    /// Commits a move event and makes `world` (at `to`) current — once its reply is known to
    /// fit `budget`, shortened if need be (a long `undone` list), so a move is never answered
    /// with an error after it commits.
    #[allow(clippy::too_many_arguments)]
    fn commit_move(
        &mut self,
        tool: &str,
        args: &Args,
        record: MoveRecord,
        world: World,
        counters: (u64, u32),
        result: Value,
        budget: usize,
    ) -> Result<(), Refusal> {
        if let Err(why) = crate::sim::budget::shorten(tool, result.clone(), budget) {
            return Err(self.refuse(tool, args, why));
        }
        let state_hash = world.state_hash();
        let mut e = self.event(Kind::Move, tool, args);
        e.command = Some(serde_json::to_string(&record).map_err(|err| err.to_string())?);
        let json = result.to_string();
        e.result_hash = Some(crate::digest::result_hash(&json));
        e.result = Some(json);
        e.state_hash = state_hash.clone();
        self.log
            .append(std::slice::from_ref(&e), record.to, &[])
            .map_err(|err| format!("The {tool} could not be recorded and was not done: {err}"))?;
        self.world = world;
        self.state_hash = state_hash;
        (self.work_since_snapshot, self.changes_since_snapshot) = counters;
        self.index_changed();
        Ok(())
    }

    /// Moves the head back over the last `count` state-changing events of this simulation.
    pub fn undo(&mut self, args: &Args, count: u64) -> Result<Undone, Refusal> {
        self.undo_within(args, count, usize::MAX)
    }

    /// `undo` whose reply must fit `budget` bytes (`--max-reply-bytes`).
    pub fn undo_within(&mut self, args: &Args, count: u64, budget: usize) -> Result<Undone, Refusal> {
        self.ensure_live()?;
        // Walk back only `count` events (plus the target): undo costs what it undoes.
        let mut walked = 0u64;
        let back = self
            .log
            .chain_back(self.log.head_seq(), &mut |e| {
                walked += 1;
                walked > count || e.kind == Kind::Root
            })
            .map_err(store_err)?;
        let reachable = back.len() as u64 > count && back[..count as usize].iter().all(|e| e.kind != Kind::Root);
        if count == 0 || !reachable {
            let chain = self.log.chain_to(self.log.head_seq()).map_err(store_err)?;
            let available = (chain.len() - 1 - Self::own_root_index(&chain)) as u64;
            let why = format!(
                "count must be from 1 to {available} (the state-changing events that can be undone); got {count}"
            );
            return Err(self.refuse("undo", args, why));
        }
        let target = &back[count as usize];
        let undone: Vec<EventRef> = back[..count as usize]
            .iter()
            .map(|e| EventRef { seq: e.seq, tool: e.tool.clone() })
            .collect();
        let rebuilt = rebuild_at(&self.log, self.id(), target.seq, false).map_err(store_err)?;
        let out = Undone {
            undone,
            head_seq: target.seq,
            current_time: rebuilt.world.current_time(),
            state_hash: rebuilt.world.state_hash(),
        };
        let record = MoveRecord {
            op: "undo".into(),
            from: self.log.head_seq(),
            to: target.seq,
            seqs: out.undone.iter().map(|r| r.seq).collect(),
        };
        let result = serde_json::to_value(&out).map_err(|e| e.to_string())?;
        let counters = (rebuilt.work_since_snapshot, rebuilt.changes_since_snapshot);
        self.commit_move("undo", args, record.clone(), rebuilt.world, counters, result, budget)?;
        self.redo.extend(record.seqs);
        Ok(out)
    }

    /// Re-applies the `count` most recently undone events (along the undone branch).
    pub fn redo(&mut self, args: &Args, count: u64) -> Result<Redone, Refusal> {
        self.redo_within(args, count, usize::MAX)
    }

    /// `redo` whose reply must fit `budget` bytes (`--max-reply-bytes`).
    pub fn redo_within(&mut self, args: &Args, count: u64, budget: usize) -> Result<Redone, Refusal> {
        self.ensure_live()?;
        let available = self.redo.len() as u64;
        if count == 0 || count > available {
            let why = format!(
                "count must be from 1 to {available} (the undone events that can be redone); got {count}"
            );
            return Err(self.refuse("redo", args, why));
        }
        let seqs: Vec<u64> = self.redo.iter().rev().take(count as usize).copied().collect();
        // Fold forward on a copy of the world: the log is only changed once all checks pass.
        let mut world = self.world.duplicate();
        let events = seqs
            .iter()
            .map(|seq| self.log.event(*seq).map_err(store_err)?.ok_or_else(|| "an undone event is missing".to_string()))
            .collect::<Result<Vec<Event>, Refusal>>()?;
        let folded = fold::fold(&mut world, &events, &self.log, &Limits::unbounded(), Verify::Each, &mut |_, _, _| Ok(()))
            .map_err(|e| store_err(e.into()))?;
        let redone = events.iter().map(|e| EventRef { seq: e.seq, tool: e.tool.clone() }).collect();
        let steps = self.work_since_snapshot + folded.work;
        let changes = self.changes_since_snapshot + folded.changes;
        let to = *seqs.last().ok_or("nothing to redo")?;
        let out = Redone {
            redone,
            head_seq: to,
            current_time: world.current_time(),
            state_hash: world.state_hash(),
        };
        let record = MoveRecord { op: "redo".into(), from: self.log.head_seq(), to, seqs };
        let result = serde_json::to_value(&out).map_err(|e| e.to_string())?;
        self.commit_move("redo", args, record, world, (steps, changes), result, budget)?;
        self.redo.truncate(self.redo.len() - count as usize);
        Ok(out)
    }

    /// One page of the log: events with seq > `since`, ascending, at most `limit`; compact
    /// (short hashes, arguments without sim_id, big result fields by their size) unless `full`.
    pub fn history(&self, since: u64, limit: usize, full: bool) -> Result<History, Refusal> {
        let events = self.log.events_since(since, limit).map_err(store_err)?;
        Ok(History {
            events: events
                .iter()
                .map(|e| HistoryEvent {
                    seq: e.seq,
                    kind: e.kind.as_str().into(),
                    parent: e.parent,
                    tool: e.tool.clone(),
                    arguments: echoed_arguments(&e.arguments, full),
                    ok: e.ok,
                    mutates: e.mutates,
                    inherited: e.inherited,
                    summary: summary(e, full),
                    state_hash: if full { e.state_hash.clone() } else { e.state_hash.chars().take(crate::log::summary::SHORT_HASH).collect() },
                })
                .collect(),
            head_seq: self.log.head_seq(),
            last_seq: self.log.last_seq(),
            truncated: false,
        })
    }

    /// Refolds the head's chain from the original create_simulation in a fresh world,
    /// checking every recorded state hash, every snapshot on the chain (bytes and state),
    /// and that the live world equals the fold.
    pub fn verify(&self) -> Result<Verified, Refusal> {
        let chain = self.log.chain_to(self.log.head_seq()).map_err(store_err)?;
        let mut out = Verified {
            ok: true,
            events_checked: 0,
            snapshots_checked: 0,
            state_hash: self.state_hash.clone(),
            first_divergence: None,
        };
        let diverge = |out: &mut Verified, seq, expected: &str, actual: String| {
            if out.first_divergence.is_none() {
                out.ok = false;
                out.first_divergence = Some(Divergence { seq, expected: expected.into(), actual });
            }
        };
        let first = chain.first().ok_or("the log has no root")?;
        let (mut world, _) = fold::create_root(first, &self.log).map_err(|e| store_err(e.into()))?;
        // After each event: count it and check the snapshot stored there (bytes and state).
        let mut checked = (0, 0);
        let mut after = |_: &World, e: &Event, _: usize| -> Result<(), FoldError> {
            checked.0 += 1;
            let Some((bytes, hash)) = self.log.snapshot_at(e.seq).map_err(|err| FoldError::Undecodable { seq: e.seq, why: err.to_string() })? else {
                return Ok(());
            };
            checked.1 += 1;
            fold::check_snapshot(e, &bytes, &hash)
        };
        let folded = fold::check_hash(&world, first)
            .and_then(|()| after(&world, first, 0))
            .and_then(|()| fold::fold(&mut world, &chain[1..], &self.log, &Limits::unbounded(), Verify::Each, &mut after));
        match folded {
            Ok(_) => {}
            Err(FoldError::Diverged { seq, expected, actual, .. }) => diverge(&mut out, seq, &expected, actual),
            Err(other) => return Err(store_err(other.into())),
        }
        (out.events_checked, out.snapshots_checked) = checked;
        if out.ok && world.state_hash() != self.state_hash {
            let head = self.log.head_seq();
            diverge(&mut out, head, &self.state_hash.clone(), world.state_hash());
        }
        Ok(out)
    }
}

/// What a fork takes from its parent, read once under the parent's lock: the chain up to the
/// fork point and the state there (snapshot bytes and hash).
pub(crate) struct ForkSource {
    chain: Vec<Event>,
    snapshot: Vec<u8>,
    state_hash: String,
    /// Simulated time at `at`.
    time: f64,
    gui: bool,
    at: u64,
    parent_id: String,
    parent_path: std::path::PathBuf,
}

impl ForkSource {
    /// The seq the fork starts from.
    pub(crate) fn at(&self) -> u64 {
        self.at
    }

    /// The simulation forked (a variant's refusal names it, never the throwaway fork).
    pub(crate) fn parent_id(&self) -> &str {
        &self.parent_id
    }

    /// `p`'s chain and state at `at_seq` (default: its head), which must be a
    /// state-changing event of it.
    pub(crate) fn of(p: &Sim, at_seq: Option<u64>) -> Result<ForkSource, Refusal> {
        ForkSource::of_log(p.log(), p.id(), p.log.path(), at_seq.unwrap_or(p.log().head_seq()))
    }

    /// `of` for a simulation this node does not hold, from a copy of its log at `path` (a
    /// sweep's variants run on other nodes than their parent's owner).
    pub(crate) fn of_file(path: &std::path::Path, at: u64) -> Result<ForkSource, Refusal> {
        let log = open_parent(path)?;
        let id = log.simulation_id().map_err(store_err)?;
        ForkSource::of_log(&log, &id, path, at)
    }

    /// Simulation `id`'s chain and state at `at` from its log (kept at `path`).
    fn of_log(log: &dyn EventLog, id: &str, path: &std::path::Path, at: u64) -> Result<ForkSource, Refusal> {
        let at_event = log.event(at).map_err(store_err)?;
        if !at_event.as_ref().is_some_and(|e| e.kind.is_state_changing()) {
            return Err(format!("at_seq {at} is not a state-changing event of simulation {id}"));
        }
        let chain = log.chain_to(at).map_err(store_err)?;
        let rebuilt = rebuild_at(log, id, at, false).map_err(store_err)?;
        Ok(ForkSource {
            chain,
            snapshot: rebuilt.world.snapshot(),
            state_hash: rebuilt.world.state_hash(),
            time: rebuilt.world.current_time(),
            gui: rebuilt.world.gui(),
            at,
            parent_id: id.to_string(),
            parent_path: path.to_path_buf(),
        })
    }
}

/// A parent's log opened read-only, to fork from without its lock.
fn open_parent(path: &std::path::Path) -> Result<Log, Refusal> {
    Log::open_read_only(path).map_err(store_err)
}

impl Registry {
    /// fork_simulation: a new simulation holding `parent`'s chain up to `at_seq` (default:
    /// its head), inherited, then its own root. The parent records the call as a read.
    pub fn fork(&self, parent_id: &str, at_seq: Option<u64>, (new_id, name): (String, Option<String>), args: &Args) -> Result<Forked, Refusal> {
        let parent = self.get(parent_id)?;
        let mut p = lock_sim(&parent);
        p.ensure_live()?;
        // Lock order: the parent, then the table (for the slot); no table lock across I/O.
        let result = self.reserve().and_then(|slot| {
            let (forked, sim) = self.fork_unpublished(&p, at_seq, (new_id, name), args)?;
            slot.fill(self.publish_sim(sim)?);
            Ok(forked)
        });
        match result {
            Ok(forked) => p.read("fork_simulation", args, |_| Ok(forked)),
            Err(why) => Err(p.refuse("fork_simulation", args, why)),
        }
    }

    /// A fork of `p` at `at_seq` (default: its head) under its partial name: a real,
    /// replayable simulation that no one else sees (not listed, not counted) until it is
    /// published, and that a restart removes if it never is.
    pub(crate) fn fork_unpublished(
        &self,
        p: &Sim,
        at_seq: Option<u64>,
        new: (String, Option<String>),
        args: &Args,
    ) -> Result<(Forked, Sim), Refusal> {
        let source = ForkSource::of(p, at_seq)?;
        self.fork_from(&source, Some(p.log()), new, args)
    }

    /// A fork made from `source` (unpublished, as `fork_unpublished`). The chain's blobs and
    /// snapshots are copied from `parent`, or, without it, from the parent's file opened
    /// read-only — so run_sweep's workers make their forks side by side, off the parent's lock.
    pub(crate) fn fork_from(
        &self,
        source: &ForkSource,
        parent: Option<&dyn EventLog>,
        (new_id, name): (String, Option<String>),
        args: &Args,
    ) -> Result<(Forked, Sim), Refusal> {
        let opened;
        let parent = match parent {
            Some(log) => log,
            None => {
                opened = open_parent(&source.parent_path)?;
                &opened
            }
        };
        let root_cmd = Command::ForkSimulation {
            simulation_id: new_id.clone(),
            parent_id: source.parent_id.clone(),
            at_seq: source.at,
            gui: source.gui,
            name: name.clone(),
        };
        let out = Forked {
            simulation_id: new_id,
            name,
            parent_id: source.parent_id.clone(),
            at_seq: source.at,
            state_hash: source.state_hash.clone(),
            viewer_url: None,
            landed: root_seq_after(&source.chain).map(|seq| crate::outputs::Landed { head_seq: seq, time: source.time }),
        };
        let result = serde_json::to_value(&out).map_err(|e| e.to_string())?;
        let state = (source.snapshot.as_slice(), source.state_hash.as_str());
        let sim = self.adopt_unpublished((&source.chain, parent, Some(parent)), state, root_cmd, "fork_simulation", args, &result)?;
        Ok((out, sim))
    }

    /// Starts a simulation whose log inherits `chain` (a fork's or a loaded file's) and whose
    /// own root, at the next seq, is `root_cmd` with `world` as its state and snapshot; a
    /// fork also copies the parent's snapshots on the chain. A failure leaves no file behind.
    pub(crate) fn adopt(
        &self,
        ancestry: (&[Event], &dyn BlobSource, Option<&dyn EventLog>),
        world: &World,
        root_cmd: Command,
        tool: &str,
        args: &Args,
        result: &Value,
    ) -> Result<Sim, Refusal> {
        let snapshot = world.snapshot();
        let sim = self.adopt_unpublished(ancestry, (&snapshot, &world.state_hash()), root_cmd, tool, args, result)?;
        self.publish_sim(sim)
    }

    /// `adopt` under the partial name (`Sim::publish` gives it its final one), its root's
    /// state given as (snapshot bytes, state hash).
    pub(crate) fn adopt_unpublished(
        &self,
        (chain, blobs, parent): (&[Event], &dyn BlobSource, Option<&dyn EventLog>),
        (snapshot, state_hash): (&[u8], &str),
        root_cmd: Command,
        tool: &str,
        args: &Args,
        result: &Value,
    ) -> Result<Sim, Refusal> {
        let seq = root_seq_after(chain).ok_or("the inherited chain is empty")?;
        let id = match &root_cmd {
            Command::ForkSimulation { simulation_id, .. } | Command::LoadSimulation { simulation_id, .. } => {
                simulation_id.clone()
            }
            _ => return Err("not a fork or load root".into()),
        };
        let arguments = Value::Object(args.clone()).to_string();
        let root = Event::root(seq, Some(seq - 1), tool, arguments, &root_cmd, result.to_string(), state_hash)?;
        let path = self.path_for(&id);
        let partial = crate::log::sqlite::partial_path(&path);
        let built = (|| {
            let mut log = Log::create(&partial, &id, self.config().sync).map_err(store_err)?;
            for (hash, bytes) in &fold::chain_blobs(chain, blobs) {
                log.put_blob(hash, bytes).map_err(store_err)?;
            }
            let snap_hash = crate::digest::content_hash(snapshot);
            log.append_root_with_ancestry(chain, parent, root, (snapshot, &snap_hash))
                .map_err(store_err)?;
            crate::crash_point!("adopt_before_publish");
            drop(log);
            // Published (renamed to its final name) by the caller, once it is wanted.
            Sim::recover(&partial, self.config().sync).map_err(store_err)
        })();
        if built.is_err() {
            crate::sim::remove_log_files(&partial);
        }
        built
    }

}

#[cfg(test)]
mod tests {
    use super::shallow;
    use serde_json::json;

    #[test]
    fn arguments_deeper_than_the_bound_are_shown_as_text() {
        let deep = json!({"a": [[[1]]], "b": 2});
        assert_eq!(shallow(deep.clone(), 8), deep);
        assert_eq!(shallow(deep, 2), json!({"a": ["[[1]]"], "b": 2}));
    }
}
