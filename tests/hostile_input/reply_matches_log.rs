//! A reply never contradicts the log: a state-changing call whose reply would not fit the
//! budget is shortened (`truncated: true`, with the counts left out) before it commits —
//! committed once, answered once, never an error after a commit; a read whose reply (images
//! included) would not fit is refused and logged as refused, never logged as answered; a kept
//! sweep's reply is measured with the ids of the simulations it keeps.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// The last event of `sim` for `tool`, paging through the history (a page holds what fits
/// the reply budget).
async fn last_event(c: &Client, sim: &str, tool: &str) -> Value {
    // Up to the last event before the paging began (each page is itself logged as a read).
    let end = c.call("get_history", json!({"sim_id": sim, "limit": 1})).await["last_seq"].as_u64().unwrap();
    let (mut since, mut found) = (0, Value::Null);
    while since < end {
        let h = c.call("get_history", json!({"sim_id": sim, "since_seq": since, "limit": 1000})).await;
        let events = h["events"].as_array().unwrap();
        let Some(last) = events.last() else { break };
        if let Some(e) = events.iter().rev().find(|e| e["tool"] == tool && e["seq"].as_u64() <= Some(end)) {
            found = e.clone();
        }
        since = last["seq"].as_u64().unwrap();
    }
    found
}

