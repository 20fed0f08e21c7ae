//! MuJoCo models and the robot tools every robotics user reaches for, for URDF and MJCF robots
//! alike: load_mjcf, get_link_state (PyBullet's getLinkState), reset_joint_state (PyBullet's
//! resetJointState). Thin adapters; the physics is in `World`.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};
use schemars::JsonSchema;

use super::PhysicsServer;
use crate::command::Command;
use crate::outputs::{LinkState, Message};
use crate::reads;
use crate::value::{self, arg, Args, Refusal};

/// get_link_state parameters.
#[derive(JsonSchema)]
#[allow(dead_code)]
struct LinkRef {
    /// Simulation id.
    sim_id: String,
    /// Object id of the robot.
    object_id: u32,
    /// Link index (PyBullet numbering; -1 = the base).
    link_index: i32,
}

/// reset_joint_state parameters.
#[derive(JsonSchema)]
#[allow(dead_code)]
struct ResetJoint {
    /// Simulation id.
    sim_id: String,
    /// Object id of the robot.
    object_id: u32,
    /// Joint index (PyBullet numbering).
    joint_index: u32,
    /// New joint position (rad or m).
    target_value: f64,
    /// New joint velocity (default 0).
    target_velocity: Option<f64>,
}

/// reset_joint_state's arguments → the command (the joint is checked against the world later).
fn decide_reset(a: &Args) -> Result<Command, Refusal> {
    let object_id = value::object_id(a, "object_id")?;
    let joint_index = value::integer("joint_index", value::required(a, "joint_index", "a joint index (integer >= 0)")?)?;
    let joint_index = u32::try_from(joint_index)
        .map_err(|_| format!("Joint index {joint_index} out of range: object {object_id} has no such joint"))?;
    let target_value = value::number("target_value", value::required(a, "target_value", "a number")?)?;
    let target_velocity = arg(a, "target_velocity").map(|v| value::number("target_velocity", v)).transpose()?;
    Ok(Command::ResetJointState { object_id, joint_index, target_value, target_velocity: target_velocity.unwrap_or(0.0) })
}

#[tool_router(router = mjcf_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// A link's world frame, centre of mass and its velocity (PyBullet's getLinkState;
    /// link -1 = the base).
    #[tool(input_schema = schema_for_type::<LinkRef>(), annotations(read_only_hint = true))]
    async fn get_link_state(&self, args: JsonObject) -> Result<Json<LinkState>, String> {
        self.read("get_link_state", args, |sim, a| reads::link_state(&sim.read_context(), a)).await
    }

    /// Teleport one joint to a position and velocity (PyBullet's resetJointState); the links
    /// below it follow. Motors stay as set.
    #[tool(input_schema = schema_for_type::<ResetJoint>())]
    async fn reset_joint_state(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("reset_joint_state", args, decide_reset).await
    }
}
