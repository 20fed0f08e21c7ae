//! The robot calls PyBullet scripts lean on, for URDF and MJCF robots alike, with PyBullet's
//! names: enable_joint_force_torque_sensor, get_joint_states, get_link_states,
//! calculate_jacobian, calculate_mass_matrix, calculate_inverse_dynamics, get_aabb,
//! get_overlapping_objects, get_closest_points. Thin adapters; the
//! physics is in `World` (`world/dynamics.rs`), the reads in `sim/dynamics_reads.rs`.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::command::Command;
use crate::mcp::PhysicsServer;
use crate::outputs::{Aabb, ClosestPoints, InverseDynamics, Overlapping, Jacobian, JointStates, LinkStates, MassMatrix, Message};
use crate::sim::dynamics_reads as reads;
use crate::params::{self, AabbQuery, ClosestPointsQuery, InverseDynamicsQuery, OverlapQuery, JacobianQuery, JointSensor, JointsRef, LinksRef, MassMatrixQuery};
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
    /// Sensor on/off: get_joint_state reports the joint's reaction wrench.
    #[tool(input_schema = schema_for_type::<params::JointSensor>())]
    async fn enable_joint_force_torque_sensor(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("enable_joint_force_torque_sensor", args, decide_sensor).await
    }

    /// get_joint_state for several joints in one call.
    #[tool(input_schema = schema_for_type::<params::JointsRef>(), annotations(read_only_hint = true))]
    async fn get_joint_states(&self, args: JsonObject) -> Result<Json<JointStates>, String> {
        self.read("get_joint_states", args, |sim, p: JointsRef| reads::joint_states(&sim.read_context(), &p)).await
    }

    /// get_link_state for several links in one call.
    #[tool(input_schema = schema_for_type::<params::LinksRef>(), annotations(read_only_hint = true))]
    async fn get_link_states(&self, args: JsonObject) -> Result<Json<LinkStates>, String> {
        self.read("get_link_states", args, |sim, p: LinksRef| reads::link_states(&sim.read_context(), &p)).await
    }

    /// Jacobian of a point on a link, world frame (docs/tools.md).
    #[tool(input_schema = schema_for_type::<params::JacobianQuery>(), annotations(read_only_hint = true))]
    async fn calculate_jacobian(&self, args: JsonObject) -> Result<Json<Jacobian>, String> {
        self.read("calculate_jacobian", args, |sim, p: JacobianQuery| reads::jacobian(&sim.read_context(), &p)).await
    }

    /// Joint-space mass matrix at joint positions.
    #[tool(input_schema = schema_for_type::<params::MassMatrixQuery>(), annotations(read_only_hint = true))]
    async fn calculate_mass_matrix(&self, args: JsonObject) -> Result<Json<MassMatrix>, String> {
        self.read("calculate_mass_matrix", args, |sim, p: MassMatrixQuery| reads::mass_matrix(&sim.read_context(), &p)).await
    }

    /// Joint torques for positions, velocities, accelerations, gravity.
    #[tool(input_schema = schema_for_type::<params::InverseDynamicsQuery>(), annotations(read_only_hint = true))]
    async fn calculate_inverse_dynamics(&self, args: JsonObject) -> Result<Json<InverseDynamics>, String> {
        self.read("calculate_inverse_dynamics", args, |sim, p: InverseDynamicsQuery| reads::inverse_dynamics(&sim.read_context(), &p)).await
    }

    /// World box around an object's or link's collision shapes.
    #[tool(input_schema = schema_for_type::<params::AabbQuery>(), annotations(read_only_hint = true))]
    async fn get_aabb(&self, args: JsonObject) -> Result<Json<Aabb>, String> {
        self.read("get_aabb", args, |sim, p: AabbQuery| crate::sim::geometry_reads::aabb(&sim.read_context(), &p)).await
    }

    /// Objects and links whose boxes overlap a world box.
    #[tool(input_schema = schema_for_type::<params::OverlapQuery>(), annotations(read_only_hint = true))]
    async fn get_overlapping_objects(&self, args: JsonObject) -> Result<Json<Overlapping>, String> {
        self.read("get_overlapping_objects", args, |sim, p: OverlapQuery| crate::sim::geometry_reads::overlapping(&sim.read_context(), &p)).await
    }

    /// Closest points of two objects or links within distance (<0: overlap).
    #[tool(input_schema = schema_for_type::<params::ClosestPointsQuery>(), annotations(read_only_hint = true))]
    async fn get_closest_points(&self, args: JsonObject) -> Result<Json<ClosestPoints>, String> {
        self.read("get_closest_points", args, |sim, p: ClosestPointsQuery| crate::sim::geometry_reads::closest_points(&sim.read_context(), &p)).await
    }
}
