//! Seeing time (docs/tools.md "Seeing time"): get_trajectory, and `look_back`, the adapter pattern
//! every tool that re-simulates the past uses — lend the chain under the simulation's lock,
//! re-simulate without it, then record the call as a read (or a refusal).

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};
use serde::Serialize;
use tokio_util::sync::CancellationToken;

use crate::params::lenient::{Int, ObjectId};
use crate::params::{self, GetTrajectory, Step};
use crate::mcp::PhysicsServer;
use crate::log::fold::{self, Lent};
use crate::outputs::Trajectory;
use crate::sim::lock_sim;
use crate::seeing::foxglove;
use crate::seeing::measure::Spec;
use crate::seeing::trajectory::{self, FileForm, Request};
use crate::sim::sampled_step::Sampling;
use crate::value::{self, Args, Refusal};
use crate::files::{write, Sandbox};

/// The interval a call asks for: (from_seq, to_seq), each None for its default.
pub(crate) type Asked = (Option<u64>, Option<u64>);

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

/// An optional `fields` list, checked (`trajectory::parse_fields`).
pub(crate) fn opt_fields(v: Option<Vec<crate::params::lenient::Text>>, name: &str) -> Result<Option<Vec<String>>, Refusal> {
    v.map(|names| trajectory::parse_fields(name, &names.into_iter().map(|t| t.0).collect::<Vec<_>>())).transpose()
}

/// An optional list of object ids.
fn opt_ids(v: Option<Vec<ObjectId>>) -> Option<Vec<u32>> {
    v.map(|ids| ids.into_iter().map(|i| i.0).collect())
}

/// How an inline table of samples is shortened: None for everything, exact (`detail:
/// "full"`), else the decimals it is rounded to before unmoved objects are listed apart.
type Shortening = Option<u32>;

/// `detail` and `precision` as every sampled series reads them (get_trajectory,
/// step_simulation's samples): compact at `trajectory::DEFAULT_DECIMALS` unless asked.
pub(crate) fn shortening(detail: Option<&crate::params::lenient::Text>, precision: Option<Int<u32>>) -> Result<Shortening, Refusal> {
    let precision = precision
        .map(|n| u32::try_from(n.get()).ok().filter(|n| *n <= 15).ok_or_else(|| format!("precision must be an integer from 0 to 15 (decimals); got {}", n.get())))
        .transpose()?;
    // Compact by default: 0.1 mm (and 1e-4 of a quaternion, ~0.01°) is finer than the questions
    // a model asks of a trajectory (did it move, when did it land) at ~40 % of the bytes; "full"
    // gives every bit.
    Ok((!crate::params::lenient::full_detail(detail)?).then_some(precision.unwrap_or(trajectory::DEFAULT_DECIMALS)))
}

/// What get_trajectory asks besides the interval: what to sample, output_path (with the form
/// its extension asks for), shortening, measures (with whether samples are asked too).
type Asking = (Request, Option<(String, FileForm)>, Shortening, Option<(Vec<Spec>, bool)>, Option<Vec<String>>);

/// get_trajectory's arguments: (from_seq, to_seq), what to sample, output_path, shortening.
fn trajectory_args(a: &Args) -> Result<(Asked, Asking), Refusal> {
    let p: GetTrajectory = params::parse("get_trajectory", a)?;
    let shortening = shortening(p.detail.as_ref(), p.precision)?;
    let interval = (opt_seq(p.from_seq, "from_seq")?, opt_seq(p.to_seq, "to_seq")?);
    let req = Request {
        every: opt_every(p.every, "every")?,
        object_ids: opt_ids(p.object_ids),
        include_velocities: p.include_velocities.is_some_and(|b| b.0),
    };
    let path = p.output_path.map(|t| t.0);
    let path = path.map(|p| trajectory::file_form(&p, "output_path", &[FileForm::Csv, FileForm::Jsonl, FileForm::Mcap]).map(|f| (p, f))).transpose()?;
    if p.measure.is_some() && path.is_some() {
        return Err("measure cannot be combined with output_path: ask for the measures in a call without output_path".into());
    }
    let fields = opt_fields(p.fields, "fields")?;
    if fields.is_some() && path.is_some() {
        return Err("fields cannot be combined with output_path: the file holds every column".into());
    }
    let samples = req.every.is_some() || req.object_ids.is_some() || fields.is_some();
    Ok((interval, (req, path, shortening, p.measure.map(|m| (m.0, samples)), fields)))
}

