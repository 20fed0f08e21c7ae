//! The built-in web viewer (docs/tools.md "Visualization"): `GET /viewer/{sim_id}` is a page that
//! follows a simulation live; it polls `GET /viewer/{sim_id}/frame`, a render of the world by
//! the same CPU rasteriser as get_camera_image plus what the page draws over it (contact points,
//! body frames) and the matrices to place them.
//!
//! The timeline (`past.rs`): `GET /viewer/{sim_id}/timeline` lists the head's chain, and
//! `/frame?seq=S` (`&step=K` inside a step event) shows a past state, re-simulated from the
//! log by the one core. While a long step runs, `/frame` shows the latest moment the stepping
//! loop published (`live.rs`) instead of waiting for it.
//!
//! The page never changes the simulation: its mouse camera is its own (query parameters), and
//! the recorded viewer settings (set_camera, enable_debug_visualization) are only read. Frames
//! are rendered without waiting for a call in flight: while a long step runs the page says so
//! and keeps its last frame.

use std::sync::Arc;

use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use base64::Engine;
use serde::{Deserialize, Serialize};

use crate::seeing::sensing::camera::{self, Mat4};
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::{contacts, render};
use crate::sim::Registry;
use crate::value::{r32, r32s};
use crate::world::{Viewer as RecordedCamera, World};

pub mod live;
pub mod past;

/// The page (one self-contained HTML file: no scripts from elsewhere).
const PAGE: &str = include_str!("page.html");

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

/// One body frame to draw: where a body is and how it is turned.
#[derive(Serialize, Debug, Clone)]
pub struct BodyFrame {
    /// The object.
    pub object_id: u32,
    /// Its link (−1: base or primitive).
    pub link_index: i64,
    /// Body origin.
    pub position: [f64; 3],
    /// Body orientation [x, y, z, w].
    pub orientation: [f64; 4],
    /// Axis length to draw (m), from the body's size.
    pub axis_length: f64,
}

/// What the page draws over a frame, taken from the world the frame shows (present, past or a
/// running step's moment alike), so scrubbing back shows the contacts and frames of then.
#[derive(Debug, Default, Clone)]
pub struct Overlays {
    /// Whether contact points are shown (enable_debug_visualization).
    pub show_contacts: bool,
    /// Whether body frames are shown.
    pub show_frames: bool,
    /// Contact points (on A) when shown.
    pub contacts: Vec<[f64; 3]>,
    /// Body frames when shown.
    pub frames: Vec<BodyFrame>,
}

impl Overlays {
    /// The overlays `w`'s recorded viewer settings ask for (computed only when shown).
    pub fn of(w: &World) -> Overlays {
        let cam = w.viewer();
        Overlays {
            show_contacts: cam.show_contacts,
            show_frames: cam.show_frames,
            contacts: if cam.show_contacts {
                contacts::contacts(w, None).into_iter().map(|c| c.position_on_a).collect()
            } else {
                Vec::new()
            },
            frames: if cam.show_frames { body_frames(w) } else { Vec::new() },
        }
    }
}

/// The recorded viewer camera.
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
    /// The simulation's recorded camera (set_camera).
    pub camera: CameraJson,
    /// Simulated time (s).
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Number of objects.
    pub objects: usize,
    /// The state hash now.
    pub state_hash: String,
    /// Whether contact points are shown (enable_debug_visualization).
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
    /// A running step's progress, [steps done, steps asked], when this frame is one of its
    /// published moments.
    pub progress: Option<[u64; 2]>,
}

/// The size the page asked for, checked against --max-image-px.
fn size(q: &FrameQuery, max_px: usize) -> Result<(u32, u32), String> {
    let (width, height) = (q.w.unwrap_or(DEFAULT_SIZE.0), q.h.unwrap_or(DEFAULT_SIZE.1));
    if width == 0 || height == 0 || width as u64 * height as u64 > max_px as u64 {
        return Err(format!("frame size {width}x{height} must be at least 1x1 and at most {max_px} pixels"));
    }
    Ok((width, height))
}

