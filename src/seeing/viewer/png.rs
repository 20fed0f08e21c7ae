//! The server-rendered frame (`GET /viewer/{sim_id}/frame`): a PNG of the world by the same CPU
//! rasteriser as get_camera_image, with the matrices it was drawn with and the overlays, for
//! clients without WebGL (and the page's fallback when WebGL is missing).

use axum::http::StatusCode;
use base64::Engine;
use serde::{Deserialize, Serialize};

use super::moment::{CameraJson, Moment, Shown};
use crate::seeing::sensing::camera::{self, Mat4};
use crate::seeing::sensing::render;
use crate::sim::SharedSim;
use crate::world::{Viewer as RecordedCamera, World};

/// The frame size when the page does not ask for one.
const DEFAULT_SIZE: (u32, u32) = (640, 480);

/// What the page may ask of a frame: its size, and its own camera (else the simulation's).
#[derive(Deserialize, Debug, Default)]
pub struct FrameQuery {
    /// Width in pixels.
    pub w: Option<u32>,
    /// Height in pixels.
    pub h: Option<u32>,
    /// The page's camera distance (m); with yaw and pitch it replaces the recorded camera.
    pub distance: Option<f64>,
    /// The page's camera yaw (degrees).
    pub yaw: Option<f64>,
    /// The page's camera pitch (degrees).
    pub pitch: Option<f64>,
    /// The page's camera target x, y, z.
    pub tx: Option<f64>,
    /// Target y.
    pub ty: Option<f64>,
    /// Target z.
    pub tz: Option<f64>,
    /// A past state: after this state-changing event of the head's chain.
    pub seq: Option<u64>,
    /// With `seq` a step event: after this many of its steps.
    pub step: Option<u64>,
}

/// What `/frame` answers: the image, the matrices it was rendered with, and overlays.
#[derive(Serialize, Debug)]
pub struct FrameJson {
    /// Simulation id.
    pub simulation_id: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// PNG, base64.
    pub png: String,
    /// View matrix used (column-major, PyBullet's convention).
    pub view_matrix: Vec<f64>,
    /// Projection matrix used.
    pub projection_matrix: Vec<f64>,
    /// What the moment says about itself.
    #[serde(flatten)]
    pub shown: Shown,
}

/// The size the page asked for, checked against --max-image-px.
fn size(q: &FrameQuery, max_px: usize) -> Result<(u32, u32), String> {
    let (width, height) = (q.w.unwrap_or(DEFAULT_SIZE.0), q.h.unwrap_or(DEFAULT_SIZE.1));
    if width == 0 || height == 0 || width as u64 * height as u64 > max_px as u64 {
        return Err(format!("frame size {width}x{height} must be at least 1x1 and at most {max_px} pixels"));
    }
    Ok((width, height))
}

/// The matrices for this frame: the page's own camera when it sent one, else the recorded one.
fn matrices(cam: &RecordedCamera, q: &FrameQuery, width: u32, height: u32) -> (Mat4, Mat4) {
    let recorded = CameraJson::of(cam);
    let own = [q.distance, q.yaw, q.pitch];
    let (distance, yaw, pitch) = match own {
        [Some(d), Some(y), Some(p)] if d.is_finite() && d > 0.0 && y.is_finite() && p.is_finite() => (d, y, p.clamp(-89.9, 89.9)),
        _ => (recorded.distance, recorded.yaw, recorded.pitch),
    };
    let target = match (q.tx, q.ty, q.tz) {
        (Some(x), Some(y), Some(z)) if x.is_finite() && y.is_finite() && z.is_finite() => [x, y, z],
        _ => recorded.target,
    };
    let view: Mat4 = camera::view_matrix_from_yaw_pitch(target, distance, yaw, pitch, 2);
    let proj: Mat4 = camera::default_projection(width, height);
    (view, proj)
}

/// Renders a captured moment of simulation `simulation_id` as the page asked, with its overlays.
pub fn scene_frame(m: &Moment, simulation_id: &str, q: &FrameQuery, max_px: usize) -> Result<FrameJson, String> {
    let (width, height) = size(q, max_px)?;
    let (view, proj) = matrices(&m.seen.scene.camera, q, width, height);
    let image = render::render_scene(&m.seen.scene, width, height, &view, &proj);
    Ok(FrameJson {
        simulation_id: simulation_id.to_string(),
        width,
        height,
        png: base64::engine::general_purpose::STANDARD.encode(image.png()?),
        view_matrix: view.to_vec(),
        projection_matrix: proj.to_vec(),
        shown: Shown::of(m),
    })
}

/// Renders one frame of `w` as the page asked; `state_hash` is the simulation's. The same
/// frame as `scene_frame` of the world captured now (`Scene::capture` gives the pixels
/// `render::render` gives).
pub fn frame(w: &World, state_hash: &str, contacts_asked: bool, q: &FrameQuery, max_px: usize) -> Result<FrameJson, String> {
    scene_frame(&super::ask::present_of(w, state_hash, contacts_asked).moment(), w.simulation_id(), q, max_px)
}

/// A failed viewer answer: an HTTP status and one sentence.
pub type Failed = (StatusCode, String);

/// The `/frame` answer for simulation `sim_id`: a past state when `q.seq` says so, else the
/// present — or, while a call holds the simulation, the newest moment its stepping published.
pub fn answer(sim: SharedSim, sim_id: &str, q: &FrameQuery, max_px: usize) -> Result<FrameJson, Failed> {
    // Held, the lock already given back: a render never holds up a call.
    let held = super::ask::held(&sim, sim_id, q.seq, q.step)?;
    scene_frame(&held.moment(), sim_id, q, max_px).map_err(|e| (StatusCode::BAD_REQUEST, e))
}
