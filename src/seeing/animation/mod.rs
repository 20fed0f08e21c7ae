//! Pictures of the past: scenes captured while an interval is re-simulated (by the one
//! re-simulation core, `fold`), rendered on all cores by the CPU rasteriser and encoded as one
//! looping GIF. render_animation, `replay --render`, the report and the viewer's timeline all
//! use this; none of them steps a world itself.
//!
//! - `palette` — one palette from the colours the frames hold (exact when they are few).
//! - `gif`     — frames → GIF with the `gif` crate (delta frames, parallel LZW).

pub mod gif;
pub mod pacing;
pub mod palette;

use rayon::prelude::*;

use crate::command::Command;
use crate::log::fold::{self, Lent};
use crate::outputs::CameraUsed;
use crate::seeing::framing;
use crate::seeing::overlay::{self, Canvas, Overlay};
use crate::seeing::sensing::camera::Mat4;
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::render;
pub use pacing::Pacing;

/// At most this many frames in one animation (docs/tools.md).
pub const MAX_FRAMES: u64 = 600;
/// At most this many pixels over all frames of one animation (RGB frames are kept until the
/// palette is known: 3 bytes each, so at most ~600 MB).
pub const MAX_TOTAL_PX: u64 = 200_000_000;

/// How frames are taken: their size, the camera asked for (`framing`: else set_camera's at the
/// interval's end, else framed — one camera for every frame), the lens and the overlay.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The view asked for (nothing: the default rule).
    pub asked: framing::Asked,
    /// A fixed projection matrix, or the default lens for this size.
    pub projection: Option<Mat4>,
    /// What is drawn over each frame.
    pub overlay: Overlay,
}

impl Camera {
    /// A camera of this size following the default rule, with the time overlay.
    pub fn sized(width: u32, height: u32) -> Camera {
        Camera { width, height, asked: framing::Asked::default(), projection: None, overlay: Overlay::Time }
    }

    /// The one view and lens for pictures of `scenes` (in time order), and the camera it is.
    pub fn fix(&self, scenes: &[&Scene]) -> (Mat4, Mat4, CameraUsed) {
        let (view, used) = framing::choose(&self.asked, scenes, f64::from(self.width) / f64::from(self.height));
        let proj = self.projection.unwrap_or_else(|| framing::lens(Some(&used), self.width, self.height));
        (view, proj, used)
    }

    /// Renders one scene (the event `seq`) with fixed matrices to RGB bytes, overlay drawn.
    pub fn rgb(&self, scene: &Scene, seq: u64, view: &Mat4, proj: &Mat4) -> Vec<u8> {
        let mut rgb = render::render_scene(scene, self.width, self.height, view, proj).rgb;
        let mut canvas = Canvas { rgb: &mut rgb, width: self.width, height: self.height };
        overlay::draw(self.overlay, &mut canvas, scene, seq, view, proj);
        rgb
    }
}

/// A scene captured at one sample of a re-simulation.
pub struct Shot {
    /// What the camera would see.
    pub scene: Scene,
    /// The event the world was at (a step event while inside it).
    pub seq: u64,
    /// Steps from the interval's start.
    pub steps: u64,
}

impl Shot {
    /// Captures the sample `m` of `w` onto `shots`, unless no object has existed yet (an empty
    /// world says nothing, so an animation starts at the first object).
    pub fn record(shots: &mut Vec<Shot>, w: &crate::world::World, m: &fold::Moment) {
        if !shots.is_empty() || w.object_count() > 0 {
            shots.push(Shot { scene: Scene::capture(w), seq: m.seq, steps: m.steps });
        }
    }
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

/// Re-simulates `lent` (the one core, `fold::resimulate`) and captures a scene at every
/// sample, telling `progress` the steps re-simulated so far (a terminal's progress bar).
/// Samples before the first object exists are left out (an empty world says nothing).
pub fn capture(lent: &Lent, every: u64, progress: &mut (dyn FnMut(u64) + Send)) -> Result<Vec<Shot>, String> {
    let mut shots: Vec<Shot> = Vec::new();
    fold::resimulate(lent, every, &mut |w, m| {
        if m.at == fold::At::Step {
            progress(m.steps);
        }
        if m.sample {
            Shot::record(&mut shots, w, m);
        }
        true
    })
    .map_err(|e| e.explained("The interval could not be re-simulated"))?;
    Ok(shots)
}

/// A rendered animation.
pub struct Animation {
    /// The GIF file.
    pub gif: Vec<u8>,
    /// Frames in it.
    pub frames: usize,
    /// Steps from the interval's start at each frame.
    pub steps: Vec<u64>,
    /// Playing time of one loop (s).
    pub duration_s: f64,
    /// Simulated time from the first frame to the last (s).
    pub simulated_s: f64,
    /// The camera every frame was taken with.
    pub camera: CameraUsed,
}

/// Encodes shots as a looping GIF: one camera for all (chosen from all of them), frames paced
/// by `pacing`, rendered on all cores.
pub fn animate_shots(shots: &[Shot], cam: &Camera, pacing: Pacing) -> Result<Animation, String> {
    let scenes: Vec<&Scene> = shots.iter().map(|s| &s.scene).collect();
    let (view, proj, used) = cam.fix(&scenes);
    let times: Vec<f64> = scenes.iter().map(|s| s.time).collect();
    let shown = pacing::pace(&times, pacing);
    let rgb: Vec<Vec<u8>> = shown.par_iter().map(|(k, _)| cam.rgb(&shots[*k].scene, shots[*k].seq, &view, &proj)).collect();
    let delays: Vec<u16> = shown.iter().map(|(_, d)| *d).collect();
    let (gif, _) = gif::encode(&gif::Frames { width: cam.width, height: cam.height, rgb: &rgb, delays: &delays })?;
    Ok(Animation {
        gif,
        frames: rgb.len(),
        steps: shown.iter().map(|(k, _)| shots[*k].steps).collect(),
        duration_s: pacing::duration_s(&shown),
        simulated_s: times.last().zip(times.first()).map_or(0.0, |(b, a)| b - a),
        camera: used,
    })
}

/// Re-simulates `lent` and encodes its samples as a GIF.
pub fn animate(lent: &Lent, every: u64, cam: &Camera, pacing: Pacing) -> Result<Animation, String> {
    animate_with(lent, every, cam, pacing, &mut |_| {})
}

/// `animate`, telling `progress` the steps re-simulated so far.
pub fn animate_with(lent: &Lent, every: u64, cam: &Camera, pacing: Pacing, progress: &mut (dyn FnMut(u64) + Send)) -> Result<Animation, String> {
    let shots = capture(lent, every, progress)?;
    // Rendering the frames is work too: not for a client that has gone.
    if fold::current_bounds().stopped() {
        return Err(fold::CANCELLED.to_string());
    }
    if shots.is_empty() {
        return Err("Nothing to show: no object exists in this interval; give a later to_seq".into());
    }
    animate_shots(&shots, cam, pacing)
}
