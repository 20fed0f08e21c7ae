//! save_simulation / load_simulation end to end: exact round trips (from the MAC'd snapshot
//! and by refold), old-server files, the workspace sandbox, and hostile or corrupt files —
//! each refused clearly, creating nothing.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

async fn scene(c: &Client) -> String {
    let s = c.new_sim(json!({})).await;
    c.ground(&s).await;
    c.call("add_box", json!({"sim_id": s, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1], "color": [1, 0, 0]})).await;
    c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [0.3, 0, 2]})).await;
    c.step(&s, 120).await;
    c.call("undo", json!({"sim_id": s})).await;
    c.call("apply_force", json!({"sim_id": s, "object_id": 2, "force": [30, 0, 0]})).await;
    c.step(&s, 90).await;
    s
}

async fn count(c: &Client) -> usize {
    c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len()
}

#[tokio::test(flavor = "multi_thread")]
async fn save_then_load_is_exact_and_evolves_alike() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let s = scene(&c).await;
    let saved = c.call("save_simulation", json!({"sim_id": s, "file_path": "saves/one.json"})).await;
    assert_eq!(saved["state_hash"], json!(c.hash(&s).await));
    let loaded = c.call("load_simulation", json!({"file_path": "saves/one.json"})).await;
    let l = loaded["simulation_id"].as_str().unwrap().to_string();
    assert_ne!(l, s);
    assert_eq!(loaded["state_hash"], saved["state_hash"]);
    for sim in [&s, &l] {
        c.call("apply_torque", json!({"sim_id": sim, "object_id": 1, "torque": [0, 0, 1]})).await;
        c.step(sim, 200).await;
    }
    assert_eq!(c.hash(&s).await, c.hash(&l).await, "the loaded simulation diverged");
    assert_eq!(c.state(&s, 2).await, c.state(&l, 2).await);
    // Its log inherits the chain and the loaded simulation verifies and survives restarts.
    let h = c.call("get_history", json!({"sim_id": l, "limit": 1000})).await;
    assert!(h["events"][0]["inherited"].as_bool().unwrap());
    assert_eq!(c.call("verify_simulation", json!({"sim_id": l})).await["ok"], true);
    let lh = c.hash(&l).await;
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&l).await, lh);

    // Without our MAC the snapshot is not trusted: the events are refolded, same result.
    let ws = server.workspace.clone();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp"))
        .args(["replay", ws.join("saves/one.json").to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["summary"]["final_hash"], saved["state_hash"], "replay of the saved file");
    let mut file: Value = serde_json::from_slice(&std::fs::read(ws.join("saves/one.json")).unwrap()).unwrap();
    file["history"]["snapshot"]["mac"] = json!("0".repeat(64));
    std::fs::write(ws.join("saves/foreign.json"), serde_json::to_vec(&file).unwrap()).unwrap();
    let again = c.call("load_simulation", json!({"file_path": "saves/foreign.json"})).await;
    assert_eq!(again["state_hash"], saved["state_hash"]);
    // Without history: the readable fields alone, objects at their saved poses.
    file.as_object_mut().unwrap().remove("history");
    std::fs::write(ws.join("saves/readable.json"), serde_json::to_vec(&file).unwrap()).unwrap();
    let r = c.call("load_simulation", json!({"file_path": "saves/readable.json"})).await;
    let rid = r["simulation_id"].as_str().unwrap();
    assert_eq!(c.state(rid, 2).await["position"], file["objects"][2]["position"]);
    assert_eq!(c.state(rid, 2).await["linear_velocity"], file["objects"][2]["linear_velocity"]);
}

