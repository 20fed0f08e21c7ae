//! Replay, history and diff of a simulation log (the CLI's `replay`, `history`, `diff`).
//!
//! `replay` processes every event in seq order — inherited ones first, abandoned branches and
//! undo/redo included — in a fresh world, reading nothing but the log. It checks the state
//! hash of every root, change and move event, every snapshot (bytes and state), and the result
//! hash of every accepted event of the current event version whose result depends only on the world (reads other than
//! get_history, verify_simulation, save_simulation and fork_simulation, whose results hold
//! pages of the log or fresh ids). Refused events are not re-executed; their recorded hash
//! must equal the state they were refused in.

use crate::log::EventLog;
use std::path::Path;

use serde::Serialize;
use serde_json::Value;

use crate::command::Command;
use crate::outputs::{EventRef, Redone, Undone};
use crate::sim::reads::{Read, ReadContext};
use crate::log::fold::{self, FoldError};
use crate::limits::Limits;
use crate::sim::{rebuild_at, MoveRecord};
use crate::log::sqlite::{Event, Kind, Log, StoreError};
use crate::value::Args;
use crate::world::World;

/// What a successful replay went through.
#[derive(Serialize, Debug, Clone)]
pub struct Summary {
    /// Events processed.
    pub events: u64,
    /// Root, change and move events whose state hash was checked.
    pub state_events: u64,
    /// Read results re-computed and checked.
    pub reads_checked: u64,
    /// Snapshots checked.
    pub snapshots_checked: u64,
    /// Simulated steps taken by all change events (every branch).
    pub steps: u64,
    /// The state hash after the last event processed.
    pub final_hash: String,
}

/// The first event whose replay disagreed with the log.
#[derive(Serialize, Debug, Clone)]
pub struct Divergence {
    /// The event.
    pub seq: u64,
    /// Its tool.
    pub tool: String,
    /// Its arguments as recorded.
    pub arguments: String,
    /// What was compared: "state hash", "result hash", "snapshot".
    pub what: String,
    /// What the log recorded.
    pub expected: String,
    /// What the replay produced.
    pub actual: String,
}

/// Why a replay stopped.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The log could not be read.
    #[error("{0}")]
    Store(#[from] StoreError),
    /// An event replayed differently.
    #[error("divergence at seq {} ({}): {} expected {}, got {}; arguments {}", .0.seq, .0.tool, .0.what, .0.expected, .0.actual, .0.arguments)]
    Diverged(Box<Divergence>),
}

struct Replayer<'a> {
    log: &'a Log,
    id: String,
    world: Option<World>,
    head: u64,
    prev_seq: u64,
    summary: Summary,
}

