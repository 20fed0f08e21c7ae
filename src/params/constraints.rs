//! Parameters of create_constraint, remove_constraint.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// create_constraint parameters (PyBullet's createConstraint, plus revolute).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CreateConstraint {
    /// Sim id.
    pub sim_id: Text,
    /// Object.
    pub parent_id: ObjectId,
    /// Object or -1.
    pub child_id: Int<i64>,
    /// fixed, prismatic, spherical or revolute.
    pub joint_type: Text,
    /// Default z.
    pub joint_axis: Option<Vec3>,
    /// Default 0.
    pub parent_frame_position: Option<Vec3>,
    /// Child frame.
    pub child_frame_position: Option<Vec3>,
    /// Default identity.
    pub parent_frame_orientation: Option<Quat>,
    /// Default identity.
    pub child_frame_orientation: Option<Quat>,
}

/// remove_constraint parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ConstraintRef {
    /// Sim id.
    pub sim_id: Text,
    /// Constraint id.
    pub constraint_id: Int<u32>,
}
