//! The built-in web viewer (docs/tools.md "Visualization"). `GET /viewer/{sim_id}` is a page
//! that draws the simulation in the browser with WebGL (three.js, vendored in `vendor/` and
//! inlined into the page, so it makes no outside request): it gets the scene once per change
//! and then poses per frame (`wire.rs`), follows the simulation live, and scrubs and plays its
//! timeline; the same page is the MCP App `ui://physics-mcp/viewer` (`app.rs`), reading the
//! same answers through MCP resources instead of HTTP (`ask.rs` serves both).
//! `GET /viewer/{sim_id}/frame` stays: a PNG rendered by the CPU rasteriser, for clients
//! without WebGL (`png.rs`).
//!
//! The timeline (`past.rs`) re-simulates any past state from the log by the one core. While a
//! long step runs, the page gets the latest moment the stepping loop published (`live.rs`)
//! instead of waiting — never a "busy" error.
//!
//! The page never changes the simulation: its camera is its own, and the recorded viewer
//! settings (set_camera, enable_debug_visualization) are only read.

use std::sync::Arc;

use axum::extract::{Path, RawQuery, State};
use axum::http::{header, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde::Serialize;

use crate::seeing::sensing::contacts;
use crate::sim::Registry;
use crate::value::r32s;
use crate::world::World;

pub mod app;
pub mod ask;
pub mod live;
pub mod moment;
pub mod past;
pub mod png;
pub mod recent;
pub mod wire;

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
    /// Contacts are shown only once enable_debug_visualization was called on the chain
    /// (`contacts_asked`): the world's hashed default says true, but a page full of contact
    /// dots nobody asked for hides the scene.
    pub fn of(w: &World, contacts_asked: bool) -> Overlays {
        let cam = w.viewer();
        let show_contacts = cam.show_contacts && contacts_asked;
        Overlays {
            show_contacts,
            show_frames: cam.show_frames,
            contacts: if show_contacts {
                contacts::contacts(w, None).into_iter().map(|c| c.position_on_a).collect()
            } else {
                Vec::new()
            },
            frames: if cam.show_frames { body_frames(w) } else { Vec::new() },
        }
    }
}

/// Parts larger than this (m, half extent) get no body frame: a ground plane's would dwarf
/// the scene.
const NO_FRAME_ABOVE: f64 = 10.0;

/// One frame per body (each primitive, each robot base and link), at the body's origin, its
/// axes as long as the body is big (0.02–1 m), so a robot's links stay readable.
fn body_frames(w: &World) -> Vec<BodyFrame> {
    let mut out: Vec<BodyFrame> = Vec::new();
    for part in &w.scene().parts {
        let Some(body) = w.physics().colliders.get(part.collider).and_then(|c| c.parent()) else { continue };
        let Some(b) = w.physics().bodies.get(body) else { continue };
        let size = f64::from(part.shape.compute_local_aabb().half_extents().max_element());
        if size.is_nan() || size > NO_FRAME_ABOVE {
            continue;
        }
        let axis_length = (size * 1.2).clamp(0.02, 1.0);
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

/// Drops everything the viewer keeps of simulation `id` — its timeline, past moments, the last
/// moment shown, inspections, clips and refusals — once it is destroyed (`Registry::destroy`).
pub fn forget(id: &str) {
    ask::forget(id);
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
        .route("/viewer/{sim_id}/{kind}", get(asked))
        .with_state(Routes { reg })
}

async fn page(State(v): State<Routes>, Path(sim_id): Path<String>) -> Response {
    match v.reg.get(&sim_id) {
        Ok(_) => ([(header::CACHE_CONTROL, "no-store")], Html(app::page(&sim_id))).into_response(),
        Err(why) => (StatusCode::NOT_FOUND, why).into_response(),
    }
}

/// `/viewer/{sim_id}/{kind}?…`: the same answers the MCP App reads as `sim://{sim_id}/viewer/{kind}?…`.
/// When the browser goes away before the answer, hyper drops this future, and with it the
/// guard that tells the blocking work to stop (its waiting and re-simulating).
async fn asked(State(v): State<Routes>, Path((sim_id, kind)): Path<(String, String)>, RawQuery(query): RawQuery) -> Response {
    let reg = v.reg.clone();
    let asking = match ask::Asking::enter(&sim_id) {
        Ok(a) => a,
        Err((status, why)) => return (status, why).into_response(),
    };
    let stop = tokio_util::sync::CancellationToken::new();
    let _stop_when_dropped = stop.clone().drop_guard();
    let out = tokio::task::spawn_blocking(move || {
        let _asking = asking;
        ask::answer_text(&reg, &sim_id, &kind, query.as_deref().unwrap_or(""), &stop)
    })
    .await;
    match out {
        Ok(Ok(json)) => ([(header::CACHE_CONTROL, "no-store"), (header::CONTENT_TYPE, "application/json")], json).into_response(),
        Ok(Err((status, why))) => (status, why).into_response(),
        Err(_) => (StatusCode::INTERNAL_SERVER_ERROR, "the viewer could not answer").into_response(),
    }
}
