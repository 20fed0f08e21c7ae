//! Seeing time (SPEC "Seeing time"): get_trajectory, and `look_back`, the adapter pattern
//! every tool that re-simulates the past uses — lend the chain under the simulation's lock,
//! re-simulate without it, then record the call as a read (or a refusal).

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};
use serde::Serialize;

use super::lenient::{Int, ObjectId};
use super::params::{self, GetTrajectory, Step};
use super::PhysicsServer;
use crate::fold::{self, Lent};
use crate::outputs::Trajectory;
use crate::sim::lock_sim;
use crate::trajectory::{self, Request};
use crate::value::{self, Args, Refusal};
use crate::files::{write, Sandbox};

/// The interval a call asks for: (from_seq, to_seq), each None for its default.
pub(crate) type Asked = (Option<u64>, Option<u64>);

/// step_simulation's sampling: (sample_every, sample_objects).
pub(crate) type StepSampling = (Option<u64>, Option<Vec<u32>>);

/// An optional seq: an integer ≥ 0.
fn opt_seq(v: Option<Int<u64>>, name: &str) -> Result<Option<u64>, Refusal> {
    v.map(|n| u64::try_from(n.get()).map_err(|_| format!("{name} must be an integer >= 0; got {}", n.get())))
        .transpose()
}

/// An optional integer that must be ≥ 1 (`every`, `sample_every`).
pub(crate) fn opt_every(v: Option<Int<u64>>, name: &str) -> Result<Option<u64>, Refusal> {
    v.map(|n| {
        u64::try_from(n.get()).ok().filter(|n| *n >= 1).ok_or_else(|| format!("{name} must be an integer >= 1; got {}", n.get()))
    })
    .transpose()
}

/// An optional list of object ids.
fn opt_ids(v: Option<Vec<ObjectId>>) -> Option<Vec<u32>> {
    v.map(|ids| ids.into_iter().map(|i| i.0).collect())
}

/// get_trajectory's arguments: (from_seq, to_seq), what to sample, output_path.
fn trajectory_args(a: &Args) -> Result<(Asked, (Request, Option<String>)), Refusal> {
    let p: GetTrajectory = params::parse("get_trajectory", a)?;
    let interval = (opt_seq(p.from_seq, "from_seq")?, opt_seq(p.to_seq, "to_seq")?);
    let req = Request {
        every: opt_every(p.every, "every")?,
        object_ids: opt_ids(p.object_ids),
        include_velocities: p.include_velocities.is_some_and(|b| b.0),
    };
    let path = p.output_path.map(|t| t.0);
    if let Some(p) = &path {
        trajectory::is_jsonl(p, "output_path")?;
    }
    Ok((interval, (req, path)))
}

/// The reply of get_trajectory: the table inline (within the reply budget) or in the file.
fn deliver(t: Trajectory, path: Option<String>, sandbox: &Sandbox) -> Result<Trajectory, Refusal> {
    let Some(user) = path else {
        // Inline: held to the reply budget where the read is logged (`look_back`).
        return Ok(t);
    };
    let bytes = trajectory::file_bytes(&t, &user, "output_path")?;
    let target = write::new_output(sandbox, "output_path", &user)?;
    write::create_new(sandbox, &target, "output_path", &user, &bytes)?;
    Ok(trajectory::summary(t, target.display().to_string()))
}

impl PhysicsServer {
    /// step_simulation with sample_every / sample_objects (`sampled_step`), on the blocking
    /// pool under the simulation's lock like any change.
    pub(crate) async fn sampled_step(
        &self,
        args: Args,
        mut control: impl FnMut(u64) -> bool + Send + 'static,
    ) -> Result<Json<crate::outputs::Stepped>, String> {
        let out = self
            .with_sim(args, move |sim, a, limits| sampled_step(sim, a, limits, &mut control))
            .await?;
        Ok(Json(out))
    }

    /// Runs `f` on an interval of simulation `sim_id` without holding the simulation: the
    /// chain is lent under its lock (`fold::lend`, no physics), `f` re-simulates on the
    /// blocking pool, and the call is recorded as a read — or, when the arguments
    /// (`parsed`), the interval or `f` refuse, as a refusal, changing nothing.
    pub(crate) async fn look_back<P: Send + 'static, T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        parse: impl FnOnce(&Args) -> Result<(Asked, P), Refusal> + Send + 'static,
        f: impl FnOnce(P, &Lent) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        let measure = move |t: &T, _: &()| crate::budget::reply_bytes(tool, serde_json::to_value(t).unwrap_or_default());
        self.look_back_with(tool, args, parse, move |p, lent| f(p, lent).map(|t| (t, ())), measure).await.map(|(t, ())| Json(t))
    }

    /// `look_back` whose `f` also returns a payload `E` that goes to the client but not into
    /// the log (render_animation's GIF bytes): the log records the result `T` only, once
    /// `measure` (the reply's bytes as it will be sent) has found it within the budget. The
    /// arguments are parsed by `parse` on the blocking pool (an output path is resolved there).
    pub(crate) async fn look_back_with<P: Send + 'static, T: Serialize + Send + 'static, E: Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        parse: impl FnOnce(&Args) -> Result<(Asked, P), Refusal> + Send + 'static,
        f: impl FnOnce(P, &Lent) -> Result<(T, E), Refusal> + Send + 'static,
        measure: impl FnOnce(&T, &E) -> usize + Send + 'static,
    ) -> Result<(T, E), String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.reg.get(&id)?;
        let budget = self.reg.limits().max_reply_bytes;
        tokio::task::spawn_blocking(move || {
            let parsed = parse(&args);
            let lent = {
                let mut s = lock_sim(&sim);
                s.ensure_live()?;
                let lent = parsed.and_then(|((from, to), p)| Ok((fold::lend(s.log(), s.id(), from, to)?, p)));
                match lent {
                    Ok(l) => l,
                    Err(why) => return Err(s.refuse(tool, &args, why)),
                }
            };
            let (lent, p) = lent;
            let out = f(p, &lent);
            let mut s = lock_sim(&sim);
            match out {
                Ok((v, extra)) => s.read_replying(tool, &args, budget, |_| Ok(v), |t, _| measure(t, &extra)).map(|v| (v, extra)),
                Err(why) => Err(s.refuse(tool, &args, why)),
            }
        })
        .await
        .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?
    }
}