/// get_trajectory's work: the interval sampled, and with an output path its file — written
/// there (never over an existing file; checked before the re-simulation too) with the reply
/// a summary; without one, the table inline (compact unless asked otherwise), held to the
/// reply budget where the read is logged (`look_back`).
fn sample_and_deliver((req, path, shortening, measures, fields): Asking, lent: &Lent, sandbox: &Sandbox) -> Result<Trajectory, Refusal> {
    if let Some((specs, samples)) = measures {
        return trajectory::sample_and_measure(lent, &req, specs, samples, (shortening, fields.as_deref()));
    }
    let Some((user, form)) = path else {
        let mut t = trajectory::sample_interval(lent, &req)?;
        if let Some(f) = &fields {
            trajectory::select(&mut t, f);
        }
        if let Some(decimals) = shortening {
            trajectory::compact(&mut t, Some(decimals));
        }
        return Ok(t);
    };
    let target = write::new_output(sandbox, "output_path", &user)?;
    let (t, bytes) = match form {
        // Poses and scene as Foxglove messages; contacts only from the command line (`replay
        // --mcap --contacts`): get_trajectory has no parameter for them.
        FileForm::Mcap => foxglove::export(lent, &req, false)?,
        _ => {
            let t = trajectory::sample_interval(lent, &req)?;
            let bytes = trajectory::file_bytes(&t, form);
            (t, bytes)
        }
    };
    write::create_new(sandbox, &target, "output_path", &user, &bytes)?;
    Ok(trajectory::summary(t, sandbox.shown(&target)))
}

impl PhysicsServer {
    /// step_simulation with sample_every / sample_objects (`Sim::step_sampled`), on the
    /// blocking pool under the simulation's lock like any change.
    pub(crate) async fn sampled_step(
        &self,
        args: Args,
        mut control: impl FnMut(u64) -> bool + Send + 'static,
    ) -> Result<Json<crate::outputs::Stepped>, String> {
        let out = self
            .with_sim("step_simulation", args, move |sim, a, limits| {
                let parsed = params::parse::<Step>("step_simulation", a).and_then(|p| {
                    let steps = match super::simulations::decide_step(&p)? {
                        crate::command::Command::StepSimulation { steps, .. } => steps,
                        _ => 0,
                    };
                    Ok((steps, step_sampling(&p)?.unwrap_or_default()))
                });
                match parsed {
                    Ok((steps, sampling)) => sim.step_sampled(a, steps, &sampling, limits, &mut control),
                    Err(why) => Err(sim.refuse("step_simulation", a, why)),
                }
            })
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
        stop: CancellationToken,
        parse: impl FnOnce(&Args) -> Result<(Asked, P), Refusal> + Send + 'static,
        f: impl FnOnce(P, &Lent) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        let measure = move |t: &T, _: &()| crate::sim::budget::reply_bytes(tool, serde_json::to_value(t).unwrap_or_default());
        self.look_back_with(tool, args, stop, parse, move |p, lent| f(p, lent).map(|t| (t, ())), measure).await.map(|(t, ())| Json(t))
    }

