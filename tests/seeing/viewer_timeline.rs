//! The viewer's timeline and live progress, over real HTTP: a past
//! state (`/frame?seq=S`, `&step=K`) is pixel for pixel what get_camera_image shows on a fork
//! at that state; while a long step runs, `/frame` shows its progress with a rising step
//! count, and watching changes no result or hash.

use crate::common;

use base64::Engine;
use common::pictures::{image_of, png_rgb};
use common::{Client, Server};
use serde_json::{json, Value};

fn base_of(mcp_url: &str) -> String {
    mcp_url.trim_end_matches("/mcp").to_string()
}

async fn get_json(url: &str) -> (u16, Value) {
    let r = reqwest::Client::new().get(url).send().await.expect("HTTP GET");
    let status = r.status().as_u16();
    let text = r.text().await.unwrap();
    (status, serde_json::from_str(&text).unwrap_or(Value::String(text)))
}

fn frame_rgb(frame: &Value) -> Vec<u8> {
    let png = base64::engine::general_purpose::STANDARD.decode(frame["png"].as_str().unwrap()).unwrap();
    png_rgb(&png).2
}

/// get_camera_image on `sim` with the frame's own matrices and size.
async fn camera_like(c: &Client, sim: &str, frame: &Value) -> Vec<u8> {
    let args = json!({"sim_id": sim, "width": frame["width"], "height": frame["height"],
        "view_matrix": frame["view_matrix"], "projection_matrix": frame["projection_matrix"]});
    let r = c.raw("get_camera_image", args).await;
    assert_ne!(r.is_error, Some(true), "{r:?}");
    png_rgb(&image_of(&r, "image/png")).2
}

async fn head(c: &Client, sim: &str) -> u64 {
    c.call("get_simulation_info", json!({"sim_id": sim})).await["head_seq"].as_u64().unwrap()
}

#[tokio::test(flavor = "multi_thread")]
async fn a_past_state_on_the_timeline_is_what_a_fork_there_shows() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let base = base_of(&server.url);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gui": true})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.4, 0.4, 0.4], "position": [0, 0, 1.5], "color": [1, 0, 0, 1], "orientation": [0.3, 0.2, 0, 1]})).await;
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [0.5, 0.3, 2.5], "color": [0.2, 0.4, 1, 1]})).await;
    let before_steps = head(&c, &sim).await;
    c.step(&sim, 90).await;
    let step_seq = head(&c, &sim).await;
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": 2, "position": [-0.5, 0, 1]})).await;
    c.step(&sim, 60).await;
    c.call("set_camera", json!({"sim_id": sim, "distance": 5, "yaw": 40, "pitch": -25, "target": [0, 0, 0.5]})).await;
    let hash = c.hash(&sim).await;

    let (status, t) = get_json(&format!("{base}/viewer/{sim}/timeline")).await;
    assert_eq!(status, 200, "{t}");
    let seqs: Vec<u64> = t["events"].as_array().unwrap().iter().map(|e| e["seq"].as_u64().unwrap()).collect();
    assert_eq!(seqs.len(), 8, "{t}");
    assert_eq!(t["events"][4]["steps"], 90);
    assert_eq!(t["events"][6]["total_steps"], 150);

    // Every state on the chain: the frame is get_camera_image on a fork there, pixel for pixel.
    for seq in seqs {
        let (status, f) = get_json(&format!("{base}/viewer/{sim}/frame?seq={seq}&w=160&h=120")).await;
        assert_eq!(status, 200, "seq {seq}: {f}");
        assert_eq!(f["seq"], seq);
        let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": seq})).await;
        let fork_id = fork["simulation_id"].as_str().unwrap();
        assert_eq!(f["state_hash"], fork["state_hash"], "seq {seq}");
        assert!(frame_rgb(&f) == camera_like(&c, fork_id, &f).await, "seq {seq}: the frame differs from the fork's picture");
        c.call("destroy_simulation", json!({"sim_id": fork_id})).await;
    }

    // Inside a step event: 37 steps into the 90.
    let (status, f) = get_json(&format!("{base}/viewer/{sim}/frame?seq={step_seq}&step=37&w=160&h=120")).await;
    assert_eq!(status, 200, "{f}");
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": before_steps})).await;
    let fork_id = fork["simulation_id"].as_str().unwrap();
    c.step(fork_id, 37).await;
    assert_eq!(f["state_hash"], c.hash(fork_id).await.as_str());
    assert_eq!(f["steps"], 37);
    assert!(frame_rgb(&f) == camera_like(&c, fork_id, &f).await, "step 37: the frame differs");
    // The page's own camera on a past state (a cached scene, turned).
    let (status, turned) = get_json(&format!("{base}/viewer/{sim}/frame?seq={step_seq}&step=37&w=160&h=120&distance=3&yaw=10&pitch=-30&tx=0&ty=0&tz=0.5")).await;
    assert_eq!(status, 200);
    assert!(frame_rgb(&turned) == camera_like(&c, fork_id, &turned).await);

    // Refusals.
    for (q, word) in [(format!("seq={step_seq}&step=0"), "step"), (format!("seq={step_seq}&step=91"), "step"), ("seq=9999".into(), "9999"), (format!("seq={}&step=1", step_seq + 1), "step")] {
        let (status, body) = get_json(&format!("{base}/viewer/{sim}/frame?{q}")).await;
        assert_eq!(status, 400, "{q}: {body}");
        assert!(body.as_str().unwrap_or_default().contains(word), "{q}: {body}");
    }
    assert_eq!(c.hash(&sim).await, hash, "looking back changed nothing");
}

