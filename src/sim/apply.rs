//! The one path by which calls change a live simulation: a list of calls carried out in
//! order, each checked against the state the earlier ones leave, each its own event, all
//! committed in one transaction after the reply has been measured. A single state-changing
//! call is a list of one ([`Mode::Alone`]); `batch` (docs/tools.md "Scale") is a list of up to
//! 10,000, all or nothing ([`Mode::AllOrNothing`]).
//!
//! - Alone, the call is applied to the live world (it was checked first, so only a
//!   cancellation can stop it part-way, and a cancelled step is recorded as the steps it
//!   took). Its reply is measured and, if need be, shortened (`budget::shorten`) before the
//!   commit; should it not fit at all, or the commit fail, the world is folded back from the
//!   log, so it never holds a change the log does not.
//! - All or nothing, the calls are applied to a copy (`World::duplicate`); the first refusal,
//!   a cancelled step or a reply over the budget refuses the whole batch — one refused event
//!   is logged and the world, its hash, head and undo chain are as before. Accepted, every
//!   call is its own event (undo granularity unchanged) and replay needs nothing new.

use crate::log::EventLog;
use serde_json::Value;

use crate::command::{Blob, Command};
use crate::limits::Limits;
use crate::outputs::{Batched, Outcome};
use crate::sim::reads::{Read, ReadContext};
use crate::sim::{snapshot_every_changes, Sim, SNAPSHOT_EVERY_BODY_STEPS};
use crate::log::sqlite::{Event, Kind};
use crate::value::{Args, Refusal};
use crate::world::{StepControl, StepObserver, World};

/// The most calls one batch may hold (docs/tools.md).
pub const MAX_CALLS: usize = 10_000;

/// The tools a batch may hold besides the state-changing ones (docs/tools.md "Scale").
pub const READS: [&str; 4] = ["get_object_state", "get_joint_state", "get_link_state", "get_simulation_info"];

/// What the adapter decided a call is: a change's command or one of the batch's reads —
/// or why the call is refused.
pub enum Planned {
    /// A state-changing call.
    Change(Result<Command, Refusal>),
    /// A read (boxed: some reads' parameters are large).
    Read(Result<Box<Read>, Refusal>),
}

/// One call: its tool, its arguments as they will be logged, what it is.
pub struct Call {
    /// The tool name.
    pub tool: String,
    /// The arguments, `sim_id` included.
    pub args: Args,
    /// The decided call.
    pub planned: Planned,
}

/// How a list of calls is carried out (module doc).
pub enum Mode<'a> {
    /// One call on the live world; `observe` sees it after every step it takes.
    Alone(StepObserver<'a>),
    /// A batch on a copy, all or nothing; refusals are logged as the batch's (`args`).
    AllOrNothing {
        /// The batch's own arguments.
        args: &'a Args,
    },
}

/// Measures each call's result as it is made (index, tool, result, whether a change): a
/// batch's running reply size, refusing the first call that would take it past the budget.
pub type Meter<'a> = &'a mut dyn FnMut(usize, &str, &Value, bool) -> Result<(), Refusal>;

/// What a list of calls did, before its events commit.
pub struct Carried {
    /// Each call's result (the recorded JSON).
    pub results: Vec<Value>,
    /// The state-changing result of a call made alone.
    pub outcome: Option<Outcome>,
    /// The head after the calls.
    pub head_seq: u64,
    /// Simulated time after the calls.
    pub time: f64,
    /// The state hash after the calls.
    pub state_hash: String,
}

/// The sentence that refuses a batch because of one of its calls.
pub fn call_refused(index: usize, tool: &str, why: &str) -> Refusal {
    format!("calls[{index}] ({tool}) was refused, so nothing changed: {why}")
}

