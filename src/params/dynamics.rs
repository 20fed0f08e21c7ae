//! Parameters of the robot calls PyBullet scripts lean on: enable_joint_force_torque_sensor,
//! get_joint_states, get_link_states, calculate_jacobian, calculate_mass_matrix,
//! calculate_inverse_dynamics, get_aabb, get_overlapping_objects, get_closest_points.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// enable_joint_force_torque_sensor parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JointSensor {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
    /// Default true.
    pub enable_sensor: Option<Bool>,
}

/// get_joint_states parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JointsRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_indices: Vec<Int<u32>>,
}

/// get_link_states parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LinksRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// -1 = base.
    pub link_indices: Vec<Int<i32>>,
}

/// calculate_jacobian parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JacobianQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// The link.
    pub link_index: Int<i32>,
    /// In the link frame.
    pub local_position: Vec3,
    /// Per movable joint.
    pub obj_positions: NumList,
    /// Per movable joint.
    pub obj_velocities: NumList,
    /// Per movable joint.
    pub obj_accelerations: NumList,
}

/// calculate_mass_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MassMatrixQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Per movable joint.
    pub obj_positions: NumList,
}

/// calculate_inverse_dynamics parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct InverseDynamicsQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Per movable joint.
    pub obj_positions: NumList,
    /// Per movable joint.
    pub obj_velocities: NumList,
    /// Per movable joint.
    pub obj_accelerations: NumList,
}

/// get_aabb parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AabbQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// -1 = base (default).
    pub link_index: Option<Int<i64>>,
}

/// get_overlapping_objects parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct OverlapQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Box corner, world.
    pub aabb_min: Vec3,
    /// Opposite corner.
    pub aabb_max: Vec3,
}

/// get_closest_points parameters (PyBullet's getClosestPoints).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ClosestPointsQuery {
    /// Sim id.
    pub sim_id: Text,
    /// Object A.
    pub body_a: ObjectId,
    /// Object B.
    pub body_b: ObjectId,
    /// Max, m.
    pub distance: NonNegative,
    /// Default all.
    pub link_index_a: Option<Int<i64>>,
    /// Default all.
    pub link_index_b: Option<Int<i64>>,
}
