//! run_sweep (docs/tools.md "Scale"): one fork per variant, its calls applied as a batch, then its
//! steps, the variants side by side on worker threads — nothing here but the existing fork,
//! batch and step paths, so each variant's result equals doing the same by hand.
//!
//! Variants are forks under their partial names while they run: real, logged simulations
//! that are not listed, not counted against --max-sims and removed at start after a crash.
//! When every variant is done they are deleted, or with `keep` published like any fork. Any
//! variant's refusal, or a cancellation, deletes them all and refuses the sweep. The swept
//! simulation only records the sweep as one read (or refused) event.
//!
//! On a cluster node the variants run on every node's sweepers instead of here
//! (`sweep_across`, `sweep_worker`), and a kept fork is published by the node that ran it as
//! soon as its variant is done (destroyed again if the sweep is refused); the sweep is decided
//! from their results here, as ever.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use serde_json::json;

use crate::sim::apply::Call;
use crate::command::Command;
use crate::outputs::{Swept, SweptObject, SweptVariant};
use crate::sim::{lock_sim, Registry, Sim};
use crate::sim::timeline::ForkSource;
use crate::value::{Args, Refusal};
use crate::world::StepControl;

/// The most variants one sweep may hold (docs/tools.md).
pub const MAX_VARIANTS: usize = 256;

/// What a sweep reports of each variant (sent to other nodes with each variant in a cluster).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Observe {
    /// The objects whose final states (and samples) are reported; None: all.
    pub object_ids: Option<Vec<u32>>,
    /// Velocities too.
    pub include_velocities: bool,
    /// Sample poses every this many steps while stepping.
    pub every: Option<u64>,
    /// Measures taken after every step (`seeing::measure`).
    #[serde(default)]
    pub measure: Vec<crate::seeing::measure::Spec>,
    /// The sample columns to keep (`trajectory::select`), None for all.
    #[serde(default)]
    pub fields: Option<Vec<String>>,
}

/// A sweep asked for: its variants' calls (decided), the steps, what to observe, whether to
/// keep the forks.
pub struct Request {
    /// One list of calls per variant.
    pub variants: Vec<Vec<Call>>,
    /// Each variant's calls as the client sent them: what another node decides them from
    /// again (its own decisions hold parsed models, which do not travel). Without one per
    /// variant (an in-process caller), a cluster node runs the sweep itself.
    pub sent: Vec<serde_json::Value>,
    /// Steps each variant takes after its calls.
    pub steps: u64,
    /// What to report.
    pub observe: Observe,
    /// Keep the forks as ordinary simulations.
    pub keep: bool,
    /// `detail: "full"`: unmoved objects reported too, samples not compacted.
    pub full: bool,
    /// How to rank the variants.
    pub rank_by: Option<Rank>,
}

/// What a sweep ranks its variants by.
#[derive(Clone, Copy, Debug)]
pub enum Rank {
    /// This object's metric, highest first.
    Metric(u32, Metric),
    /// The answer to `observe.measure[i]`: values highest first, moments (first,
    /// first_contact) earliest first, never last.
    Measure(usize),
}

/// How a sweep is decided once its variants ran: (keep, detail full, rank_by, each variant's
/// varied arguments).
pub(super) type How = (bool, bool, Option<Rank>, Vec<serde_json::Map<String, serde_json::Value>>);

