//! Parameters of render_animation.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// render_animation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RenderAnimation {
    /// Sim id.
    pub sim_id: Text,
    /// Default: before the last step.
    pub from_seq: Option<Int<u64>>,
    /// Default: the head.
    pub to_seq: Option<Int<u64>>,
    /// Default: ~100 frames.
    pub every: Option<Int<u64>>,
    /// Pixels (default 320).
    pub width: Option<Int<u32>>,
    /// Pixels (default 240).
    pub height: Option<Int<u32>>,
    /// Most frames per second shown, 1-50 (default 30).
    pub fps: Option<Int<u32>>,
    /// Playback speed (default 1: real time).
    pub speed: Option<Positive>,
    /// "time" (default), "ids" or "none".
    pub overlay: Option<Text>,
    /// 16 floats (default: set_camera at to_seq, else framed).
    pub view_matrix: Option<Matrix>,
    /// Camera distance (m); unset terms framed.
    pub distance: Option<Positive>,
    /// Degrees.
    pub yaw: Option<Num>,
    /// Degrees.
    pub pitch: Option<Num>,
    /// Point looked at.
    pub target: Option<Vec3>,
    /// 16 floats (default: fov 60).
    pub projection_matrix: Option<Matrix>,
    /// New .gif file.
    pub output_path: Option<Text>,
}
