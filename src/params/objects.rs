//! Parameters of add_box/sphere/cylinder/capsule, poses, forces, torques, velocities, dynamics, remove_object.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// add_box parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddBox {
    /// Sim id.
    pub sim_id: Text,
    /// HALF-extents [hx, hy, hz] (m).
    pub dimensions: Vec3,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// false: no contacts, still seen.
    pub collides: Option<Bool>,
}

/// add_sphere parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddSphere {
    /// Sim id.
    pub sim_id: Text,
    /// Radius (m).
    pub radius: Positive,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// false: no contacts, still seen.
    pub collides: Option<Bool>,
}

/// add_cylinder / add_capsule parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddRound {
    /// Sim id.
    pub sim_id: Text,
    /// Radius (m).
    pub radius: Positive,
    /// Along local z (m).
    pub height: Positive,
    /// World (m).
    pub position: Vec3,
    /// kg (default 1; 0 = static).
    pub mass: Option<NonNegative>,
    /// RGB(A) in [0, 1].
    pub color: Option<Color>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// false: no contacts, still seen.
    pub collides: Option<Bool>,
}

/// Parameters naming an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ObjectRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
}

/// set_object_pose parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetPose {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// World (m).
    pub position: Vec3,
    /// Default identity.
    pub orientation: Option<Quat>,
}

/// apply_force parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ApplyForce {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// N, world frame.
    pub force: Vec3,
    /// World point (default: centre of mass).
    pub position: Option<Vec3>,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
}

/// apply_torque parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ApplyTorque {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// N·m, world frame.
    pub torque: Vec3,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
}

/// set_object_velocity parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetVelocity {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// m/s.
    pub linear_velocity: Option<Vec3>,
    /// rad/s.
    pub angular_velocity: Option<Vec3>,
}

/// change_dynamics parameters: give at least one property; each must be ≥ 0.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ChangeDynamics {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
    /// kg (0 = static).
    pub mass: Option<NonNegative>,
    /// Coulomb coefficient.
    pub lateral_friction: Option<NonNegative>,
    /// Recorded only.
    pub spinning_friction: Option<NonNegative>,
    /// Recorded only.
    pub rolling_friction: Option<NonNegative>,
    /// Bounce needs both bodies > 0.
    pub restitution: Option<NonNegative>,
    /// Default 0.04.
    pub linear_damping: Option<NonNegative>,
    /// Default 0.04.
    pub angular_damping: Option<NonNegative>,
    /// Recorded only.
    pub contact_stiffness: Option<NonNegative>,
    /// Recorded only.
    pub contact_damping: Option<NonNegative>,
}

/// get_dynamics_info parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DynamicsRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
}

/// set_collision_filter_group_mask parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CollisionFilterGroupMask {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// -1 = base (default).
    pub link_index: Option<Int<i64>>,
    /// Bits it belongs to.
    pub collision_filter_group: Int<u32>,
    /// Bits it collides with.
    pub collision_filter_mask: Int<u32>,
}

/// set_collision_filter_pair parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CollisionFilterPair {
    /// Sim id.
    pub sim_id: Text,
    /// First object.
    pub object_id_a: ObjectId,
    /// Second object.
    pub object_id_b: ObjectId,
    /// Default -1 (base).
    pub link_index_a: Option<Int<i64>>,
    /// Default -1 (base).
    pub link_index_b: Option<Int<i64>>,
    /// false turns their contacts off.
    pub enable_collision: Bool,
}
