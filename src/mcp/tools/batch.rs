//! The batch tool, and the one place that turns a `{tool, arguments}` call into what a batch
//! or a sweep's variant applies (`plan`): each tool's own parameter type and `decide`
//! function, so a call in a batch is checked exactly as the same call made alone.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{JsonObject, RequestMetaObject};
use rmcp::{tool, tool_router, Peer, RoleServer};
use serde_json::Value;
use tokio_util::sync::CancellationToken;

use crate::params::{self, CallSpec};
use super::{constraints, dynamics, mjcf, objects, robots, simulations, viewer};
use crate::mcp::{Params, PhysicsServer};
use crate::sim::apply::{call_refused, Call, Planned, MAX_CALLS, READS};
use crate::command::Command;
use crate::outputs::Batched;
use crate::sim::reads::Read;
use crate::command::ParsedModels;
use crate::files::{Reader, Sandbox};
use crate::value::{Args, Refusal};

/// A change tool's decision: its arguments parsed as `P`, then its `decide`.
fn change<P: Params>(tool: &str, a: &Args, decide: impl FnOnce(P) -> Result<Command, Refusal>) -> Planned {
    Planned::Change(params::parse::<P>(tool, a).and_then(decide))
}

/// A read's decision: its arguments parsed as `P` (strictly, as the tool alone would).
fn read<P: Params>(tool: &str, a: &Args, wrap: fn(P) -> Read) -> Planned {
    Planned::Read(params::parse::<P>(tool, a).map(|p| Box::new(wrap(p))))
}

/// What one request reads and parses before its simulation is locked: each distinct file
/// once (`Reader`), each distinct model once (`ParsedModels`).
pub(crate) struct Ahead {
    reader: Reader,
    models: ParsedModels,
}

impl Ahead {
    /// For one request in `sandbox`.
    pub(crate) fn new(sandbox: &Sandbox) -> Ahead {
        Ahead { reader: Reader::new(sandbox), models: ParsedModels::default() }
    }
}

/// What `tool` with arguments `a` is inside a batch; None for a tool a batch cannot hold.
fn decide(ahead: &mut Ahead, tool: &str, a: &Args) -> Option<Planned> {
    let planned = decide_call(&mut ahead.reader, tool, a)?;
    Some(match planned {
        Planned::Change(decided) => Planned::Change(decided.and_then(|c| c.ready_in(&mut ahead.models))),
        read => read,
    })
}

/// `decide` before the models are parsed.
fn decide_call(reader: &mut Reader, tool: &str, a: &Args) -> Option<Planned> {
    Some(match tool {
        "add_box" => change(tool, a, objects::decide_box),
        "add_sphere" => change(tool, a, objects::decide_sphere),
        "add_cylinder" => change(tool, a, objects::decide_cylinder),
        "add_capsule" => change(tool, a, objects::decide_capsule),
        "set_object_pose" => change(tool, a, objects::decide_pose),
        "apply_force" => change(tool, a, objects::decide_force),
        "apply_torque" => change(tool, a, objects::decide_torque),
        "set_object_velocity" => change(tool, a, objects::decide_velocity),
        "change_dynamics" => change(tool, a, objects::decide_dynamics),
        "remove_object" => change(tool, a, objects::decide_remove),
        "step_simulation" => change(tool, a, |p: params::Step| {
            if super::trajectory::step_sampling(&p)?.is_some() {
                return Err("sample_every, sample_objects and measure are not available inside a batch or sweep (run_sweep has observe.measure)".into());
            }
            simulations::decide_step(&p)
        }),
        "set_timestep" => change(tool, a, simulations::decide_timestep),
        "set_joint_motor_control" => change(tool, a, robots::decide_motor),
        "set_joint_motor_control_array" => change(tool, a, robots::decide_motor_array),
        "set_joint_trajectory" => change(tool, a, robots::decide_trajectory),
        "set_collision_filter_group_mask" => change(tool, a, objects::decide_filter),
        "set_collision_filter_pair" => change(tool, a, objects::decide_pair),
        "reset_joint_state" => change(tool, a, mjcf::decide_reset),
        "enable_joint_force_torque_sensor" => change(tool, a, dynamics::decide_sensor),
        "set_actuator_controls" => change(tool, a, mjcf::decide_controls),
        "create_constraint" => change(tool, a, constraints::decide_create),
        "remove_constraint" => change(tool, a, constraints::decide_remove),
        "enable_debug_visualization" => change(tool, a, viewer::decide_debug),
        "set_camera" => change(tool, a, viewer::decide_camera),
        "load_urdf" => change(tool, a, |p: params::LoadUrdf| crate::files::urdf::load_urdf_command(reader, &p)),
        "load_mjcf" => change(tool, a, |p: params::LoadMjcf| crate::files::mjcf::load_mjcf_command(reader, &p)),
        "get_object_state" => read(tool, a, Read::ObjectState),
        "get_joint_state" => read(tool, a, Read::JointState),
        "get_link_state" => read(tool, a, Read::LinkState),
        "get_joint_states" => read(tool, a, Read::JointStates),
        "get_link_states" => read(tool, a, Read::LinkStates),
        "get_sensor_data" => read(tool, a, Read::SensorData),
        "get_simulation_info" => read(tool, a, Read::SimulationInfo),
        _ => return None,
    })
}

