//! The one fold routine: decode an event → check its command → apply it → compare the world
//! with the event's recorded state hash. Recovery, undo/redo, forks, verification, loading a
//! foreign saved file and `replay` all fold through here, so they cannot disagree about what an
//! event means (a cancelled step, #16) or let an unchecked command into `World::apply`.

use crate::log::EventLog;
use std::sync::atomic::Ordering::Relaxed;
use std::collections::BTreeSet;

use serde_json::Value;

use crate::command::{BlobSource, Command};
use crate::limits::Limits;
use crate::outputs::Outcome;
use crate::log::sqlite::{Event, Kind, StoreError};
use crate::world::World;

/// Why a fold stopped at an event.
#[derive(Debug, Clone)]
pub enum FoldError {
    /// The event does not decode (no command, bad JSON, a missing blob).
    Undecodable {
        /// The event.
        seq: u64,
        /// Why.
        why: String,
    },
    /// The command does not pass `Command::validate` (a hostile or foreign log).
    Refused {
        /// The event.
        seq: u64,
        /// The refusal sentence.
        why: String,
    },
    /// The event's model names a file the log does not hold (an MJCF `<asset><model file>`
    /// recorded before files were resolved into blobs): folding it would read that file.
    NeedsFile {
        /// The event.
        seq: u64,
        /// The file as the model names it.
        file: String,
    },
    /// Shutdown stopped the fold (a re-simulation) at this event.
    Stopped {
        /// The event.
        seq: u64,
    },
    /// The re-simulation's caller stopped it at this event: its client cancelled the request
    /// or went away (`Bounds::stop`).
    Cancelled {
        /// The event.
        seq: u64,
    },
    /// The re-simulation would cost more than its caller allows (`Bounds::max_work`); refused
    /// before anything was folded. The sentence says what would fit.
    OverBudget {
        /// The refusal sentence (`Price::refusal`).
        why: String,
    },
    /// The world after the event is not the one the event recorded.
    Diverged {
        /// The event.
        seq: u64,
        /// Its tool.
        tool: String,
        /// What the event recorded.
        expected: String,
        /// What folding gave.
        actual: String,
    },
}

impl std::fmt::Display for FoldError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FoldError::Undecodable { seq, why } => write!(f, "event {seq} does not decode: {why}"),
            FoldError::Refused { seq, why } => write!(f, "event {seq} is refused: {why}"),
            FoldError::NeedsFile { seq, file } => write!(f, "event {seq} needs file {file}, which the log does not hold"),
            FoldError::Stopped { seq } => write!(f, "{} at event {seq}", crate::shutdown::STOPPED),
            FoldError::Cancelled { seq } => write!(f, "{CANCELLED} (at event {seq})"),
            FoldError::OverBudget { why } => f.write_str(why),
            FoldError::Diverged { seq, tool, expected, actual } => {
                write!(f, "state hash diverges at seq {seq} ({tool}): expected {expected}, got {actual}")
            }
        }
    }
}

/// The sentence a re-simulation stopped by its caller ends with: nobody waits for its answer.
pub const CANCELLED: &str = "The request was cancelled or its client went away; the re-simulation was stopped";

impl FoldError {
    /// The sentence a caller shows for this error, `what` (e.g. "The interval could not be
    /// re-simulated") leading the ones that say the log is at fault; a stop or a refusal over
    /// budget is its own sentence.
    pub fn explained(&self, what: &str) -> String {
        match self {
            FoldError::Cancelled { .. } | FoldError::OverBudget { .. } => self.to_string(),
            _ => format!("{what}: {self}"),
        }
    }
}

impl From<FoldError> for StoreError {
    fn from(e: FoldError) -> Self {
        StoreError::Corrupt(e.to_string())
    }
}

/// Which recorded state hashes a fold compares.
#[derive(Clone, Copy, Debug)]
pub enum Verify {
    /// Every event's (recovery, verification, foreign files, replay).
    Each,
    /// Only this event's (undo and fork: the fold is deterministic and the target proves it).
    Only(u64),
}

/// What a fold did, for the snapshot policy (`sim::SNAPSHOT_EVERY_*`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Folded {
    /// Simulation work in body-steps (`work`).
    pub work: u64,
    /// State-changing events applied.
    pub changes: u32,
}

/// Simulation work a command did, in body-steps (the snapshot policy's measure).
pub fn work(cmd: &Command, world: &World) -> u64 {
    match cmd {
        Command::StepSimulation { steps, .. } => steps * (world.object_count() as u64).max(1),
        _ => 0,
    }
}

/// The event version from which a step's command records the steps taken.
const STEPS_AS_TAKEN_SINCE: u32 = 2;