/// The arguments each variant sets differently from some other variant (`SweptVariant::varied`),
/// from the calls as the client sent them, named "tool.argument" ("tool[k].argument" when a
/// variant calls a tool twice); empty when the calls are not known (an in-process caller).
fn varied(sent: &[serde_json::Value]) -> Vec<serde_json::Map<String, serde_json::Value>> {
    use std::collections::{BTreeMap, BTreeSet};
    let flat: Vec<BTreeMap<String, serde_json::Value>> = sent
        .iter()
        .map(|calls| {
            let calls = calls.as_array().map(Vec::as_slice).unwrap_or_default();
            let tools: Vec<&str> = calls.iter().map(|c| c.get("tool").and_then(serde_json::Value::as_str).unwrap_or("")).collect();
            let mut m = BTreeMap::new();
            for (k, c) in calls.iter().enumerate() {
                let tool = tools[k];
                let name = if tools.iter().filter(|t| **t == tool).count() > 1 { format!("{tool}[{k}]") } else { tool.to_string() };
                for (a, v) in c.get("arguments").and_then(serde_json::Value::as_object).into_iter().flatten() {
                    if a != "sim_id" {
                        m.insert(format!("{name}.{a}"), v.clone());
                    }
                }
            }
            m
        })
        .collect();
    let keys: BTreeSet<&String> = flat.iter().flat_map(BTreeMap::keys).collect();
    let differing: Vec<&String> = keys.into_iter().filter(|k| flat.iter().any(|m| m.get(*k) != flat[0].get(*k))).collect();
    flat.iter().map(|m| differing.iter().filter_map(|k| m.get(*k).map(|v| ((*k).clone(), v.clone()))).collect()).collect()
}

/// What rank_by compares (highest first).
#[derive(Clone, Copy, Debug)]
pub enum Metric {
    /// Distance moved during the steps.
    Displacement,
    /// Highest speed after any step.
    PeakSpeed,
    /// Final height.
    FinalZ,
}

impl Metric {
    fn of(self, o: &SweptObject) -> f64 {
        match self {
            Metric::Displacement => o.displacement,
            Metric::PeakSpeed => o.peak_speed,
            Metric::FinalZ => o.position[2],
        }
    }
}

/// A step control per variant (progress and cancellation), made by the caller.
pub type Control = Box<dyn FnMut(u64) -> bool + Send>;

/// How a node decides a variant's calls from the JSON a client sent (the MCP layer's
/// `batch::plan`, which this layer cannot name): given the workspace, the swept simulation's
/// id and the variant's `[{tool, arguments}]`, a refusal naming the call.
pub type Planner = fn(&crate::files::Sandbox, &str, &serde_json::Value) -> Result<Vec<Call>, Refusal>;

/// One variant to run: its index, its decided calls, its step control.
pub(super) type Variant = (usize, Vec<Call>, Control);

/// A variant's outcome with its fork (when one was made), before the sweep is decided.
pub(super) type Ran<F> = (Option<F>, Result<SweptVariant, Refusal>);

/// A variant's fork as a sweep holds it once the variant ran: the fork itself when it ran
/// here, or where it is when it ran on another node (`sweep_across`). What is done with the
/// forks once the sweep is decided depends only on this.
pub(super) trait VariantFork: Sized {
    /// The fork's simulation id (named in the reply when kept).
    fn fork_id(&self) -> String;
    /// Gives up every fork (a refusal, a cancellation, or keep=false).
    fn discard_all(reg: &Registry, forks: Vec<Self>);
    /// Makes every fork an ordinary simulation in the slots reserved for them.
    fn keep_all(reg: &Registry, swept: Swept, forks: Vec<Self>, slots: Vec<crate::sim::Slot<'_>>) -> Result<Swept, Refusal>;
}

impl VariantFork for Sim {
    fn fork_id(&self) -> String {
        self.id().to_string()
    }

    fn discard_all(_: &Registry, forks: Vec<Sim>) {
        discard(forks);
    }