/// The calls of a batch or variant on simulation `sim_id`, decided in order; a call naming an
/// unknown tool, a tool a batch cannot hold or another simulation refuses them all (`where_`
/// names the list in the sentence: "calls" or "variants[i].calls").
pub(crate) fn plan(ahead: &mut Ahead, sim_id: &str, specs: Vec<CallSpec>) -> Result<Vec<Call>, (usize, String, Refusal)> {
    let mut calls = Vec::with_capacity(specs.len());
    for (i, spec) in specs.into_iter().enumerate() {
        let mut args = spec.arguments.unwrap_or_default();
        match args.get("sim_id") {
            None | Some(Value::Null) => {
                args.insert("sim_id".into(), Value::String(sim_id.to_string()));
            }
            Some(Value::String(s)) if s == sim_id => {}
            Some(other) => {
                let why = format!("arguments.sim_id is {other}, another simulation; a batch works on {sim_id} only");
                return Err((i, spec.tool, why));
            }
        }
        let Some(planned) = decide(ahead, &spec.tool, &args) else {
            let why = if PhysicsServer::tool_names().any(|t| t == spec.tool) {
                format!(
                    "{} cannot be inside a batch or sweep; they take the state-changing tools and {}",
                    spec.tool,
                    READS.join(", ")
                )
            } else {
                format!("{} is not a tool of this server", spec.tool)
            };
            return Err((i, spec.tool, why));
        };
        calls.push(Call { tool: spec.tool, args, planned });
    }
    Ok(calls)
}

/// The steps a batch's step calls ask for together (for progress only; refusals come later).
fn steps_asked(a: &Args) -> u64 {
    let calls = a.get("calls").and_then(Value::as_array).map(Vec::as_slice).unwrap_or_default();
    let steps = calls.iter().filter(|c| c.get("tool").and_then(Value::as_str) == Some("step_simulation"));
    steps
        .map(|c| c.pointer("/arguments/steps").and_then(Value::as_u64).unwrap_or(1))
        .fold(0u64, u64::saturating_add)
        .max(1)
}

/// The batch's calls, refused as a whole when there are none or too many; their files read
/// and models parsed (before the simulation is locked).
fn batch_calls(sandbox: &Sandbox, a: &Args) -> Result<Vec<Call>, Refusal> {
    let p: params::Batch = params::parse("batch", a)?;
    crate::params::lenient::full_detail(p.detail.as_ref())?;
    let n = p.calls.len();
    if n == 0 || n > MAX_CALLS {
        return Err(format!("calls must hold 1 to {MAX_CALLS} calls; got {n}"));
    }
    plan(&mut Ahead::new(sandbox), &p.sim_id.0, p.calls).map_err(|(i, tool, why)| call_refused(i, &tool, &why))
}

#[tool_router(router = batch_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Up to 10,000 calls, all or nothing, each its own event: state-changing tools and
    /// get_object_state/joint_state/link_state/simulation_info.
    #[tool(input_schema = schema_for_type::<params::Batch>())]
    async fn batch(
        &self,
        args: JsonObject,
        meta: RequestMetaObject,
        peer: Peer<RoleServer>,
        ct: CancellationToken,
    ) -> Result<Json<Batched>, String> {
        let watch = crate::mcp::progress::Watch::new(&meta, peer, ct, steps_asked(&args));
        let mut control = watch.control();
        let sandbox = self.reg.sandbox().clone();
        let out = self
            .with_sim_prepared("batch", args, move |a| batch_calls(&sandbox, a), move |sim, a, limits, calls| match calls {
                Ok(calls) => sim.batch(a, calls, limits, &mut control),
                Err(why) => Err(sim.refuse("batch", a, why)),
            })
            .await;
        watch.finish().await;
        out.map(Json)
    }
}
