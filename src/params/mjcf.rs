//! Parameters of load_mjcf, get_link_state, reset_joint_state, set_actuator_controls,
//! get_sensor_data.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// load_mjcf parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LoadMjcf {
    /// Sim id.
    pub sim_id: Text,
    /// Workspace MJCF file.
    pub file_path: Text,
    /// Default 0.
    pub position: Option<Vec3>,
    /// Default identity.
    pub orientation: Option<Quat>,
    /// Fix a free root (default false).
    pub use_fixed_base: Option<Bool>,
    /// `<key>` to start from (default qpos0).
    pub keyframe: Option<Text>,
    /// Impose `<option>` timestep, gravity.
    pub use_model_options: Option<Bool>,
}

/// get_link_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct LinkRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// -1 = base.
    pub link_index: Int<i32>,
}

/// reset_joint_state parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ResetJoint {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// PyBullet numbering.
    pub joint_index: Int<u32>,
    /// Position, rad or m.
    pub target_value: Num,
    /// Default 0.
    pub target_velocity: Option<Num>,
}

/// set_actuator_controls parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ActuatorControlsSet {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// A list in actuator order, or {name: value}.
    pub controls: Controls,
}

/// get_sensor_data parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SensorsRef {
    /// Sim id.
    pub sim_id: Text,
    /// Object id.
    pub object_id: ObjectId,
    /// Default all.
    pub names: Option<Vec<Text>>,
}
