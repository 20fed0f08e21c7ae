//! Robots in saved files. The old server documented a URDF object's
//! file as `urdf_path` but its code wrote `file_path`; our files carry both, load either, and
//! files written before `urdf_path` was added keep loading. Old-server files (no `history`)
//! with robots load as the old server loaded them: the URDF read from the workspace (sandboxed
//! like load_urdf, built-in assets included) at the saved base pose, stored in the new log.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// A server whose workspace holds the fixtures, a client of it, and the folder they live in.
async fn start() -> (tempfile::TempDir, Server, Client) {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    (dir, server, c)
}

async fn count(c: &Client) -> usize {
    c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len()
}

/// A JSON file the server wrote.
fn read_json(path: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn sqlite_files(server: &Server) -> usize {
    std::fs::read_dir(&server.data)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "sqlite"))
        .count()
}

/// An old-server file: a plane (built-in), the arm under `key` = `path`, a box, and a fixed
/// constraint between the box and the arm. Object ids have gaps, as PyBullet's can.
fn old_file(key: &str, path: &str) -> Value {
    json!({
        "gravity": [0, 0, -9.81],
        "timestep": 0.004166666666666667,
        "objects": [
            {"object_id": 0, "type": "urdf", "urdf_path": "plane.urdf",
             "position": [0, 0, 0], "orientation": [0, 0, 0, 1],
             "linear_velocity": [0, 0, 0], "angular_velocity": [0, 0, 0]},
            {"object_id": 4, "type": "urdf", key: path,
             "position": [0.5, -0.2, 0.01], "orientation": [0, 0, 0.5, 0.8660254],
             "linear_velocity": [0, 0, 0], "angular_velocity": [0, 0, 0]},
            {"object_id": 9, "type": "primitive", "shape": "box", "dimensions": [0.1, 0.2, 0.3], "mass": 2,
             "color": [1, 0, 0, 1], "position": [1, 1, 0.5], "orientation": [0, 0, 0, 1],
             "linear_velocity": [0.2, 0, 0], "angular_velocity": [0, 0, 0.5]}
        ],
        "constraints": [
            {"constraint_id": 0, "parent_id": 9, "child_id": 4, "joint_type": "fixed",
             "joint_axis": [0, 0, 1], "parent_frame_position": [0, 0, 0], "child_frame_position": [0, 0, 0.5],
             "parent_frame_orientation": [0, 0, 0, 1], "child_frame_orientation": [0, 0, 0, 1]}
        ]
    })
}

fn close(a: &Value, b: &[f64]) -> bool {
    a.as_array().unwrap().iter().zip(b).all(|(x, y)| (x.as_f64().unwrap() - y).abs() < 1e-6)
}