impl Replayer<'_> {
    fn diverged(e: &Event, what: &str, expected: &str, actual: &str) -> ReplayError {
        ReplayError::Diverged(Box::new(Divergence {
            seq: e.seq,
            tool: e.tool.clone(),
            arguments: e.arguments.clone(),
            what: what.into(),
            expected: expected.into(),
            actual: actual.into(),
        }))
    }

    fn world(&self, e: &Event) -> Result<&World, ReplayError> {
        self.world
            .as_ref()
            .ok_or_else(|| Self::diverged(e, "order", "a root first", "no world yet"))
    }

    fn check_state(&mut self, e: &Event) -> Result<(), ReplayError> {
        let actual = self.world(e)?.state_hash();
        if actual != e.state_hash {
            return Err(Self::diverged(e, "state hash", &e.state_hash, &actual));
        }
        self.summary.final_hash = actual;
        Ok(())
    }

    /// Results are re-checked for events whose version's rules are still known
    /// (`command::result_rechecked`); an older event's result was computed under rules that
    /// are gone (docs/log-format.md "Compatibility of logs and files"); its state hash is
    /// still checked.
    fn check_result(e: &Event, result: &Value) -> Result<(), ReplayError> {
        if !crate::command::result_rechecked(e.version) {
            return Ok(());
        }
        let actual = crate::digest::result_hash(&result.to_string());
        match &e.result_hash {
            Some(expected) if *expected != actual => {
                Err(Self::diverged(e, "result hash", expected, &actual))
            }
            _ => Ok(()),
        }
    }

    fn check_snapshot(&mut self, e: &Event) -> Result<(), ReplayError> {
        if let Some((bytes, hash)) = self.log.snapshot_at(e.seq)? {
            fold::check_snapshot(e, &bytes, &hash).map_err(|err| match err {
                FoldError::Diverged { expected, actual, .. } => Self::diverged(e, "snapshot", &expected, &actual),
                other => ReplayError::Store(other.into()),
            })?;
            self.summary.snapshots_checked += 1;
        }
        Ok(())
    }

    fn event(&mut self, e: &Event) -> Result<(), ReplayError> {
        match e.kind {
            Kind::Root => {
                let cmd = fold::decode(e, self.log)
                    .map_err(|err| ReplayError::Store(err.into()))?
                    .ok_or_else(|| Self::diverged(e, "command", "a root command", "none"))?;
                match &cmd {
                    Command::CreateSimulation { .. } => {
                        let (w, result) = fold::create_root(e, self.log).map_err(|err| ReplayError::Store(err.into()))?;
                        self.world = Some(w);
                        Self::check_result(e, &result.to_value())?;
                    }
                    Command::ForkSimulation { .. } | Command::LoadSimulation { .. } => {
                        let w = self.world.take().ok_or_else(|| Self::diverged(e, "order", "an inherited chain", "none"))?;
                        let (id, gui, name) = fold::root_identity(&cmd).ok_or_else(|| Self::diverged(e, "command", "a root command", "another"))?;
                        self.world = Some(w.with_identity(id, gui).with_name(name));
                    }
                    _ => return Err(Self::diverged(e, "command", "a root command", "another")),
                }
                self.head = e.seq;
                self.summary.state_events += 1;
                self.check_state(e)?;
                self.check_snapshot(e)?;
            }
            Kind::Change => {
                if e.parent != Some(self.head) {
                    let expected = format!("{:?}", e.parent);
                    return Err(Self::diverged(e, "parent", &expected, &self.head.to_string()));
                }
                let world = self.world.as_mut().ok_or_else(|| Self::diverged(e, "order", "a root first", "no world"))?;
                // The state hash is compared below (naming it as such); the result first.
                let (cmd, result) = fold::fold_event(world, e, self.log, &Limits::unbounded(), false).map_err(|err| match err {
                    FoldError::Refused { why, .. } => Self::diverged(e, "command", "an acceptable command", &why),
                    other => ReplayError::Store(other.into()),
                })?;
                if let Command::StepSimulation { steps, .. } = cmd {
                    self.summary.steps += steps;
                }
                Self::check_result(e, &result.map_or(Value::Null, |r| r.to_value()))?;
                self.head = e.seq;
                self.summary.state_events += 1;
                self.check_state(e)?;
                self.check_snapshot(e)?;
            }
            Kind::Move => {
                let record: MoveRecord = serde_json::from_str(e.command.as_deref().unwrap_or(""))
                    .map_err(|err| Self::diverged(e, "command", "a move record", &err.to_string()))?;
                let rebuilt = rebuild_at(self.log, &self.id, record.to, true)?;
                let world = rebuilt.world;
                let refs = record
                    .seqs
                    .iter()
                    .map(|s| {
                        let tool = self.log.event(*s)?.map(|x| x.tool).unwrap_or_default();
                        Ok(EventRef { seq: *s, tool })
                    })
                    .collect::<Result<Vec<_>, StoreError>>()?;
                let (time, hash) = (world.current_time(), world.state_hash());
                let result = if record.op == "undo" {
                    serde_json::to_value(Undone { undone: refs, head_seq: record.to, current_time: time, state_hash: hash })
                } else {
                    serde_json::to_value(Redone { redone: refs, head_seq: record.to, current_time: time, state_hash: hash })
                }
                .unwrap_or(Value::Null);
                Self::check_result(e, &result)?;
                self.world = Some(world);
                self.head = record.to;
                self.summary.state_events += 1;
                self.check_state(e)?;
            }
            Kind::Read => {
                let args = read_arguments(self.log, &e.arguments);
                let read = Read::recorded(&e.tool, &args).map_err(|why| Self::diverged(e, "read", "a read it can re-run", &why))?;
                let world = self.world(e)?;
                let hash = world.state_hash();
                let cx = ReadContext { world, head_seq: self.head, last_seq: self.prev_seq, state_hash: &hash, rules: e.version };
                match read.replay(&cx) {
                    Some(Ok(result)) => {
                        Self::check_result(e, &result)?;
                        self.summary.reads_checked += 1;
                    }
                    Some(Err(why)) => return Err(Self::diverged(e, "result", "an accepted read", &why)),
                    None => {}
                }
                self.check_state(e)?;
            }
            Kind::Refused => self.check_state(e)?,
        }
        self.summary.events += 1;
        self.prev_seq = e.seq;
        Ok(())
    }
}