    fn keep_all(reg: &Registry, swept: Swept, forks: Vec<Sim>, slots: Vec<crate::sim::Slot<'_>>) -> Result<Swept, Refusal> {
        reg.keep_all(swept, forks, slots)
    }
}

/// One variant while it runs: its fork and what it is to do.
pub(super) struct Running {
    index: usize,
    sim: Sim,
    calls: Vec<Call>,
    control: Control,
}

impl Registry {
    /// Runs a sweep of simulation `id` on `workers` threads (module doc). `controls` gives
    /// each variant its step control; `budget` is the reply budget the answer must fit;
    /// `turn`, the caller's turn on the swept simulation, is given back once the forks'
    /// source is taken.
    pub fn sweep(
        &self,
        id: &str,
        args: &Args,
        req: Request,
        mut controls: impl FnMut() -> Control,
        (workers, budget): (usize, usize),
        turn: Option<crate::sim::queue::Turn>,
    ) -> Result<Swept, Refusal> {
        let parent = self.get(id)?;
        let Request { variants, sent, steps, observe, keep, full, rank_by } = req;
        // What every fork copies, read once under the parent's lock; the forks themselves are
        // made by the workers, side by side, from the parent's file.
        let (source, slots) = {
            let p = lock_sim(&parent);
            p.ensure_live()?;
            // Lock order: the parent, then the table (for the kept variants' slots).
            let ready = self
                .check_sweep(variants.len(), steps)
                .and_then(|()| crate::sim::budget::sweep_forks(p.world(), variants.len(), workers, keep, self.limits().max_request_bytes))
                .and_then(|()| check_samples(p.world(), variants.len(), steps, &observe, budget))
                .and_then(|()| if keep { self.reserve_many(variants.len()).map_err(|why| format!("keep=true: {why}; keep fewer variants or set keep=false")) } else { Ok(Vec::new()) })
                .and_then(|slots| Ok((ForkSource::of(&p, None)?, slots)));
            match ready {
                Ok(r) => r,
                Err(why) => {
                    drop(p);
                    return Err(lock_sim(&parent).refuse("run_sweep", args, why));
                }
            }
        };
        // The swept simulation is free for other calls while the variants run.
        drop(turn);
        let how = (keep, full, rank_by, varied(&sent));
        if let Some(nodes) = self.sweepers().filter(|_| sent.len() == variants.len()) {
            let controls = (0..sent.len()).map(|_| controls()).collect();
            let sweep = uuid::Uuid::new_v4().to_string();
            let done = self.sweep_across(&nodes, &sweep, source, crate::sim::sweep_across::Across { sent, steps, observe, keep }, controls);
            let concluded = self.conclude(&parent, args, done, how, (budget, slots));
            // Every sweep ends with a verdict (a kept one wrote its own in `keep_all`): workers
            // still waiting for an answer follow it.
            nodes.decided(&sweep);
            return concluded;
        }
        let fork_args = fork_arguments(id, source.at());
        let items: Vec<Variant> =
            variants.into_iter().enumerate().map(|(index, calls)| (index, calls, controls())).collect();
        // Memory held stays one fork per worker (plus the kept ones): a variant's fork is
        // deleted as soon as it has run unless kept, and only its summary stays. The summaries
        // are measured as they come: once they pass the reply budget, the variants not yet
        // started are not run.
        let (sent, over) = (AtomicUsize::new(0), AtomicBool::new(false));
        let done = run_all(items, workers, |variant| {
            let index = variant.0;
            if over.load(Ordering::Relaxed) {
                return (None, Err(format!("variants[{index}] was not run: {}", over_budget_sweep(budget))));
            }
            let (sim, result) = self.fork_and_run(&source, &fork_args, variant, steps, &observe);
            if let Ok(v) = &result {
                let bytes = serde_json::to_vec(v).map_or(usize::MAX, |b| b.len());
                if sent.fetch_add(bytes, Ordering::Relaxed).saturating_add(bytes) > budget {
                    over.store(true, Ordering::Relaxed);
                }
            }
            match keep {
                true => (sim, result),
                false => {
                    discard(sim);
                    (None, result)
                }
            }
        });
        self.conclude(&parent, args, done, how, (budget, slots))
    }

    /// Forks `source` and runs one variant on the fork: what a sweep's worker does with each
    /// variant, on this node or another.
    pub(super) fn fork_and_run(&self, source: &ForkSource, fork_args: &Args, (index, calls, control): Variant, steps: u64, observe: &Observe) -> Ran<Sim> {
        match self.fork_from(source, None, (uuid::Uuid::new_v4().to_string(), None), fork_args) {
            Ok((_, sim)) => run_variant(Running { index, sim, calls, control }, source.parent_id(), steps, observe, self.limits()),
            Err(why) => (None, Err(format!("variants[{index}] could not be forked: {why}"))),
        }
    }

