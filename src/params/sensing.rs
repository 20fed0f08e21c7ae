//! Parameters of rays, contacts, camera matrices, get_camera_image.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// ray_test parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTest {
    /// Sim id.
    pub sim_id: Text,
    /// Start, world.
    pub ray_from: Vec3,
    /// End, world.
    pub ray_to: Vec3,
}

/// ray_test_batch parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RayTestBatch {
    /// Sim id.
    pub sim_id: Text,
    /// Starts (at most --max-rays).
    pub rays_from: Vec3List,
    /// Ends, one per start.
    pub rays_to: Vec3List,
    /// New .json file.
    pub output_path: Option<Text>,
}

/// get_collisions_for_pair parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CollisionPair {
    /// Sim id.
    pub sim_id: Text,
    /// Object A.
    pub obj_a: ObjectId,
    /// Object B.
    pub obj_b: ObjectId,
}

/// compute_view_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrix {
    /// Eye.
    pub camera_eye_position: Vec3d,
    /// Target.
    pub camera_target_position: Vec3d,
    /// Up.
    pub camera_up_vector: Vec3d,
}

/// compute_view_matrix_from_yaw_pitch parameters (roll 0).
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ViewMatrixYawPitch {
    /// Distance (m).
    pub distance: Num64,
    /// Degrees.
    pub yaw: Num64,
    /// Degrees.
    pub pitch: Num64,
    /// Target.
    pub target_position: Vec3d,
    /// 2: z up (default), 1: y up.
    pub up_axis_index: Option<Int<u8>>,
    /// Only 0.
    pub roll: Option<Num64>,
}

/// compute_projection_matrix parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ProjectionMatrix {
    /// Vertical, degrees.
    pub fov: Num64,
    /// Width / height.
    pub aspect: Num64,
    /// m, > 0.
    pub near_plane: Num64,
    /// m, > near_plane.
    pub far_plane: Num64,
}

/// get_camera_image parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraImage {
    /// Sim id.
    pub sim_id: Text,
    /// Pixels.
    pub width: Int<u32>,
    /// Pixels.
    pub height: Int<u32>,
    /// 16 floats (default: set_camera or framed).
    pub view_matrix: Option<Matrix>,
    /// 16 floats (default: fov 60).
    pub projection_matrix: Option<Matrix>,
    /// Ignored.
    pub renderer: Option<serde_json::Value>,
    /// Per-pixel depth (m).
    pub include_depth: Option<Bool>,
    /// Per-pixel object id.
    pub include_segmentation: Option<Bool>,
    /// New .png file (+ .npy arrays).
    pub output_path: Option<Text>,
}