#[tokio::test(flavor = "multi_thread")]
async fn old_server_files_with_robots_load_from_urdf_path_file_path_or_an_absolute_path() {
    let (_dir, server, c) = start().await;
    let ws = server.workspace.clone();
    let absolute = ws.join("iiwa14.urdf").display().to_string();
    let mut loaded = Vec::new();
    for (name, key, path) in [
        ("by_urdf_path.json", "urdf_path", "iiwa14.urdf"),
        ("by_file_path.json", "file_path", "iiwa14.urdf"),
        ("absolute.json", "urdf_path", absolute.as_str()),
    ] {
        std::fs::write(ws.join(name), serde_json::to_vec(&old_file(key, path)).unwrap()).unwrap();
        let n = count(&c).await;
        let r = c.try_call("load_simulation", json!({"file_path": name})).await;
        let s = r.unwrap_or_else(|e| panic!("{name}: {e}"))["simulation_id"].as_str().unwrap().to_string();
        assert_eq!(count(&c).await, n + 1, "{name}");
        let info = c.call("get_simulation_info", json!({"sim_id": s})).await;
        let kinds: Vec<&str> = info["objects"].as_array().unwrap().iter().map(|o| o["type"].as_str().unwrap()).collect();
        assert_eq!(kinds, ["urdf", "urdf", "primitive"], "{name}");
        assert_eq!(c.call("get_num_joints", json!({"sim_id": s, "object_id": 1})).await["num_joints"], 8, "{name}");
        assert_eq!(c.call("get_num_joints", json!({"sim_id": s, "object_id": 0})).await["num_joints"], 0, "{name}");
        let plane = c.state(&s, 0).await;
        assert!(close(&plane["position"], &[0.0, 0.0, 0.0]), "{name}: {plane}");
        assert_eq!(c.call("get_dynamics_info", json!({"sim_id": s, "object_id": 0})).await["body_type"], "static");
        let arm = c.state(&s, 1).await;
        assert!(close(&arm["position"], &[0.5, -0.2, 0.01]), "{name}: {arm}");
        assert!(close(&arm["orientation"], &[0.0, 0.0, 0.5, 0.8660254]), "{name}: {arm}");
        let boxed = c.state(&s, 2).await;
        assert_eq!(boxed["position"], json!([1.0, 1.0, 0.5]), "{name}");
        assert_eq!(boxed["linear_velocity"], json!([0.2, 0.0, 0.0]), "{name}");
        assert_eq!(boxed["angular_velocity"], json!([0.0, 0.0, 0.5]), "{name}");
        assert_eq!(info["objects"][2]["dimensions"], json!([0.1, 0.2, 0.3]), "{name}");
        assert_eq!(info["objects"][2]["mass"], json!(2.0), "{name}");
        // The constraint's old ids (9, 4) name the re-created box and arm (2, 1).
        assert_eq!(info["constraints"][0]["parent_id"], 2, "{name}");
        assert_eq!(info["constraints"][0]["child_id"], 1, "{name}");
        // The robots are ordinary load_urdf events of the new log.
        let h = c.call("get_history", json!({"sim_id": s, "limit": 100})).await;
        let urdfs = h["events"].as_array().unwrap().iter().filter(|e| e["tool"] == "load_urdf").count();
        assert_eq!(urdfs, 2, "{name}");
        loaded.push(s);
    }
    // The URDF travels in the log as a blob: the simulations verify without the file.
    std::fs::remove_file(ws.join("iiwa14.urdf")).unwrap();
    for s in &loaded {
        assert_eq!(c.call("verify_simulation", json!({"sim_id": s})).await["ok"], true);
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn old_server_files_naming_a_urdf_outside_the_workspace_are_refused_and_create_nothing() {
    let (dir, server, c) = start().await;
    let ws = server.workspace.clone();
    let outside = dir.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::copy(ws.join("iiwa14.urdf"), outside.join("iiwa14.urdf")).unwrap();
    let absolute = outside.join("iiwa14.urdf").display().to_string();
    let cases = [
        ("relative_escape.json", old_file("urdf_path", "../outside/iiwa14.urdf"), "Access denied"),
        ("absolute_escape.json", old_file("file_path", &absolute), "Access denied"),
        ("missing.json", old_file("urdf_path", "nowhere.urdf"), "does not exist"),
    ];
    let mut both = old_file("urdf_path", "iiwa14.urdf");
    both["objects"][1]["file_path"] = json!("plane.urdf");
    let n = count(&c).await;
    let logs = sqlite_files(&server);
    for (name, file, expected) in cases.into_iter().chain([("both.json", both, "different files")]) {
        std::fs::write(ws.join(name), serde_json::to_vec(&file).unwrap()).unwrap();
        let e = c.try_call("load_simulation", json!({"file_path": name})).await.unwrap_err();
        assert!(e.contains(expected) && e.contains("objects[1]"), "{name}: {e}");
        assert_eq!(count(&c).await, n, "{name} created a simulation");
        assert_eq!(sqlite_files(&server), logs, "{name} left a log behind");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn saved_robots_carry_both_path_keys_and_files_without_urdf_path_still_load() {
    let (_dir, server, c) = start().await;
    let ws = server.workspace.clone();
    let s = c.new_sim(json!({})).await;
    c.call("load_urdf", json!({"sim_id": s, "file_path": "plane.urdf"})).await;
    let arm = json!({"sim_id": s, "file_path": "iiwa14.urdf", "position": [0, 0, 0.01], "use_fixed_base": true});
    c.call("load_urdf", arm).await;
    c.call("add_box", json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [0.6, 0, 0.5]})).await;
    c.call("set_joint_motor_control", json!({"sim_id": s, "object_id": 1, "joint_index": 1, "control_mode": "POSITION_CONTROL", "target_position": 0.5})).await;
    c.step(&s, 60).await;
    let saved = c.call("save_simulation", json!({"sim_id": s, "file_path": "robot.json"})).await;
    let mut file = read_json(&ws.join("robot.json"));
    let robot = &file["objects"][1];
    assert_eq!((&robot["type"], &robot["urdf_path"], &robot["file_path"]), (&json!("urdf"), &json!("iiwa14.urdf"), &json!("iiwa14.urdf")));
    assert_eq!(file["objects"][0]["urdf_path"], "plane.urdf");
    let round = c.call("load_simulation", json!({"file_path": "robot.json"})).await;
    assert_eq!(round["state_hash"], saved["state_hash"], "save → load of a robot");

    // A file saved before `urdf_path` existed (only `file_path`) still loads, exactly.
    for o in file["objects"].as_array_mut().unwrap() {
        o.as_object_mut().unwrap().remove("urdf_path");
    }
    std::fs::write(ws.join("before.json"), serde_json::to_vec(&file).unwrap()).unwrap();
    let before = c.try_call("load_simulation", json!({"file_path": "before.json"})).await;
    assert_eq!(before.unwrap_or_else(|e| panic!("a file without urdf_path: {e}"))["state_hash"], saved["state_hash"]);

    // Without its history the same file loads as the old server's would: robots at their
    // saved base poses (fixed base kept), joints free at zero.
    file.as_object_mut().unwrap().remove("history");
    std::fs::write(ws.join("readable.json"), serde_json::to_vec(&file).unwrap()).unwrap();
    let r = c.call("load_simulation", json!({"file_path": "readable.json"})).await;
    let rid = r["simulation_id"].as_str().unwrap();
    assert_eq!(c.state(rid, 1).await["position"], file["objects"][1]["position"]);
    assert_eq!(c.state(rid, 2).await["position"], file["objects"][2]["position"]);
    assert_eq!(c.call("get_num_joints", json!({"sim_id": rid, "object_id": 1})).await["num_joints"], 8);
    assert_eq!(c.call("get_dynamics_info", json!({"sim_id": rid, "object_id": 1})).await["body_type"], "static");
}
