//! Constraint tools: create_constraint, remove_constraint (generate_revolute_joint, which
//! writes a URDF, lives with the robot tools).

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use super::objects::quat_or_identity;
use crate::params::{self, ConstraintRef, CreateConstraint};
use crate::mcp::PhysicsServer;
use crate::command::{Command, ConstraintSpec, ConstraintType};
use crate::outputs::{ConstraintCreated, Message};
use crate::value::Refusal;

pub(super) fn decide_create(p: CreateConstraint) -> Result<Command, Refusal> {
    let child_id = match p.child_id.get() {
        -1 => None,
        c => Some(u32::try_from(c).map_err(|_| format!("child_id must be an object id or -1 (the world); got {c}"))?),
    };
    let name = p.joint_type.0;
    let joint_type = ConstraintType::parse(&name).ok_or_else(|| {
        format!("joint_type must be fixed, prismatic, spherical or revolute; got {name:?}")
    })?;
    let joint_axis = p.joint_axis.map_or([0.0, 0.0, 1.0], |v| v.0);
    let needs_axis = matches!(joint_type, ConstraintType::Prismatic | ConstraintType::Revolute);
    if needs_axis && joint_axis.iter().all(|x| *x == 0.0) {
        return Err(format!("joint_axis must be a non-zero vector for a {} constraint; got [0, 0, 0]", joint_type.name()));
    }
    Ok(Command::CreateConstraint {
        spec: ConstraintSpec {
            parent_id: p.parent_id.0,
            child_id,
            joint_type,
            joint_axis,
            parent_frame_position: p.parent_frame_position.map(|v| v.0).unwrap_or_default(),
            child_frame_position: p.child_frame_position.map(|v| v.0).unwrap_or_default(),
            parent_frame_orientation: quat_or_identity(p.parent_frame_orientation),
            child_frame_orientation: quat_or_identity(p.child_frame_orientation),
        },
    })
}

pub(super) fn decide_remove(p: ConstraintRef) -> Result<Command, Refusal> {
    let i = p.constraint_id.get();
    let constraint_id = u32::try_from(i)
        .map_err(|_| format!("constraint_id must be a constraint id (integer >= 0); got {i}"))?;
    Ok(Command::RemoveConstraint { constraint_id })
}

#[tool_router(router = constraint_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// PyBullet's createConstraint (child_id -1: the world); see docs/tools.md.
    #[tool(input_schema = schema_for_type::<params::CreateConstraint>())]
    async fn create_constraint(&self, args: JsonObject) -> Result<Json<ConstraintCreated>, String> {
        self.change("create_constraint", args, decide_create).await
    }

    /// Remove a constraint.
    #[tool(
        input_schema = schema_for_type::<params::ConstraintRef>(),
        annotations(destructive_hint = true)
    )]
    async fn remove_constraint(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("remove_constraint", args, decide_remove).await
    }
}