    /// `look_back` whose `f` also returns a payload `E` that goes to the client but not into
    /// the log (render_animation's GIF bytes): the log records the result `T` only, once
    /// `measure` (the reply's bytes as it will be sent) has found it within the budget. The
    /// arguments are parsed by `parse` on the blocking pool (an output path is resolved there).
    /// The re-simulation is held to `--max-work` (priced before it runs) and stopped when
    /// `stop` is cancelled (the client cancelled the request or its session ended).
    pub(crate) async fn look_back_with<P: Send + 'static, T: Serialize + Send + 'static, E: Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        stop: CancellationToken,
        parse: impl FnOnce(&Args) -> Result<(Asked, P), Refusal> + Send + 'static,
        f: impl FnOnce(P, &Lent) -> Result<(T, E), Refusal> + Send + 'static,
        measure: impl FnOnce(&T, &E) -> usize + Send + 'static,
    ) -> Result<(T, E), String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.sim(&id).await?;
        let budget = self.reg.limits().max_reply_bytes;
        let failed = || "Internal error: the call failed and changed nothing".to_string();
        // The chain is lent in the call's turn on the simulation; the re-simulation holds no
        // turn; the read is recorded in a second turn, which it waits for without the
        // --max-waiting bound (its work is done: it only has an answer to record).
        let turn = self.turn(&id, tool).await?;
        let held = sim.clone();
        let (lent, args) = tokio::task::spawn_blocking(move || {
            let _turn = turn;
            let parsed = parse(&args);
            let mut s = lock_sim(&held);
            if let Err(why) = s.ensure_live() {
                return (Err(why), args);
            }
            let lent = parsed.and_then(|((from, to), p)| Ok((fold::lend(s.log(), s.id(), from, to)?, p)));
            match lent {
                Ok(l) => (Ok(l), args),
                Err(why) => (Err(s.refuse(tool, &args, why)), args),
            }
        })
        .await
        .map_err(|_| failed())?;
        let (lent, p) = lent?;
        let bounds = fold::Bounds { stop: Some(stop), max_work: Some(self.reg.limits().max_work) };
        let out = tokio::task::spawn_blocking(move || fold::bounded(bounds, || f(p, &lent))).await.map_err(|_| failed())?;
        let turn = self.reg.queues().turn(&id, tool, usize::MAX).await?;
        tokio::task::spawn_blocking(move || {
            let _turn = turn;
            let mut s = lock_sim(&sim);
            match out {
                Ok((v, extra)) => s.read_replying(tool, &args, budget, |_| Ok(v), |t, _| measure(t, &extra)).map(|v| (v, extra)),
                Err(why) => Err(s.refuse(tool, &args, why)),
            }
        })
        .await
        .map_err(|_| failed())?
    }
}

#[tool_router(router = time_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Samples and measures of a past interval, re-simulated (docs/tools.md).
    #[tool(input_schema = schema_for_type::<params::GetTrajectory>(), annotations(read_only_hint = true))]
    async fn get_trajectory(&self, args: JsonObject, ct: CancellationToken) -> Result<Json<Trajectory>, String> {
        let sandbox = self.reg.sandbox().clone();
        self.look_back("get_trajectory", args, ct, trajectory_args, move |asking, lent| sample_and_deliver(asking, lent, &sandbox)).await
    }
}

/// step_simulation's sampling arguments, None when neither sample_every nor sample_objects
/// is given (a plain step).
pub(crate) fn step_sampling(p: &Step) -> Result<Option<Sampling>, Refusal> {
    let every = opt_every(p.sample_every, "sample_every")?;
    let object_ids = opt_ids(p.sample_objects.clone());
    let compact = shortening(p.detail.as_ref(), p.precision)?;
    let samples = every.is_some() || object_ids.is_some();
    let measure = p.measure.clone().map(|m| m.0).unwrap_or_default();
    let fields = opt_fields(p.fields.clone(), "fields")?;
    let samples = samples || fields.is_some();
    Ok((samples || p.measure.is_some()).then_some(Sampling { every, object_ids, include_velocities: false, compact, samples, measure, fields }))
}
