//! The robot calls PyBullet scripts lean on, over MCP/HTTP against pybullet 3.2.7
//! (tests/reference/pybullet_robot_dynamics.json, written by scripts/robot_dynamics_fixtures.py):
//! the joint reaction wrench of a KUKA iiwa holding a pose under gravity with its force/torque
//! sensors on, and the sensor switch as a recorded, undoable change refused on bad input.

use crate::common;

use std::path::Path;

use common::{Client, Server};
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/pybullet_robot_dynamics.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().unwrap()).collect()
}

async fn load(c: &Client, sim: &str, file: &str) -> u64 {
    let args = json!({"sim_id": sim, "file_path": file, "use_fixed_base": true});
    c.call("load_urdf", args).await["object_id"].as_u64().unwrap()
}

async fn joint(c: &Client, sim: &str, id: u64, j: u64) -> Value {
    c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await
}

/// The KUKA held by position motors at a bent pose: with every sensor on, each joint's
/// reaction wrench is PyBullet's within 5% of the largest force (forces) and of the largest
/// moment (moments); the whole arm's static equilibrium holds within 1e-3: the base joint
/// carries the arm's weight, and each joint's moment about its axis is its motor's torque.
#[tokio::test(flavor = "multi_thread")]
async fn reaction_wrench_of_a_kuka_holding_a_pose_is_pybullets() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let r = &reference()["holding"];
    let sim = c.new_sim(json!({})).await;
    let id = load(&c, &sim, r["robot"].as_str().unwrap()).await;
    let q = floats(&r["positions"]);
    for (j, x) in q.iter().enumerate() {
        c.call("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j, "target_value": x})).await;
        let before = joint(&c, &sim, id, j as u64).await;
        assert_eq!(floats(&before["reaction_forces"]), vec![0.0; 6], "a joint without a sensor reports zeros");
        c.call("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
    }
    let joints: Vec<usize> = (0..q.len()).collect();
    c.call("set_joint_motor_control_array", json!({"sim_id": sim, "object_id": id, "joint_indices": joints,
        "control_mode": "POSITION_CONTROL", "target_positions": q, "forces": vec![r["max_force"].clone(); q.len()]})).await;
    c.step(&sim, r["steps"].as_u64().unwrap()).await;
    let want: Vec<Vec<f64>> = r["joints"].as_array().unwrap().iter().map(|j| floats(&j["reaction_forces"])).collect();
    let mut got = Vec::new();
    for j in 0..q.len() {
        got.push(floats(&joint(&c, &sim, id, j as u64).await["reaction_forces"]));
    }
    let largest = |k: std::ops::Range<usize>| want.iter().flat_map(|w| w[k.clone()].to_vec()).fold(0.0f64, |m, x| m.max(x.abs()));
    let (f_max, m_max) = (largest(0..3), largest(3..6));
    for (j, (g, w)) in got.iter().zip(&want).enumerate() {
        for k in 0..6 {
            let scale = if k < 3 { f_max } else { m_max };
            assert!((g[k] - w[k]).abs() <= 0.05 * scale, "joint {j} component {k}: {g:?} vs pybullet {w:?}");
        }
    }
    // The arm below joint 0 weighs 17.5 kg (iiwa links 1–7).
    let weight = got[0][..3].iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!((weight - 17.5 * 9.81).abs() < 1e-3 * weight, "base joint carries {weight} N, not the arm's weight");
}

/// The switch is a change: recorded (undo turns it off again) and refused on a bad joint with
/// nothing changed.
#[tokio::test(flavor = "multi_thread")]
async fn sensor_switch_is_an_undoable_change_and_bad_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let id = load(&c, &sim, "kuka_iiwa/model.urdf").await;
    c.call("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 1, "target_value": 0.5})).await;
    let hash = c.hash(&sim).await;
    let bad = c.try_call("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": id, "joint_index": 99})).await;
    let why = bad.expect_err("joint 99 is refused");
    assert!(why.contains("99"), "{why}");
    assert_eq!(c.hash(&sim).await, hash, "a refusal changes nothing");
    c.call("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": id, "joint_index": 1})).await;
    assert_ne!(c.hash(&sim).await, hash, "a sensor is hashed state");
    let on = floats(&joint(&c, &sim, id, 1).await["reaction_forces"]);
    assert!(on.iter().any(|x| x.abs() > 1.0), "a sensed joint reports its wrench: {on:?}");
    let sensed = c.hash(&sim).await;
    let fork = c.call("fork_simulation", json!({"sim_id": sim})).await["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c.hash(&fork).await, sensed, "a fork carries the sensor");
    assert_eq!(floats(&joint(&c, &fork, id, 1).await["reaction_forces"]), on);
    let verified = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(verified["ok"], json!(true), "the log refolds to the recorded hashes: {verified}");
    c.call("undo", json!({"sim_id": sim})).await;
    assert_eq!(c.hash(&sim).await, hash, "undo turns the sensor off");
    assert_eq!(floats(&joint(&c, &sim, id, 1).await["reaction_forces"]), vec![0.0; 6]);
}

