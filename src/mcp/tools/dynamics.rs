//! The robot calls PyBullet scripts lean on, for URDF and MJCF robots alike:
//! enable_joint_force_torque_sensor (PyBullet's enableJointForceTorqueSensor). Thin adapters;
//! the physics is in `World` (`world/dynamics.rs`).

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::command::Command;
use crate::mcp::PhysicsServer;
use crate::outputs::Message;
use crate::params::{self, JointSensor};
use crate::value::Refusal;

/// enable_joint_force_torque_sensor's arguments → the command (the joint is checked later).
pub(super) fn decide_sensor(p: JointSensor) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let joint_index = p.joint_index.get();
    let joint_index = u32::try_from(joint_index)
        .map_err(|_| format!("Joint index {joint_index} out of range: object {object_id} has no such joint"))?;
    Ok(Command::EnableJointForceTorqueSensor {
        object_id,
        joint_index,
        enable: p.enable_sensor.is_none_or(|b| b.0),
    })
}

#[tool_router(router = dynamics_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Turn a joint's force/torque sensor on (default) or off: get_joint_state then reports
    /// its reaction wrench.
    #[tool(input_schema = schema_for_type::<params::JointSensor>())]
    async fn enable_joint_force_torque_sensor(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("enable_joint_force_torque_sensor", args, decide_sensor).await
    }
}
