//! The one fold routine: decode an event → check its command → apply it → compare the world
//! with the event's recorded state hash. Recovery, undo/redo, forks, verification, loading a
//! foreign saved file and `replay` all fold through here, so they cannot disagree about what an
//! event means (a cancelled step, #16) or let an unchecked command into `World::apply`.

use serde_json::Value;

use crate::command::{BlobSource, Command};
use crate::limits::Limits;
use crate::outputs::Outcome;
use crate::store::{Event, StoreError};
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
            FoldError::Diverged { seq, tool, expected, actual } => {
                write!(f, "state hash diverges at seq {seq} ({tool}): expected {expected}, got {actual}")
            }
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
        Command::StepSimulation { steps } => steps * (world.object_count() as u64).max(1),
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
    let result = match &cmd {
        Command::ForkSimulation { .. } | Command::LoadSimulation { .. } => None,
        Command::CreateSimulation { .. } => {
            return Err(FoldError::Refused { seq: e.seq, why: "a second create_simulation in one chain".into() })
        }
        _ => {
            cmd.validate(world, limits).map_err(|why| FoldError::Refused { seq: e.seq, why })?;
            Some(world.apply(&cmd, &mut |_| true))
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
/// (a foreign file's root may hold anything), with the command's own result.
pub fn create_root(e: &Event, blobs: &dyn BlobSource) -> Result<(World, Outcome), FoldError> {
    let refused = |why: String| FoldError::Refused { seq: e.seq, why };
    let root = decode(e, blobs)?.ok_or_else(|| refused("it has no command".into()))?;
    root.validate_values().map_err(refused)?;
    World::create(&root).ok_or_else(|| refused("the chain does not start with create_simulation".into()))
}

/// The `gui` flag a root command carries (None for any other command).
pub fn root_gui(cmd: &Command) -> Option<bool> {
    match cmd {
        Command::CreateSimulation { gui, .. }
        | Command::ForkSimulation { gui, .. }
        | Command::LoadSimulation { gui, .. } => Some(*gui),
        _ => None,
    }
}