#[tokio::test(flavor = "multi_thread")]
async fn a_load_whose_reply_is_too_big_is_shortened_and_committed_once() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    // 4,000 bodies with long names: about 1.5 MB of model, a `bodies` list over 1 MiB.
    let pad = "n".repeat(280);
    let bodies: String = (0..4000).map(|i| format!("<body name=\"{pad}_{i:04}\" pos=\"{} 0 0\"><geom size=\"0.01\"/></body>", i as f64 * 0.03)).collect();
    std::fs::write(server.workspace.join("many.xml"), format!("<mujoco><worldbody>{bodies}</worldbody></mujoco>")).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let r = c.raw("load_mjcf", json!({"sim_id": sim, "file_path": "many.xml"})).await;
    assert_ne!(r.is_error, Some(true), "the load is answered, not refused: {r:?}");
    let out = r.structured_content.clone().unwrap();
    assert_eq!(out["truncated"], json!(true), "{}", out.to_string().chars().take(300).collect::<String>());
    let shown = out["bodies"].as_array().unwrap().len() as u64;
    assert_eq!(shown + out["omitted"]["bodies"].as_u64().unwrap(), 4000);
    assert!(serde_json::to_vec(&r).unwrap().len() <= 1 << 20);
    // One robot, one change event: what the client was told.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["objects"].as_array().unwrap().len(), 1, "{info}");
    let h = c.call("get_history", json!({"sim_id": sim})).await;
    let loads: Vec<&Value> = h["events"].as_array().unwrap().iter().filter(|e| e["tool"] == "load_mjcf").collect();
    assert_eq!(loads.len(), 1);
    assert_eq!(loads[0]["kind"], "change");
    common::assert_replays(&server.data, &sim);
    // The shortened reply is the one measured before the commit, not a late rescue.
    assert!(!server.stderr.lock().unwrap().iter().any(|l| l.contains("was not measured")), "a reply was rescued after its call was recorded");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_read_whose_reply_is_too_big_is_logged_as_refused() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-reply-bytes", "20000"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    // A busy, colourful scene: its images do not compress to a few KB.
    let mut calls = Vec::new();
    for i in 0..200 {
        let (x, y) = ((i % 20) as f64 * 0.25 - 2.5, (i / 20) as f64 * 0.25 - 1.2);
        let color = [(i * 37 % 100) as f64 / 100.0, (i * 53 % 100) as f64 / 100.0, (i * 71 % 100) as f64 / 100.0, 1.0];
        calls.push(json!({"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [x, y, 0.5 + (i % 7) as f64 * 0.1], "color": color}}));
    }
    for part in calls.chunks(40) {
        c.call("batch", json!({"sim_id": sim, "calls": part})).await;
    }
    c.step(&sim, 60).await;
    let view = c.call("compute_view_matrix", json!({"camera_eye_position": [0, -4, 3], "camera_target_position": [0, 0, 0.3], "camera_up_vector": [0, 0, 1]})).await["view_matrix"].clone();
    for (tool, args) in [
        ("get_camera_image", json!({"sim_id": sim, "width": 640, "height": 480, "view_matrix": view})),
        ("render_animation", json!({"sim_id": sim, "width": 320, "height": 240, "every": 2, "view_matrix": view})),
    ] {
        let r = c.raw(tool, args.clone()).await;
        assert_eq!(r.is_error, Some(true), "{tool}: the reply fits 20000 bytes after all; make the scene busier");
        let why = r.content[0].as_text().unwrap().text.clone();
        assert!(why.contains("--max-reply-bytes"), "{tool}: {why}");
        let e = last_event(&c, &sim, tool).await;
        assert_eq!(e["kind"], "refused", "{tool}: the log must say what the client got: {e}");
        // With output_path the same call fits and is logged as read.
        let mut to_file = args.as_object().unwrap().clone();
        to_file.insert("output_path".into(), json!(if tool == "get_camera_image" { "shot.png" } else { "clip.gif" }));
        c.call(tool, Value::Object(to_file)).await;
        assert_eq!(last_event(&c, &sim, tool).await["kind"], "read");
    }
}

/// A sweep of `n` variants that observes no object: its reply is mostly the variants' hashes
/// (and, kept, their ids).
fn sweep(sim: &str, n: usize, keep: bool) -> Value {
    let variants: Vec<Value> = (0..n).map(|i| json!([{"tool": "set_object_velocity", "arguments": {"object_id": 1, "linear_velocity": [i as f64 * 0.01, 0, 0]}}])).collect();
    json!({"sim_id": sim, "variants": variants, "steps": 2, "observe": {"object_ids": []}, "keep": keep})
}

/// The bytes `tool`'s reply takes on the wire (as the server measures it, envelope aside).
fn reply_bytes(r: &rmcp::model::CallToolResult) -> usize {
    serde_json::to_vec(r).unwrap().len()
}

/// A simulation with a floor and one box.
async fn scene(c: &Client) -> String {
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    sim
}

#[tokio::test(flavor = "multi_thread")]
async fn a_kept_sweep_is_measured_with_the_ids_it_keeps() {
    const N: usize = 120;
    // First, with room to spare: how big the replies are with and without the kept ids.
    let (unkept, kept) = {
        let dir = tempfile::tempdir().unwrap();
        let server = Server::start(dir.path(), &["--max-sims", "400"]);
        let c = server.client().await;
        let sim = scene(&c).await;
        let unkept = reply_bytes(&c.raw("run_sweep", sweep(&sim, N, false)).await);
        let kept = reply_bytes(&c.raw("run_sweep", sweep(&sim, N, true)).await);
        (unkept, kept)
    };
    let budget = (unkept + kept) / 2;
    assert!(kept > unkept + 2000 && budget >= 16384, "unkept {unkept}, kept {kept}: choose another N");
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-reply-bytes", &budget.to_string(), "--max-sims", "400"]);
    let c = server.client().await;
    let sim = scene(&c).await;
    let r = c.raw("run_sweep", sweep(&sim, N, false)).await;
    assert_ne!(r.is_error, Some(true), "without keep the reply fits {budget} bytes: {r:?}");
    let r = c.raw("run_sweep", sweep(&sim, N, true)).await;
    assert_eq!(r.is_error, Some(true), "a kept sweep's ids must count ({budget} bytes)");
    let listed = c.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"].as_array().unwrap().len(), 1, "a refused sweep keeps nothing: {listed}");
    assert_eq!(last_event(&c, &sim, "run_sweep").await["kind"], "refused");
}