/// The recorded camera as the page sees it, and the matrices for this frame: the page's own
/// camera when it sent one, else the recorded one.
fn matrices(cam: &RecordedCamera, q: &FrameQuery, width: u32, height: u32) -> (CameraJson, Mat4, Mat4) {
    let recorded = CameraJson {
        distance: r32(cam.distance),
        yaw: r32(cam.yaw),
        pitch: r32(cam.pitch),
        target: r32s(cam.target),
    };
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
    (recorded, view, proj)
}

/// What a frame of a captured scene (a past state, a running step's moment) says about it.
pub struct SceneInfo<'a> {
    /// Simulation id.
    pub simulation_id: &'a str,
    /// Steps since creation.
    pub steps: u64,
    /// Simulated time (s).
    pub time: f64,
    /// Objects.
    pub objects: usize,
    /// State hash ("" while a step runs: it is only computed at the end).
    pub state_hash: &'a str,
    /// The past event shown.
    pub seq: Option<u64>,
    /// Steps into it.
    pub step: Option<u64>,
    /// [done, asked] of a running step.
    pub progress: Option<[u64; 2]>,
    /// What to draw over it, taken when the scene was captured.
    pub overlays: &'a Overlays,
}

/// Renders a captured scene as the page asked, with the overlays of its moment.
pub fn scene_frame(s: &Scene, info: SceneInfo, q: &FrameQuery, max_px: usize) -> Result<FrameJson, String> {
    let (width, height) = size(q, max_px)?;
    let (recorded, view, proj) = matrices(&s.camera, q, width, height);
    let image = render::render_scene(s, width, height, &view, &proj);
    Ok(FrameJson {
        simulation_id: info.simulation_id.to_string(),
        width,
        height,
        png: base64::engine::general_purpose::STANDARD.encode(image.png()?),
        view_matrix: view.to_vec(),
        projection_matrix: proj.to_vec(),
        camera: recorded,
        time: info.time,
        steps: info.steps,
        objects: info.objects,
        state_hash: info.state_hash.to_string(),
        show_contacts: info.overlays.show_contacts,
        show_frames: info.overlays.show_frames,
        contacts: info.overlays.contacts.clone(),
        frames: info.overlays.frames.clone(),
        seq: info.seq,
        step: info.step,
        progress: info.progress,
    })
}

/// Renders one frame of `w` as the page asked; `state_hash` is the simulation's. The same
/// frame as `scene_frame` of the world captured now (`Scene::capture` gives the pixels
/// `render::render` gives).
pub fn frame(w: &World, state_hash: &str, q: &FrameQuery, max_px: usize) -> Result<FrameJson, String> {
    let overlays = Overlays::of(w);
    let info = SceneInfo {
        simulation_id: w.simulation_id(),
        steps: w.steps(),
        time: w.current_time(),
        objects: w.object_count(),
        state_hash,
        seq: None,
        step: None,
        progress: None,
        overlays: &overlays,
    };
    scene_frame(&Scene::capture(w), info, q, max_px)
}

/// One frame per body (each primitive, each robot base and link), at the body's origin.
fn body_frames(w: &World) -> Vec<BodyFrame> {
    let mut out: Vec<BodyFrame> = Vec::new();
    for part in &w.scene().parts {
        let Some(body) = w.physics().colliders.get(part.collider).and_then(|c| c.parent()) else { continue };
        let Some(b) = w.physics().bodies.get(body) else { continue };
        let size = f64::from(part.shape.compute_local_aabb().half_extents().max_element());
        let axis_length = (size * 1.5).clamp(0.05, 2.0);
        if let Some(last) = out.last_mut() {
            if last.object_id == part.object_id && last.link_index == part.link_index {
                last.axis_length = last.axis_length.max(axis_length);
                continue;
            }
        }
        let p = b.position();
        out.push(BodyFrame {
            object_id: part.object_id,
            link_index: part.link_index,
            position: r32s(p.translation.to_array()),
            orientation: r32s(p.rotation.to_array()),
            axis_length,
        });
    }
    out
}

