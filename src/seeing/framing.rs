//! Which camera a picture is taken with when the caller gives no view matrix — one rule for
//! every picture (get_camera_image, render_animation, `replay --render`, the report, the
//! `sim://…/image` resource):
//!
//! 1. a view matrix given → that;
//! 2. any of `distance`, `yaw`, `pitch`, `target` given → those, the rest as framed (4.);
//! 3. set_camera has moved the camera from the initial one by the moment pictured (an
//!    interval's last event) → its camera;
//! 4. else **framed**: looking at the objects that move over the pictures (all of them that can
//!    move when none does, or when the movers move little — less than `STILL_SHARE` of the
//!    extent of everything that can move, so a rocking domino does not crop its row out; the
//!    fixed ones, ground left out, when there are only those) from a three-quarter elevated
//!    view, close enough that they fill the frame. A picture asked for `whole_scene` (the
//!    session report's) frames everything but the ground over all its scenes.
//!
//! An interval is taken with one camera throughout (no cuts), so what set_camera does to past
//! frames is the same for every look-back tool: the camera in effect at the interval's last
//! event is used for all of its frames.

use rapier3d::prelude::Vector;

use crate::outputs::CameraUsed;
use crate::seeing::sensing::camera::{self, Mat4};
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::shading::CASTER_MAX_SIZE;
use crate::world::Viewer;

/// The framed view's direction: from the front-right, looking down.
pub const FRAMED_YAW: f64 = 50.0;
/// The framed view's elevation (degrees; < 0 looks down).
pub const FRAMED_PITCH: f64 = -30.0;
/// The default lens's vertical field of view (`camera::default_projection`).
const FOV_DEG: f64 = 60.0;
/// Framed objects fill this share of the view's half-width or half-height at most.
const MARGIN: f64 = 1.0 / 0.85;
/// An object whose points move at least this far (m) over the pictures, and at least
/// `MOVED_SHARE` of the farthest any object moves, has moved.
const MOVED: f32 = 1e-3;
const MOVED_SHARE: f32 = 0.05;
/// Movers whose largest motion is under this share of the diagonal of everything that can move
/// move little: the picture frames everything that can move instead of zooming onto them.
const STILL_SHARE: f32 = 0.05;

/// A camera in set_camera's terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terms {
    /// Distance to the target (m).
    pub distance: f64,
    /// Yaw (degrees).
    pub yaw: f64,
    /// Pitch (degrees).
    pub pitch: f64,
    /// Point looked at.
    pub target: [f64; 3],
}

impl Terms {
    /// The camera set_camera recorded.
    pub fn of_viewer(v: &Viewer) -> Terms {
        Terms { distance: v.distance.into(), yaw: v.yaw.into(), pitch: v.pitch.into(), target: v.target.map(f64::from) }
    }

    /// Its view matrix (z up, as set_camera's).
    pub fn view(&self) -> Mat4 {
        camera::view_matrix_from_yaw_pitch(self.target, self.distance, self.yaw, self.pitch, 2)
    }

    fn used(&self, source: &str) -> CameraUsed {
        let r = |v: f64| (v * 1e6).round() / 1e6;
        CameraUsed {
            source: source.into(),
            distance: Some(r(self.distance)),
            yaw: Some(r(self.yaw)),
            pitch: Some(r(self.pitch)),
            target: Some(self.target.map(r)),
        }
    }
}

/// What the caller asked for (each term optional).
#[derive(Clone, Debug, Default)]
pub struct Asked {
    /// A view matrix (column-major).
    pub view: Option<Mat4>,
    /// Distance (m, > 0).
    pub distance: Option<f64>,
    /// Yaw (degrees).
    pub yaw: Option<f64>,
    /// Pitch (degrees).
    pub pitch: Option<f64>,
    /// Target point.
    pub target: Option<[f64; 3]>,
    /// Frame everything but the ground over all the scenes, moving or not (the report: one
    /// camera in which the scene can be seen being built).
    pub whole_scene: bool,
}

impl Asked {
    fn any_term(&self) -> bool {
        self.distance.is_some() || self.yaw.is_some() || self.pitch.is_some() || self.target.is_some()
    }