/// Runs a step of `steps` on another connection and polls `/frame` while it runs; returns the
/// distinct step counts of the progress frames seen, in order.
async fn watch_step(url: &str, base: &str, sim: &str, steps: u64) -> Vec<u64> {
    let stepping = {
        let (url, sim) = (url.to_string(), sim.to_string());
        tokio::spawn(async move {
            let c = Client::connect(&url).await;
            c.call("step_simulation", json!({"sim_id": sim, "steps": steps})).await
        })
    };
    let mut seen: Vec<u64> = Vec::new();
    let mut asked = 0;
    while !stepping.is_finished() {
        // The WebGL page's poses and the server-rendered frame alike: never "busy".
        asked += 1;
        let kind = if asked % 2 == 0 { "poses?" } else { "frame?w=80&h=60&" };
        let (status, f) = get_json(&format!("{base}/viewer/{sim}/{kind}")).await;
        assert!(stepping.is_finished() || status == 200, "{kind} answered {status} during a step: {f}");
        if status == 200 && kind == "poses?" && f["progress"].is_array() {
            assert!(!f["poses"].as_str().unwrap().is_empty());
            continue;
        }
        if status == 200 && f["progress"].is_array() {
            assert_eq!(f["progress"][1], steps);
            assert!(!f["png"].as_str().unwrap().is_empty());
            let s = f["steps"].as_u64().unwrap();
            if seen.last() != Some(&s) {
                seen.push(s);
            }
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    assert_eq!(stepping.await.unwrap()["steps_taken"], steps);
    seen
}

#[tokio::test(flavor = "multi_thread")]
async fn a_long_step_shows_its_progress_and_watching_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let base = base_of(&server.url);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gui": true})).await;
    // Bodies in free fall never sleep, so every step costs the same.
    for i in 0..100 {
        let p = [(i % 5) as f64 * 0.5 - 1.0, (i / 5 % 5) as f64 * 0.5 - 1.0, 0.5 + (i / 25) as f64 * 0.5];
        c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": p, "color": [0.8, 0.3, 0.1, 1]})).await;
    }
    // Watch steps of doubling length until one lasted about 3 s on this machine (the clock only
    // makes the step long enough to be watched; what is asserted does not depend on it).
    let (mut steps, mut at, mut seen) = (2_000u64, 0, Vec::new());
    for _ in 0..8 {
        at = head(&c, &sim).await;
        let started = std::time::Instant::now();
        seen = watch_step(&server.url, &base, &sim, steps).await;
        if started.elapsed().as_secs_f64() >= 3.0 || steps >= 256_000 {
            break;
        }
        steps *= 2;
    }
    assert!(seen.len() >= 6, "progress frames seen: {seen:?} over {steps} steps");
    assert!(seen.windows(2).all(|w| w[1] > w[0]), "the step count rises: {seen:?}");
    let watched = c.hash(&sim).await;

    // An unwatched fork from the same state, stepped the same, ends in the same state.
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": at})).await;
    let fork_id = fork["simulation_id"].as_str().unwrap();
    c.step(fork_id, steps).await;
    assert_eq!(c.hash(fork_id).await, watched);
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    // After the step, the present again.
    let (status, f) = get_json(&format!("{base}/viewer/{sim}/frame?w=80&h=60")).await;
    assert_eq!(status, 200);
    assert!(f["progress"].is_null());
    assert_eq!(f["state_hash"], watched.as_str());
}

/// Scrubbing back shows the overlays of then: contacts and body frames of a past state are
/// those the present frame of a fork at that state shows, and before enable_debug_visualization
/// turned body frames on none are drawn.
#[tokio::test(flavor = "multi_thread")]
async fn a_past_frame_carries_the_overlays_of_its_moment() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let base = base_of(&server.url);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gui": true})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.4, 0.4, 0.4], "position": [0, 0, 0.6]})).await;
    let before = head(&c, &sim).await;
    c.call("enable_debug_visualization", json!({"sim_id": sim, "show_contacts": true, "show_frames": true})).await;
    c.step(&sim, 120).await;
    let settled = head(&c, &sim).await;
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": 1, "position": [0, 0, 3]})).await;

    let (status, f) = get_json(&format!("{base}/viewer/{sim}/frame?seq={before}&w=80&h=60")).await;
    assert_eq!(status, 200, "{f}");
    assert_eq!(f["show_frames"], false, "body frames are off by default: {f}");
    assert!(f["frames"].as_array().unwrap().is_empty(), "{f}");
    assert!(f["contacts"].as_array().unwrap().is_empty(), "the box hangs above the ground then: {f}");

    let (status, past) = get_json(&format!("{base}/viewer/{sim}/frame?seq={settled}&w=80&h=60")).await;
    assert_eq!(status, 200, "{past}");
    assert_eq!(past["show_frames"], true);
    assert!(!past["contacts"].as_array().unwrap().is_empty(), "the settled box touches the ground: {past}");
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": settled})).await;
    let fork_id = fork["simulation_id"].as_str().unwrap();
    let (status, now) = get_json(&format!("{base}/viewer/{fork_id}/frame?w=80&h=60")).await;
    assert_eq!(status, 200, "{now}");
    assert_eq!(past["frames"], now["frames"], "body frames of then");
    assert_eq!(past["contacts"], now["contacts"], "contacts of then");
    // The present differs (the box was lifted), so the past frame is not the present one.
    let (_, present) = get_json(&format!("{base}/viewer/{sim}/frame?w=80&h=60")).await;
    assert_ne!(present["frames"], past["frames"]);
}

