//! Pictures of the past: scenes captured while an interval is re-simulated (by the one
//! re-simulation core, `fold`), rendered on all cores by the CPU rasteriser and encoded as one
//! looping GIF. render_animation, `replay --render`, the report and the viewer's timeline all
//! use this; none of them steps a world itself.
//!
//! - `palette` — one palette from the colours the frames hold (exact when they are few).
//! - `gif`     — frames → GIF with the `gif` crate (delta frames, parallel LZW).

pub mod gif;
pub mod palette;

use std::sync::Mutex;

use rayon::prelude::*;

use crate::command::Command;
use crate::log::fold::{self, Lent};
use crate::seeing::sensing::camera::{self, Mat4};
use crate::seeing::sensing::render;
use crate::seeing::sensing::capture::Scene;
use crate::world::Viewer;
/// At most this many frames in one animation (docs/tools.md).
pub const MAX_FRAMES: u64 = 600;
/// At most this many pixels over all frames of one animation (RGB frames are kept until the
/// palette is known: 3 bytes each, so at most ~600 MB).
pub const MAX_TOTAL_PX: u64 = 200_000_000;

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

/// the documented default sampling: about 100 samples over the interval, `max(1, ceil(steps / 100))`.
pub fn default_every(steps: u64) -> u64 {
    steps.div_ceil(100).max(1)
}

/// How many samples (frames) re-simulating `lent` every `every` steps gives: the first state,
/// one after every `every`-th step, and the last state when anything changed after the last
/// of those (a step remainder or an event that is not a step).
pub fn sample_count(lent: &Lent, every: u64) -> u64 {
    let every = every.max(1);
    let steps = lent.interval_steps();
    let others = lent
        .chain
        .iter()
        .filter(|(e, c)| e.seq > lent.interval.from_seq && !matches!(c, Command::StepSimulation { .. }))
        .count();
    1 + steps / every + u64::from(!steps.is_multiple_of(every) || others > 0)
}

/// Checks an animation's size before any work: at most `MAX_FRAMES` frames, `max_px` pixels a
/// frame (--max-image-px), `MAX_TOTAL_PX` in all. Refusals name the parameter to change.
pub fn check_size(frames: u64, every: u64, cam: &Camera, max_px: usize) -> Result<(), String> {
    let px = u64::from(cam.width) * u64::from(cam.height);
    if cam.width == 0 || cam.height == 0 || px > max_px as u64 {
        return Err(format!(
            "Image too large: {}x{} = {px} pixels a frame (at least 1x1, at most {max_px}, --max-image-px); give a smaller width and height",
            cam.width, cam.height
        ));
    }
    if frames > MAX_FRAMES {
        return Err(format!(
            "Too many frames: every={every} gives {frames} frames (at most {MAX_FRAMES}); give a larger every or a shorter interval (from_seq, to_seq)"
        ));
    }
    if frames * px > MAX_TOTAL_PX {
        return Err(format!(
            "Too many pixels: {frames} frames of {}x{} (at most {MAX_TOTAL_PX} pixels in all); give a smaller width and height or a larger every",
            cam.width, cam.height
        ));
    }
    Ok(())
}

/// Re-simulates `lent` (the one core, `fold::resimulate`) and renders a frame at every sample,
/// each on the thread pool as soon as its scene is captured, so rendering overlaps the physics.
/// Returns the RGB frames in order and the steps from the interval's start of each.
pub fn frames_of(lent: &Lent, every: u64, cam: &Camera) -> Result<(Vec<Vec<u8>>, Vec<u64>), String> {
    frames_with(lent, every, cam, &mut |_| {})
}

/// `frames_of`, telling `progress` the steps re-simulated so far (a terminal's progress bar).
pub fn frames_with(lent: &Lent, every: u64, cam: &Camera, progress: &mut (dyn FnMut(u64) + Send)) -> Result<(Vec<Vec<u8>>, Vec<u64>), String> {
    let rendered: Mutex<Vec<(usize, Vec<u8>)>> = Mutex::new(Vec::new());
    let mut steps = Vec::new();
    // In place: the re-simulation runs on the calling thread, only the rendering on the pool.
    // (`rayon::scope` would run it on a global-pool worker, which while its step waits may
    // start another caller's whole animation on its own stack.)
    let outcome = rayon::in_place_scope(|s| {
        let rendered = &rendered;
        fold::resimulate(lent, every, &mut |w, m| {
            if m.at == fold::At::Step {
                progress(m.steps);
            }
            if m.sample {
                let (k, scene) = (steps.len(), Scene::capture(w));
                steps.push(m.steps);
                s.spawn(move |_| {
                    let rgb = cam.rgb(&scene);
                    rendered.lock().unwrap_or_else(|p| p.into_inner()).push((k, rgb));
                });
            }
            true
        })
        .map(|_| ())
    });
    outcome.map_err(|e| format!("The interval could not be re-simulated: {e}"))?;
    let mut frames = rendered.into_inner().unwrap_or_else(|p| p.into_inner());
    frames.sort_by_key(|(k, _)| *k);
    Ok((frames.into_iter().map(|(_, f)| f).collect(), steps))
}

/// A rendered animation.
pub struct Animation {
    /// The GIF file.
    pub gif: Vec<u8>,
    /// Frames in it.
    pub frames: usize,
    /// Steps from the interval's start at each frame.
    pub steps: Vec<u64>,
}

/// Re-simulates `lent` and encodes its samples as a GIF at `fps`.
pub fn animate(lent: &Lent, every: u64, cam: &Camera, fps: u32) -> Result<Animation, String> {
    animate_with(lent, every, cam, fps, &mut |_| {})
}

/// `animate`, telling `progress` the steps re-simulated so far.
pub fn animate_with(lent: &Lent, every: u64, cam: &Camera, fps: u32, progress: &mut (dyn FnMut(u64) + Send)) -> Result<Animation, String> {
    let (rgb, steps) = frames_with(lent, every, cam, progress)?;
    let frames = gif::Frames { width: cam.width, height: cam.height, rgb: &rgb, delay_cs: gif::delay_for_fps(fps) };
    let (bytes, _) = gif::encode(&frames)?;
    Ok(Animation { gif: bytes, frames: rgb.len(), steps })
}
