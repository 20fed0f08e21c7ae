//! A foreign saved file is refolded through the same validation as a tool
//! call, so a hostile file cannot feed `World::apply` a timestep ≤ 0, a zero quaternion, a zero
//! joint axis or ±inf. Each bad value is refused in one sentence naming it, and nothing is
//! created.

use crate::common;

use common::Server;
use serde_json::{json, Value};

/// Rewrites the command of the first history event of `tool` with `edit`.
fn tamper(file: &Value, tool: &str, edit: impl Fn(&mut Value)) -> Value {
    let mut f = file.clone();
    let events = f["history"]["events"].as_array_mut().unwrap();
    let e = events.iter_mut().find(|e| e["tool"] == tool).unwrap_or_else(|| panic!("no {tool} in the file"));
    let mut cmd: Value = serde_json::from_str(e["command"].as_str().unwrap()).unwrap();
    edit(&mut cmd);
    e["command"] = json!(cmd.to_string());
    f
}

#[tokio::test(flavor = "multi_thread")]
async fn hostile_saved_files_are_refused_naming_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    c.call("set_timestep", json!({"sim_id": sim, "timestep": 0.01})).await;
    c.call("set_camera", json!({"sim_id": sim, "distance": 3, "yaw": 10, "pitch": -20, "target": [0, 0, 0]})).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": 1, "child_id": -1, "joint_type": "revolute",
        "joint_axis": [0, 1, 0], "child_frame_position": [0, 0, 1]})).await;
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": 1, "mass": 2})).await;
    c.step(&sim, 10).await;
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "good.json"})).await;
    let good: Value = serde_json::from_slice(&std::fs::read(server.workspace.join("good.json")).unwrap()).unwrap();
    // A file is foreign without our snapshot: the load refolds every event.
    let mut foreign = good.clone();
    foreign["history"]["snapshot"] = Value::Null;
    std::fs::write(server.workspace.join("foreign.json"), foreign.to_string()).unwrap();
    c.call("load_simulation", json!({"file_path": "foreign.json"})).await;

    let huge = json!(1e39); // finite in JSON, infinite as the engine's f32
    let cases: Vec<(&str, Value, &str)> = vec![
        ("zero timestep", tamper(&foreign, "set_timestep", |c| c["timestep"] = json!(0.0)), "timestep must be a finite number > 0"),
        ("negative timestep", tamper(&foreign, "set_timestep", |c| c["timestep_given"] = json!(-0.01)), "timestep must be a finite number > 0"),
        ("zero quaternion", tamper(&foreign, "add_box", |c| c["orientation"] = json!([0, 0, 0, 0])), "orientation must be a unit quaternion"),
        ("zero joint axis", tamper(&foreign, "create_constraint", |c| c["spec"]["joint_axis"] = json!([0, 0, 0])), "joint_axis must be a non-zero vector"),
        ("infinite position", tamper(&foreign, "add_box", |c| c["position"] = json!([huge, 0, 1])), "position must be finite numbers"),
        ("infinite gravity", tamper(&foreign, "create_simulation", |c| c["gravity"] = json!([0, 0, huge])), "gravity must be finite numbers"),
        ("zero dimension", tamper(&foreign, "add_box", |c| c["shape"]["box"]["half_extents"] = json!([0, 0.1, 0.1])), "dimensions must be a finite number > 0"),
        ("negative mass", tamper(&foreign, "change_dynamics", |c| c["change"]["mass"] = json!(-1)), "mass must be a finite number >= 0"),
        ("zero camera distance", tamper(&foreign, "set_camera", |c| c["distance"] = json!(0)), "distance must be a finite number > 0"),
        ("infinite camera yaw", tamper(&foreign, "set_camera", |c| c["yaw"] = huge.clone()), "yaw must be finite numbers"),
    ];
    let count = |c: &Value| c["simulations"].as_array().unwrap().len();
    let before = count(&c.call("list_simulations", json!({})).await);
    let files = || std::fs::read_dir(&server.data).unwrap().count();
    let files_before = files();
    for (what, file, says) in &cases {
        std::fs::write(server.workspace.join("bad.json"), file.to_string()).unwrap();
        let e = c.try_call("load_simulation", json!({"file_path": "bad.json"})).await.unwrap_err();
        assert!(e.contains(says), "{what}: {e}");
        assert!(!e.contains('\n') && e.len() < 400, "{what}: one sentence, got {e}");
        assert_eq!(count(&c.call("list_simulations", json!({})).await), before, "{what} created a simulation");
        assert_eq!(files(), files_before, "{what} left a file");
    }
}