/// The command an event recorded, with its blobs' bytes filled in from `blobs`, as it was
/// carried out (`Command::as_done`: before event version 2 a cancelled step was logged as the
/// steps asked; its recorded result says how many it took — an upcast of old events only, so
/// a newer event whose command and result disagree is corrupt, not corrected). None for events
/// without a command.
pub fn decode(e: &Event, blobs: &dyn BlobSource) -> Result<Option<Command>, FoldError> {
    let Some(text) = e.command.as_deref() else {
        return Ok(None);
    };
    let undecodable = |why: String| FoldError::Undecodable { seq: e.seq, why };
    let mut cmd: Command = serde_json::from_str(text).map_err(|err| undecodable(err.to_string()))?;
    cmd.hydrate(blobs).map_err(undecodable)?;
    Ok(Some(upcast(cmd, e)))
}

/// The blobs the commands of `chain` refer to, by hash, read from `src`: what a fork or a
/// saved file must carry so its chain folds without the log it came from.
pub fn chain_blobs(chain: &[Event], src: &dyn BlobSource) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    for e in chain {
        let Some(cmd) = e.command.as_deref().and_then(|c| serde_json::from_str::<Command>(c).ok()) else { continue };
        for b in cmd.blobs() {
            if !out.contains_key(&b.hash) {
                if let Some(bytes) = src.blob(&b.hash) {
                    out.insert(b.hash.clone(), bytes);
                }
            }
        }
    }
    out
}

/// `cmd` (recorded by `e`) as it was carried out: events older than `STEPS_AS_TAKEN_SINCE`
/// get the steps their recorded result says they took; newer ones are returned unchanged.
pub fn upcast(cmd: Command, e: &Event) -> Command {
    if e.version >= STEPS_AS_TAKEN_SINCE {
        return cmd;
    }
    match e.result.as_deref().and_then(|r| serde_json::from_str::<Value>(r).ok()) {
        Some(result) => cmd.as_done(&result),
        None => cmd,
    }
}

/// Checks a stored snapshot taken at event `e`: its bytes against their recorded hash, and the
/// world it restores to against `e`'s recorded state hash (verify_simulation and replay).
pub fn check_snapshot(e: &Event, bytes: &[u8], hash: &str) -> Result<(), FoldError> {
    let diverged = |expected: &str, actual: String| FoldError::Diverged {
        seq: e.seq,
        tool: e.tool.clone(),
        expected: expected.into(),
        actual,
    };
    let bytes_hash = crate::digest::content_hash(bytes);
    if bytes_hash != hash {
        return Err(diverged(hash, bytes_hash));
    }
    match World::restore("snapshot-check", false, bytes) {
        Ok(w) if w.state_hash() == e.state_hash => Ok(()),
        Ok(w) => Err(diverged(&e.state_hash, w.state_hash())),
        Err(err) => Err(diverged(&e.state_hash, err)),
    }
}

/// Compares the world with the state hash `e` recorded.
pub fn check_hash(world: &World, e: &Event) -> Result<(), FoldError> {
    let actual = world.state_hash();
    if actual == e.state_hash {
        Ok(())
    } else {
        Err(FoldError::Diverged { seq: e.seq, tool: e.tool.clone(), expected: e.state_hash.clone(), actual })
    }
}

/// Applies an accepted command to `world` under the rules of event version `version`, with
/// `World::apply_observed`'s hooks: the one place a change's result is computed, live
/// (`sim::apply`) and in every fold, so replay re-derives what the log recorded. A step that
/// asks `measure` (from `measure::RECORDED_SINCE`) is measured over its first state and every
/// step it takes (`seeing::measure::Meter`), the exact answers part of its result; an older
/// event's step is applied as it was (its result had none).
pub fn apply(world: &mut World, cmd: &Command, version: u32, control: crate::world::StepControl, observe: crate::world::StepObserver) -> Outcome {
    let specs = match cmd {
        Command::StepSimulation { measure: Some(specs), .. } if version >= crate::measure::RECORDED_SINCE && !specs.is_empty() => specs,
        _ => return world.apply_observed(cmd, control, observe),
    };
    let mut meter = crate::seeing::measure::Meter::new(specs.clone());
    meter.see(world);
    let mut out = world.apply_observed(cmd, control, &mut |w: &World| {
        observe(w);
        meter.see(w);
    });
    if let Outcome::Stepped(stepped) = &mut out {
        stepped.measures = Some(meter.finish(None));
    }
    out
}

/// Folds one state-changing event onto `world`: decode, check against the world and `limits`,
/// apply (a fork's or load's root in a chain changes nothing; a second create_simulation is
/// refused), and compare the recorded hash when `verify` says so. Returns the command and
/// its result.
pub fn fold_event(
    world: &mut World,
    e: &Event,
    blobs: &dyn BlobSource,
    limits: &Limits,
    verify: bool,
) -> Result<(Command, Option<Outcome>), FoldError> {
    let cmd = decode(e, blobs)?.ok_or_else(|| FoldError::Undecodable { seq: e.seq, why: "it has no command".into() })?;
    fold_decoded(world, e, cmd, limits, verify, &mut |_| true, &mut |_| {})
}

