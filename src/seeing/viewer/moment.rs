//! A moment the viewer shows — the present, a running step's published moment, or a past one
//! re-simulated — and what every viewer answer says about it (time, steps, hash, where on the
//! chain, the recorded camera, contacts and body frames), so the WebGL page's poses
//! (`ask.rs`) and the PNG frame (`png.rs`) describe a moment in one way.

use serde::Serialize;

use super::{BodyFrame, Overlays};
use crate::seeing::sensing::capture::Scene;
use crate::value::{r32, r32s};
use crate::world::Viewer as RecordedCamera;

/// A captured moment and what is known of it besides the scene.
pub struct Moment<'a> {
    /// What the camera sees then (with its time, steps and recorded camera).
    pub scene: &'a Scene,
    /// Objects then.
    pub objects: usize,
    /// The state hash ("" for a running step's moment: hashes are computed at its end).
    pub state_hash: &'a str,
    /// The past event shown (None: the present).
    pub seq: Option<u64>,
    /// Steps into event `seq`.
    pub step: Option<u64>,
    /// [done, asked] of a running step.
    pub progress: Option<[u64; 2]>,
    /// Contacts and body frames then, as the recorded settings ask.
    pub overlays: &'a Overlays,
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
        Shown {
            camera: CameraJson::of(&m.scene.camera),
            time: m.scene.time,
            steps: m.scene.steps,
            objects: m.objects,
            state_hash: m.state_hash.to_string(),
            show_contacts: m.overlays.show_contacts,
            show_frames: m.overlays.show_frames,
            contacts: m.overlays.contacts.clone(),
            frames: m.overlays.frames.clone(),
            seq: m.seq,
            step: m.step,
            progress: m.progress,
        }
    }
}
