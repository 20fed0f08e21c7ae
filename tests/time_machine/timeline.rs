//! Undo, redo, history, fork and verify over real MCP/HTTP, including refusals and restarts.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

async fn scene(c: &Client) -> (String, Vec<String>) {
    let sim = c.new_sim(json!({})).await;
    let mut hashes = vec![c.hash(&sim).await];
    let calls = [
        ("add_box", json!({"dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})),
        ("add_box", json!({"dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]})),
        ("step_simulation", json!({"steps": 100})),
        ("add_sphere", json!({"radius": 0.2, "position": [0, 0, 2]})),
        ("step_simulation", json!({"steps": 50})),
    ];
    for (tool, mut a) in calls {
        a["sim_id"] = json!(sim);
        c.call(tool, a).await;
        c.state(&sim, 0).await; // reads between changes must be skipped by undo
        hashes.push(c.hash(&sim).await);
    }
    (sim, hashes)
}

#[tokio::test(flavor = "multi_thread")]
async fn undo_and_redo_move_along_the_chain_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (sim, h) = scene(&c).await;
    let before = c.state(&sim, 1).await;

    let u = c.call("undo", json!({"sim_id": sim})).await;
    assert_eq!(u["undone"][0]["tool"], "step_simulation");
    assert_eq!(c.hash(&sim).await, h[4]);
    let u = c.call("undo", json!({"sim_id": sim, "count": 2})).await;
    assert_eq!(u["undone"].as_array().unwrap().len(), 2);
    assert_eq!(u["state_hash"], json!(h[2]));
    assert_eq!(c.hash(&sim).await, h[2]);
    assert_eq!(u["current_time"], json!(0.0));

    // Too far: refused, nothing moves.
    let e = c.try_call("undo", json!({"sim_id": sim, "count": 3})).await.unwrap_err();
    assert!(e.contains("count must be from 1 to 2"), "{e}");
    assert_eq!(c.hash(&sim).await, h[2]);

    let r = c.call("redo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(r["redone"].as_array().unwrap().len(), 3);
    assert_eq!(c.hash(&sim).await, h[5], "undo 3 + redo 3 must give the same hash");
    assert_eq!(c.state(&sim, 1).await, before);
    let e = c.try_call("redo", json!({"sim_id": sim})).await.unwrap_err();
    assert!(e.contains("count must be from 1 to 0"), "{e}");

    // Undo rewinds the id counter; a new call starts a branch and leaves nothing to redo.
    c.call("undo", json!({"sim_id": sim, "count": 2})).await;
    let added = c.call("add_capsule", json!({"sim_id": sim, "radius": 0.1, "height": 0.2, "position": [1, 1, 1]})).await;
    assert_eq!(added["object_id"], 2, "the id of the undone sphere is given again");
    assert!(c.try_call("redo", json!({"sim_id": sim})).await.is_err());

    // The head, the branch and the redo stack survive a kill -9.
    let h_now = c.hash(&sim).await;
    c.call("undo", json!({"sim_id": sim})).await;
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, h[3]);
    c.call("redo", json!({"sim_id": sim})).await;
    assert_eq!(c.hash(&sim).await, h_now);
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    assert_eq!(v["first_divergence"], Value::Null);
    assert!(v["events_checked"].as_u64().unwrap() >= 4);
}

#[tokio::test(flavor = "multi_thread")]
async fn history_lists_every_call_in_pages() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (sim, _) = scene(&c).await;
    let _ = c.try_call("add_box", json!({"sim_id": sim, "dimensions": [1, 1], "position": [0, 0, 0]})).await;
    c.call("undo", json!({"sim_id": sim})).await;
    let page = c.call("get_history", json!({"sim_id": sim, "limit": 1000})).await;
    let events = page["events"].as_array().unwrap();
    let kinds: Vec<&str> = events.iter().map(|e| e["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds[0], "root");
    assert!(kinds.contains(&"change") && kinds.contains(&"read") && kinds.contains(&"refused") && kinds.contains(&"move"));
    let seqs: Vec<u64> = events.iter().map(|e| e["seq"].as_u64().unwrap()).collect();
    assert!(seqs.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(page["last_seq"].as_u64().unwrap(), *seqs.last().unwrap(), "own call excluded");
    let refused = events.iter().find(|e| e["kind"] == "refused").unwrap();
    assert!(refused["summary"].as_str().unwrap().contains("dimensions"));
    assert_eq!(refused["ok"], false);
    assert_eq!(refused["arguments"]["dimensions"], json!([1, 1]));
    // Changes point at the head they were applied on.
    let changes: Vec<&Value> = events.iter().filter(|e| e["kind"] == "change").collect();
    assert_eq!(changes[0]["parent"], events[0]["seq"]);
    assert_eq!(changes[1]["parent"], changes[0]["seq"]);
    // Paging.
    let p1 = c.call("get_history", json!({"sim_id": sim, "since_seq": 2, "limit": 3})).await;
    let s1: Vec<u64> = p1["events"].as_array().unwrap().iter().map(|e| e["seq"].as_u64().unwrap()).collect();
    assert_eq!(s1, vec![3, 4, 5]);
    let e = c.try_call("get_history", json!({"sim_id": sim, "limit": 0})).await.unwrap_err();
    assert!(e.contains("limit"), "{e}");
}

/// get_history answers compactly by default — hashes by their first 12 hex, arguments without
/// the sim's own id, results as JSON (not JSON in strings), what each read returned in one
/// line — and as recorded with `detail: "full"`.
#[tokio::test(flavor = "multi_thread")]
async fn history_is_compact_by_default_and_full_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let calls = [
        ("add_box", json!({"dimensions": [5, 5, 0.5], "position": [0, 0, -0.25], "mass": 0})),
        ("add_box", json!({"dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]})),
        ("step_simulation", json!({"steps": 100})),
        ("get_object_state", json!({"object_id": 1})),
        ("add_sphere", json!({"radius": 0.2, "position": [0, 0, 2]})),
        ("step_simulation", json!({"steps": 50})),
        ("get_all_collisions", json!({})),
        ("undo", json!({})),
        ("add_box", json!({"dimensions": [1, 1], "position": [0, 0, 0]})),
    ];
    for (tool, mut a) in calls {
        a["sim_id"] = json!(sim);
        let _ = c.try_call(tool, a).await;
    }
    let hash = c.hash(&sim).await;
    let compact = c.raw("get_history", json!({"sim_id": sim, "since_seq": 0, "limit": 10})).await;
    let full = c.raw("get_history", json!({"sim_id": sim, "limit": 10, "detail": "full"})).await;
    let wire = |r: &rmcp::model::CallToolResult| serde_json::to_string(r).unwrap().len();
    let (small, big) = (wire(&compact), wire(&full));
    // Measured: 5.8 KB by default (72%), 8.1 KB full, and about as much before, when summaries
    // were JSON text. Results that grow add to both alike, so the bound leaves some room.
    eprintln!("10-event history on the wire: {small} B by default, {big} B with detail full");
    assert!(small * 5 < big * 4 && small < 6_500, "the default ({small} B) is not under 80% of the full answer ({big} B)");

    let page = compact.structured_content.unwrap();
    let events = page["events"].as_array().unwrap();
    assert_eq!(events.len(), 10);
    for e in events {
        assert_eq!(e["state_hash"].as_str().unwrap().len(), 12, "{e}");
        assert!(e["arguments"].get("sim_id").is_none(), "{e}");
    }
    let by_seq = |seq: usize| &events[seq - 1];
    assert_eq!(by_seq(3)["summary"]["object_id"], 1, "a change's result as an object: {}", by_seq(3));
    assert!(by_seq(4)["summary"].get("simulation_id").is_none(), "{}", by_seq(4));
    assert_eq!(by_seq(3)["arguments"], json!({"dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]}));
    assert_eq!(by_seq(1)["summary"]["simulation_id"], sim.as_str(), "a root keeps the id it made");
    let read = by_seq(5)["summary"].as_str().unwrap();
    assert!(read.contains(" position=[") && read.contains("linear_velocity=[") && read.chars().count() <= 160, "{read}");
    assert_eq!(by_seq(9)["summary"]["undone"][0]["tool"], "step_simulation", "{}", by_seq(9));
    assert_eq!(by_seq(9)["summary"]["state_hash"], json!(&hash[..12]));
    assert!(by_seq(10)["summary"].as_str().unwrap().starts_with("refused: "), "{}", by_seq(10));
    assert_eq!(by_seq(9)["state_hash"], json!(&hash[..12]));

    // Full: every hash whole, the arguments as recorded; summaries still structured.
    let page = full.structured_content.unwrap();
    let events = page["events"].as_array().unwrap();
    for e in events {
        assert_eq!(e["state_hash"].as_str().unwrap().len(), 64, "{e}");
        assert!(e["kind"] == "root" || e["arguments"]["sim_id"] == sim.as_str(), "{e}");
    }
    assert_eq!(events[8]["state_hash"], json!(hash));
    assert_eq!(events[8]["summary"]["state_hash"], json!(hash));
    assert_eq!(events[3]["summary"]["simulation_id"], sim.as_str());
    assert_eq!(events[4]["summary"], json!(read), "a read's summary is its line either way");

    // An unknown detail is refused, naming it.
    let e = c.try_call("get_history", json!({"sim_id": sim, "detail": "everything"})).await.unwrap_err();
    assert!(e.contains("detail") && e.contains("full"), "{e}");
}

/// A batch's reads record what they returned too, as the same reads alone do.
#[tokio::test(flavor = "multi_thread")]
async fn a_batch_read_shows_what_it_returned() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let calls = json!([
        {"tool": "add_box", "arguments": {"dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]}},
        {"tool": "get_object_state", "arguments": {"object_id": 0}},
    ]);
    c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    c.state(&sim, 0).await;
    let events = c.call("get_history", json!({"sim_id": sim, "since_seq": 1})).await["events"].as_array().unwrap().clone();
    let lines: Vec<&str> = events.iter().filter(|e| e["tool"] == "get_object_state").map(|e| e["summary"].as_str().unwrap()).collect();
    assert_eq!(lines.len(), 2);
    assert!(lines[0].contains("position=[0,0,1]"), "{lines:?}");
    assert_eq!(lines[0], lines[1], "the same read says the same in a batch and alone");
}

#[tokio::test(flavor = "multi_thread")]
async fn forks_inherit_history_and_evolve_alike() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sims", "4"]);
    let c = server.client().await;
    let (sim, h) = scene(&c).await;
    let f = c.call("fork_simulation", json!({"sim_id": sim})).await;
    let fork = f["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(f["state_hash"], json!(h[5]));
    for s in [&sim, &fork] {
        c.call("apply_force", json!({"sim_id": s, "object_id": 1, "force": [10, 0, 40]})).await;
        c.step(s, 120).await;
    }
    assert_eq!(c.hash(&sim).await, c.hash(&fork).await, "fork diverged from its parent");
    assert_eq!(c.state(&sim, 2).await, c.state(&fork, 2).await);

    // Fork at an earlier event: the state recorded there.
    let hist = c.call("get_history", json!({"sim_id": sim, "limit": 1000, "detail": "full"})).await;
    let third_change = hist["events"].as_array().unwrap().iter().filter(|e| e["kind"] == "change").nth(2).unwrap().clone();
    let early = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": third_change["seq"]})).await;
    assert_eq!(early["state_hash"], third_change["state_hash"]);
    let early_id = early["simulation_id"].as_str().unwrap().to_string();
    let eh = c.call("get_history", json!({"sim_id": early_id, "limit": 1000})).await;
    let ev = eh["events"].as_array().unwrap();
    assert!(ev[..ev.len() - 1].iter().all(|e| e["inherited"] == true));
    assert_eq!(ev.last().unwrap()["kind"], "root");
    // Undo never goes past the fork's own root.
    assert!(c.try_call("undo", json!({"sim_id": early_id})).await.is_err());

    // Refusals: a read's seq, an unknown sim, the simulation limit.
    let read_seq = hist["events"].as_array().unwrap().iter().find(|e| e["kind"] == "read").unwrap()["seq"].clone();
    let e = c.try_call("fork_simulation", json!({"sim_id": sim, "at_seq": read_seq})).await.unwrap_err();
    assert!(e.contains("not a state-changing event"), "{e}");
    assert!(c.try_call("fork_simulation", json!({"sim_id": "nope"})).await.unwrap_err().contains("Simulation nope not found"));
    c.call("fork_simulation", json!({"sim_id": sim})).await; // 4th
    let e = c.try_call("fork_simulation", json!({"sim_id": sim})).await.unwrap_err();
    assert!(e.contains("--max-sims"), "{e}");
    let n = c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len();
    assert_eq!(n, 4);

    // Forks survive restarts and verify.
    let fh = c.hash(&fork).await;
    server.kill();
    let server = Server::start(dir.path(), &["--max-sims", "4"]);
    let c = server.client().await;
    assert_eq!(c.hash(&fork).await, fh);
    let v = c.call("verify_simulation", json!({"sim_id": early_id})).await;
    assert_eq!(v["ok"], true, "{v}");
}