/// `fold_event` for an already decoded command, with the step hooks of `World::apply_observed`
/// (`control` may stop a step early; `observe` sees the world after every step). The one
/// place an event's command reaches `World::apply` (through `apply`).
pub fn fold_decoded(
    world: &mut World,
    e: &Event,
    cmd: Command,
    limits: &Limits,
    verify: bool,
    control: crate::world::StepControl,
    observe: crate::world::StepObserver,
) -> Result<(Command, Option<Outcome>), FoldError> {
    let result = match &cmd {
        Command::ForkSimulation { .. } | Command::LoadSimulation { .. } => {
            // It changes nothing, but its values (a label) are held to the edge's rules.
            cmd.validate_values().map_err(|why| FoldError::Refused { seq: e.seq, why })?;
            None
        }
        Command::CreateSimulation { .. } => {
            return Err(FoldError::Refused { seq: e.seq, why: "a second create_simulation in one chain".into() })
        }
        _ => {
            // A fold reads nothing but the log: a model that names a file of its own is not
            // folded (docs/log-format.md "Compatibility of logs and files": the one exception to old logs folding).
            if let Command::LoadMjcf { mjcf, .. } = &cmd {
                if let Some(r) = crate::world::mjcf::file_reference(&String::from_utf8_lossy(&mjcf.bytes)) {
                    return Err(FoldError::NeedsFile { seq: e.seq, file: r.file });
                }
            }
            cmd.validate(world, limits).map_err(|why| FoldError::Refused { seq: e.seq, why })?;
            Some(apply(world, &cmd, e.version, control, observe).land(e.seq, world.current_time()))
        }
    };
    if verify {
        check_hash(world, e)?;
    }
    Ok((cmd, result))
}

/// Folds `events` (a chain's state-changing events after `world`'s, oldest first) onto
/// `world` with `fold_event`; `after(world, event, index)` sees each folded event (snapshot
/// checks, progress) and may stop the fold with an error.
pub fn fold(
    world: &mut World,
    events: &[Event],
    blobs: &dyn BlobSource,
    limits: &Limits,
    verify: Verify,
    after: &mut dyn FnMut(&World, &Event, usize) -> Result<(), FoldError>,
) -> Result<Folded, FoldError> {
    let mut done = Folded::default();
    for (i, e) in events.iter().enumerate() {
        let check = match verify {
            Verify::Each => true,
            Verify::Only(seq) => seq == e.seq,
        };
        let (cmd, _) = fold_event(world, e, blobs, limits, check)?;
        done.work += work(&cmd, world);
        done.changes += 1;
        after(world, e, i)?;
    }
    Ok(done)
}

/// The world a chain's first event (create_simulation) builds, its values validated first
/// (a foreign file's root may hold anything), under the state hash rules of the root's event
/// version, with the command's own result.
pub fn create_root(e: &Event, blobs: &dyn BlobSource) -> Result<(World, Outcome), FoldError> {
    let refused = |why: String| FoldError::Refused { seq: e.seq, why };
    let root = decode(e, blobs)?.ok_or_else(|| refused("it has no command".into()))?;
    root.validate_values().map_err(refused)?;
    let (world, result) = World::create(&root).ok_or_else(|| refused("the chain does not start with create_simulation".into()))?;
    // The chain keeps the state hash its root was recorded under (older logs: v1).
    let world = world.with_hash_rules(crate::command::hash_rules_of(e.version));
    let result = result.land(e.seq, world.current_time());
    Ok((world, result))
}

/// Who a root command says its simulation is: its id, its `gui` flag and its label (None for
/// any other command). A label a hand-edited log holds that a call could not have given is
/// left out. The one place the three root kinds are read for identity.
pub fn root_identity(cmd: &Command) -> Option<(&str, bool, Option<String>)> {
    match cmd {
        Command::CreateSimulation { simulation_id, gui, name, .. }
        | Command::ForkSimulation { simulation_id, gui, name, .. }
        | Command::LoadSimulation { simulation_id, gui, name, .. } => {
            Some((simulation_id, *gui, name.clone().filter(|n| crate::value::label("name", n).is_ok())))
        }
        _ => None,
    }
}

// ---- Looking back: the one re-simulation core (docs/design.md "The re-simulation core") ----

