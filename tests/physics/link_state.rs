//! get_link_state and reset_joint_state over MCP/HTTP against pybullet 3.2.7's getLinkState
//! after resetJointState (tests/reference/pybullet_link_state.json, written by
//! scripts/link_state_fixtures.py), plus the event semantics: a reset is a change that undo
//! reverts, and bad input is refused naming the parameter with nothing changed.

use crate::common;

use std::path::Path;

use common::{Client, Server};
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/pybullet_link_state.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Largest difference between two quaternions up to sign.
fn quat_diff(a: &[f64], b: &[f64]) -> f64 {
    let d = |s: f64| a.iter().zip(b).map(|(x, y)| (x - s * y).abs()).fold(0.0, f64::max);
    d(1.0).min(d(-1.0))
}

fn vec_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

async fn link(c: &Client, sim: &str, id: u64, i: i64) -> Value {
    c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": i})).await
}

#[tokio::test(flavor = "multi_thread")]
async fn link_states_after_resets_equal_pybullet() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    for (file, robot) in r["robots"].as_object().unwrap() {
        let sim = c.new_sim(json!({})).await;
        let args = json!({"sim_id": sim, "file_path": file, "position": r["base_position"],
                          "orientation": r["base_orientation"], "use_fixed_base": true});
        let id = c.call("load_urdf", args).await["object_id"].as_u64().unwrap();
        for reset in robot["resets"].as_array().unwrap() {
            let a = json!({"sim_id": sim, "object_id": id, "joint_index": reset["joint_index"],
                           "target_value": reset["target_value"], "target_velocity": reset["target_velocity"]});
            c.call("reset_joint_state", a).await;
        }
        for j in robot["joints"].as_array().unwrap() {
            let s = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j["joint_index"]})).await;
            for k in ["joint_position", "joint_velocity"] {
                let (got, want) = (s[k].as_f64().unwrap(), j[k].as_f64().unwrap());
                assert!((got - want).abs() < 1e-6, "{file} joint {}: {k} {got} vs pybullet {want}", j["joint_index"]);
            }
        }
        for want in robot["links"].as_array().unwrap() {
            let got = link(&c, &sim, id, want["link_index"].as_i64().unwrap()).await;
            let at = format!("{file} link {}", want["link_index"]);
            for k in ["link_world_position", "com_world_position", "linear_velocity", "angular_velocity"] {
                let d = vec_diff(&floats(&got[k]), &floats(&want[k]));
                assert!(d < 2e-5, "{at}: {k} {} vs pybullet {} (off by {d})", got[k], want[k]);
            }
            for k in ["link_world_orientation", "com_world_orientation"] {
                let d = quat_diff(&floats(&got[k]), &floats(&want[k]));
                assert!(d < 2e-5, "{at}: {k} {} vs pybullet {} (off by {d})", got[k], want[k]);
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn reset_is_an_undoable_change_and_bad_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let arm = c.call("load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "use_fixed_base": true}))
        .await["object_id"].as_u64().unwrap();
    let box_id = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [2, 0, 1]}))
        .await["object_id"].as_u64().unwrap();
    let before = c.hash(&sim).await;
    let tip_before = link(&c, &sim, arm, 1).await;
    c.call("reset_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 0, "target_value": 0.5})).await;
    let q = c.call("get_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    assert_eq!(q["joint_position"].as_f64().unwrap(), 0.5);
    assert_eq!(q["joint_velocity"].as_f64().unwrap(), 0.0);
    assert_ne!(c.hash(&sim).await, before, "a reset changes the state");
    assert_ne!(link(&c, &sim, arm, 1).await["link_world_position"], tip_before["link_world_position"]);
    c.call("undo", json!({"sim_id": sim})).await;
    assert_eq!(c.hash(&sim).await, before, "undo reverts a reset");
    assert_eq!(link(&c, &sim, arm, 1).await, tip_before);
    // The base (-1) of a robot and a primitive's only link.
    let base = link(&c, &sim, arm, -1).await;
    assert_eq!(base["link_world_position"], json!([0.0, 0.0, 0.0]));
    let b = link(&c, &sim, box_id, -1).await;
    assert_eq!(b["link_world_position"], json!([2.0, 0.0, 1.0]));

    let s = sim.as_str();
    let rows = [
        ("reset_joint_state", json!({"sim_id": s, "object_id": arm, "joint_index": 9, "target_value": 0}), "out of range"),
        ("reset_joint_state", json!({"sim_id": s, "object_id": 99, "joint_index": 0, "target_value": 0}), "Object 99 not found"),
        ("reset_joint_state", json!({"sim_id": s, "object_id": arm, "joint_index": 0}), "target_value"),
        ("reset_joint_state", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "target_value": "x"}), "target_value"),
        ("reset_joint_state", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "target_value": 0, "target_velocity": [1]}), "target_velocity"),
        ("reset_joint_state", json!({"sim_id": s, "object_id": box_id, "joint_index": 0, "target_value": 0}), "out of range"),
        ("get_link_state", json!({"sim_id": s, "object_id": arm, "link_index": 2}), "link_index"),
        ("get_link_state", json!({"sim_id": s, "object_id": arm, "link_index": -2}), "link_index"),
        ("get_link_state", json!({"sim_id": s, "object_id": arm}), "link_index"),
        ("get_link_state", json!({"sim_id": s, "object_id": 99, "link_index": 0}), "Object 99 not found"),
    ];
    for (tool, args, needle) in rows {
        let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} must be refused"));
        assert!(err.contains(needle), "{tool} {args}: {err}");
    }
    assert_eq!(c.hash(&sim).await, before, "refusals change nothing");
}
