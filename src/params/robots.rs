//! Parameters of load_urdf, joints and motors, inverse kinematics, generate_revolute_joint.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// load_urdf parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LoadUrdf {
    /// Sim id.
    pub sim_id: Text,
    /// Workspace-relative URDF, or a built-in.
    pub file_path: Text,
    /// Base position (default 0).
    pub position: Option<Vec3>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// Fix the base (default false).
    pub use_fixed_base: Option<Bool>,
}

/// Parameters naming a joint of an object.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JointRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
}

/// set_joint_motor_control parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MotorControl {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
    /// POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL.
    pub control_mode: ControlModeName,
    /// rad or m; required for POSITION_CONTROL.
    pub target_position: Option<Num>,
    /// Default 0.
    pub target_velocity: Option<Num>,
    /// Max effort (default: URDF limit, else 500); TORQUE_CONTROL's torque.
    pub force: Option<Num>,
    /// Default 0.1.
    pub position_gain: Option<NonNegative>,
    /// Default 1.
    pub velocity_gain: Option<NonNegative>,
}

/// set_joint_motor_control_array parameters: one entry per joint in each list.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct MotorControlArray {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_indices: Vec<Int<u32>>,
    /// As set_joint_motor_control's, for all.
    pub control_mode: ControlModeName,
    /// Required for POSITION_CONTROL.
    pub target_positions: Option<NumList>,
    /// Default 0s.
    pub target_velocities: Option<NumList>,
    /// As force, per joint.
    pub forces: Option<NumList>,
    /// Default 0.1s.
    pub position_gains: Option<NumList>,
    /// Default 1s.
    pub velocity_gains: Option<NumList>,
}

/// set_joint_trajectory parameters: per waypoint (row) one value per joint.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct JointTrajectory {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Movable joints.
    pub joint_indices: Vec<Int<u32>>,
    /// s from now, rising.
    pub times: NumList,
    /// Row per time.
    pub positions: Vec<NumList>,
    /// Row per time.
    pub velocities: Option<Vec<NumList>>,
    /// Per joint.
    pub forces: Option<NumList>,
    /// Default 0.1s.
    pub position_gains: Option<NumList>,
    /// Default 1s.
    pub velocity_gains: Option<NumList>,
}

/// calculate_inverse_kinematics parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct InverseKinematics {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Link index.
    pub end_effector_link_index: Int<u32>,
    /// World (m).
    pub target_position: Vec3,
    /// Optional.
    pub target_orientation: Option<Quat>,
    /// Default URDF's.
    pub lower_limits: Option<NumList>,
    /// Default URDF's.
    pub upper_limits: Option<NumList>,
    /// Ignored.
    pub joint_ranges: Option<NumList>,
    /// Default current.
    pub rest_poses: Option<NumList>,
}

/// generate_revolute_joint parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct GenerateRevolute {
    /// box, sphere or cylinder.
    pub parent_shape: Text,
    /// As parent_shape.
    pub child_shape: Text,
    /// Half-extents, [r] or [r, h].
    pub parent_dimensions: NumList,
    /// As parent_dimensions.
    pub child_dimensions: NumList,
    /// kg (default 1).
    pub parent_mass: Option<Positive>,
    /// kg (default 1).
    pub child_mass: Option<Positive>,
    /// Default z.
    pub joint_axis: Option<Vec3>,
    /// Default 0.
    pub joint_origin: Option<Vec3>,
    /// rad (default -pi).
    pub joint_lower_limit: Option<Num>,
    /// rad (default pi).
    pub joint_upper_limit: Option<Num>,
    /// Default 100.
    pub max_effort: Option<NonNegative>,
    /// Default 10.
    pub max_velocity: Option<NonNegative>,
    /// Default generated/revolute_<n>.urdf.
    pub output_path: Option<Text>,
    /// Replace another file (default false).
    pub overwrite: Option<Bool>,
}