    /// Refuses a view matrix together with camera terms (which would win is not obvious).
    pub fn check(&self) -> Result<(), String> {
        if self.view.is_some() && self.any_term() {
            return Err("view_matrix cannot be given with camera; give one or the other".into());
        }
        Ok(())
    }
}

/// The lens of a picture given no projection: the default one (fov 60, near 0.01, far 100),
/// its far plane pushed out for a camera this rule placed (framed or given terms) far enough
/// back that 100 m would cut the scene it frames (a scene over ~60 m across).
pub fn lens(used: Option<&CameraUsed>, width: u32, height: u32) -> Mat4 {
    let placed = used.filter(|u| u.source == "framed" || u.source == "given").and_then(|u| u.distance);
    match placed {
        Some(d) if 4.0 * d > 100.0 => camera::projection_matrix(FOV_DEG, f64::from(width) / f64::from(height), 0.01, 4.0 * d),
        _ => camera::default_projection(width, height),
    }
}

/// The view matrix for pictures of `scenes` (in time order; the last one's viewer camera
/// counts) with an image aspect of `aspect`, and the camera it is.
pub fn choose(asked: &Asked, scenes: &[&Scene], aspect: f64) -> (Mat4, CameraUsed) {
    if let Some(view) = asked.view {
        return (view, CameraUsed { source: "view_matrix".into(), distance: None, yaw: None, pitch: None, target: None });
    }
    let last = scenes.last();
    let set = last.filter(|s| !s.camera.camera_is_initial()).map(|s| Terms::of_viewer(&s.camera));
    let (terms, source) = match (asked.any_term(), set) {
        (false, Some(t)) => (t, "set_camera"),
        (given, _) => {
            let looked_at = if asked.whole_scene { whole(scenes) } else { bounds(scenes) };
            let mut t = framed_bounds(looked_at, aspect, asked.yaw.unwrap_or(FRAMED_YAW), asked.pitch.unwrap_or(FRAMED_PITCH));
            t.distance = asked.distance.unwrap_or(t.distance);
            t.target = asked.target.unwrap_or(t.target);
            (t, if given { "given" } else { "framed" })
        }
    };
    (terms.view(), terms.used(source))
}

/// The camera that frames `scenes` from (yaw, pitch): looking at the centre of the framed
/// objects' bounds, from the nearest distance at which every corner of those bounds is inside
/// the default lens's view with a margin (`MARGIN` of the half-width on each side).
pub fn framed(scenes: &[&Scene], aspect: f64, yaw: f64, pitch: f64) -> Terms {
    framed_bounds(bounds(scenes), aspect, yaw, pitch)
}

/// The camera that frames the world box `looked_at` (as `framed`; the initial camera, turned to
/// (yaw, pitch), when there is nothing to look at).
fn framed_bounds(looked_at: Option<(Vector, Vector)>, aspect: f64, yaw: f64, pitch: f64) -> Terms {
    let Some((lo, hi)) = looked_at else {
        let initial = Terms::of_viewer(&Viewer::default());
        return Terms { yaw, pitch, ..initial };
    };
    let center = ((lo + hi) * 0.5).to_array().map(f64::from);
    // The camera's axes for this direction (a view matrix's rows: right, up, and back).
    let v = Terms { distance: 1.0, yaw, pitch, target: center }.view();
    let (right, up, back) = ([v[0], v[4], v[8]], [v[1], v[5], v[9]], [v[2], v[6], v[10]]);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let tan_v = (FOV_DEG / 2.0).to_radians().tan();
    let tan_h = tan_v * aspect.max(1e-3);
    let (lo, hi) = (lo.to_array().map(f64::from), hi.to_array().map(f64::from));
    let mut distance: f64 = 0.1;
    for corner in 0..8 {
        let p = [0, 1, 2].map(|k| if corner >> k & 1 == 0 { lo[k] } else { hi[k] } - center[k]);
        // A corner `ahead` of the target (further from the camera) may sit nearer the edge.
        let ahead = -dot(p, back);
        let side = (dot(p, right).abs() / tan_h).max(dot(p, up).abs() / tan_v) * MARGIN;
        distance = distance.max(side - ahead).max(0.05 - ahead);
    }
    Terms { distance, yaw, pitch, target: center }
}

