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
    /// Max fps, 1-50 (default 30).
    pub fps: Option<Int<u32>>,
    /// Default 1: real time.
    pub speed: Option<Positive>,
    /// time (default), ids or none.
    pub overlay: Option<Text>,
    /// 16 floats (default: camera).
    pub view_matrix: Option<Matrix>,
    /// set_camera's terms; unset: framed.
    pub camera: Option<CameraTerms>,
    /// 16 floats (default: fov 60).
    pub projection_matrix: Option<Matrix>,
    /// New .gif file.
    pub output_path: Option<Text>,
}