    /// Decides the sweep from its variants' outcomes (`finish`), keeps or gives up the forks,
    /// and records the sweep on the swept simulation as a read (or a refusal).
    fn conclude<F: VariantFork>(
        &self,
        parent: &crate::sim::SharedSim,
        args: &Args,
        done: Vec<Ran<F>>,
        how: How,
        (budget, slots): (usize, Vec<crate::sim::Slot<'_>>),
    ) -> Result<Swept, Refusal> {
        let keep = how.0;
        let outcome = finish(done, how, budget);
        let mut p = lock_sim(parent);
        // The lease, checked when the answer is decided (in a cluster the variants ran
        // meanwhile, and this node may have lost the swept simulation): refused, nothing kept.
        if let Err(why) = p.ensure_live() {
            let (Ok((_, sims)) | Err((_, sims))) = outcome;
            F::discard_all(self, sims);
            return Err(why);
        }
        let (swept, sims) = match outcome {
            Ok(ok) => ok,
            Err((why, sims)) => {
                F::discard_all(self, sims);
                return Err(p.refuse("run_sweep", args, why));
            }
        };
        let swept = if keep {
            F::keep_all(self, swept, sims, slots)
        } else {
            F::discard_all(self, sims);
            Ok(swept)
        };
        match swept {
            Ok(s) => p.read("run_sweep", args, |_| Ok(s)),
            Err(why) => Err(p.refuse("run_sweep", args, why)),
        }
    }

    /// The sweep's own bounds: 1–256 variants and steps within --max-steps.
    fn check_sweep(&self, variants: usize, steps: u64) -> Result<(), Refusal> {
        if variants == 0 || variants > MAX_VARIANTS {
            return Err(format!("variants must hold 1 to {MAX_VARIANTS} variants; got {variants}"));
        }
        let max = self.limits().max_steps;
        if steps > max {
            return Err(format!("steps must be at most {max} (--max-steps); got {steps}"));
        }
        Ok(())
    }

    /// Publishes every variant's fork into the slot reserved for it (the result already
    /// names them). Should one fail (a full disk), the rest are deleted and the sweep says
    /// which were kept.
    fn keep_all(&self, swept: Swept, sims: Vec<Sim>, slots: Vec<crate::sim::Slot<'_>>) -> Result<Swept, Refusal> {
        let mut sims = sims.into_iter();
        let mut kept = Vec::new();
        for ((v, sim), slot) in swept.variants.iter().zip(sims.by_ref()).zip(slots) {
            let id = sim.id().to_string();
            match self.publish_sim(sim) {
                Ok(sim) => slot.fill(sim),
                Err(why) => {
                    discard(sims);
                    return Err(format!("variants[{}] could not be kept ({why}); kept before it: {kept:?}", v.index));
                }
            }
            kept.push(id);
        }
        Ok(swept)
    }
}

/// The fewest bytes one sampled pose takes in a sweep's trajectories (three coordinates of a
/// compact sample and their commas): a lower bound for pricing samples before the work.
const SAMPLE_BYTES_MIN: u64 = 12;

/// Refuses before the work a sweep whose samples alone could not fit the reply budget:
/// variants × observed objects × samples × [`SAMPLE_BYTES_MIN`].
fn check_samples(world: &crate::world::World, variants: usize, steps: u64, observe: &Observe, budget: usize) -> Result<(), Refusal> {
    let Some(every) = observe.every else { return Ok(()) };
    let objects = observe.object_ids.as_ref().map_or(world.object_count(), Vec::len).max(1) as u64;
    let samples = steps / every.max(1) + 2;
    let least = (variants as u64).saturating_mul(objects).saturating_mul(samples).saturating_mul(SAMPLE_BYTES_MIN);
    if least <= budget as u64 {
        return Ok(());
    }
    Err(format!(
        "observe.every: {variants} variants × {objects} objects × {samples} samples would reply at least {least} bytes, over the reply budget of {budget} bytes (--max-reply-bytes); ask for a larger every, fewer object_ids, or fewer variants per sweep"
    ))
}

/// Why the variants after the reply budget was passed were not run.
fn over_budget_sweep(budget: usize) -> String {
    format!("the variants before it already fill the reply budget of {budget} bytes (--max-reply-bytes); ask for fewer object_ids, a larger every, or fewer variants per sweep")
}

/// The arguments a variant's root records: those of the fork it is.
pub(super) fn fork_arguments(parent: &str, at_seq: u64) -> Args {
    let mut a = sim_arguments(parent);
    a.insert("at_seq".into(), json!(at_seq));
    a
}

/// Runs `f` on every item on `workers` threads, each taking the next item when done with
/// one; results come back in the items' order. Plain threads, not a rayon pool: a variant's
/// step runs on its worker's stepping pool (physics-core `world/threads.rs`), and a rayon
/// worker waiting for that would start other variants meanwhile — one "worker" would keep
/// several variants and their steps in flight, and `workers` would no longer say how many
/// cores a sweep takes.
fn run_all<T: Send, R: Send>(items: Vec<T>, workers: usize, f: impl Fn(T) -> R + Sync) -> Vec<R> {
    let n = items.len();
    let queue = Mutex::new(items.into_iter().enumerate());
    let done: Mutex<Vec<Option<R>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..workers.clamp(1, n.max(1)) {
            s.spawn(|| loop {
                let next = queue.lock().unwrap_or_else(|e| e.into_inner()).next();
                let Some((i, item)) = next else { break };
                let r = f(item);
                done.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(r);
            });
        }
    });
    let done = done.into_inner().unwrap_or_else(|e| e.into_inner());
    done.into_iter().map(|r| r.expect("every item was taken by a worker")).collect()
}

