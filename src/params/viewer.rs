//! Parameters of enable_debug_visualization, set_camera.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// enable_debug_visualization parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct DebugVisualization {
    /// Sim id.
    pub sim_id: Text,
    /// Contact points (default true).
    pub show_contacts: Option<Bool>,
    /// Body frames (default false).
    pub show_frames: Option<Bool>,
}

/// set_camera parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SetCamera {
    /// Sim id.
    pub sim_id: Text,
    /// Distance (m).
    pub distance: Positive,
    /// Degrees.
    pub yaw: Num,
    /// Degrees (< 0 looks down).
    pub pitch: Num,
    /// Point looked at.
    pub target: Vec3,
}