/// The timeline a watching page reads after every call (extended from the last one it read)
/// holds each event of the chain with the time its call answered — across a set_timestep, an
/// undo (the head moves back: read again from the root) and a branch after it.
#[tokio::test(flavor = "multi_thread")]
async fn a_watched_timeline_keeps_each_events_time_across_undo() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let base = base_of(&server.url);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gui": true})).await;
    let mut landed: Vec<(u64, f64)> = Vec::new();
    let at = |r: &Value| (r["head_seq"].as_u64().unwrap(), r["time"].as_f64().unwrap());
    let calls = [
        ("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})),
        ("step_simulation", json!({"sim_id": sim, "steps": 24})),
        ("set_timestep", json!({"sim_id": sim, "timestep": 0.01})),
        ("step_simulation", json!({"sim_id": sim, "steps": 10})),
    ];
    for (tool, args) in calls {
        landed.push(at(&c.call(tool, args).await));
        assert_eq!(get_json(&format!("{base}/viewer/{sim}/timeline")).await.0, 200);
    }
    c.call("undo", json!({"sim_id": sim})).await;
    landed.pop();
    assert_eq!(get_json(&format!("{base}/viewer/{sim}/timeline")).await.0, 200);
    landed.push(at(&c.call("step_simulation", json!({"sim_id": sim, "steps": 5})).await));
    let (status, t) = get_json(&format!("{base}/viewer/{sim}/timeline")).await;
    assert_eq!(status, 200, "{t}");
    let marks: Vec<(u64, f64)> = t["events"].as_array().unwrap()[1..].iter().map(|m| (m["seq"].as_u64().unwrap(), m["time"].as_f64().unwrap())).collect();
    assert_eq!(marks.len(), landed.len(), "{t}");
    for ((seq, time), (want_seq, want_time)) in marks.iter().zip(&landed) {
        assert_eq!(seq, want_seq, "{t}");
        assert!((time - want_time).abs() < 1e-9, "seq {seq}: timeline {time} vs the call's {want_time}");
    }
    assert!((landed.last().unwrap().1 - (0.1 + 0.05)).abs() < 1e-6, "24/240 + 5 × 0.01: {landed:?}");
}