/// The chain from the nearest snapshot a fold may start from at or before `before` up to
/// `target` (oldest first), with that snapshot's bytes (hash checked; None: the chain starts
/// at create_simulation — a loaded file's inherited chain, or a log from before snapshot
/// version 3). Walks back only as far as it must; undo, fork, recovery and re-simulation
/// all start here.
pub fn chain_from_snapshot(log: &dyn EventLog, target: u64, before: u64) -> Result<(Vec<Event>, Option<Vec<u8>>), StoreError> {
    let snapshots: BTreeSet<u64> = log.snapshot_seqs()?.into_iter().collect();
    let mut chain = Vec::new();
    let mut from = Some(target);
    while let Some(seq) = from {
        let part = log.chain_back(seq, &mut |e| e.seq <= before && snapshots.contains(&e.seq))?;
        let oldest = part.last().ok_or_else(|| StoreError::Corrupt(format!("event {seq} is missing")))?;
        let (at, parent) = (oldest.seq, oldest.parent);
        from = parent;
        let snapshot = if at <= before && snapshots.contains(&at) { log.snapshot_at(at)? } else { None };
        chain.extend(part);
        if let Some((bytes, hash)) = snapshot {
            if crate::digest::content_hash(&bytes) != hash {
                return Err(StoreError::Corrupt(format!("snapshot at seq {at} does not match its hash")));
            }
            // Older-version snapshots are walked past: their hashes still prove the chain.
            if World::foldable_snapshot(&bytes) {
                chain.reverse();
                return Ok((chain, Some(bytes)));
            }
        }
    }
    chain.reverse();
    Ok((chain, None))
}

/// A stretch of a chain: from the state after event `from_seq` to the state after `to_seq`
/// (both state-changing events of the chain that leads to `to_seq`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Interval {
    /// The event whose resulting state is the interval's first.
    pub from_seq: u64,
    /// The event whose resulting state is the interval's last.
    pub to_seq: u64,
}

/// What a log lends a re-simulation, copied while the simulation is locked (fast: no
/// physics): the snapshot to start from and the decoded chain after it. Re-simulating it
/// (`resimulate`) needs neither the log nor the lock.
#[derive(Clone)]
pub struct Lent {
    /// The simulation's id (the scratch world's identity; not hashed).
    pub id: String,
    /// Snapshot bytes at `chain[0]` (None: `chain[0]` is create_simulation).
    pub start: Option<Vec<u8>>,
    /// The chain from the start to `interval.to_seq`, oldest first, commands decoded.
    pub chain: Vec<(Event, Command)>,
    /// The stretch to observe.
    pub interval: Interval,
    /// Steps of `interval.to_seq`'s step event the caller needs (None: all of them): a moment
    /// inside a step event (the viewer's `poses?seq&step`, whose observer stops there) is
    /// priced only that far.
    pub until_step: Option<u64>,
    /// The seqs of the chain's later snapshots (after `chain[0]`), for saying which later
    /// `from_seq` would start from one (`Price::refusal`).
    pub snapshots: Vec<u64>,
}

impl std::fmt::Debug for Lent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Lent({} {:?}, {} events, snapshot: {})", self.id, self.interval, self.chain.len(), self.start.is_some())
    }
}

impl Lent {
    /// Steps the interval's step events take (every recorded step is as taken, see `upcast`).
    pub fn interval_steps(&self) -> u64 {
        self.chain
            .iter()
            .filter(|(e, _)| e.seq > self.interval.from_seq)
            .map(|(_, c)| match c {
                Command::StepSimulation { steps, .. } => *steps,
                _ => 0,
            })
            .sum()
    }
}

/// What re-simulating a lent chain costs, in body-steps (steps × objects, as `work` counts
/// them), priced before anything is folded: from the start world's object count, each
/// command's change to it (an added object or model counts one, a removal takes one away — an
/// upper bound, since a load that fails adds none) and each step event's steps.
#[derive(Clone, Debug)]
pub struct Price {
    /// (seq, body-steps from the start through that event), oldest first.
    pub through: Vec<(u64, u64)>,
}

impl Price {
    /// Prices `lent` from a start world of `objects` objects.
    pub fn of(lent: &Lent, objects: usize) -> Price {
        let mut objects = objects as u64;
        let mut total = 0u64;
        let mut through = Vec::with_capacity(lent.chain.len());
        for (i, (e, cmd)) in lent.chain.iter().enumerate() {
            if i > 0 {
                match cmd {
                    Command::AddBody { .. } | Command::LoadUrdf { .. } | Command::LoadMjcf { .. } => objects += 1,
                    Command::RemoveObject { .. } => objects = objects.saturating_sub(1),
                    Command::StepSimulation { steps, .. } => {
                        let steps = match lent.until_step {
                            Some(k) if e.seq == lent.interval.to_seq => k.min(*steps),
                            _ => *steps,
                        };
                        total = total.saturating_add(steps.saturating_mul(objects.max(1)));
                    }
                    _ => {}
                }
            }
            through.push((e.seq, total));
        }
        Price { through }
    }

    /// The whole re-simulation's cost.
    pub fn total(&self) -> u64 {
        self.through.last().map_or(0, |(_, w)| *w)
    }