/// Largest |a − b| over two matrices given as rows, and the largest |b|.
fn matrix_diff(a: &Value, b: &Value) -> (f64, f64) {
    let rows = |m: &Value| -> Vec<Vec<f64>> { m.as_array().unwrap().iter().map(floats).collect() };
    let (a, b) = (rows(a), rows(b));
    assert_eq!((a.len(), a[0].len()), (b.len(), b[0].len()), "matrix shapes");
    let diff = a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    (diff, b.iter().flatten().fold(0.0f64, |m, y| m.max(y.abs())))
}

/// calculate_jacobian, calculate_mass_matrix and calculate_inverse_dynamics of the KUKA iiwa
/// and the Franka Panda at 5 random configurations, velocities and accelerations equal
/// PyBullet's within 1e-5 of each matrix's largest entry.
#[tokio::test(flavor = "multi_thread")]
async fn jacobian_mass_matrix_and_inverse_dynamics_are_pybullets() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gravity": reference()["gravity"]})).await;
    for robot in reference()["dynamics"].as_array().unwrap() {
        let name = robot["robot"].as_str().unwrap();
        let id = load(&c, &sim, name).await;
        for (k, case) in robot["cases"].as_array().unwrap().iter().enumerate() {
            let (q, qd, qdd) = (&case["positions"], &case["velocities"], &case["accelerations"]);
            let at = format!("{name} case {k}");
            let j = c.call("calculate_jacobian", json!({"sim_id": sim, "object_id": id, "link_index": robot["link_index"],
                "local_position": robot["local_position"], "obj_positions": q, "obj_velocities": qd, "obj_accelerations": qdd})).await;
            for key in ["linear_jacobian", "angular_jacobian"] {
                let (d, scale) = matrix_diff(&j[key], &case[key]);
                assert!(d <= 1e-5 * scale, "{at}: {key} off by {d} (largest entry {scale})");
            }
            let m = c.call("calculate_mass_matrix", json!({"sim_id": sim, "object_id": id, "obj_positions": q})).await;
            let (d, scale) = matrix_diff(&m["mass_matrix"], &case["mass_matrix"]);
            assert!(d <= 1e-5 * scale, "{at}: mass_matrix off by {d} (largest entry {scale}): {} vs {}", m["mass_matrix"], case["mass_matrix"]);
            let t = c.call("calculate_inverse_dynamics", json!({"sim_id": sim, "object_id": id, "obj_positions": q,
                "obj_velocities": qd, "obj_accelerations": qdd})).await;
            let (d, scale) = matrix_diff(&json!([t["joint_forces"]]), &json!([case["joint_forces"]]));
            assert!(d <= 1e-5 * scale, "{at}: joint_forces off by {d} (largest {scale}): {} vs {}", t["joint_forces"], case["joint_forces"]);
        }
    }
    let bad = c.try_call("calculate_mass_matrix", json!({"sim_id": sim, "object_id": 0, "obj_positions": [0.1]})).await;
    assert!(bad.expect_err("a short list is refused").contains("obj_positions"));
}

/// get_joint_states and get_link_states answer each index exactly as the one-at-a-time calls.
#[tokio::test(flavor = "multi_thread")]
async fn many_at_once_equals_one_at_a_time_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let id = load(&c, &sim, "franka_panda/panda.urdf").await;
    c.call("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": id, "joint_index": 3})).await;
    c.call("set_joint_motor_control", json!({"sim_id": sim, "object_id": id, "joint_index": 1, "control_mode": "VELOCITY_CONTROL", "target_velocity": 0.5})).await;
    c.step(&sim, 30).await;
    let joints = [0, 3, 1, 9, 3];
    let many = c.call("get_joint_states", json!({"sim_id": sim, "object_id": id, "joint_indices": joints})).await;
    for (k, j) in joints.iter().enumerate() {
        assert_eq!(many["joint_states"][k], joint(&c, &sim, id, *j).await, "joint {j}");
    }
    let links = [-1, 2, 6, 10];
    let many = c.call("get_link_states", json!({"sim_id": sim, "object_id": id, "link_indices": links})).await;
    for (k, l) in links.iter().enumerate() {
        let one = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": l})).await;
        assert_eq!(many["link_states"][k], one, "link {l}");
    }
    let bad = c.try_call("get_joint_states", json!({"sim_id": sim, "object_id": id, "joint_indices": [0, 42]})).await;
    assert!(bad.expect_err("joint 42 is refused").contains("42"));
}
