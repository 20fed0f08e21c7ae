//! The built-in web viewer over real HTTP against the real server: `viewer_url` for gui
//! simulations, the page, frames rendered from the recorded camera (or the page's own), the
//! overlays placed by the frame's own matrices on the bodies they belong to, and the guards
//! (token by query, host names, unknown simulations, sizes) — reading frames never changes
//! the simulation.

use crate::common;

use base64::Engine;
use common::Server;
use serde_json::{json, Value};

/// `url` + `path`, the status and body, with an optional `Host` header.
async fn get(base: &str, path: &str, host: Option<&str>) -> (u16, String) {
    let mut req = reqwest::Client::new().get(format!("{base}{path}"));
    if let Some(h) = host {
        req = req.header("Host", h);
    }
    let r = req.send().await.expect("HTTP GET");
    (r.status().as_u16(), r.text().await.expect("body"))
}

fn base_of(mcp_url: &str) -> String {
    mcp_url.trim_end_matches("/mcp").to_string()
}

/// Decodes the frame's PNG into (width, height, rgb).
fn pixels(frame: &Value) -> (u32, u32, Vec<u8>) {
    let png = base64::engine::general_purpose::STANDARD.decode(frame["png"].as_str().unwrap()).unwrap();
    let mut reader = png::Decoder::new(std::io::Cursor::new(png)).read_info().unwrap();
    let mut px = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut px).unwrap();
    (info.width, info.height, px)
}

/// A world point to a pixel with the frame's column-major matrices (what the page does).
fn project(frame: &Value, p: [f64; 3]) -> [f64; 2] {
    let m = |k: &str| -> Vec<f64> { frame[k].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect() };
    let mul = |m: &[f64], v: [f64; 4]| -> [f64; 4] {
        std::array::from_fn(|r| m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r] * v[3])
    };
    let c = mul(&m("projection_matrix"), mul(&m("view_matrix"), [p[0], p[1], p[2], 1.0]));
    let (w, h) = (frame["width"].as_f64().unwrap(), frame["height"].as_f64().unwrap());
    [(c[0] / c[3] + 1.0) / 2.0 * w, (1.0 - c[1] / c[3]) / 2.0 * h]
}

