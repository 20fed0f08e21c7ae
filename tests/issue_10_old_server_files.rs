//! Issue #10 item 3: saved robots name their URDF both ways. The old server documented a URDF
//! object's file as `urdf_path` but its code wrote `file_path`; our files carry both, and files
//! written before `urdf_path` was added keep loading.

mod common;

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

/// A JSON file the server wrote.
#[allow(clippy::disallowed_methods)] // the test inspects saved files; the server's world never reads files
fn read_json(path: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
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
}