/// Steps asked by the calls' step commands together, refused over --max-steps before any work.
fn check_steps(calls: &[Call], limits: &Limits) -> Result<(), Refusal> {
    let steps: u64 = calls
        .iter()
        .map(|c| match &c.planned {
            Planned::Change(Ok(Command::StepSimulation { steps, .. })) => *steps,
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

/// The calls worked out (on the live world or a copy), not yet written.
struct Worked {
    carried: Carried,
    events: Vec<Event>,
    /// Snapshots due along the way: (seq, bytes, content hash).
    snapshots: Vec<(u64, Vec<u8>, String)>,
    blobs: Vec<Blob>,
    work_since_snapshot: u64,
    changes_since_snapshot: u32,
}

impl Sim {
    /// A single state-changing call: `decided` is the adapter's parse of the arguments. The
    /// command is checked, applied, its reply measured against `limits.max_reply_bytes`
    /// (shortened if need be), then committed (with a snapshot when due) and answered.
    pub fn change(
        &mut self,
        tool: &str,
        args: &Args,
        decided: Result<Command, Refusal>,
        limits: &Limits,
        control: StepControl,
    ) -> Result<Outcome, Refusal> {
        self.change_observed(tool, args, decided, limits, control, &mut |_| {})
    }

    /// `change` with `observe` seeing the world after every step the command takes (step
    /// samples, live viewer progress). It cannot change the state: the event, its recorded
    /// result and its hash are exactly those of `change`.
    pub fn change_observed(
        &mut self,
        tool: &str,
        args: &Args,
        decided: Result<Command, Refusal>,
        limits: &Limits,
        control: StepControl,
        observe: StepObserver,
    ) -> Result<Outcome, Refusal> {
        let call = Call { tool: tool.to_string(), args: args.clone(), planned: Planned::Change(decided) };
        let budget = limits.max_reply_bytes;
        // The reply the MCP layer will send (`budget::shorten` again, the same way) must fit.
        let measure = |c: &Carried| c.results.first().map_or(Ok(()), |v| crate::sim::budget::shorten(tool, v.clone(), budget).map(|_| ()));
        let (carried, ()) = self.carry_out(vec![call], Mode::Alone(observe), limits, control, &mut |_, _, _, _| Ok(()), measure)?;
        carried.outcome.ok_or_else(|| "Internal error: the call gave no result".to_string())
    }

    /// `batch`: applies `calls` all or nothing (module doc). `args` are the batch's own
    /// arguments (for the refused event); the answer must fit `limits.max_reply_bytes`.
    ///
    /// Its cost is decided before its work: the reads it holds are priced from the world
    /// (`budget::batch_reads`) and the copy it works on from the world's size, each refused
    /// past its budget saying what fits; then each call's result is measured as it is made,
    /// and the first that would take the reply past the budget refuses the batch, so no
    /// more than a reply's worth of results is ever built.
    pub fn batch(&mut self, args: &Args, calls: Vec<Call>, limits: &Limits, control: StepControl) -> Result<Batched, Refusal> {
        let budget = limits.max_reply_bytes;
        // Checked by the adapter; a change's echo of its arguments is left out unless "full".
        let full = args.get("detail").and_then(Value::as_str) == Some("full");
        let priced = crate::sim::budget::batch_reads(&calls, &self.world, budget)
            .and_then(|()| crate::sim::budget::world_copy(&self.world, limits.max_request_bytes, "batch"));
        if let Err(why) = priced {
            return Err(self.refuse("batch", args, why));
        }
        let changes: Vec<bool> = calls.iter().map(|c| matches!(c.planned, Planned::Change(_))).collect();
        let mut sent = crate::sim::budget::BATCH_ENVELOPE;
        let mut meter = |i: usize, _: &str, value: &Value, change: bool| {
            sent += match (change, full) {
                (true, false) => compact_change(value).to_string().len(),
                _ => value.to_string().len(),
            } + 1;
            if sent > budget {
                return Err(crate::sim::budget::batch_over_budget(i, budget));
            }
            Ok(())
        };
        let (_, out) = self.carry_out(calls, Mode::AllOrNothing { args }, limits, control, &mut meter, |c| {
            let results = match full {
                true => c.results.clone(),
                false => c.results.iter().zip(&changes).map(|(r, change)| if *change { compact_change(r) } else { r.clone() }).collect(),
            };
            let out = Batched { results, head_seq: c.head_seq, time: c.time, state_hash: c.state_hash.clone() };
            let bytes = crate::sim::budget::reply_bytes("batch", serde_json::to_value(&out).unwrap_or_default());
            if bytes > budget {
                return Err(crate::sim::budget::over_budget("batch", bytes as u64, budget));
            }
            Ok(out)
        })?;
        Ok(out)
    }

    /// The one path (module doc): works the calls out, lets `reply` build and measure the
    /// answer, then commits every event in one transaction. A refusal is logged (as the
    /// call's own alone, as the batch's otherwise) and changes nothing.
    pub(crate) fn carry_out<R>(
        &mut self,
        calls: Vec<Call>,
        mut mode: Mode,
        limits: &Limits,
        control: StepControl,
        meter: Meter,
        reply: impl FnOnce(&Carried) -> Result<R, Refusal>,
    ) -> Result<(Carried, R), Refusal> {
        self.ensure_live()?;
        let alone = matches!(mode, Mode::Alone(_));
        let (tool, args) = match &mode {
            Mode::Alone(_) => calls.first().map(|c| (c.tool.clone(), c.args.clone())).unwrap_or_default(),
            Mode::AllOrNothing { args } => ("batch".to_string(), (*args).clone()),
        };
        // A batch's steps together; a call alone is held to --max-steps by its own check,
        // whose sentence names its own parameter.
        if !alone {
            if let Err(why) = check_steps(&calls, limits) {
                return Err(self.refuse(&tool, &args, why));
            }
        }
        let mut copy = (!alone).then(|| self.world.duplicate());
        let mut nothing = |_: &World| {};
        let observe: StepObserver = match &mut mode {
            Mode::Alone(o) => &mut **o,
            Mode::AllOrNothing { .. } => &mut nothing,
        };
        let from = (self.log.next_seq(), self.log.head_seq(), (self.work_since_snapshot, self.changes_since_snapshot));
        let world = match copy.as_mut() {
            Some(w) => w,
            None => &mut self.world,
        };
        let worked = work_out(from, &self.state_hash, world, calls, alone, limits, control, observe, meter);
        let worked = match worked {
            Ok(w) => w,
            Err(why) => {
                // Alone, a refusal comes before the world is touched; anything later (an event
                // that would not encode) folds the log back, so memory never runs ahead of it.
                if alone && self.world.state_hash() != self.state_hash {
                    self.reload();
                }
                return Err(self.refuse(&tool, &args, why));
            }
        };
        let changes = worked.events.iter().any(|e| e.kind == Kind::Change);
        let answer = match reply(&worked.carried) {
            Ok(r) => r,
            Err(why) => {
                if alone && changes {
                    // Applied to the live world but not to be sent: fold the log back first.
                    self.reload();
                }
                return Err(self.refuse(&tool, &args, why));
            }
        };
        let Worked { carried, events, snapshots, blobs, work_since_snapshot, changes_since_snapshot } = worked;
        if let Err(why) = self.commit_worked(events, &carried, &snapshots, &blobs) {
            if alone {
                // The world moved but the log did not: fold the log again so they agree.
                self.reload();
                return Err(self.refuse(&tool, &args, format!("The call could not be recorded and was undone: {why}")));
            }
            return Err(self.refuse(&tool, &args, format!("The batch could not be recorded and changed nothing: {why}")));
        }
        if let Some(world) = copy {
            self.world = world;
        }
        self.state_hash = carried.state_hash.clone();
        self.work_since_snapshot = work_since_snapshot;
        self.changes_since_snapshot = changes_since_snapshot;
        if !snapshots.is_empty() {
            self.thin_snapshots();
        }
        if changes {
            self.redo.clear();
            self.index_changed();
        }
        Ok((carried, answer))
    }

    /// Writes the calls' blobs, then their events, the new head and the snapshots in one
    /// transaction; a slow snapshot is noted as a stall.
    fn commit_worked(&mut self, events: Vec<Event>, carried: &Carried, snapshots: &[(u64, Vec<u8>, String)], blobs: &[Blob]) -> Result<(), String> {
        // Each distinct file once (a batch may load one robot many times).
        let mut stored = std::collections::BTreeSet::new();
        for b in blobs.iter().filter(|b| stored.insert(b.hash.as_str())) {
            self.log.put_blob(&b.hash, &b.bytes).map_err(|e| format!("its files could not be recorded: {e}"))?;
        }
        let events: Vec<Event> = events
            .into_iter()
            .map(|mut e| {
                e.arguments = self.log.store_arguments(std::mem::take(&mut e.arguments));
                e
            })
            .collect();
        let snaps: Vec<crate::log::sqlite::Snap> = snapshots.iter().map(|(s, b, h)| (*s, b.as_slice(), h.as_str())).collect();
        let started = std::time::Instant::now();
        self.log.append(&events, carried.head_seq, &snaps).map_err(|e| e.to_string())?;
        let ms = started.elapsed().as_millis() as u64;
        if let Some((seq, bytes, _)) = snapshots.last() {
            if ms >= crate::sim::stall_ms() {
                self.stalls.push(format!("the snapshot at seq {seq} ({} bytes) took {ms} ms to write", bytes.len()));
            }
        }
        Ok(())
    }
}

/// Applies `calls` to `world` in order, building their events (seqs from `next_seq`, the head
/// moving from `head`), the snapshots due on the way (from the counters `since`) and each
/// call's result. Nothing is written.
#[allow(clippy::too_many_arguments)]
fn work_out(
    (next_seq, mut head, since): (u64, u64, (u64, u32)),
    hash: &str,
    world: &mut World,
    calls: Vec<Call>,
    alone: bool,
    limits: &Limits,
    control: StepControl,
    observe: StepObserver,
    meter: Meter,
) -> Result<Worked, Refusal> {
    let (mut work_since, mut changes_since) = since;
    let mut hash = hash.to_string();
    let mut events = Vec::with_capacity(calls.len());
    let mut snapshots = Vec::new();
    let mut results = Vec::with_capacity(calls.len());
    let mut blobs = Vec::new();
    let mut outcome = None;
    let head_before = head;
    for (i, call) in calls.into_iter().enumerate() {
        let seq = next_seq + i as u64;
        let refused = |why: Refusal| if alone { why } else { call_refused(i, &call.tool, &why) };
        // Arguments stay raw JSON until the calls commit (`store_arguments` may write a blob).
        let mut e = Event::blank(seq, Kind::Read, &call.tool, serde_json::to_string(&call.args).unwrap_or_default());
        match call.planned {
            Planned::Change(decided) => {
                let cmd = decided.and_then(|c| c.validate(world, limits).map(|()| c)).map_err(refused)?;
                let asked = match &cmd {
                    Command::StepSimulation { steps, .. } => Some(*steps),
                    _ => None,
                };
                blobs.extend(cmd.blobs().into_iter().cloned());
                let result = crate::log::fold::apply(world, &cmd, crate::command::EVENT_VERSION, &mut *control, &mut *observe).land(seq, world.current_time());
                let cancelled = asked.is_some_and(|a| result.steps_taken().is_some_and(|t| t < a));
                if cancelled && !alone {
                    return Err(format!("The batch was cancelled at calls[{i}] ({}) and changed nothing", call.tool));
                }
                // Logged as carried out: a cancelled step records the steps it took, so every
                // fold of the log repeats exactly what the world did.
                let cmd = cmd.as_taken(result.steps_taken());
                work_since += crate::log::fold::work(&cmd, world);
                changes_since += 1;
                let value = result.to_value();
                let json = value.to_string();
                hash = world.state_hash();
                e.kind = Kind::Change;
                e.mutates = true;
                e.parent = Some(head);
                e.command = Some(serde_json::to_string(&cmd).map_err(|err| err.to_string())?);
                e.result_hash = Some(crate::digest::result_hash(&json));
                e.result = Some(json);
                e.state_hash = hash.clone();
                head = seq;
                // Alone, a snapshot is taken for real work (steps) where it happens. A batch
                // takes at most one, after its last call (below), as one step of all its
                // steps would: a snapshot per step call of a 400-call batch was 400 world
                // copies held in memory until the commit, and as many in the log.
                if alone && work_since >= SNAPSHOT_EVERY_BODY_STEPS {
                    snapshots.push(snapshot_of(world, seq));
                    (work_since, changes_since) = (0, 0);
                }
                meter(i, &call.tool, &value, true).map_err(refused)?;
                results.push(value);
                if alone {
                    outcome = Some(result);
                }
            }
            Planned::Read(read) => {
                let cx = ReadContext { world, head_seq: head, last_seq: seq - 1, state_hash: &hash, rules: crate::command::EVENT_VERSION };
                let value = read
                    .and_then(|r| r.replay(&cx).unwrap_or_else(|| Err("not a read a batch can hold".into())))
                    .map_err(refused)?;
                e.result_hash = Some(crate::digest::result_hash(&value.to_string()));
                e.state_hash = hash.clone();
                e.summary = Some(crate::log::summary::one_line(&value));
                meter(i, &call.tool, &value, false).map_err(refused)?;
                results.push(value);
            }
        }
        events.push(e);
    }
    let due = work_since >= SNAPSHOT_EVERY_BODY_STEPS || changes_since >= snapshot_every_changes(world.object_count());
    if due && head != head_before {
        snapshots.push(snapshot_of(world, head));
        (work_since, changes_since) = (0, 0);
    }
    let carried = Carried { results, outcome, head_seq: head, time: world.current_time(), state_hash: hash };
    Ok(Worked { carried, events, snapshots, blobs, work_since_snapshot: work_since, changes_since_snapshot: changes_since })
}

/// A snapshot of `world` taken at event `seq`: (seq, bytes, content hash).
fn snapshot_of(world: &World, seq: u64) -> (u64, Vec<u8>, String) {
    let (bytes, hash) = crate::sim::snapshot_with_hash(world);
    (seq, bytes, hash)
}

/// What a batch reports of a change by default: the ids and values it made (an added object's
/// id, a step's time), not the echo of its arguments or its sentence — "ok" when nothing is
/// left. 100 add_box calls cost ~2 KB instead of ~10 KB.
fn compact_change(result: &Value) -> Value {
    const KEPT: &[&str] = &["object_id", "constraint_id", "num_joints", "steps_taken", "current_time", "timestep", "truncated"];
    match result {
        Value::Object(m) => {
            let kept: serde_json::Map<String, Value> = m.iter().filter(|(k, _)| KEPT.contains(&k.as_str())).map(|(k, v)| (k.clone(), v.clone())).collect();
            if kept.is_empty() {
                Value::String("ok".into())
            } else {
                Value::Object(kept)
            }
        }
        other => other.clone(),
    }
}