/// The bounding box of the red pixels.
fn red_box(w: u32, px: &[u8]) -> [f64; 4] {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (i, p) in px.chunks(3).enumerate() {
        if p[0] > 100 && p[1] < 60 && p[2] < 60 {
            let (x, y) = ((i as u32 % w) as f64, (i as u32 / w) as f64);
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
    }
    [x0, x1, y0, y1]
}

#[tokio::test(flavor = "multi_thread")]
async fn the_viewer_follows_a_gui_simulation_without_changing_it() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let base = base_of(&server.url);
    let c = server.client().await;

    let plain = c.call("create_simulation", json!({})).await;
    assert!(plain.get("viewer_url").is_none(), "{plain}");
    let created = c.call("create_simulation", json!({"gui": true})).await;
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(created["gui_enabled"], true);
    assert_eq!(created["viewer_url"], format!("{base}/viewer/{sim}"));

    c.call("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.1], "position": [0, 0, -0.1], "mass": 0})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 0.5], "color": [1, 0, 0, 1]})).await;
    c.step(&sim, 240).await;

    let (status, page) = get(&base, &format!("/viewer/{sim}"), None).await;
    assert_eq!(status, 200);
    assert!(page.contains("<canvas") && page.contains(&sim), "the page names its simulation");

    // Debug visualization switched off: the image from the recorded camera, no overlays.
    c.call("enable_debug_visualization", json!({"sim_id": sim, "show_contacts": false, "show_frames": false})).await;
    let hash = c.hash(&sim).await;
    let (status, body) = get(&base, &format!("/viewer/{sim}/frame?w=320&h=240"), None).await;
    assert_eq!(status, 200, "{body}");
    let f: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(f["state_hash"], hash.as_str());
    assert_eq!(f["steps"], 240);
    assert_eq!(f["camera"], json!({"distance": 5.0, "yaw": 50.0, "pitch": -35.0, "target": [0.0, 0.0, 0.0]}));
    assert_eq!(f["contacts"], json!([]));
    assert_eq!(f["frames"], json!([]));
    let (w, h, px) = pixels(&f);
    assert_eq!((w, h), (320, 240));
    let red = red_box(w, &px);
    assert!(red[0] < red[1], "the red box is in view");

    // With contacts and frames on: the four contact points of the resting box, placed by the
    // frame's matrices, land on the box's pixels; its frame's origin projects inside them too.
    c.call("enable_debug_visualization", json!({"sim_id": sim, "show_contacts": true, "show_frames": true})).await;
    let (_, body) = get(&base, &format!("/viewer/{sim}/frame?w=320&h=240"), None).await;
    let f: Value = serde_json::from_str(&body).unwrap();
    let contacts = f["contacts"].as_array().unwrap();
    assert_eq!(contacts.len(), 4, "{f}");
    let inside = |p: [f64; 2]| p[0] >= red[0] - 2.0 && p[0] <= red[1] + 2.0 && p[1] >= red[2] - 2.0 && p[1] <= red[3] + 2.0;
    for p in contacts {
        let xyz = [p[0].as_f64().unwrap(), p[1].as_f64().unwrap(), p[2].as_f64().unwrap()];
        assert!(xyz[2].abs() < 0.01, "contact on the ground: {xyz:?}");
        assert!(inside(project(&f, xyz)), "contact {xyz:?} at {:?} outside the box's pixels {red:?}", project(&f, xyz));
    }
    let frames = f["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    let bx = &frames[1];
    let origin: Vec<f64> = bx["position"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert!((origin[2] - 0.2).abs() < 0.01);
    assert!(inside(project(&f, [origin[0], origin[1], origin[2]])));

    // The page's own camera turns the view; set_camera moves the recorded one. Neither the
    // frames nor the page change the state hash beyond set_camera's own (recorded) change.
    let (_, body) = get(&base, &format!("/viewer/{sim}/frame?w=320&h=240&distance=3&yaw=140&pitch=-20&tx=0&ty=0&tz=0"), None).await;
    let turned: Value = serde_json::from_str(&body).unwrap();
    assert_ne!(turned["view_matrix"], f["view_matrix"]);
    assert_eq!(turned["camera"], f["camera"], "the page's camera is its own");
    assert_eq!(c.hash(&sim).await, f["state_hash"].as_str().unwrap(), "frames changed the world");
    c.call("set_camera", json!({"sim_id": sim, "distance": 3, "yaw": 140, "pitch": -20, "target": [0, 0, 0]})).await;
    let (_, body) = get(&base, &format!("/viewer/{sim}/frame?w=320&h=240"), None).await;
    let followed: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(followed["view_matrix"], turned["view_matrix"], "set_camera is the page's default camera");

    // Guards: unknown simulation, a foreign Host (DNS rebinding), an oversized frame.
    assert_eq!(get(&base, "/viewer/no-such-sim", None).await.0, 404);
    assert_eq!(get(&base, "/viewer/no-such-sim/frame", None).await.0, 404);
    assert_eq!(get(&base, &format!("/viewer/{sim}"), Some("evil.example")).await.0, 403);
    for kind in ["poses", "timeline", "clip?from_seq=1", "object?id=0"] {
        assert_eq!(get(&base, &format!("/viewer/{sim}/{kind}"), Some("evil.example")).await.0, 403, "{kind}");
    }
    let (status, why) = get(&base, &format!("/viewer/{sim}/frame?w=100000&h=100000"), None).await;
    assert_eq!(status, 400, "{why}");

    // A fork of a gui simulation, and a load with gui, carry a viewer too (fork_simulation has
    // no gui parameter: the fork is shown when its parent is; an unknown parameter is refused).
    let fork = c.call("fork_simulation", json!({"sim_id": sim})).await;
    let fork_id = fork["simulation_id"].as_str().unwrap();
    assert_eq!(fork["viewer_url"], format!("{base}/viewer/{fork_id}"), "{fork}");
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "v.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "v.json", "gui": true})).await;
    let loaded_id = loaded["simulation_id"].as_str().unwrap();
    assert_eq!(loaded["viewer_url"], format!("{base}/viewer/{loaded_id}"), "{loaded}");
    let loaded = c.call("load_simulation", json!({"file_path": "v.json"})).await;
    assert!(loaded.get("viewer_url").is_none(), "{loaded}");
}

#[tokio::test(flavor = "multi_thread")]
async fn with_a_token_the_viewer_wants_it_in_the_query() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--token", "s3cret"]);
    let base = base_of(&server.url);
    // Create a simulation over MCP with the bearer token.
    let cfg = rmcp::transport::streamable_http_client::StreamableHttpClientTransportConfig::with_uri(server.url.clone())
        .auth_header("s3cret");
    let transport = rmcp::transport::StreamableHttpClientTransport::from_config(cfg);
    let client = common::Client { service: rmcp::ServiceExt::serve((), transport).await.expect("initialize") };
    let sim = client.new_sim(json!({"gui": true})).await;
    assert_eq!(get(&base, &format!("/viewer/{sim}"), None).await.0, 401);
    assert_eq!(get(&base, &format!("/viewer/{sim}?token=wrong"), None).await.0, 401);
    assert_eq!(get(&base, &format!("/viewer/{sim}?token=s3cret"), None).await.0, 200);
    let (status, body) = get(&base, &format!("/viewer/{sim}/frame?w=64&h=48&token=s3cret"), None).await;
    assert_eq!(status, 200, "{body}");
    for kind in ["poses", "timeline", "clip?from_seq=1", "object?id=0"] {
        assert_eq!(get(&base, &format!("/viewer/{sim}/{kind}"), None).await.0, 401, "{kind} without the token");
        let sep = if kind.contains('?') { '&' } else { '?' };
        let (status, body) = get(&base, &format!("/viewer/{sim}/{kind}{sep}token=s3cret"), None).await;
        assert!(status == 200 || kind.starts_with("object") && status == 400, "{kind}: {status} {body}");
    }
    // The query token opens the viewer only, not MCP.
    assert_eq!(get(&base, "/mcp?token=s3cret", None).await.0, 401);
}