/// Replays a simulation log (see the module docs); `progress(done, total)` is called after
/// every event.
pub fn replay(path: &Path, until: Option<u64>, mut progress: impl FnMut(u64, u64)) -> Result<Summary, ReplayError> {
    let log = Log::open_read_only(path)?;
    let events: Vec<Event> = log
        .all_events()?
        .into_iter()
        .filter(|e| until.is_none_or(|u| e.seq <= u))
        .collect();
    let mut r = Replayer {
        log: &log,
        id: log.simulation_id()?,
        world: None,
        head: 0,
        prev_seq: 0,
        summary: Summary {
            events: 0,
            state_events: 0,
            reads_checked: 0,
            snapshots_checked: 0,
            steps: 0,
            final_hash: String::new(),
        },
    };
    let total = events.len() as u64;
    for e in &events {
        r.event(e)?;
        progress(r.summary.events, total);
    }
    Ok(r.summary)
}

/// A saved JSON file, parsed (not verified).
fn read_saved(path: &Path) -> Result<crate::files::save_format::SaveFile, StoreError> {
    let bytes = crate::files::read::read_operator_file(path, crate::files::save_format::MAX_SAVE_BYTES).map_err(StoreError::Corrupt)?;
    serde_json::from_slice(&bytes).map_err(|e| StoreError::Corrupt(format!("not a saved simulation: {e}")))
}

/// Replays a saved JSON file's history: every event refolded from create_simulation in a
/// fresh world (its snapshot is never trusted here), every recorded state hash checked.
pub fn replay_saved(path: &Path, mut progress: impl FnMut(u64, u64)) -> Result<Summary, ReplayError> {
    let h = read_saved(path)?
        .history
        .ok_or_else(|| StoreError::Corrupt("the file has no history to replay".into()))?;
    let untrusted = [0u8; 32];
    let limits = crate::limits::Limits { max_steps: u64::MAX, ..Default::default() };
    let (world, chain) = crate::files::save_format::world_from_history(&h, &untrusted, &limits, &mut progress)
        .map_err(|why| {
            ReplayError::Diverged(Box::new(Divergence {
                seq: 0,
                tool: "history".into(),
                arguments: String::new(),
                what: "refold".into(),
                expected: "every recorded hash".into(),
                actual: why,
            }))
        })?;
    let steps = chain
        .iter()
        .filter_map(|e| match fold::decode(e, &crate::command::NoBlobs) {
            Ok(Some(Command::StepSimulation { steps, .. })) => Some(steps),
            _ => None,
        })
        .sum();
    Ok(Summary {
        events: chain.len() as u64,
        state_events: chain.len() as u64,
        reads_checked: 0,
        snapshots_checked: 0,
        steps,
        final_hash: world.state_hash(),
    })
}

/// The engine build that made one root event of a log or saved file.
#[derive(Serialize, Debug, Clone, PartialEq, Eq)]
pub struct RootBuild {
    /// The root event.
    pub seq: u64,
    /// The build it records, or `UNRECORDED_ENGINE_BUILD` for a root from before builds were
    /// recorded.
    pub engine: String,
    /// Whether the root recorded it (false: read as the build of its time).
    pub recorded: bool,
    /// The crates whose versions differ from this binary's build, compared as maps
    /// (`engine::differences`); empty, and left out of the JSON, when this build made it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub differences: Vec<crate::engine::CrateDifference>,
}

/// Which engine builds made a log's roots (inherited ones included), against this binary's:
/// docs/log-format.md "Compatibility of logs and files" wants `replay` to say so before anything else when they differ.
#[derive(Serialize, Debug, Clone)]
pub struct EngineBuilds {
    /// This binary's build (`engine::ENGINE_BUILD`).
    pub this: String,
    /// Every root event, in seq order.
    pub roots: Vec<RootBuild>,
    /// Whether any root was made by another build than this binary.
    pub differs: bool,
}