/// One variant's calls (as a batch) and steps, then what `observe` asks of it.
pub(super) fn run_variant(r: Running, parent: &str, steps: u64, observe: &Observe, limits: &crate::limits::Limits) -> (Option<Sim>, Result<SweptVariant, Refusal>) {
    let Running { index, mut sim, calls, mut control } = r;
    let fork = sim.id().to_string();
    // A panic in the engine fails this variant (its fork is deleted with the others), not
    // the worker thread and with it the whole server request.
    let worked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        variant_work(&mut sim, calls, steps, observe, limits, &mut control)
    }))
    .unwrap_or_else(|_| Err("the engine failed while simulating it (an internal error); nothing was kept".into()));
    // The fork is a throwaway the client never saw: a refusal names the parent instead.
    let out = worked
        .map_err(|why| format!("variants[{index}]: {}", why.replace(&fork, parent)))
        .map(|(state_hash, objects, trajectory, unmoved, measures)| SweptVariant { index, simulation_id: None, state_hash, objects, trajectory, unmoved, measures, varied: None });
    (Some(sim), out)
}

/// What a variant reports: (state hash, objects, trajectory, the objects that did not move at
/// all: no speed, no spin, the same pose and joint positions at the end, measures — exact).
type Report = (String, Vec<SweptObject>, Option<crate::outputs::Trajectory>, Vec<u32>, Option<Vec<crate::outputs::Measured>>);