/// The world bounds of what a framed camera looks at: the parts of objects that move between
/// the scenes, over all of them; else every part that can move, in the last scene; else the
/// fixed parts that are not ground-sized. None when there is nothing to look at.
fn bounds(scenes: &[&Scene]) -> Option<(Vector, Vector)> {
    let (moving, most) = moving_objects(scenes);
    let mut acc = Bounds::default();
    let mut movable = Bounds::default();
    scenes.iter().flat_map(|s| s.parts.iter()).filter(|p| !p.fixed).for_each(|p| movable.add(p));
    let extent = movable.get().map_or(0.0, |(lo, hi)| (hi - lo).length());
    if !moving.is_empty() && most >= STILL_SHARE * extent {
        for s in scenes {
            s.parts.iter().filter(|p| moving.binary_search(&p.object_id).is_ok()).for_each(|p| acc.add(p));
        }
    }
    let last = scenes.last()?;
    if acc.is_empty() {
        last.parts.iter().filter(|p| !p.fixed).for_each(|p| acc.add(p));
    }
    if acc.is_empty() {
        for p in last.parts.iter() {
            let aabb = p.shape.compute_aabb(&p.pose);
            if (aabb.maxs - aabb.mins).max_element() <= CASTER_MAX_SIZE {
                acc.add(p);
            }
        }
    }
    acc.get()
}

/// Ids of the objects that move between scenes (sorted), and the largest motion: those whose motion — the farthest any
/// of their parts' points gets from where it first was — is at least `MOVED` and at least
/// `MOVED_SHARE` of the largest motion, so boxes settling by a fraction of a millimetre under
/// a falling one are not what the picture is about.
fn moving_objects(scenes: &[&Scene]) -> (Vec<u32>, f32) {
    use std::collections::BTreeMap;
    let mut first: BTreeMap<(u32, usize), rapier3d::prelude::Pose> = BTreeMap::new();
    let mut motion: BTreeMap<u32, f32> = BTreeMap::new();
    for s in scenes {
        let mut nth: BTreeMap<u32, usize> = BTreeMap::new();
        for p in s.parts.iter().filter(|p| !p.fixed) {
            let k = nth.entry(p.object_id).or_default();
            let key = (p.object_id, *k);
            *k += 1;
            let seen = *first.entry(key).or_insert(p.pose);
            // A bound on how far any point of the part moved: its origin's move plus the turn
            // (angle) times its reach from the origin.
            let reach = p.shape.compute_local_aabb().maxs.abs().max(p.shape.compute_local_aabb().mins.abs()).length();
            let turn = seen.rotation.angle_between(p.pose.rotation);
            let d = (seen.translation - p.pose.translation).length() + if turn.is_finite() { turn * reach } else { 0.0 };
            let m = motion.entry(p.object_id).or_default();
            *m = m.max(d);
        }
    }
    let most = motion.values().copied().fold(0.0f32, f32::max);
    (motion.into_iter().filter(|(_, d)| *d >= MOVED && *d >= MOVED_SHARE * most).map(|(id, _)| id).collect(), most)
}

/// The world bounds of every part of every scene that is not ground-sized (fixed or not).
fn whole(scenes: &[&Scene]) -> Option<(Vector, Vector)> {
    let mut acc = Bounds::default();
    for p in scenes.iter().flat_map(|s| s.parts.iter()) {
        let aabb = p.shape.compute_aabb(&p.pose);
        if (aabb.maxs - aabb.mins).max_element() <= CASTER_MAX_SIZE {
            acc.add(p);
        }
    }
    acc.get()
}

/// A growing axis-aligned box.
#[derive(Default)]
struct Bounds(Option<(Vector, Vector)>);

impl Bounds {
    fn add(&mut self, p: &crate::seeing::sensing::capture::Posed) {
        let aabb = p.shape.compute_aabb(&p.pose);
        if !(aabb.mins.is_finite() && aabb.maxs.is_finite()) {
            return;
        }
        self.0 = Some(match self.0 {
            None => (aabb.mins, aabb.maxs),
            Some((lo, hi)) => (lo.min(aabb.mins), hi.max(aabb.maxs)),
        });
    }

    fn is_empty(&self) -> bool {
        self.0.is_none()
    }

    fn get(&self) -> Option<(Vector, Vector)> {
        self.0
    }
}