impl EngineBuilds {
    fn of(roots: impl Iterator<Item = (u64, Option<String>)>) -> EngineBuilds {
        let this = crate::engine::ENGINE_BUILD;
        let roots: Vec<RootBuild> = roots
            .map(|(seq, recorded)| {
                let engine = crate::engine::engine_build_of(recorded.as_deref()).to_owned();
                let differences = crate::engine::differences(&engine, this);
                RootBuild { seq, engine, recorded: recorded.is_some(), differences }
            })
            .collect();
        let differs = roots.iter().any(|r| !r.differences.is_empty());
        EngineBuilds { this: this.into(), roots, differs }
    }

    /// The roots made by another build than this binary.
    pub fn foreign(&self) -> Vec<&RootBuild> {
        self.roots.iter().filter(|r| !r.differences.is_empty()).collect()
    }

    /// One line naming, for each root another build made, the crates that differ (`crate:
    /// recorded → this binary`), or `None` when this build made them all.
    pub fn warning(&self) -> Option<String> {
        let foreign = self.foreign();
        if foreign.is_empty() {
            return None;
        }
        let which: Vec<String> = foreign
            .iter()
            .map(|r| {
                let crates: Vec<String> = r.differences.iter().map(ToString::to_string).collect();
                format!("root event {} ({})", r.seq, crates.join("; "))
            })
            .collect();
        Some(format!(
            "engine build differs (crate: recorded → this binary): {}; this log was made by another engine build, so its recorded hashes may not reproduce",
            which.join(", ")
        ))
    }
}

/// The engine builds of a simulation log's roots, or of a saved JSON file's (`.json`).
pub fn engine_builds(path: &Path) -> Result<EngineBuilds, StoreError> {
    if path.extension().is_some_and(|x| x == "json") {
        let events = read_saved(path)?.history.map(|h| h.events).unwrap_or_default();
        return Ok(EngineBuilds::of(events.into_iter().filter(|e| e.kind == "root").map(|e| (e.seq, e.engine))));
    }
    let events = Log::open_read_only(path)?.all_events()?;
    Ok(EngineBuilds::of(events.into_iter().filter(|e| e.kind == Kind::Root).map(|e| (e.seq, e.engine))))
}

/// The events of a log, for `history`.
pub fn events(path: &Path) -> Result<Vec<Event>, StoreError> {
    Log::open_read_only(path)?.all_events()
}

/// The first event where two logs differ (seq, kind, tool, arguments, command, outcome or
/// hashes),
/// described in one line; None when they are the same.
pub fn diff(a: &Path, b: &Path) -> Result<Option<String>, StoreError> {
    let (ea, eb) = (events(a)?, events(b)?);
    for (x, y) in ea.iter().zip(&eb) {
        let fields = [
            ("seq", x.seq.to_string(), y.seq.to_string()),
            ("kind", x.kind.as_str().to_string(), y.kind.as_str().to_string()),
            ("tool", x.tool.clone(), y.tool.clone()),
            ("arguments", x.arguments.clone(), y.arguments.clone()),
            ("command", format!("{:?}", x.command), format!("{:?}", y.command)),
            ("ok", x.ok.to_string(), y.ok.to_string()),
            ("result hash", format!("{:?}", x.result_hash), format!("{:?}", y.result_hash)),
            ("state hash", x.state_hash.clone(), y.state_hash.clone()),
        ];
        if let Some((what, va, vb)) = fields.iter().find(|(_, va, vb)| va != vb) {
            return Ok(Some(format!(
                "first divergence at event #{} (seq {} / {}), tool {}: {what} differs: {va} vs {vb}",
                ea.iter().position(|e| e.seq == x.seq).unwrap_or(0) + 1,
                x.seq,
                y.seq,
                x.tool
            )));
        }
    }
    if ea.len() != eb.len() {
        return Ok(Some(format!(
            "the logs agree on their first {} events; then one has {} events and the other {}",
            ea.len().min(eb.len()),
            ea.len(),
            eb.len()
        )));
    }
    Ok(None)
}