fn variant_work(
    sim: &mut Sim,
    calls: Vec<Call>,
    steps: u64,
    observe: &Observe,
    limits: &crate::limits::Limits,
    control: StepControl,
) -> Result<Report, Refusal> {
    let id = sim.id().to_string();
    if !calls.is_empty() {
        // The caller's reply budget: a variant's batch answers no client, but what it builds
        // is held to the same bound as any batch, so a sweep cannot build more than a batch can.
        sim.batch(&sim_arguments(&id), calls, limits, &mut *control)?;
    }
    let mut trajectory = None;
    let ids: Vec<u32> = match &observe.object_ids {
        Some(ids) => ids.clone(),
        None => sim.world().objects().map(|(id, _)| id).collect(),
    };
    let start_poses: Vec<Option<Vec<f64>>> = ids.iter().map(|id| pose_key(sim.world(), *id)).collect();
    let mut peak = vec![0f64; ids.len()];
    let mut spun = vec![false; ids.len()];
    crate::seeing::measure::check_objects("observe.measure", &observe.measure, |id| sim.world().has_object(id))?;
    let mut meter = crate::seeing::measure::Meter::new(observe.measure.clone());
    meter.see(sim.world());
    // After every step: the peak speed as get_object_state reports velocities (each component
    // rounded to its shortest decimal), computed only when the engine's speed could beat the
    // peak — the rounding moves a component by under one part in 10^7 — so the result is the
    // same as rounding every time, without formatting every velocity of every object each step
    // (that was most of a sweep's time). A component is non-zero exactly when its rounding is.
    let mut watch = |w: &crate::world::World| {
        if !meter.is_empty() {
            meter.see(w);
        }
        for ((p, turning), id) in peak.iter_mut().zip(spun.iter_mut()).zip(&ids) {
            let Some((linear, angular)) = w.raw_velocities(*id) else { continue };
            *turning |= angular.iter().any(|v| *v != 0.0);
            let raw = linear.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>().sqrt();
            if raw > 0.0 && raw * (1.0 + 1e-6) >= *p {
                if let Some(s) = w.object_state(*id) {
                    *p = p.max(s.linear_velocity.iter().map(|v| v * v).sum::<f64>().sqrt());
                }
            }
        }
    };
    if steps > 0 {
        let mut a = sim_arguments(&id);
        a.insert("steps".into(), json!(steps));
        let stepped = match observe.every {
            Some(every) => {
                a.insert("sample_every".into(), json!(every));
                if let Some(ids) = &observe.object_ids {
                    a.insert("sample_objects".into(), json!(ids));
                }
                let sampling = crate::sim::sampled_step::Sampling {
                    every: Some(every),
                    object_ids: observe.object_ids.clone(),
                    include_velocities: observe.include_velocities,
                    // Compacted once the sweep is done (`finish`), with the rest of the answer.
                    compact: None,
                    samples: true,
                    measure: Vec::new(),
                    fields: observe.fields.clone(),
                };
                let s = sim.step_sampled_watched(&a, steps, &sampling, limits, &mut *control, &mut watch)?;
                trajectory = s.trajectory.clone();
                s.steps_taken
            }
            None => {
                let out = sim.change_observed("step_simulation", &a, Ok(Command::step(steps)), limits, &mut *control, &mut watch)?;
                out.steps_taken().unwrap_or(steps)
            }
        };
        if stepped < steps {
            return Err("the sweep was cancelled".into());
        }
    }
    let w = sim.world();
    let mut objects = Vec::with_capacity(ids.len());
    let mut still = Vec::new();
    for (((object_id, peak_speed), turned), before) in ids.into_iter().zip(peak).zip(spun).zip(start_poses) {
        if peak_speed == 0.0 && !turned && before.is_some() && before == pose_key(w, object_id) {
            still.push(object_id);
        }
        let s = w.object_state(object_id).ok_or_else(|| format!("observe.object_ids: object {object_id} does not exist"))?;
        let v = observe.include_velocities;
        // The pose key starts with the base position.
        let displacement = before.as_ref().map_or(0.0, |f| (0..3).map(|k| (s.position[k] - f[k]).powi(2)).sum::<f64>().sqrt());
        objects.push(SweptObject {
            object_id,
            position: s.position,
            orientation: s.orientation,
            linear_velocity: v.then_some(s.linear_velocity),
            angular_velocity: v.then_some(s.angular_velocity),
            displacement,
            peak_speed,
        });
    }
    let measures = (!meter.is_empty()).then(|| meter.finish(None));
    Ok((sim.state_hash().to_string(), objects, trajectory, still, measures))
}

/// An object's pose as numbers — base position and orientation, and a robot's joint positions
/// — to tell whether it moved at all (a fixed-base arm swings without moving its base).
fn pose_key(w: &crate::world::World, id: u32) -> Option<Vec<f64>> {
    let s = w.object_state(id)?;
    let mut key: Vec<f64> = s.position.iter().chain(&s.orientation).copied().collect();
    let joints = w.objects().find(|(i, _)| *i == id).and_then(|(_, o)| o.kind.robot()).map_or(0, |r| r.links.len());
    key.extend((0..joints).filter_map(|j| w.joint_state(id, j)).map(|j| j.joint_position.scalar()));
    Some(key)
}