    /// Refuses a re-simulation of `lent` costing more than `max` body-steps (`--max-work`), in one
    /// sentence that says what fits: the latest `to_seq` whose re-simulation does, or the
    /// earliest later `from_seq` that starts from a snapshot close enough.
    pub fn check(&self, lent: &Lent, max: u64) -> Result<(), FoldError> {
        let total = self.total();
        if total <= max {
            return Ok(());
        }
        let Interval { from_seq, to_seq } = lent.interval;
        let start = self.through.first().map_or(from_seq, |(s, _)| *s);
        let cost_at = |seq: u64| self.through.iter().find(|(s, _)| *s == seq).map_or(0, |(_, w)| *w);
        let mut fits = Vec::new();
        if let Some((seq, _)) = self.through.iter().rev().find(|(s, w)| *s > from_seq && *s < to_seq && *w <= max) {
            fits.push(format!("a to_seq at or before {seq}"));
        }
        if let Some(seq) = lent.snapshots.iter().find(|s| **s > from_seq && **s < to_seq && total - cost_at(**s) <= max) {
            fits.push(format!("a from_seq at or after {seq} (a snapshot is kept there)"));
        }
        let fits = if fits.is_empty() {
            "no shorter interval of these events fits; a server started with a higher --max-work can re-simulate it".to_string()
        } else {
            format!("{} fits", fits.join(", or "))
        };
        Err(FoldError::OverBudget {
            why: format!(
                "Re-simulating simulation {}'s events {start} to {to_seq} would cost {total} body-steps (steps × objects), over the {max} one request may cost (--max-work); {fits}",
                lent.id
            ),
        })
    }
}

/// What a re-simulation on this thread may cost and who may stop it, set by its caller around
/// the work (`bounded`): a client's request is held to `--max-work` and stopped when the client
/// cancels or goes away; the command line (`replay`, `report`) runs unbounded.
#[derive(Clone, Debug, Default)]
pub struct Bounds {
    /// Cancelled when nobody waits for the answer any more.
    pub stop: Option<tokio_util::sync::CancellationToken>,
    /// Most body-steps one re-simulation may cost (None: any).
    pub max_work: Option<u64>,
}

impl Bounds {
    /// Whether the caller has stopped the work.
    pub fn stopped(&self) -> bool {
        self.stop.as_ref().is_some_and(|s| s.is_cancelled())
    }
}

thread_local! {
    static BOUNDS: std::cell::RefCell<Bounds> = std::cell::RefCell::new(Bounds::default());
}

/// Runs `f` with every re-simulation it makes on this thread held to `bounds` (the ones in force
/// before are back afterwards, even if `f` panics).
pub fn bounded<T>(bounds: Bounds, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<Bounds>);
    impl Drop for Restore {
        fn drop(&mut self) {
            if let Some(b) = self.0.take() {
                BOUNDS.with(|cell| *cell.borrow_mut() = b);
            }
        }
    }
    let _restore = Restore(Some(BOUNDS.with(|cell| cell.replace(bounds))));
    f()
}

/// The bounds in force on this thread (`bounded`).
pub fn current_bounds() -> Bounds {
    BOUNDS.with(|cell| cell.borrow().clone())
}

fn is_step(e: &Event) -> bool {
    e.command.as_deref().is_some_and(|c| matches!(serde_json::from_str::<Command>(c), Ok(Command::StepSimulation { .. })))
}

/// the documented default `from_seq` for an interval ending at `to`: the state just before the most
/// recent step_simulation on the chain (the root's when there is none).
pub fn default_from(log: &dyn EventLog, to: u64) -> Result<u64, StoreError> {
    let back = log.chain_back(to, &mut |e| e.kind == Kind::Root || is_step(e))?;
    let last = back.last().ok_or_else(|| StoreError::Corrupt(format!("event {to} is missing")))?;
    Ok(match (last.kind, last.parent) {
        (Kind::Root, _) | (_, None) => last.seq,
        (_, Some(parent)) => parent,
    })
}

