//! MuJoCo models and the robot tools every robotics user reaches for, for URDF and MJCF robots
//! alike: load_mjcf, get_link_state (PyBullet's getLinkState), reset_joint_state (PyBullet's
//! resetJointState). Thin adapters; the physics is in `World`.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use super::params::{self, LinkRef, ResetJoint};
use super::PhysicsServer;
use crate::command::Command;
use crate::outputs::{LinkState, Message, MjcfLoaded};
use crate::reads;
use crate::value::Refusal;

/// reset_joint_state's arguments → the command (the joint is checked against the world later).
fn decide_reset(p: ResetJoint) -> Result<Command, Refusal> {
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

#[tool_router(router = mjcf_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Load a MuJoCo MJCF model (Gymnasium, dm_control, Menagerie style) from the workspace as
    /// one robot: link -1 is the worldbody (or a free-joint root), one joint per hinge/slide
    /// in file order, joint positions are MuJoCo's qpos. `ignored` lists what of the file is
    /// not simulated. The text (includes spliced) is stored in the log, so replay, undo and
    /// load never read the files again.
    #[tool(input_schema = schema_for_type::<params::LoadMjcf>())]
    async fn load_mjcf(&self, args: JsonObject) -> Result<Json<MjcfLoaded>, String> {
        let reg = self.reg.clone();
        self.change("load_mjcf", args, move |p: params::LoadMjcf| crate::mjcf_files::load_mjcf_command(reg.sandbox(), &p))
            .await
    }

    /// A link's world frame, centre of mass and its velocity (PyBullet's getLinkState;
    /// link -1 = the base).
    #[tool(input_schema = schema_for_type::<params::LinkRef>(), annotations(read_only_hint = true))]
    async fn get_link_state(&self, args: JsonObject) -> Result<Json<LinkState>, String> {
        self.read("get_link_state", args, |sim, p: LinkRef| reads::link_state(&sim.read_context(), &p)).await
    }

    /// Teleport one joint to a position and velocity (PyBullet's resetJointState); the links
    /// below it follow. Motors stay as set.
    #[tool(input_schema = schema_for_type::<params::ResetJoint>())]
    async fn reset_joint_state(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("reset_joint_state", args, decide_reset).await
    }
}
