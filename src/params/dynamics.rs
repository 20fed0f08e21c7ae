//! Parameters of the robot calls PyBullet scripts lean on: enable_joint_force_torque_sensor.

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