/// Copies what re-simulating `from..to` of simulation `id` needs out of `log` (defaults:
/// `to` = the head, `from` = `default_from`). Refuses, naming the parameter, an end that
/// is not a state-changing event on the chain or a start after the end.
pub fn lend(log: &dyn EventLog, id: &str, from: Option<u64>, to: Option<u64>) -> Result<Lent, String> {
    let read = |e: StoreError| format!("The simulation's log could not be read: {e}");
    let to = to.unwrap_or(log.head_seq());
    if !log.event(to).map_err(read)?.is_some_and(|e| e.kind.is_state_changing()) {
        return Err(format!("to_seq {to} is not a state-changing event of simulation {id}"));
    }
    let from = match from {
        Some(f) => f,
        None => default_from(log, to).map_err(read)?,
    };
    if from > to {
        return Err(format!("from_seq {from} is after to_seq {to}; give a from_seq at or before to_seq"));
    }
    let (chain, start) = chain_from_snapshot(log, to, from).map_err(read)?;
    if !chain.iter().any(|e| e.seq == from) {
        return Err(off_chain(log, id, from, to).map_err(read)?);
    }
    let chain = chain
        .into_iter()
        .map(|e| {
            let cmd = decode(&e, log).map_err(|err| read(err.into()))?;
            let cmd = cmd.ok_or_else(|| read(StoreError::Corrupt(format!("event {} has no command", e.seq))))?;
            Ok((e, cmd))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let taken: BTreeSet<u64> = log.snapshot_seqs().map_err(read)?.into_iter().collect();
    let snapshots = chain.iter().skip(1).map(|(e, _)| e.seq).filter(|s| taken.contains(s)).collect();
    Ok(Lent { id: id.to_string(), start, chain, interval: Interval { from_seq: from, to_seq: to }, until_step: None, snapshots })
}

/// Why `from` cannot start an interval ending at `to`, and what to ask instead: an event of
/// another branch (undone, or left by a later change) is reached through its own chain, or
/// continued in a fork made there.
fn off_chain(log: &dyn EventLog, id: &str, from: u64, to: u64) -> Result<String, StoreError> {
    Ok(match log.event(from)? {
        Some(e) if e.kind.is_state_changing() => format!(
            "from_seq {from} is on another branch of simulation {id} (undone or replaced), not on the chain to to_seq {to}; \
             give to_seq={from} to look at that branch, or fork_simulation at_seq={from} to continue from it"
        ),
        Some(_) => format!("from_seq {from} is a read, not a state-changing event of simulation {id}; get_history lists the changes"),
        None => format!("from_seq {from} is not an event of simulation {id}; get_history lists its events"),
    })
}

/// Where an observer is called during a re-simulation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum At {
    /// The interval's first state (after `from_seq`).
    Start,
    /// Inside a step event, after every `every`-th step counted from the interval's start.
    Step,
    /// After an event of the interval (after `from_seq`) has been applied and its hash checked.
    Boundary,
}

/// What an observer is told with the world it sees.
#[derive(Clone, Copy, Debug)]
pub struct Moment {
    /// Which kind of point this is.
    pub at: At,
    /// The event the world is at (Start: `from_seq`; Step: the step event in progress).
    pub seq: u64,
    /// Steps simulated since the interval's start.
    pub steps: u64,
    /// Steps taken so far inside event `seq` (0 at Start and for events that are not steps).
    pub step_in_event: u64,
    /// Whether this is one of the documented samples: the first state, every `every`-th step, and the
    /// last state when anything changed since the previous sample.
    pub sample: bool,
    /// Whether this is the interval's last point (the Boundary of `to_seq`, or Start when
    /// `from_seq == to_seq`).
    pub last: bool,
}

/// the sampling rule (docs/tools.md "Seeing time"), shared by re-simulation and live stepping (step_simulation's
/// `sample_every`): sample the first state, after every `every`-th step counted from it, and
/// the last state when anything changed since the previous sample.
#[derive(Clone, Copy, Debug)]
pub struct Cadence {
    every: u64,
    /// Steps counted since the start.
    pub steps: u64,
    dirty: bool,
}

impl Cadence {
    /// Counting from the first state (which is always a sample).
    pub fn new(every: u64) -> Cadence {
        Cadence { every: every.max(1), steps: 0, dirty: false }
    }

    /// One step was taken: whether this is a sample.
    pub fn step(&mut self) -> bool {
        self.steps += 1;
        self.dirty = !self.steps.is_multiple_of(self.every);
        !self.dirty
    }

    /// Something other than a step changed the world.
    pub fn changed(&mut self) {
        self.dirty = true;
    }

    /// At the last state: whether it is a sample (something changed since the last one).
    pub fn end(&mut self) -> bool {
        std::mem::take(&mut self.dirty)
    }
}

/// Sees a re-simulation: the world (read-only) and where it is; returning false stops the
/// re-simulation there (the world returned is then wherever it stopped, unchecked).
pub type Observer<'a> = &'a mut (dyn FnMut(&World, &Moment) -> bool + Send);

/// The one re-simulation: restores `lent`'s snapshot into a scratch world, folds its chain
/// through `fold_decoded` checking every recorded state hash (a mismatch names the seq), and
/// calls `observer` at the interval's start, every `every` steps (≥ 1) inside step events,
/// and after every event of the interval. Returns the world at the interval's end. Nothing
/// live is touched: a `Lent` is a copy.
///
/// Held to the thread's `Bounds`: priced (`Price`) once the start world is restored and
/// refused over `max_work` before any event is folded; stopped at the next step when `stop`
/// is cancelled (as by shutdown, with its own sentence).
pub fn resimulate(lent: &Lent, every: u64, observer: Observer) -> Result<World, FoldError> {
    resimulate_stepwise(lent, every, false, observer)
}

/// `resimulate` whose observer also sees the world after every step in between the samples
/// (`Moment::sample` false there): what measures taken at every step ride on (get_trajectory's
/// `measure`), while the samples stay those of `every`.
pub fn resimulate_each(lent: &Lent, every: u64, observer: Observer) -> Result<World, FoldError> {
    resimulate_stepwise(lent, every, true, observer)
}

fn resimulate_stepwise(lent: &Lent, every: u64, each: bool, observer: Observer) -> Result<World, FoldError> {
    let every = every.max(1);
    let bounds = current_bounds();
    let (first, _) = lent.chain.first().ok_or(FoldError::Undecodable { seq: lent.interval.to_seq, why: "the chain is empty".into() })?;
    if bounds.stopped() {
        return Err(FoldError::Cancelled { seq: first.seq });
    }
    let mut world = match &lent.start {
        Some(bytes) => World::restore(&lent.id, false, bytes).map_err(|why| FoldError::Undecodable { seq: first.seq, why })?,
        None => create_root(first, &crate::command::NoBlobs)?.0.with_identity(&lent.id, false),
    };
    if let Some(max) = bounds.max_work {
        Price::of(lent, world.object_count()).check(lent, max)?;
    }
    check_hash(&world, first)?;
    let Interval { from_seq, to_seq } = lent.interval;
    let start = |world: &World, observer: &mut (dyn FnMut(&World, &Moment) -> bool + Send)| {
        let m = Moment { at: At::Start, seq: from_seq, steps: 0, step_in_event: 0, sample: true, last: from_seq == to_seq };
        observer(world, &m) && from_seq != to_seq
    };
    let mut started = first.seq == from_seq;
    if started && !start(&world, observer) {
        return Ok(world);
    }
    let mut cadence = Cadence::new(every);
    let limits = Limits::unbounded();
    for (e, cmd) in &lent.chain[1..] {
        // Atomic only because a step may run on the world's pool (see physics-core's threads.rs).
        let stop = std::sync::atomic::AtomicBool::new(false);
        let mut in_event = 0u64;
        {
            let mut on_step = |w: &World| {
                if !started || stop.load(Relaxed) {
                    return;
                }
                in_event += 1;
                let sample = cadence.step();
                if sample || each {
                    let m = Moment { at: At::Step, seq: e.seq, steps: cadence.steps, step_in_event: in_event, sample, last: false };
                    stop.store(!observer(w, &m), Relaxed);
                }
            };
            let mut control = |_: u64| !stop.load(Relaxed) && !crate::shutdown::requested() && !bounds.stopped();
            fold_decoded(&mut world, e, cmd.clone(), &limits, false, &mut control, &mut on_step)?;
        }
        if crate::shutdown::requested() {
            return Err(FoldError::Stopped { seq: e.seq });
        }
        if bounds.stopped() {
            tracing::info!(simulation = %lent.id, seq = e.seq, "re-simulation stopped: nobody waits for its answer");
            return Err(FoldError::Cancelled { seq: e.seq });
        }
        if stop.load(Relaxed) {
            return Ok(world);
        }
        check_hash(&world, e)?;
        if !started {
            started = e.seq == from_seq;
            if started && !start(&world, observer) {
                return Ok(world);
            }
            continue;
        }
        if !matches!(cmd, Command::StepSimulation { .. }) {
            cadence.changed();
        }
        let last = e.seq == to_seq;
        let sample = last && cadence.end();
        let m = Moment { at: At::Boundary, seq: e.seq, steps: cadence.steps, step_in_event: in_event, sample, last };
        if !observer(&world, &m) || last {
            break;
        }
    }
    Ok(world)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Shape;
    use crate::sim::{lock_sim, Config, Registry};
    use crate::log::sqlite::SyncMode;
    use crate::value::Args;

    fn body(z: f32, mass: f32) -> Command {
        Command::AddBody {
            shape: Shape::Box { half_extents: [0.5, 0.5, 0.5] },
            position: [0.0, 0.0, z],
            orientation: [0.0, 0.0, 0.0, 1.0],
            mass,
            color: None,
            collides: true,
        }
    }

    /// Positions of object 1 after each of `n` single steps on a fresh fold of `cmds`.
    fn stepwise(cmds: &[Command]) -> Vec<[f64; 3]> {
        let mut w = World::create(&Command::CreateSimulation { simulation_id: "r".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) }).unwrap().0;
        let mut out = vec![];
        for c in cmds {
            match c {
                Command::StepSimulation { steps, .. } => {
                    for _ in 0..*steps {
                        w.apply(&Command::step(1), &mut |_| true);
                        out.push(w.object_state(1).unwrap().position);
                    }
                }
                c => {
                    w.apply(c, &mut |_| true);
                }
            }
        }
        out
    }

    /// A registry in a temporary directory holding one empty simulation `id`.
    fn one_simulation(id: &str) -> (tempfile::TempDir, Registry) {
        let dir = tempfile::tempdir().unwrap();
        let reg = Registry::open(Config {
            data_dir: dir.path().join("data"),
            workspace: dir.path().join("ws"),
            limits: Limits::default(),
            sync: SyncMode::Normal,
        })
        .unwrap();
        reg.create(Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) }, &Args::new()).unwrap();
        (dir, reg)
    }

    #[test]
    fn resimulated_samples_equal_single_steps_and_hashes_hold() {
        let (_dir, reg) = one_simulation("s");
        let cmds = vec![
            body(-0.5, 0.0),
            body(2.0, 1.0),
            Command::step(30),
            Command::SetObjectPose { object_id: 1, position: [0.0, 0.0, 3.0], orientation: [0.0, 0.0, 0.0, 1.0] },
            Command::step(45),
        ];
        let s = reg.get("s").unwrap();
        let mut sim = lock_sim(&s);
        for c in &cmds {
            sim.change("t", &Args::new(), Ok(c.clone()), &Limits::default(), &mut |_| true).unwrap();
        }
        let reference = stepwise(&cmds);
        let head = sim.log().head_seq();
        // Default interval: the last step only.
        let lent = lend(sim.log(), sim.id(), None, None).unwrap();
        assert_eq!(lent.interval, Interval { from_seq: head - 1, to_seq: head });
        assert_eq!(lent.interval_steps(), 45);
        // From the first body to the head, every 7 steps.
        let lent = lend(sim.log(), sim.id(), Some(2), None).unwrap();
        let mut seen = vec![];
        let end = resimulate(&lent, 7, &mut |w, m| {
            if m.sample {
                seen.push((m.at, m.steps, w.object_state(1).map(|s| s.position)));
            }
            true
        })
        .unwrap();
        assert_eq!(end.state_hash(), sim.state_hash());
        assert_eq!(seen[0], (At::Start, 0, None));
        let steps: Vec<u64> = seen.iter().map(|s| s.1).collect();
        assert_eq!(steps, [0, 7, 14, 21, 28, 35, 42, 49, 56, 63, 70, 75]);
        for (_, k, p) in &seen[1..] {
            assert_eq!(p.unwrap(), reference[*k as usize - 1], "step {k}");
        }
        // Refusals.
        assert!(lend(sim.log(), sim.id(), Some(head), Some(2)).unwrap_err().contains("from_seq"));
        assert!(lend(sim.log(), sim.id(), None, Some(999)).unwrap_err().contains("to_seq 999"));
        // Stopping early: the observer's false ends it.
        let mut n = 0;
        resimulate(&lent, 1, &mut |_, _| {
            n += 1;
            n < 5
        })
        .unwrap();
        assert_eq!(n, 5);
    }

    #[test]
    fn a_re_simulation_is_priced_before_it_runs_and_stopped_when_asked() {
        let (_dir, reg) = one_simulation("p");
        let s = reg.get("p").unwrap();
        let mut sim = lock_sim(&s);
        let root = sim.log().head_seq();
        // Two objects, 30 steps (60 body-steps); a third, 45 steps (135).
        for c in [body(-0.5, 0.0), body(2.0, 1.0), Command::step(30), body(4.0, 1.0), Command::step(45)] {
            sim.change("t", &Args::new(), Ok(c), &Limits::default(), &mut |_| true).unwrap();
        }
        let head = sim.log().head_seq();
        let lent = lend(sim.log(), sim.id(), Some(root), None).unwrap();
        drop(sim);
        let price = Price::of(&lent, 0);
        assert_eq!(price.total(), 195);
        let within = |max: u64, stop: Option<tokio_util::sync::CancellationToken>| {
            bounded(Bounds { stop, max_work: Some(max) }, || resimulate(&lent, 1, &mut |_, _| true).map(|w| w.state_hash()))
        };
        assert!(within(195, None).is_ok());
        let why = within(194, None).unwrap_err().to_string();
        assert!(why.contains("would cost 195 body-steps") && why.contains(&format!("a to_seq at or before {} fits", head - 1)), "{why}");
        // Outside the scope, no bound.
        assert!(resimulate(&lent, 1, &mut |_, _| true).is_ok());
        // A stop before or during the work.
        let stop = tokio_util::sync::CancellationToken::new();
        stop.cancel();
        assert!(matches!(within(u64::MAX, Some(stop)), Err(FoldError::Cancelled { .. })));
        // A moment inside the last step event is priced only that far.
        let inside = Lent { until_step: Some(5), interval: Interval { from_seq: root, to_seq: head }, ..lent.clone() };
        assert_eq!(Price::of(&inside, 0).total(), 60 + 15);
    }
}
