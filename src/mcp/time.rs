//! Seeing time (SPEC "Seeing time"): get_trajectory, and `look_back`, the adapter pattern
//! every tool that re-simulates the past uses — lend the chain under the simulation's lock,
//! re-simulate without it, then record the call as a read (or a refusal).

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};
use schemars::JsonSchema;
use serde::Serialize;

use super::PhysicsServer;
use crate::fold::{self, Lent};
use crate::outputs::Trajectory;
use crate::sim::lock_sim;
use crate::trajectory::{self, Request};
use crate::value::{self, Args, Refusal};
use crate::workspace::Sandbox;

/// get_trajectory parameters.
#[derive(JsonSchema)]
#[allow(dead_code)]
pub struct GetTrajectory {
    /// Simulation id.
    pub sim_id: String,
    /// State-changing event whose resulting state starts the interval (default: the state
    /// just before the last step_simulation).
    pub from_seq: Option<u64>,
    /// State-changing event that ends the interval (default: the head).
    pub to_seq: Option<u64>,
    /// Steps between samples (default: about 100 samples).
    pub every: Option<u64>,
    /// Objects to sample (default: all).
    pub object_ids: Option<Vec<u32>>,
    /// Also sample velocities (default false).
    pub include_velocities: Option<bool>,
    /// Write the whole table to this .csv or .jsonl file in the workspace; reply a summary.
    pub output_path: Option<String>,
}

/// The interval a call asks for: (from_seq, to_seq), each None for its default.
pub(crate) type Asked = (Option<u64>, Option<u64>);

/// step_simulation's sampling: (sample_every, sample_objects).
pub(crate) type StepSampling = (Option<u64>, Option<Vec<u32>>);

/// An optional non-negative integer argument.
fn opt_u64(a: &Args, name: &str) -> Result<Option<u64>, Refusal> {
    value::arg(a, name)
        .map(|v| {
            let n = value::integer(name, v)?;
            u64::try_from(n).map_err(|_| format!("{name} must be an integer >= 0; got {n}"))
        })
        .transpose()
}

/// An optional integer argument that must be ≥ 1 (`every`, `sample_every`).
pub(crate) fn opt_every(a: &Args, name: &str) -> Result<Option<u64>, Refusal> {
    value::arg(a, name)
        .map(|v| {
            let n = value::integer(name, v)?;
            u64::try_from(n).ok().filter(|n| *n >= 1).ok_or_else(|| format!("{name} must be an integer >= 1; got {n}"))
        })
        .transpose()
}

/// An optional list of object ids.
pub(crate) fn opt_ids(a: &Args, name: &str) -> Result<Option<Vec<u32>>, Refusal> {
    let Some(v) = value::arg(a, name) else { return Ok(None) };
    let list = v.as_array().ok_or_else(|| format!("{name} must be a list of object ids; got {}", value::show(v)))?;
    let ids = list
        .iter()
        .map(|x| {
            let n = value::integer(name, x)?;
            u32::try_from(n).map_err(|_| format!("{name} must hold object ids (integers >= 0); got {n}"))
        })
        .collect::<Result<Vec<u32>, Refusal>>()?;
    Ok(Some(ids))
}

/// get_trajectory's arguments: (from_seq, to_seq), what to sample, output_path.
fn trajectory_args(a: &Args) -> Result<(Asked, (Request, Option<String>)), Refusal> {
    let interval = (opt_u64(a, "from_seq")?, opt_u64(a, "to_seq")?);
    let req = Request {
        every: opt_every(a, "every")?,
        object_ids: opt_ids(a, "object_ids")?,
        include_velocities: value::bool_or(a, "include_velocities", false)?,
    };
    let path = value::arg(a, "output_path").map(|_| value::string(a, "output_path")).transpose()?;
    if let Some(p) = &path {
        trajectory::is_jsonl(p, "output_path")?;
    }
    Ok((interval, (req, path)))
}

/// Where a new output file goes: inside the workspace, not existing yet (never overwritten).
pub(crate) fn new_output(sandbox: &Sandbox, user: &str) -> Result<std::path::PathBuf, Refusal> {
    let target = sandbox.writable(user).map_err(|e| format!("output_path: {}", e.replacen("file_path ", "", 1)))?;
    if target.exists() {
        return Err(format!("output_path {user} already exists; give a new file name (files are never overwritten)"));
    }
    Ok(target)
}

