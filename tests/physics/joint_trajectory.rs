//! set_joint_trajectory over MCP/HTTP: a KUKA iiwa moved through five IK poses in one call
//! passes each pose (its forward kinematics, read off a second simulation reset to the IK
//! solution) within 1 cm at its time and ends within 1 mm; the trajectory is state: a fork, an
//! undo/redo and a restart give identical hashes, and the log verifies; a motor call ends it;
//! bad input is refused with nothing changed.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

const ARM: &str = "kuka_iiwa/model.urdf";
const EE: u64 = 6;
const TARGETS: [[f64; 3]; 5] = [[0.5, 0.0, 0.6], [0.4, 0.3, 0.7], [0.2, 0.4, 0.9], [0.3, -0.3, 0.8], [0.5, -0.1, 0.5]];
const TIMES: [f64; 5] = [0.6, 1.2, 1.8, 2.4, 3.0];
/// Steps between waypoints at the default 1/240 s.
const STEPS: u64 = 144;

async fn arm(c: &Client, sim: &str) -> u64 {
    c.call("load_urdf", json!({"sim_id": sim, "file_path": ARM, "use_fixed_base": true})).await["object_id"].as_u64().unwrap()
}

async fn ee_position(c: &Client, sim: &str, id: u64) -> [f64; 3] {
    common::v3(&c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": EE})).await["link_world_position"])
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// calculate_inverse_kinematics ×5 (each from the last solution), and where each solution
/// puts the end effector (forward kinematics: a second simulation reset to it).
async fn poses(c: &Client, sim: &str, id: u64) -> (Vec<Value>, Vec<[f64; 3]>) {
    let fk_sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let fk = arm(c, &fk_sim).await;
    let (mut solutions, mut reached) = (Vec::new(), Vec::new());
    let mut rest = json!(vec![0.0; 7]);
    for target in TARGETS {
        let ik = c.call("calculate_inverse_kinematics", json!({"sim_id": sim, "object_id": id, "end_effector_link_index": EE,
            "target_position": target, "rest_poses": rest})).await;
        let q = ik["joint_positions"].clone();
        for (j, x) in q.as_array().unwrap().iter().enumerate() {
            c.call("reset_joint_state", json!({"sim_id": fk_sim, "object_id": fk, "joint_index": j, "target_value": x})).await;
        }
        reached.push(ee_position(c, &fk_sim, fk).await);
        rest = q.clone();
        solutions.push(q);
    }
    (solutions, reached)
}

fn trajectory_args(sim: &str, id: u64, positions: &[Value]) -> Value {
    json!({"sim_id": sim, "object_id": id, "joint_indices": [0, 1, 2, 3, 4, 5, 6], "times": TIMES, "positions": positions,
        "forces": vec![300.0; 7], "position_gains": vec![0.3; 7], "velocity_gains": vec![1.0; 7]})
}

#[tokio::test(flavor = "multi_thread")]
async fn an_arm_follows_five_ik_poses_in_one_call_and_replays_identically() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let id = arm(&c, &sim).await;
    let (positions, reached) = poses(&c, &sim, id).await;
    let before = c.hash(&sim).await;

    // Refused with nothing changed: times not increasing, a row of the wrong length, a fixed joint.
    let mut bad = trajectory_args(&sim, id, &positions);
    bad["times"] = json!([0.6, 0.6, 1.8, 2.4, 3.0]);
    assert!(c.try_call("set_joint_trajectory", bad).await.expect_err("equal times").contains("times"));
    let mut bad = trajectory_args(&sim, id, &positions);
    bad["positions"][2] = json!([0.1, 0.2]);
    assert!(c.try_call("set_joint_trajectory", bad).await.expect_err("short row").contains("positions[2]"));
    let mut bad = trajectory_args(&sim, id, &positions);
    bad["joint_indices"] = json!([0, 1, 2, 3, 4, 5, 40]);
    assert!(c.try_call("set_joint_trajectory", bad).await.expect_err("joint 40").contains("40"));
    assert_eq!(c.hash(&sim).await, before, "a refusal changes nothing");

    c.call("set_joint_trajectory", trajectory_args(&sim, id, &positions)).await;
    assert_ne!(c.hash(&sim).await, before, "a trajectory is hashed state");
    for (k, want) in reached.iter().enumerate() {
        c.step(&sim, STEPS).await;
        let got = ee_position(&c, &sim, id).await;
        assert!(dist(got, *want) < 0.01, "waypoint {k} at {} s: end effector at {got:?}, pose {want:?}", TIMES[k]);
        let state = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 2})).await;
        if k + 1 < TIMES.len() {
            assert_eq!(state["trajectory"]["next_waypoint"], json!(k + 1), "{state}");
            assert_eq!(state["trajectory"]["duration"], json!(3.0));
        } else {
            assert!(state.get("trajectory").is_none(), "the trajectory ends at its last waypoint: {state}");
        }
    }
    c.step(&sim, 240).await;
    let end = ee_position(&c, &sim, id).await;
    assert!(dist(end, reached[4]) < 1e-3, "the arm holds the last pose within 1 mm: {end:?} vs {:?}", reached[4]);
    let ended = c.hash(&sim).await;

    // The same trajectory from the same start, in a fork taken mid-way: identical hashes.
    c.call("undo", json!({"sim_id": sim, "count": 6})).await;
    let fork = c.call("fork_simulation", json!({"sim_id": sim})).await["simulation_id"].as_str().unwrap().to_string();
    let mid = c.hash(&sim).await;
    assert_eq!(c.hash(&fork).await, mid, "fork");
    c.call("redo", json!({"sim_id": sim, "count": 6})).await;
    assert_eq!(c.hash(&sim).await, ended, "undo/redo");
    for _ in 0..TIMES.len() {
        c.step(&fork, STEPS).await;
    }
    c.step(&fork, 240).await;
    assert_eq!(c.hash(&fork).await, ended, "the fork follows the same trajectory");

    // A motor call ends the joint's trajectory; the others follow on.
    c.call("undo", json!({"sim_id": fork, "count": 5})).await;
    c.call("set_joint_motor_control", json!({"sim_id": fork, "object_id": id, "joint_index": 0, "control_mode": "VELOCITY_CONTROL", "target_velocity": 0})).await;
    let j0 = c.call("get_joint_state", json!({"sim_id": fork, "object_id": id, "joint_index": 0})).await;
    let j1 = c.call("get_joint_state", json!({"sim_id": fork, "object_id": id, "joint_index": 1})).await;
    assert!(j0.get("trajectory").is_none() && j1["trajectory"].is_object(), "{j0} {j1}");

    // A restart serves the same state, and the log refolds to its recorded hashes.
    drop(c);
    server.terminate();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, ended, "restart");
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
}