/// The interval `replay --trajectory/--render` and `report` look at, lent from the log at
/// `path` (opened read-only and handed back): the whole chain of the head (from its first
/// event) unless `from`/`to` say otherwise.
pub fn open_interval(path: &Path, from: Option<u64>, to: Option<u64>) -> Result<(Log, fold::Lent), String> {
    if path.extension().is_some_and(|x| x == "json") {
        return Err(format!("{}: pictures and trajectories need a simulation log (.sqlite), not a saved file", path.display()));
    }
    let log = Log::open_read_only(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let id = log.simulation_id().map_err(|e| e.to_string())?;
    let to = to.unwrap_or(log.head_seq());
    let from = match from {
        Some(f) => f,
        None => log.chain_back(to, &mut |_| false).map_err(|e| e.to_string())?.last().map_or(to, |e| e.seq),
    };
    let lent = fold::lend(&log, &id, Some(from), Some(to))?;
    Ok((log, lent))
}

/// `open_interval`'s lent interval alone.
pub fn lend_interval(path: &Path, from: Option<u64>, to: Option<u64>) -> Result<fold::Lent, String> {
    open_interval(path, from, to).map(|(_, lent)| lent)
}

/// `replay FILE --trajectory OUT`: every object's poses and velocities over the interval,
/// sampled by the one re-simulation core (recorded hashes checked), written as .csv or .jsonl.
/// An existing `out` is replaced only with `force` (`--force`).
pub fn write_trajectory(path: &Path, out: &Path, args: &crate::cli::IntervalArgs, force: bool) -> Result<crate::outputs::Trajectory, String> {
    use crate::seeing::trajectory::{self, FileForm};
    let form = trajectory::file_form(&out.display().to_string(), "--trajectory", &[FileForm::Csv, FileForm::Jsonl])?;
    let (lent, req) = interval_request(path, args, true)?;
    let t = trajectory::sample_interval(&lent, &req)?;
    crate::files::write::write_operator_file(out, &trajectory::file_bytes(&t, form), force)?;
    Ok(t)
}

/// `replay FILE --mcap OUT`: the same interval and samples as `--trajectory`, every object,
/// as Foxglove messages (`seeing::foxglove`), with the contact points when `contacts`
/// (`--contacts`). An existing `out` is replaced only with `force`. Returns the trajectory
/// sampled and the file's size.
pub fn write_mcap(path: &Path, out: &Path, args: &crate::cli::IntervalArgs, contacts: bool, force: bool) -> Result<(crate::outputs::Trajectory, usize), String> {
    use crate::seeing::trajectory::{self, FileForm};
    trajectory::file_form(&out.display().to_string(), "--mcap", &[FileForm::Mcap])?;
    let (lent, req) = interval_request(path, args, false)?;
    let (t, bytes) = crate::seeing::foxglove::export(&lent, &req, contacts)?;
    crate::files::write::write_operator_file(out, &bytes, force)?;
    Ok((t, bytes.len()))
}

/// The interval `args` names of the log at `path` and what to sample of it: every object,
/// at `--every` (refused when 0), velocities when `velocities`.
fn interval_request(path: &Path, args: &crate::cli::IntervalArgs, velocities: bool) -> Result<(fold::Lent, crate::seeing::trajectory::Request), String> {
    if args.every == Some(0) {
        return Err("--every must be at least 1".into());
    }
    let lent = lend_interval(path, args.from, args.to)?;
    Ok((lent, crate::seeing::trajectory::Request { every: args.every, object_ids: None, include_velocities: velocities }))
}

/// A read's recorded arguments: inline, or — over 64 KB, as a large ray batch's are — the
/// blob `{"blob": hash, "bytes": n}` points to (`Log::store_arguments`). Every read takes a
/// sim_id, so real arguments are never that two-field object.
fn read_arguments(log: &dyn EventLog, stored: &str) -> Args {
    let args: Args = serde_json::from_str(stored).unwrap_or_default();
    let blob = match (args.len(), args.get("blob").and_then(Value::as_str), args.get("bytes")) {
        (2, Some(hash), Some(_)) => log.get_blob(hash),
        _ => None,
    };
    blob.and_then(|bytes| serde_json::from_slice(&bytes).ok()).unwrap_or(args)
}