/// The reply of get_trajectory: the table inline (within the reply budget) or in the file.
fn deliver(t: Trajectory, path: Option<String>, sandbox: &Sandbox) -> Result<Trajectory, Refusal> {
    let Some(user) = path else {
        trajectory::check_reply(&t, "every")?;
        return Ok(t);
    };
    let bytes = trajectory::file_bytes(&t, &user, "output_path")?;
    let target = new_output(sandbox, &user)?;
    sandbox.write_atomic(&target, &bytes)?;
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
            .with_sim(args, move |sim, a, limits| sampled_step(sim, a, super::simulations::decide_step(a), limits, &mut control))
            .await?;
        serde_json::from_value(out).map(Json).map_err(|e| format!("Internal error: unexpected result shape: {e}"))
    }

    /// Runs `f` on an interval of simulation `sim_id` without holding the simulation: the
    /// chain is lent under its lock (`fold::lend`, no physics), `f` re-simulates on the
    /// blocking pool, and the call is recorded as a read — or, when the arguments
    /// (`parsed`), the interval or `f` refuse, as a refusal, changing nothing.
    pub(crate) async fn look_back<P: Send + 'static, T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        parsed: Result<(Asked, P), Refusal>,
        f: impl FnOnce(P, &Lent) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.reg.get(&id)?;
        tokio::task::spawn_blocking(move || {
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
                Ok(v) => s.read(tool, &args, |_| Ok(v)),
                Err(why) => Err(s.refuse(tool, &args, why)),
            }
        })
        .await
        .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?
        .map(Json)
    }
}

#[tool_router(router = time_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Poses (and velocities, robot joint positions) sampled over any past interval of the
    /// simulation, re-simulated exactly from its log: columnar arrays, one entry per sample.
    #[tool(input_schema = schema_for_type::<GetTrajectory>(), annotations(read_only_hint = true))]
    async fn get_trajectory(&self, args: JsonObject) -> Result<Json<Trajectory>, String> {
        let parsed = trajectory_args(&args);
        let sandbox = self.reg.sandbox().clone();
        self.look_back("get_trajectory", args, parsed, move |(req, path), lent| {
            let t = trajectory::sample_interval(lent, &req)?;
            deliver(t, path, &sandbox)
        })
        .await
    }
}

/// step_simulation's sampling arguments: (sample_every, sample_objects), None when neither
/// is given (a plain step).
pub(crate) fn step_sampling(a: &Args) -> Result<Option<StepSampling>, Refusal> {
    let every = opt_every(a, "sample_every")?;
    let ids = opt_ids(a, "sample_objects")?;
    Ok((every.is_some() || ids.is_some()).then_some((every, ids)))
}

/// A step taken by `Sim::change_observed` with a `Sampler` watching: the event, its recorded
/// result and hash are a plain step's; the samples (SPEC's rule, `fold::Cadence`) are added
/// to the reply only. Bounds are checked before stepping, since a step cannot be refused
/// after it is taken.
pub(crate) fn sampled_step(
    sim: &mut crate::sim::Sim,
    a: &Args,
    decided: Result<crate::command::Command, Refusal>,
    limits: &crate::limits::Limits,
    control: crate::world::StepControl,
) -> Result<serde_json::Value, Refusal> {
    let checked = (|| {
        let (every, ids) = step_sampling(a)?.unwrap_or_default();
        let cmd = decided?;
        let steps = match &cmd {
            crate::command::Command::StepSimulation { steps } => *steps,
            _ => 0,
        };
        let w = sim.world();
        let listed: Vec<u32> = ids.clone().unwrap_or_else(|| w.tables.objects.keys().copied().collect());
        if let Some(id) = listed.iter().find(|id| !w.has_object(**id)) {
            return Err(format!("sample_objects: object {id} does not exist in simulation {}", w.simulation_id()));
        }
        let every = every.unwrap_or_else(|| trajectory::default_every(steps));
        let samples = trajectory::max_samples(steps, every);
        trajectory::check_cells(samples, listed.len() as u64, "sample_every")?;
        let numbers = listed.iter().map(|id| trajectory::numbers_per_object(w, *id, false)).sum();
        trajectory::check_reply_bound(samples, numbers, "sample_every")?;
        Ok((cmd, every, ids))
    })();
    let (cmd, every, ids) = match checked {
        Ok(c) => c,
        Err(why) => return Err(sim.refuse("step_simulation", a, why)),
    };
    let (from, seq) = (sim.log().head_seq(), sim.log().next_seq());
    let req = Request { every: Some(every), object_ids: ids, include_velocities: false };
    let mut sampler = trajectory::Sampler::new(fold::Interval { from_seq: from, to_seq: seq }, every, &req);
    sampler.sample(sim.world(), from);
    let mut cadence = fold::Cadence::new(every);
    let mut observe = |w: &crate::world::World| {
        if cadence.step() {
            sampler.sample(w, seq);
        }
    };
    let mut result = sim.change_observed("step_simulation", a, Ok(cmd), limits, control, &mut observe)?;
    if cadence.end() {
        sampler.sample(sim.world(), seq);
    }
    // The samples' seq is the event's, which `change` appended right after `head_seq`.
    debug_assert_eq!(sim.log().head_seq(), seq);
    if let Ok(t) = sampler.finish("sample_every") {
        result["trajectory"] = serde_json::to_value(t).unwrap_or_default();
    }
    Ok(result)
}
