//! Parameters of add_box/sphere/cylinder/capsule, poses, forces, torques, velocities, dynamics, remove_object.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// add_box parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddBox {
    /// Simulation id.
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
}

/// add_sphere parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddSphere {
    /// Simulation id.
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
}

/// add_cylinder / add_capsule parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct AddRound {
    /// Simulation id.
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
}

/// Parameters naming an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ObjectRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
}

/// set_object_pose parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetPose {
    /// Simulation id.
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
    /// Simulation id.
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
    /// Simulation id.
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
    /// Simulation id.
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
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
    /// kg (0 = static).
    pub mass: Option<NonNegative>,
    /// Coulomb coefficient.
    pub lateral_friction: Option<NonNegative>,
    /// Stored, not simulated.
    pub spinning_friction: Option<NonNegative>,
    /// Stored, not simulated.
    pub rolling_friction: Option<NonNegative>,
    /// Bounce needs both bodies > 0.
    pub restitution: Option<NonNegative>,
    /// Default 0.04.
    pub linear_damping: Option<NonNegative>,
    /// Default 0.04.
    pub angular_damping: Option<NonNegative>,
    /// Stored, not simulated.
    pub contact_stiffness: Option<NonNegative>,
    /// Stored, not simulated.
    pub contact_damping: Option<NonNegative>,
}

/// get_dynamics_info parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DynamicsRef {
    /// Simulation id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Default -1 (base).
    pub link_index: Option<Int<i64>>,
}
