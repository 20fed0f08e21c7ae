//! MuJoCo models and the robot tools every robotics user reaches for, for URDF and MJCF robots
//! alike: load_mjcf, get_link_state (PyBullet's getLinkState), reset_joint_state (PyBullet's
//! resetJointState). Thin adapters; the physics is in `World`.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::{self, LinkRef, ResetJoint};
use crate::mcp::PhysicsServer;
use crate::command::Command;
use crate::outputs::{LinkState, Message, MjcfLoaded, SensorData};
use crate::sim::reads;
use crate::value::Refusal;

/// reset_joint_state's arguments → the command (the joint is checked against the world later).
pub(super) fn decide_reset(p: ResetJoint) -> Result<Command, Refusal> {
    let object_id = p.object_id.0;
    let joint_index = p.joint_index.get();
    let joint_index = u32::try_from(joint_index)
        .map_err(|_| format!("Joint index {joint_index} out of range: object {object_id} has no such joint"))?;
    Ok(Command::ResetJointState {
        object_id,
        joint_index,
        target_value: p.target_value.0,
        target_velocity: p.target_velocity.map_or(0.0, |v| v.0),
    })
}

/// set_actuator_controls' arguments → the command (the actuators are checked later).
pub(super) fn decide_controls(p: params::ActuatorControlsSet) -> Result<Command, Refusal> {
    Ok(Command::SetActuatorControls { object_id: p.object_id.0, controls: p.controls.0 })
}

#[tool_router(router = mjcf_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Load an MJCF model as one robot; `ignored`: what is not simulated.
    #[tool(input_schema = schema_for_type::<params::LoadMjcf>())]
    async fn load_mjcf(&self, args: JsonObject) -> Result<Json<MjcfLoaded>, String> {
        self.change_reading("load_mjcf", args, |p: params::LoadMjcf, reader| crate::files::mjcf::load_mjcf_command(reader, &p))
            .await
    }

    /// Set an MJCF model's actuator controls (held).
    #[tool(input_schema = schema_for_type::<params::ActuatorControlsSet>())]
    async fn set_actuator_controls(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_actuator_controls", args, decide_controls).await
    }

    /// An MJCF model's MuJoCo sensordata.
    #[tool(input_schema = schema_for_type::<params::SensorsRef>(), annotations(read_only_hint = true))]
    async fn get_sensor_data(&self, args: JsonObject) -> Result<Json<SensorData>, String> {
        self.read("get_sensor_data", args, |sim, p: params::SensorsRef| reads::sensor_data(&sim.read_context(), &p)).await
    }

    /// A link's frame (link_world_*: the URDF link frame, which IK targets) and centre of mass (com_world_*), and its velocity.
    #[tool(input_schema = schema_for_type::<params::LinkRef>(), annotations(read_only_hint = true))]
    async fn get_link_state(&self, args: JsonObject) -> Result<Json<LinkState>, String> {
        self.read("get_link_state", args, |sim, p: LinkRef| reads::link_state(&sim.read_context(), &p)).await
    }

    /// Teleport a joint to a position and velocity; motors stay.
    #[tool(input_schema = schema_for_type::<params::ResetJoint>())]
    async fn reset_joint_state(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("reset_joint_state", args, decide_reset).await
    }
}
