//! Pictures of the past: scenes captured while an interval is re-simulated (by the one
//! re-simulation core, `fold`), rendered on all cores by the CPU rasteriser and encoded as one
//! looping GIF. render_animation, `replay --render`, the report and the viewer's timeline all
//! use this; none of them steps a world itself.
//!
//! - `palette` — one palette from the colours the frames hold (exact when they are few).
//! - `gif`     — frames → GIF with the `gif` crate (delta frames, parallel LZW).

pub mod gif;
pub mod palette;

use rayon::prelude::*;

use crate::sensing::camera::{self, Mat4};
use crate::sensing::render;
use crate::sensing::scene::Scene;
use crate::world::Viewer;

/// An inline GIF's limit: base64 grows it by 4/3, and the reply must stay within 1 MiB.
pub const MAX_INLINE_GIF_BYTES: usize = 740 * 1024;
/// At most this many frames in one animation (SPEC).
pub const MAX_FRAMES: usize = 600;

/// How frames are taken: their size and, when given, fixed matrices (else each frame uses the
/// viewer camera recorded at that moment, as get_camera_image does without matrices).
#[derive(Clone, Debug)]
pub struct Camera {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// A fixed view matrix (column-major), or the recorded camera's.
    pub view: Option<Mat4>,
    /// A fixed projection matrix, or the default lens for this size.
    pub projection: Option<Mat4>,
}

/// The view matrix of a recorded viewer camera (set_camera): what get_camera_image, the
/// `sim://…/image` resource and the viewer use when given no matrix.
pub fn recorded_view(v: &Viewer) -> Mat4 {
    camera::view_matrix_from_yaw_pitch(v.target.map(f64::from), v.distance.into(), v.yaw.into(), v.pitch.into(), 2)
}

impl Camera {
    /// The matrices for a frame of `scene`.
    pub fn matrices(&self, scene: &Scene) -> (Mat4, Mat4) {
        let view = self.view.unwrap_or_else(|| recorded_view(&scene.camera));
        let proj = self.projection.unwrap_or_else(|| camera::default_projection(self.width, self.height));
        (view, proj)
    }

    /// Renders one scene to RGB bytes.
    pub fn rgb(&self, scene: &Scene) -> Vec<u8> {
        let (view, proj) = self.matrices(scene);
        render::render_scene(scene, self.width, self.height, &view, &proj).rgb
    }
}

/// Renders every scene (in parallel, order kept) to RGB frames.
pub fn render_all(scenes: &[Scene], cam: &Camera) -> Vec<Vec<u8>> {
    scenes.par_iter().map(|s| cam.rgb(s)).collect()
}

/// Renders scenes into a looping GIF shown at `fps` frames per second.
pub fn gif_of(scenes: &[Scene], cam: &Camera, fps: u32) -> Result<Vec<u8>, String> {
    let rgb = render_all(scenes, cam);
    let frames = gif::Frames { width: cam.width, height: cam.height, rgb: &rgb, delay_cs: gif::delay_for_fps(fps) };
    Ok(gif::encode(&frames)?.0)
}
