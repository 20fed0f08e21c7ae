//! A moment the viewer shows — the present, a running step's published moment, or a past one
//! re-simulated — and what every viewer answer says about it (time, steps, hash, where on the
//! chain, the recorded camera, contacts and body frames), so the WebGL page's poses
//! (`ask.rs`) and the PNG frame (`png.rs`) describe a moment in one way.

use serde::Serialize;

use super::{BodyFrame, Overlays};
use crate::seeing::sensing::capture::Scene;
use crate::value::{r32, r32s};
use crate::world::{Viewer as RecordedCamera, World};

/// What a world looks like to the viewer at one moment, detached from the world: the present,
/// a running step's published moment and a re-simulated past state are all one of these.
pub struct Captured {
    /// What the camera sees (with its time, steps and recorded camera).
    pub scene: Scene,
    /// Objects then.
    pub objects: usize,
    /// Contacts and body frames then, as the recorded settings ask.
    pub overlays: Overlays,
}

impl Captured {
    /// `w` as it is now; `contacts_asked`: see `Overlays::of`.
    pub fn of(w: &World, contacts_asked: bool) -> Captured {
        Captured { scene: Scene::capture(w), objects: w.object_count(), overlays: Overlays::of(w, contacts_asked) }
    }

    /// Bytes this moment holds, for the viewer's byte-bounded caches (`recent.rs`): its parts,
    /// the points and faces of the meshes they point to (a re-simulated moment holds the only
    /// copy of its scratch world's meshes; a shape shared by several parts is counted for
    /// each, an upper bound) and its overlays.
    pub fn bytes(&self) -> usize {
        let parts: usize = self.scene.parts.iter().map(|p| std::mem::size_of_val(p) + shape_bytes(&*p.shape)).sum();
        parts + self.overlays.contacts.len() * 24 + self.overlays.frames.len() * std::mem::size_of::<BodyFrame>()
    }
}

/// The heap bytes of a shape's points and faces (meshes, hulls, compounds of them); a
/// primitive's are none.
fn shape_bytes(shape: &dyn rapier3d::parry::shape::Shape) -> usize {
    if let Some(m) = shape.as_trimesh() {
        return m.vertices().len() * 12 + m.indices().len() * 12;
    }
    if let Some(c) = shape.as_convex_polyhedron() {
        return c.points().len() * 12 * 4;
    }
    if let Some(c) = shape.as_compound() {
        return c.shapes().iter().map(|(_, s)| 64 + shape_bytes(&**s)).sum();
    }
    0
}

/// A captured moment and where it is: what every viewer answer describes.
pub struct Moment<'a> {
    /// The moment.
    pub seen: &'a Captured,
    /// The state hash ("" for a running step's moment: hashes are computed at its end).
    pub state_hash: &'a str,
    /// The past event shown (None: the present).
    pub seq: Option<u64>,
    /// Steps into event `seq`.
    pub step: Option<u64>,
    /// [done, asked] of a running step.
    pub progress: Option<[u64; 2]>,
}

/// The recorded viewer camera (set_camera).
#[derive(Serialize, Debug)]
pub struct CameraJson {
    /// Distance (m).
    pub distance: f64,
    /// Yaw (degrees).
    pub yaw: f64,
    /// Pitch (degrees).
    pub pitch: f64,
    /// Target point.
    pub target: [f64; 3],
}

impl CameraJson {
    /// The recorded camera as answers carry it.
    pub fn of(cam: &RecordedCamera) -> CameraJson {
        CameraJson { distance: r32(cam.distance), yaw: r32(cam.yaw), pitch: r32(cam.pitch), target: r32s(cam.target) }
    }
}

/// What every viewer answer says about its moment (flattened into the answer).
#[derive(Serialize, Debug)]
pub struct Shown {
    /// The simulation's recorded camera then.
    pub camera: CameraJson,
    /// Simulated time (s).
    pub time: f64,
    /// Steps since creation.
    pub steps: u64,
    /// Number of objects.
    pub objects: usize,
    /// The state hash ("" for a running step's moment).
    pub state_hash: String,
    /// Whether contact points are shown (enable_debug_visualization called).
    pub show_contacts: bool,
    /// Whether body frames are shown.
    pub show_frames: bool,
    /// Contact points (on A) when shown.
    pub contacts: Vec<[f64; 3]>,
    /// Body frames when shown.
    pub frames: Vec<BodyFrame>,
    /// The past event shown (None: the present).
    pub seq: Option<u64>,
    /// Steps into event `seq` shown.
    pub step: Option<u64>,
    /// A running step's progress, [steps done, steps asked], when this is one of its
    /// published moments.
    pub progress: Option<[u64; 2]>,
}

impl Shown {
    /// What `m` says about itself.
    pub fn of(m: &Moment) -> Shown {
        let (scene, overlays) = (&m.seen.scene, &m.seen.overlays);
        Shown {
            camera: CameraJson::of(&scene.camera),
            time: scene.time,
            steps: scene.steps,
            objects: m.seen.objects,
            state_hash: m.state_hash.to_string(),
            show_contacts: overlays.show_contacts,
            show_frames: overlays.show_frames,
            contacts: overlays.contacts.clone(),
            frames: overlays.frames.clone(),
            seq: m.seq,
            step: m.step,
            progress: m.progress,
        }
    }
}