#[tool_router(router = time_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Poses sampled over a past interval, re-simulated from the log (columnar).
    #[tool(input_schema = schema_for_type::<params::GetTrajectory>(), annotations(read_only_hint = true))]
    async fn get_trajectory(&self, args: JsonObject) -> Result<Json<Trajectory>, String> {
        let sandbox = self.reg.sandbox().clone();
        self.look_back("get_trajectory", args, trajectory_args, move |(req, path), lent| {
            let t = trajectory::sample_interval(lent, &req)?;
            deliver(t, path, &sandbox)
        })
        .await
    }
}

/// step_simulation's sampling arguments: (sample_every, sample_objects), None when neither
/// is given (a plain step).
pub(crate) fn step_sampling(p: &Step) -> Result<Option<StepSampling>, Refusal> {
    let every = opt_every(p.sample_every, "sample_every")?;
    let ids = opt_ids(p.sample_objects.clone());
    Ok((every.is_some() || ids.is_some()).then_some((every, ids)))
}

/// A step taken by `Sim::change_observed` with a `Sampler` watching: the event, its recorded
/// result and hash are a plain step's; the samples (SPEC's rule, `fold::Cadence`) are added
/// to the reply only. Bounds are checked before stepping, since a step cannot be refused
/// after it is taken.
pub(crate) fn sampled_step(
    sim: &mut crate::sim::Sim,
    a: &Args,
    limits: &crate::limits::Limits,
    control: crate::world::StepControl,
) -> Result<crate::outputs::Stepped, Refusal> {
    sampled_step_with(sim, a, limits, control, false)
}

/// `sampled_step`, with velocities in the samples when `include_velocities` (run_sweep's
/// observe).
pub(crate) fn sampled_step_with(
    sim: &mut crate::sim::Sim,
    a: &Args,
    limits: &crate::limits::Limits,
    control: crate::world::StepControl,
    include_velocities: bool,
) -> Result<crate::outputs::Stepped, Refusal> {
    let checked = (|| {
        let p: Step = params::parse("step_simulation", a)?;
        let (every, ids) = step_sampling(&p)?.unwrap_or_default();
        let cmd = super::simulations::decide_step(&p)?;
        let steps = match &cmd {
            crate::command::Command::StepSimulation { steps } => *steps,
            _ => 0,
        };
        let w = sim.world();
        let listed: Vec<u32> = ids.clone().unwrap_or_else(|| w.objects().map(|(id, _)| id).collect());
        if let Some(id) = listed.iter().find(|id| !w.has_object(**id)) {
            return Err(format!("sample_objects: object {id} does not exist in simulation {}", w.simulation_id()));
        }
        let every = every.unwrap_or_else(|| trajectory::default_every(steps));
        let samples = trajectory::max_samples(steps, every);
        trajectory::check_cells(samples, listed.len() as u64, "sample_every")?;
        let numbers = listed.iter().map(|id| trajectory::numbers_per_object(w, *id, include_velocities)).sum();
        // And against --max-reply-bytes, which may be lower than the default: the central
        // reply check could only refuse after the steps were taken.
        crate::budget::check_structured_bound("step_simulation", trajectory::reply_bound(samples, numbers), limits.max_reply_bytes)?;
        Ok((cmd, every, ids))
    })();
    let (cmd, every, ids) = match checked {
        Ok(c) => c,
        Err(why) => return Err(sim.refuse("step_simulation", a, why)),
    };
    let (from, seq) = (sim.log().head_seq(), sim.log().next_seq());
    let req = Request { every: Some(every), object_ids: ids, include_velocities };
    let mut sampler = trajectory::Sampler::new(fold::Interval { from_seq: from, to_seq: seq }, every, &req);
    sampler.sample(sim.world(), from);
    let mut cadence = fold::Cadence::new(every);
    let mut observe = |w: &crate::world::World| {
        if cadence.step() {
            sampler.sample(w, seq);
        }
    };
    let outcome = sim.change_observed("step_simulation", a, Ok(cmd), limits, control, &mut observe)?;
    let mut result = crate::outputs::Stepped::try_from(outcome)
        .map_err(|_| "Internal error: step_simulation gave a result of an unexpected kind".to_string())?;
    if cadence.end() {
        sampler.sample(sim.world(), seq);
    }
    // The samples' seq is the event's, which `change` appended right after `head_seq`.
    debug_assert_eq!(sim.log().head_seq(), seq);
    result.trajectory = sampler.finish("sample_every").ok();
    Ok(result)
}