#[tokio::test(flavor = "multi_thread")]
async fn an_old_server_file_loads_approximately() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let old = json!({
        "gravity": [0, 0, -9.81],
        "timestep": 0.004166666666666667,
        "objects": [
            {"object_id": 0, "type": "primitive", "shape": "box", "dimensions": [5, 5, 0.5], "mass": 0,
             "color": null, "position": [0, 0, -0.5], "orientation": [0, 0, 0, 1],
             "linear_velocity": [0, 0, 0], "angular_velocity": [0, 0, 0]},
            {"object_id": 3, "type": "primitive", "shape": "sphere", "dimensions": [0.25], "mass": 2,
             "color": [0, 1, 0, 1], "position": [1, 2, 3], "orientation": [0, 0, 0, 1],
             "linear_velocity": [0.5, 0, 0], "angular_velocity": [0, 0, 1]}
        ],
        "constraints": []
    });
    std::fs::create_dir_all(&server.workspace).unwrap();
    std::fs::write(server.workspace.join("old.json"), serde_json::to_vec(&old).unwrap()).unwrap();
    let r = c.call("load_simulation", json!({"file_path": "old.json"})).await;
    let s = r["simulation_id"].as_str().unwrap();
    let st = c.state(s, 1).await;
    assert_eq!(st["position"], json!([1.0, 2.0, 3.0]));
    assert_eq!(st["linear_velocity"], json!([0.5, 0.0, 0.0]));
    let info = c.call("get_dynamics_info", json!({"sim_id": s, "object_id": 1})).await;
    assert_eq!(info["mass"], json!(2.0));
    assert_eq!(c.call("get_dynamics_info", json!({"sim_id": s, "object_id": 0})).await["body_type"], "static");
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_paths_and_bad_files_are_refused_and_create_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-steps", "1000"]);
    let c = server.client().await;
    let s = scene(&c).await;
    c.call("save_simulation", json!({"sim_id": s, "file_path": "good.json"})).await;
    let ws = server.workspace.clone();
    let good: Value = serde_json::from_slice(&std::fs::read(ws.join("good.json")).unwrap()).unwrap();
    let outside = dir.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::os::unix::fs::symlink(&outside, ws.join("escape")).unwrap();
    let evil = format!("{}_evil", ws.display());
    std::fs::create_dir_all(&evil).unwrap();
    let hash = c.hash(&s).await;
    let n = count(&c).await;
    for path in ["../x.json", "/tmp/x.json", "escape/x.json", &format!("{evil}/x.json"), "../data/x.json", ""] {
        let e = c.try_call("save_simulation", json!({"sim_id": s, "file_path": path})).await.unwrap_err();
        assert!(e.contains("Access denied") || e.contains("non-empty"), "{path}: {e}");
        assert_eq!(c.hash(&s).await, hash);
    }
    assert!(!outside.join("x.json").exists());

    let write = |name: &str, bytes: Vec<u8>| std::fs::write(ws.join(name), bytes).unwrap();
    write("garbage.json", b"{not json".to_vec());
    let full = serde_json::to_vec(&good).unwrap();
    write("truncated.json", full[..full.len() / 2].to_vec());
    let mut t = good.clone();
    let last = t["history"]["events"].as_array().unwrap().len() - 1;
    t["history"]["events"][last]["state_hash"] = json!("0".repeat(64));
    write("tampered.json", serde_json::to_vec(&t).unwrap());
    let mut g = good.clone();
    g["gravity"] = json!([0, 0, -1]);
    write("disagree.json", serde_json::to_vec(&g).unwrap());
    let mut h = good.clone();
    h["history"]["snapshot"]["bytes"] = json!("AAAA");
    h["history"]["snapshot"]["mac"] = json!("00");
    let steps = h["history"]["events"].as_array().unwrap().iter().position(|e| e["tool"] == "step_simulation").unwrap();
    let mut cmd: Value = serde_json::from_str(h["history"]["events"][steps]["command"].as_str().unwrap()).unwrap();
    cmd["steps"] = json!(100_000_000u64);
    h["history"]["events"][steps]["command"] = json!(cmd.to_string());
    write("hostile.json", serde_json::to_vec(&h).unwrap());
    let cases = [
        ("missing.json", "does not exist"),
        ("../good.json", "Access denied"),
        ("garbage.json", "not a valid saved simulation"),
        ("truncated.json", "not a valid saved simulation"),
        ("tampered.json", "state hash diverges"),
        ("disagree.json", "readable fields disagree with its history: gravity"),
        ("hostile.json", "--max-steps"),
    ];
    for (file, expected) in cases {
        let e = c.try_call("load_simulation", json!({"file_path": file})).await.unwrap_err();
        assert!(e.contains(expected), "{file}: {e}");
        assert_eq!(count(&c).await, n, "{file} created a simulation");
    }
    let data_files = std::fs::read_dir(&server.data).unwrap().filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "sqlite")).count();
    assert_eq!(data_files, n, "a failed load left a log behind");
}
