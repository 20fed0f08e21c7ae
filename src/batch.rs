//! `batch` (SPEC "Scale"): many calls on one simulation in one request, all or nothing.
//!
//! The calls are applied in order to a working copy of the world (`World::duplicate`), each
//! checked against the state the earlier ones leave. The first refusal (or a cancelled step)
//! refuses the whole batch: one refused event is logged and the world, its hash, head and
//! undo chain are as before. Accepted, every call is its own event — a change or a read,
//! exactly what the same call made alone records — and all of them commit in one
//! transaction, so undo still takes back one call and replay needs nothing new.

use serde_json::Value;

use crate::command::Command;
use crate::limits::Limits;
use crate::outputs::Batched;
use crate::reads::{Read, ReadContext};
use crate::sim::{Sim, SNAPSHOT_EVERY_BODY_STEPS, SNAPSHOT_EVERY_CHANGES};
use crate::store::{Event, Kind};
use crate::value::{Args, Refusal};
use crate::world::StepControl;

/// The most calls one batch may hold (SPEC).
pub const MAX_CALLS: usize = 10_000;

/// The tools a batch may hold besides the state-changing ones (SPEC "Scale").
pub const READS: [&str; 4] = ["get_object_state", "get_joint_state", "get_link_state", "get_simulation_info"];

/// What the adapter decided a call is: a change's command or one of the batch's reads —
/// or why the call is refused, which refuses the batch.
pub enum Planned {
    /// A state-changing call.
    Change(Result<Command, Refusal>),
    /// A read (boxed: some reads' parameters are large).
    Read(Result<Box<Read>, Refusal>),
}

/// One call of a batch: its tool, its arguments as they will be logged, what it is.
pub struct Call {
    /// The tool name.
    pub tool: String,
    /// The arguments, `sim_id` included.
    pub args: Args,
    /// The decided call.
    pub planned: Planned,
}

/// The sentence that refuses a batch because of one of its calls.
pub fn call_refused(index: usize, tool: &str, why: &str) -> Refusal {
    format!("calls[{index}] ({tool}) was refused, so nothing changed: {why}")
}

/// Steps asked by the batch's step calls together, refused over --max-steps before any work.
fn check_steps(calls: &[Call], limits: &Limits) -> Result<(), Refusal> {
    let steps: u64 = calls
        .iter()
        .map(|c| match &c.planned {
            Planned::Change(Ok(Command::StepSimulation { steps })) => *steps,
            _ => 0,
        })
        .fold(0u64, u64::saturating_add);
    if steps > limits.max_steps {
        return Err(format!(
            "calls: the batch's steps come to {steps}, over the {} allowed in one request (--max-steps)",
            limits.max_steps
        ));
    }
    Ok(())
}

impl Sim {
    /// Applies `calls` all or nothing (module doc). `args` are the batch's own arguments (for
    /// the refused event); `budget` is the reply budget the answer must fit.
    pub fn batch(
        &mut self,
        args: &Args,
        calls: Vec<Call>,
        limits: &Limits,
        budget: usize,
        control: StepControl,
    ) -> Result<Batched, Refusal> {
        self.ensure_live()?;
        let planned = check_steps(&calls, limits).and_then(|()| self.plan(calls, limits, control));
        let Plan { work, events, snapshots, results, blobs } = match planned {
            Ok(p) => p,
            Err(why) => return Err(self.refuse("batch", args, why)),
        };
        let head_seq = events.iter().rev().find(|e| e.kind == Kind::Change).map_or(self.log.head_seq(), |e| e.seq);
        let state_hash = events.last().map_or(self.state_hash.clone(), |e| e.state_hash.clone());
        let out = Batched { results, head_seq, state_hash };
        let bytes = crate::mcp::reply::reply_bytes("batch", serde_json::to_value(&out).unwrap_or_default());
        if bytes > budget {
            return Err(self.refuse("batch", args, crate::mcp::reply::over_budget("batch", bytes as u64, budget)));
        }
        for b in &blobs {
            if let Err(err) = self.log.put_blob(&b.hash, &b.bytes) {
                return Err(self.refuse("batch", args, format!("The batch's files could not be recorded: {err}")));
            }
        }
        let events: Vec<Event> = events
            .into_iter()
            .map(|mut e| {
                e.arguments = self.log.store_arguments(std::mem::take(&mut e.arguments));
                e
            })
            .collect();
        let snaps: Vec<crate::store::Snap> = snapshots.iter().map(|(s, b, h)| (*s, b.as_slice(), h.as_str())).collect();
        if let Err(err) = self.log.append_batch(&events, head_seq, &snaps) {
            return Err(self.refuse("batch", args, format!("The batch could not be recorded and changed nothing: {err}")));
        }
        self.world = work.world;
        self.state_hash = out.state_hash.clone();
        self.work_since_snapshot = work.work_since_snapshot;
        self.changes_since_snapshot = work.changes_since_snapshot;
        if !snapshots.is_empty() {
            self.thin_snapshots();
        }
        if events.iter().any(|e| e.kind == Kind::Change) {
            self.redo.clear();
        }
        Ok(out)
    }

