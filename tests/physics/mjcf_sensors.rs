//! get_sensor_data over MCP/HTTP, on one server, against MuJoCo itself
//! (tests/reference/mjcf_sensors.json, written by scripts/mjcf_sensor_reference.py for the
//! hand-written tests/fixtures/mjcf/sensor_arm.xml):
//! - at fixed poses and velocities, every kinematic sensor within `KINEMATIC` and the
//!   acceleration-stage ones (accelerometer, force, torque, at zero joint acceleration as
//!   MuJoCo's mj_inverse with qacc = 0) within `DYNAMIC`;
//! - after a short run under the same controls, within `RUN` (the trajectory is the engine's);
//! - as a read: unknown names and objects without sensors are refused naming the parameter,
//!   a subset keeps the model's order, unsupported sensors are listed in `ignored`, and a fork
//!   (a snapshot) keeps the sensors.

use crate::common;

use std::path::Path;

use common::Server;
use serde_json::{json, Value};

/// Positions, orientations and velocities at a pose: the engine's joint coordinates and body
/// poses are f32, the arm is 1 m long (f32 resolution ≈ 1e-7 m there; the chain's forward
/// kinematics accumulates a few ulps per link).
const KINEMATIC: f64 = 1e-5;
/// Accelerometer, force, torque: the same f64 Newton–Euler pass as MuJoCo's, on f32 masses,
/// inertias and frames (measured ≤ 1.3e-6 on values up to 13 N).
const DYNAMIC: f64 = 1e-5;
/// After 0.3 s of the same controls: the engine's trajectory, not MuJoCo's (its solver and
/// integrator differ), as in tests/physics/mjcf_actuators.rs.
const RUN: f64 = 0.05;

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/mjcf_sensors.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// The largest difference of our reading from MuJoCo's per sensor (a quaternion up to sign).
fn differences(ours: &Value, theirs: &Value) -> Vec<(String, f64)> {
    let ours: Vec<&Value> = ours["sensors"].as_array().unwrap().iter().collect();
    let mut out = Vec::new();
    for (name, want) in theirs.as_object().unwrap().iter().filter(|(n, _)| !NOT_COMPUTED.contains(&n.as_str())) {
        let got = ours.iter().find(|s| s["name"] == name.as_str()).unwrap_or_else(|| panic!("no sensor {name} in {ours:?}"));
        let (got, want): (Vec<f64>, Vec<f64>) = (
            got["data"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect(),
            want.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect(),
        );
        assert_eq!(got.len(), want.len(), "{name}");
        let diff = |sign: f64| got.iter().zip(&want).map(|(a, b)| (sign * a - b).abs()).fold(0.0, f64::max);
        let quat = got.len() == 4;
        out.push((name.clone(), if quat { diff(1.0).min(diff(-1.0)) } else { diff(1.0) }));
    }
    out
}

/// The fixture's sensors get_sensor_data does not compute (listed in `ignored`; MuJoCo's values
/// stay in the reference). `palm_touch` is computed since event version 8 (nothing touches the
/// palm here: 0, as MuJoCo's; tests/physics/mjcf_touch.rs checks contacts).
const NOT_COMPUTED: [&str; 1] = ["tip_in_upper"];

fn is_dynamic(name: &str) -> bool {
    ["accelerometer", "elbow_force", "elbow_torque", "slider_force"].contains(&name)
}

#[tokio::test(flavor = "multi_thread")]
async fn sensors_match_mujoco_and_read_as_reads() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let loaded = c.call("load_mjcf", json!({"sim_id": s, "file_path": "mjcf/sensor_arm.xml", "use_model_options": true})).await;
    let id = loaded["object_id"].as_u64().unwrap();
    let ignored = loaded["ignored"].to_string();
    assert!(!ignored.contains("<sensor>"), "{ignored}");
    assert!(!ignored.contains("palm_touch"), "{ignored}");
    assert!(ignored.contains("sensor tip_in_upper: frames relative to a reference frame"), "{ignored}");

    let sim_info = c.call("get_simulation_info", json!({"sim_id": s})).await;
    assert_eq!(sim_info["objects"][0]["sensors"].as_array().map(Vec::len), Some(28), "{sim_info}");

    let mut report = Vec::new();
    for (k, pose) in r["poses"].as_array().unwrap().iter().enumerate() {
        let mut calls = Vec::new();
        for j in 0..3 {
            calls.push(json!({"tool": "reset_joint_state", "arguments": {"object_id": id, "joint_index": j,
                "target_value": pose["qpos"][j], "target_velocity": pose["qvel"][j]}}));
        }
        calls.push(json!({"tool": "set_actuator_controls", "arguments": {"object_id": id, "controls": pose["ctrl"]}}));
        calls.push(json!({"tool": "get_sensor_data", "arguments": {"object_id": id}}));
        let out = c.call("batch", json!({"sim_id": s, "calls": calls})).await;
        let ours = out["results"].as_array().unwrap().last().unwrap().clone();
        for (name, d) in differences(&ours, &pose["sensors"]) {
            let tolerance = if is_dynamic(&name) { DYNAMIC } else { KINEMATIC };
            report.push((k, name, d, tolerance));
        }
    }
    let worst: Vec<_> = report.iter().filter(|(_, _, d, t)| d > t).collect();
    eprintln!("REPORT sensors against MuJoCo at poses (pose, sensor, max |diff|): {:?}", report.iter().map(|(k, n, d, _)| (k, n, format!("{d:.1e}"))).collect::<Vec<_>>());
    assert!(worst.is_empty(), "over tolerance: {worst:?}");

    // The run: from qpos0 at rest under the reference's controls.
    let run = &r["run"];
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let loaded = c.call("load_mjcf", json!({"sim_id": s, "file_path": "mjcf/sensor_arm.xml", "use_model_options": true})).await;
    let id = loaded["object_id"].as_u64().unwrap();
    c.call("set_actuator_controls", json!({"sim_id": s, "object_id": id, "controls": run["ctrl"]})).await;
    c.step(s, run["steps"].as_u64().unwrap()).await;
    let ours = c.call("get_sensor_data", json!({"sim_id": s, "object_id": id})).await;
    let diffs = differences(&ours, &run["sensors"]);
    eprintln!("REPORT sensors against MuJoCo after the run: {diffs:.4?}");
    for (name, d) in &diffs {
        assert!(*d <= RUN, "{name}: {d} over {RUN} after the run");
    }

    // A read: a subset in the model's order; refusals name the parameter and change nothing.
    let read = json!({"sim_id": s, "object_id": id, "names": ["gyro", "q_shoulder"]});
    let some = c.call("get_sensor_data", read).await;
    let names: Vec<&str> = some["sensors"].as_array().unwrap().iter().map(|x| x["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["q_shoulder", "gyro"], "{some}");
    let before = c.hash(s).await;
    let e = c.try_call("get_sensor_data", json!({"sim_id": s, "object_id": id, "names": ["nope"]})).await.expect_err("refused");
    assert!(e.contains("names lists no sensor \"nope\""), "{e}");
    let cube = c.call("add_box", json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [3, 0, 0], "mass": 0})).await["object_id"].clone();
    let e = c.try_call("get_sensor_data", json!({"sim_id": s, "object_id": cube})).await.expect_err("refused");
    assert!(e.contains("object_id") && e.contains("has no sensors"), "{e}");
    c.call("undo", json!({"sim_id": s})).await;
    assert_eq!(c.hash(s).await, before, "the reads changed the state");

    // A fork restores the snapshot: the sensors come with it.
    let fork = c.call("fork_simulation", json!({"sim_id": s})).await["simulation_id"].as_str().unwrap().to_string();
    let forked = c.call("get_sensor_data", json!({"sim_id": fork, "object_id": id})).await;
    assert_eq!(forked, ours, "the fork reads the same sensors");
}