/// Shared state of the viewer's HTTP routes (not `world::Viewer`, the recorded camera).
#[derive(Clone)]
struct Routes {
    reg: Arc<Registry>,
}

/// The viewer's routes, to be merged into the HTTP app (behind the same token and host checks).
pub fn router(reg: Arc<Registry>) -> Router {
    Router::new()
        .route("/viewer/{sim_id}", get(page))
        .route("/viewer/{sim_id}/frame", get(frame_route))
        .route("/viewer/{sim_id}/timeline", get(timeline_route))
        .with_state(Routes { reg })
}

async fn page(State(v): State<Routes>, Path(sim_id): Path<String>) -> Response {
    match v.reg.get(&sim_id) {
        Ok(_) => {
            // The id is a UUID we issued, but escape it anyway: it lands in HTML and JS.
            let safe: String = sim_id.chars().filter(|c| c.is_ascii_alphanumeric() || *c == '-').collect();
            Html(PAGE.replace("{{SIM_ID}}", &safe)).into_response()
        }
        Err(why) => (StatusCode::NOT_FOUND, why).into_response(),
    }
}

async fn frame_route(State(v): State<Routes>, Path(sim_id): Path<String>, Query(q): Query<FrameQuery>) -> Response {
    let sim = match v.reg.get(&sim_id) {
        Ok(s) => s,
        Err(why) => return (StatusCode::NOT_FOUND, why).into_response(),
    };
    let max_px = v.reg.limits().max_image_px;
    let out = tokio::task::spawn_blocking(move || {
        let busy = || (StatusCode::SERVICE_UNAVAILABLE, "busy: a call is running".to_string());
        let bad = |e: String| (StatusCode::BAD_REQUEST, e);
        if let Some(seq) = q.seq {
            // A past state: lend under the lock (no physics), re-simulate without it.
            let req = {
                let Ok(guard) = sim.try_lock() else { return Err(busy()) };
                past::request(&guard, seq, q.step).map_err(bad)?
            };
            let p = past::resolve(req).map_err(bad)?;
            let info = SceneInfo {
                simulation_id: &sim_id,
                steps: p.steps,
                time: p.time,
                objects: p.objects,
                state_hash: &p.state_hash,
                seq: Some(seq),
                step: q.step,
                progress: None,
                overlays: &p.overlays,
            };
            return scene_frame(&p.scene, info, &q, max_px).map_err(bad);
        }
        // Never wait behind a long call: show what its stepping last published, if anything.
        let Ok(guard) = sim.try_lock() else {
            let Some(p) = live::latest(&sim_id) else { return Err(busy()) };
            let info = SceneInfo {
                simulation_id: &sim_id,
                steps: p.steps,
                time: p.time,
                objects: p.objects,
                state_hash: "",
                seq: None,
                step: None,
                progress: Some([p.done, p.total]),
                overlays: &p.overlays,
            };
            return scene_frame(&p.scene, info, &q, max_px).map_err(bad);
        };
        frame(guard.world(), guard.state_hash(), &q, max_px).map_err(bad)
    })
    .await;
    match out {
        Ok(Ok(json)) => ([(header::CACHE_CONTROL, "no-store")], axum::Json(json)).into_response(),
        Ok(Err((code, why))) => (code, why).into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the frame could not be rendered").into_response(),
    }
}

async fn timeline_route(State(v): State<Routes>, Path(sim_id): Path<String>) -> Response {
    let sim = match v.reg.get(&sim_id) {
        Ok(s) => s,
        Err(why) => return (StatusCode::NOT_FOUND, why).into_response(),
    };
    let out = tokio::task::spawn_blocking(move || {
        let Ok(guard) = sim.try_lock() else { return Err((StatusCode::SERVICE_UNAVAILABLE, "busy: a call is running".to_string())) };
        past::timeline(&guard).map_err(|e| (StatusCode::INTERNAL_SERVER_ERROR, e))
    })
    .await;
    match out {
        Ok(Ok(json)) => ([(header::CACHE_CONTROL, "no-store")], axum::Json(json)).into_response(),
        Ok(Err((code, why))) => (code, why).into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the timeline could not be read").into_response(),
    }
}