/// The variants' results in order with their forks, or the first refusal (by variant index)
/// with every fork to delete; an answer over the reply budget is refused too.
#[allow(clippy::type_complexity)]
fn finish<F: VariantFork>(
    done: Vec<Ran<F>>,
    (keep, full, rank_by, varied): How,
    budget: usize,
) -> Result<(Swept, Vec<F>), (Refusal, Vec<F>)> {
    let mut sims = Vec::with_capacity(done.len());
    let mut variants = Vec::with_capacity(done.len());
    let mut first_refusal = None;
    for (sim, r) in done {
        sims.extend(sim);
        match r {
            Ok(v) => variants.push(v),
            Err(why) => {
                first_refusal.get_or_insert(why);
            }
        }
    }
    if let Some(why) = first_refusal {
        return Err((why, sims));
    }
    if keep {
        // Kept variants are named in the reply: measured with their ids, before any is kept.
        for (v, sim) in variants.iter_mut().zip(&sims) {
            v.simulation_id = Some(sim.fork_id());
        }
    }
    for (v, echo) in variants.iter_mut().zip(varied) {
        v.varied = (!echo.is_empty()).then_some(echo);
    }
    let ranking = match rank_by {
        None => None,
        Some(Rank::Measure(i)) => {
            let key = |v: &SweptVariant| v.measures.as_ref().and_then(|m| m.get(i)).and_then(crate::seeing::measure::rank_key);
            let mut scored: Vec<(Option<f64>, usize)> = variants.iter().map(|v| (key(v), v.index)).collect();
            // Highest first, never last; ties keep the variants' order.
            scored.sort_by(|a, b| match (a.0, b.0) {
                (Some(x), Some(y)) => y.total_cmp(&x),
                (x, y) => y.is_some().cmp(&x.is_some()),
            }.then(a.1.cmp(&b.1)));
            Some(scored.into_iter().map(|(_, i)| i).collect())
        }
        Some(Rank::Metric(id, metric)) => {
            let mut scored = Vec::with_capacity(variants.len());
            for v in &variants {
                match v.objects.iter().find(|o| o.object_id == id) {
                    Some(o) => scored.push((metric.of(o), v.index)),
                    None => return Err((format!("rank_by.object_id: object {id} is not observed in variants[{}]", v.index), sims)),
                }
            }
            // Highest first; ties keep the variants' order.
            scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            Some(scored.into_iter().map(|(_, i)| i).collect())
        }
    };
    if full {
        variants.iter_mut().for_each(|v| v.unmoved.clear());
    }
    if !full {
        for v in &mut variants {
            let still = std::mem::take(&mut v.unmoved);
            v.objects.retain(|o| !still.contains(&o.object_id));
            v.unmoved = still;
            // Computed in f64 from the f32 poses and velocities the engine holds: the f32 they
            // come to keeps all they know, at half the digits (`detail: "full"`: every bit).
            for o in &mut v.objects {
                o.displacement = crate::value::r32(o.displacement as f32);
                o.peak_speed = crate::value::r32(o.peak_speed as f32);
            }
            if let Some(t) = &mut v.trajectory {
                crate::seeing::trajectory::compact(t, Some(crate::seeing::trajectory::DEFAULT_DECIMALS));
            }
            for m in v.measures.iter_mut().flatten() {
                crate::seeing::measure::round(m, crate::seeing::trajectory::DEFAULT_DECIMALS);
            }
        }
    }
    let swept = Swept { variants, ranking };
    let bytes = crate::sim::budget::reply_bytes("run_sweep", serde_json::to_value(&swept).unwrap_or_default());
    if bytes > budget {
        return Err((crate::sim::budget::over_budget("run_sweep", bytes as u64, budget), sims));
    }
    Ok((swept, sims))
}

/// Deletes variants' forks (never published: their partial files).
pub(super) fn discard(sims: impl IntoIterator<Item = Sim>) {
    for sim in sims {
        sim.delete();
    }
}

/// `{"sim_id": id}`: the arguments of a variant's batch, as its log records them.
fn sim_arguments(id: &str) -> Args {
    let mut a = Args::new();
    a.insert("sim_id".into(), json!(id));
    a
}
