//! The run_sweep tool: parses the sweep, gives each variant a step control (progress across
//! all variants, cancellation) and runs `Registry::sweep` on the blocking pool.

use std::sync::atomic::AtomicU64;
use std::sync::Arc;

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{JsonObject, RequestMetaObject};
use rmcp::{tool, tool_router, Peer, RoleServer};
use tokio_util::sync::CancellationToken;

use crate::params::{self, CallSpec, Sweep};
use crate::mcp::PhysicsServer;
use crate::sim::apply::{call_refused, Call};
use crate::outputs::Swept;
use crate::sim::lock_sim;
use crate::sim::sweep::{Control, Metric, Observe, Rank, Request, MAX_VARIANTS};
use crate::value::{self, Args, Refusal};
use serde_json::Value;

/// The sweep a call asks for, every variant's calls decided (a refusal names the variant
/// and the call).
fn sweep_request(sandbox: &crate::files::Sandbox, a: &Args) -> Result<Request, Refusal> {
    let p: Sweep = params::parse("run_sweep", a)?;
    let n = p.variants.len();
    if n == 0 || n > MAX_VARIANTS {
        return Err(format!("variants must hold 1 to {MAX_VARIANTS} variants; got {n}"));
    }
    let steps = u64::try_from(p.steps.get()).map_err(|_| format!("steps must be an integer >= 0; got {}", p.steps.get()))?;
    let o = p.observe.unwrap_or_default();
    let observe = Observe {
        object_ids: o.object_ids.map(|ids| ids.into_iter().map(|i| i.0).collect()),
        include_velocities: o.include_velocities.is_some_and(|b| b.0),
        every: super::trajectory::opt_every(o.every, "observe.every")?,
        measure: o.measure.map(|m| m.0).unwrap_or_default(),
        fields: super::trajectory::opt_fields(o.fields, "observe.fields")?,
    };
    let mut variants = Vec::with_capacity(n);
    let mut ahead = super::batch::Ahead::new(sandbox);
    for (v, calls) in p.variants.into_iter().enumerate() {
        let planned = plan_calls(&mut ahead, &p.sim_id.0, calls).map_err(|why| format!("variants[{v}]: {why}"))?;
        variants.push(planned);
    }
    // Parsed above, so an array of arrays: each variant's calls as the client sent them.
    let sent = a.get("variants").and_then(Value::as_array).cloned().unwrap_or_default();
    let rank_by = match p.rank_by {
        None => None,
        Some(r) => Some(rank_by(r, observe.measure.len())?),
    };
    let full = crate::params::lenient::full_detail(p.detail.as_ref())?;
    Ok(Request { variants, sent, steps, observe, keep: p.keep.is_some_and(|b| b.0), full, rank_by })
}

/// What rank_by asks: one of observe.measure (by index), or an object's metric.
fn rank_by(r: crate::params::RankBy, measures: usize) -> Result<Rank, Refusal> {
    if let Some(i) = r.measure {
        let i = usize::try_from(i.get()).ok().filter(|i| *i < measures);
        return match (i, r.object_id, r.metric) {
            (Some(i), None, None) => Ok(Rank::Measure(i)),
            (None, ..) => Err(format!("rank_by.measure must be an index into observe.measure (0 to {}); observe.measure holds {measures}", measures.max(1) - 1)),
            _ => Err("rank_by takes either measure or object_id with metric, not both".into()),
        };
    }
    let (Some(id), Some(metric)) = (r.object_id, r.metric) else {
        return Err("rank_by needs measure (an index into observe.measure) or object_id with metric".into());
    };
    let metric = match metric.0.as_str() {
        "displacement" => Metric::Displacement,
        "peak_speed" => Metric::PeakSpeed,
        "final_z" => Metric::FinalZ,
        other => return Err(format!("rank_by.metric must be displacement, peak_speed or final_z; got {other:?}")),
    };
    Ok(Rank::Metric(id.0, metric))
}

/// One variant's calls decided (a refusal names the call).
fn plan_calls(ahead: &mut super::batch::Ahead, sim_id: &str, calls: Vec<CallSpec>) -> Result<Vec<Call>, Refusal> {
    super::batch::plan(ahead, sim_id, calls).map_err(|(i, tool, why)| call_refused(i, &tool, &why))
}

/// A variant sent to this node by another node's sweep, decided here as the sweeping node
/// decided it (the same workspace, the same parameters).
fn plan_sent(sandbox: &crate::files::Sandbox, sim_id: &str, calls: &Value) -> Result<Vec<Call>, Refusal> {
    let calls: Vec<CallSpec> = serde_json::from_value(calls.clone()).map_err(|e| format!("the variant's calls do not parse: {e}"))?;
    plan_calls(&mut super::batch::Ahead::new(sandbox), sim_id, calls)
}

impl PhysicsServer {
    /// Makes a cluster node run sweep variants for every node of its cluster (nothing for an
    /// embedded server): its sweepers decide the calls they are sent with this layer's
    /// `batch::plan`, which the registry cannot name, so they are started from here.
    pub fn start_sweepers(reg: &Arc<crate::sim::Registry>) -> anyhow::Result<()> {
        reg.start_sweepers(plan_sent)
    }
}

#[tool_router(router = sweep_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Fork per variant in parallel, apply its calls, step, summarise (docs/tools.md).
    #[tool(input_schema = schema_for_type::<params::Sweep>())]
    async fn run_sweep(
        &self,
        args: JsonObject,
        meta: RequestMetaObject,
        peer: Peer<RoleServer>,
        ct: CancellationToken,
    ) -> Result<Json<Swept>, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.sim(&id).await?;
        // Counted from the parameters alone, for progress; the files the variants name are
        // read (and their models parsed) on the blocking pool, below.
        let (n, steps, keep) = params::parse::<Sweep>("run_sweep", &args).map_or((1, 1, false), |p| {
            (p.variants.len().max(1), u64::try_from(p.steps.get()).unwrap_or(1), p.keep.is_some_and(|b| b.0))
        });
        let watch = crate::mcp::progress::Watch::new(&meta, peer, ct, (n as u64).saturating_mul(steps).max(1));
        let done = Arc::new(AtomicU64::new(0));
        let mut controls: Vec<Control> = (0..n).map(|_| Box::new(watch.shared_control(done.clone())) as Control).collect();
        let reg = self.reg.clone();
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
        let budget = self.reg.limits().max_reply_bytes;
        let sandbox = self.reg.sandbox().clone();
        let failed = || "Internal error: the sweep failed and changed nothing".to_string();
        // The variants' files are read before the sweep waits for its turn on the simulation,
        // which it holds only while the forks' source is taken (`Registry::sweep`).
        let (req, args) = tokio::task::spawn_blocking(move || (sweep_request(&sandbox, &args), args)).await.map_err(|_| failed())?;
        let out = match self.turn(&id, "run_sweep").await {
            Ok(turn) => tokio::task::spawn_blocking(move || match req {
                Ok(req) => {
                    let next = move || controls.pop().unwrap_or_else(|| Box::new(|_| true));
                    reg.sweep(&id, &args, req, next, (workers, budget), Some(turn))
                }
                Err(why) => {
                    let _turn = turn;
                    let mut s = lock_sim(&sim);
                    s.ensure_live()?;
                    Err(s.refuse("run_sweep", &args, why))
                }
            })
            .await
            .map_err(|_| failed()),
            Err(busy) => Ok(Err(busy)),
        };
        watch.finish().await;
        let out = out?.map(Json);
        if keep {
            self.simulations_changed(out)
        } else {
            out
        }
    }
}