    /// Applies the calls to a copy of the world, building their events (seqs after the
    /// log's last), the snapshots due on the way and each call's result. Nothing is written.
    fn plan(&self, calls: Vec<Call>, limits: &Limits, control: StepControl) -> Result<Plan, Refusal> {
        let mut work = crate::sim::Rebuilt {
            world: self.world.duplicate(),
            work_since_snapshot: self.work_since_snapshot,
            changes_since_snapshot: self.changes_since_snapshot,
        };
        let (mut head, mut hash) = (self.log.head_seq(), self.state_hash.clone());
        let mut events = Vec::with_capacity(calls.len());
        let mut snapshots = Vec::new();
        let mut results = Vec::with_capacity(calls.len());
        let mut blobs = Vec::new();
        for (i, call) in calls.into_iter().enumerate() {
            let seq = self.log.next_seq() + i as u64;
            let refused = |why: Refusal| call_refused(i, &call.tool, &why);
            // Arguments stay raw JSON until the batch commits (`store_arguments` may write a blob).
            let mut e = crate::sim::blank_event(seq, Kind::Read, &call.tool, serde_json::to_string(&call.args).unwrap_or_default());
            match call.planned {
                Planned::Change(decided) => {
                    let cmd = decided.and_then(|c| c.validate(&work.world, limits).map(|()| c)).map_err(refused)?;
                    let asked = match &cmd {
                        Command::StepSimulation { steps } => Some(*steps),
                        _ => None,
                    };
                    blobs.extend(cmd.blobs().into_iter().cloned());
                    let result = work.world.apply(&cmd, &mut *control);
                    if asked.is_some_and(|a| result.steps_taken().is_some_and(|t| t < a)) {
                        return Err(format!("The batch was cancelled at calls[{i}] ({}) and changed nothing", call.tool));
                    }
                    work.work_since_snapshot += crate::fold::work(&cmd, &work.world);
                    work.changes_since_snapshot += 1;
                    let value = result.to_value();
                    let json = value.to_string();
                    hash = work.world.state_hash();
                    e.kind = Kind::Change;
                    e.mutates = true;
                    e.parent = Some(head);
                    e.command = Some(serde_json::to_string(&cmd).map_err(|err| err.to_string())?);
                    e.result_hash = Some(crate::digest::result_hash(&json));
                    e.result = Some(json);
                    e.state_hash = hash.clone();
                    head = seq;
                    // Within a batch a snapshot is taken for real work (steps); the count of
                    // cheap changes is settled once, at the batch's last change (below).
                    if work.work_since_snapshot >= SNAPSHOT_EVERY_BODY_STEPS {
                        snapshots.push(snapshot_of(&work.world, seq));
                        work.work_since_snapshot = 0;
                        work.changes_since_snapshot = 0;
                    }
                    results.push(value);
                }
                Planned::Read(read) => {
                    let cx = ReadContext { world: &work.world, head_seq: head, last_seq: seq - 1, state_hash: &hash };
                    let value = read
                        .and_then(|r| r.replay(&cx).unwrap_or_else(|| Err("not a read a batch can hold".into())))
                        .map_err(refused)?;
                    e.result_hash = Some(crate::digest::result_hash(&value.to_string()));
                    e.state_hash = hash.clone();
                    results.push(value);
                }
            }
            events.push(e);
        }
        if work.changes_since_snapshot >= SNAPSHOT_EVERY_CHANGES && head != self.log.head_seq() {
            snapshots.push(snapshot_of(&work.world, head));
            work.work_since_snapshot = 0;
            work.changes_since_snapshot = 0;
        }
        Ok(Plan { work, events, snapshots, results, blobs })
    }
}

/// A snapshot of `world` taken at event `seq`: (seq, bytes, content hash).
fn snapshot_of(world: &crate::world::World, seq: u64) -> (u64, Vec<u8>, String) {
    let (bytes, hash) = crate::sim::snapshot_with_hash(world);
    (seq, bytes, hash)
}

/// A batch worked out on a copy of the world, not yet written.
struct Plan {
    /// The world after the last call, with the snapshot bookkeeping.
    work: crate::sim::Rebuilt,
    /// One event per call, in seq order.
    events: Vec<Event>,
    /// Snapshots due along the way: (seq, bytes, content hash).
    snapshots: Vec<(u64, Vec<u8>, String)>,
    /// Each call's result.
    results: Vec<Value>,
    /// The files the calls carry (load_urdf, load_mjcf), stored before the events.
    blobs: Vec<crate::command::Blob>,
}
