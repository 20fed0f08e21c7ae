//! MJCF actuators and set_actuator_controls over MCP/HTTP, on one server:
//! - against MuJoCo itself (tests/reference/mjcf_actuators.json, written by
//!   scripts/mjcf_actuator_reference.py): reacher, pusher and inverted_pendulum for 2 s and
//!   inverted_double_pendulum for 0.5 s under the same sinusoid controls, at the model's own
//!   timestep, every joint's RMS difference from MuJoCo's trajectory within a stated tolerance;
//! - against MuJoCo, actuator_mix.xml (intvelocity, damper, general affine and integrator)
//!   started at its keyframe with the keyframe's `ctrl` held, and the attributes not applied
//!   (`dampratio`, `timeconst`, `actearly`, `actuatorfrcrange`) listed in `ignored`;
//! - against analytic statics: a `position` servo holds a hinge where kp·(ctrl − q) balances
//!   gravity, a `forcerange` caps it, a `velocity` actuator drives a slide at its control;
//! - as a recorded change: refusals name the parameter and change nothing; by-name controls
//!   keep the others; undo; the last call driving a joint wins (set_joint_motor_control then
//!   set_actuator_controls).

use crate::common;

use std::path::Path;

use common::{Client, Server};
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/mjcf_actuators.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// RMS tolerance per joint (rad or m) against MuJoCo's trajectory: rapier's solver, limits and
/// integrator differ from MuJoCo's, in f32. inverted_pendulum's pole falls over in these 2 s
/// and its cart reaches its slider's limit (MuJoCo's limits are soft), so it drifts most.
fn tolerance(model: &str) -> f64 {
    match model {
        "inverted_pendulum" => 0.1,
        _ => 0.05,
    }
}

/// Drives one model with the reference's controls in one batch; returns each joint's RMS
/// difference from MuJoCo's samples.
async fn drive(c: &Client, model: &str, r: &Value) -> Vec<f64> {
    let sim = c.new_sim(json!({})).await;
    let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": format!("mjcf/{model}.xml"), "use_model_options": true})).await;
    let id = loaded["object_id"].as_u64().unwrap();
    let controls = r["controls"].as_array().unwrap();
    assert_eq!(loaded["actuators"].as_array().map(Vec::len), Some(controls.len()), "{model}: {loaded}");
    assert!(!loaded["ignored"].to_string().contains("<actuator>"), "{model}: {}", loaded["ignored"]);
    let dt = r["timestep"].as_f64().unwrap();
    let (steps, every) = (r["steps"].as_u64().unwrap(), r["every"].as_u64().unwrap());
    let joints: Vec<usize> = (0..r["joints"].as_array().unwrap().len()).collect();
    let mut calls = Vec::new();
    for k in 0..steps {
        let t = k as f64 * dt;
        let u: Vec<f64> = controls
            .iter()
            .map(|s| {
                let f = |n: &str| s[n].as_f64().unwrap();
                f("amplitude") * (2.0 * std::f64::consts::PI * f("frequency") * t + f("phase")).sin()
            })
            .collect();
        calls.push(json!({"tool": "set_actuator_controls", "arguments": {"object_id": id, "controls": u}}));
        calls.push(json!({"tool": "step_simulation", "arguments": {"steps": 1}}));
        if (k + 1) % every == 0 {
            calls.push(json!({"tool": "get_joint_states", "arguments": {"object_id": id, "joint_indices": joints}}));
        }
    }
    let out = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let states: Vec<&Value> = out["results"].as_array().unwrap().iter().filter(|x| x.get("joint_states").is_some()).collect();
    let samples = r["samples"].as_array().unwrap();
    assert_eq!(states.len(), samples.len(), "{model}");
    let mut sq = vec![0.0; joints.len()];
    for (ours, theirs) in states.iter().zip(samples) {
        for j in &joints {
            let q = ours["joint_states"][j]["joint_position"].as_f64().unwrap();
            let m = theirs["qpos"][j].as_f64().unwrap();
            sq[*j] += (q - m).powi(2);
        }
    }
    sq.iter().map(|s| (s / samples.len() as f64).sqrt()).collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn actuators_follow_mujoco_and_controls_are_recorded_changes() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    let mut report = Vec::new();
    for (model, m) in r["models"].as_object().unwrap() {
        report.push((model.clone(), drive(&c, model, m).await));
    }
    eprintln!("REPORT RMS per joint against MuJoCo: {report:.4?}");
    for (model, rms) in &report {
        let worst = rms.iter().copied().fold(0.0, f64::max);
        assert!(worst <= tolerance(model), "{model}: RMS per joint {rms:?} over {}", tolerance(model));
    }
    let rms = from_keyframe(&c, "actuator_mix", &r["keyframes"]["actuator_mix"]).await;
    eprintln!("REPORT RMS per joint against MuJoCo from keyframe start (ctrl held): {rms:.4?}");
    assert!(rms.iter().all(|x| *x <= tolerance("actuator_mix")), "actuator_mix from its keyframe: {rms:?}");
    unapplied_attributes_listed(&c, &server).await;
    statics_and_changes(&c, &server).await;
}

/// Loads `model` at the reference's keyframe (its `ctrl` starts the controls) and steps it
/// with nothing set; returns each joint's RMS difference from MuJoCo's samples.
async fn from_keyframe(c: &Client, model: &str, r: &Value) -> Vec<f64> {
    let sim = c.new_sim(json!({})).await;
    let loaded = c
        .call("load_mjcf", json!({"sim_id": sim, "file_path": format!("mjcf/{model}.xml"), "use_model_options": true, "keyframe": r["keyframe"]}))
        .await;
    let id = loaded["object_id"].as_u64().unwrap();
    let every = r["every"].as_u64().unwrap();
    let samples = r["samples"].as_array().unwrap();
    let joints: Vec<usize> = (0..samples[0]["qpos"].as_array().unwrap().len()).collect();
    let mut calls = Vec::new();
    for _ in samples {
        calls.push(json!({"tool": "step_simulation", "arguments": {"steps": every}}));
        calls.push(json!({"tool": "get_joint_states", "arguments": {"object_id": id, "joint_indices": joints}}));
    }
    let out = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let states: Vec<&Value> = out["results"].as_array().unwrap().iter().filter(|x| x.get("joint_states").is_some()).collect();
    let mut sq = vec![0.0; joints.len()];
    for (ours, theirs) in states.iter().zip(samples) {
        for j in &joints {
            sq[*j] += (ours["joint_states"][j]["joint_position"].as_f64().unwrap() - theirs["qpos"][j].as_f64().unwrap()).powi(2);
        }
    }
    sq.iter().map(|s| (s / samples.len() as f64).sqrt()).collect()
}

/// MuJoCo's attributes the actuators do not apply are named in `ignored`.
async fn unapplied_attributes_listed(c: &Client, server: &Server) {
    let xml = r#"<mujoco><worldbody><body name="a"><joint name="j" type="hinge" actuatorfrcrange="-1 1"/>
      <geom type="sphere" size="0.1" mass="1"/></body></worldbody>
      <actuator><position joint="j" kp="10" dampratio="1" timeconst="0.1" actearly="true"/></actuator></mujoco>"#;
    std::fs::write(server.workspace.join("unapplied.xml"), xml).unwrap();
    let sim = c.new_sim(json!({})).await;
    let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "unapplied.xml"})).await;
    let ignored = loaded["ignored"].to_string();
    for a in ["dampratio (on <position>)", "timeconst (on <position>)", "actearly (on <position>)", "actuatorfrcrange (on <joint>)"] {
        assert!(ignored.contains(a), "{a} not in {ignored}");
    }
}

/// A hinge arm (1 kg at 0.5 m, gravity along −z, axis y) with a position servo, a weak
/// force-limited motor on a second arm, and a velocity actuator on a slide.
const SERVO_XML: &str = r#"<mujoco model="servo">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="2"/>
      <geom type="sphere" size="0.05" pos="0.5 0 0" mass="1"/>
    </body>
    <body name="weak" pos="2 0 1">
      <joint name="hinge2" type="hinge" axis="0 1 0" damping="2"/>
      <geom type="sphere" size="0.05" pos="0.5 0 0" mass="1"/>
    </body>
    <body name="cart" pos="4 0 1">
      <joint name="slide" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.1" mass="2"/>
    </body>
  </worldbody>
  <actuator>
    <position name="servo" joint="hinge" kp="200" kv="5" ctrlrange="-1 1"/>
    <motor name="capped" joint="hinge2" gear="2" forcerange="-1 1"/>
    <velocity name="drive" joint="slide" kv="50"/>
  </actuator>
</mujoco>"#;

async fn statics_and_changes(c: &Client, server: &Server) {
    std::fs::write(server.workspace.join("servo.xml"), SERVO_XML).unwrap();
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let loaded = c.call("load_mjcf", json!({"sim_id": s, "file_path": "servo.xml", "use_model_options": true})).await;
    let id = loaded["object_id"].as_u64().unwrap();
    assert_eq!(
        loaded["actuators"],
        json!([
            {"name": "servo", "type": "position", "joint_index": 0, "ctrlrange": [-1.0, 1.0]},
            {"name": "capped", "type": "motor", "joint_index": 1, "forcerange": [-1.0, 1.0]},
            {"name": "drive", "type": "velocity", "joint_index": 2}
        ]),
        "{loaded}"
    );
    // get_joint_info lists a joint's actuators, get_simulation_info the model's.
    let info = c.call("get_joint_info", json!({"sim_id": s, "object_id": id, "joint_index": 0})).await;
    assert_eq!(info["actuators"], json!([{"name": "servo", "type": "position", "joint_index": 0, "ctrlrange": [-1.0, 1.0]}]), "{info}");
    let sim_info = c.call("get_simulation_info", json!({"sim_id": s})).await;
    assert_eq!(sim_info["objects"][0]["actuators"], loaded["actuators"], "{sim_info}");
    let set = |controls: Value| json!({"sim_id": s, "object_id": id, "controls": controls});

    // Refusals name the parameter and change nothing.
    let before = c.hash(s).await;
    for (controls, says) in [
        (json!([0.1, 0.2]), "controls has 2 values"),
        (json!({"nope": 1}), "no actuator \"nope\""),
        (json!("fast"), "controls must be a list"),
        (json!([0.1, "x", 0.3]), "controls[1]"),
    ] {
        let e = c.try_call("set_actuator_controls", set(controls.clone())).await.expect_err("refused");
        assert!(e.contains(says), "{controls}: {e}");
    }
    let box_id = c.call("add_box", json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [0, 5, 0], "mass": 0})).await["object_id"].clone();
    let e = c.try_call("set_actuator_controls", json!({"sim_id": s, "object_id": box_id, "controls": [1]})).await.expect_err("refused");
    assert!(e.contains("has no actuators"), "{e}");
    c.call("undo", json!({"sim_id": s})).await;
    assert_eq!(c.hash(s).await, before, "refusals changed the state");

    // A positive q about +y tips an arm down, and gravity's torque about y is +m·g·l·cos q:
    // the servo holds its arm where kp·(ctrl − q) + m·g·l·cos q = 0; the capped motor's −5 is
    // clamped to −1 (× gear 2 = −2 N·m, not −10, which would lift the arm over), so its arm
    // rests where m·g·l·cos q = 2; the cart runs at the velocity actuator's control.
    c.call("set_actuator_controls", set(json!([0.3, -5.0, 0.4]))).await;
    c.step(s, 2500).await;
    let joint = |st: &Value, j: usize| st["joint_states"][j].clone();
    let st = c.call("get_joint_states", json!({"sim_id": s, "object_id": id, "joint_indices": [0, 1, 2]})).await;
    let q = joint(&st, 0)["joint_position"].as_f64().unwrap();
    let mgl = 1.0 * 9.81 * 0.5;
    let balance = 200.0 * (0.3 - q) + mgl * q.cos();
    assert!(balance.abs() < 0.05, "servo q = {q}: kp·(ctrl − q) + m g l cos q = {balance}");
    let rest = joint(&st, 1)["joint_position"].as_f64().unwrap();
    let expected = (2.0 / mgl).acos();
    assert!((rest - expected).abs() < 0.01, "capped motor's arm at {rest}, expected {expected}");
    let v = joint(&st, 2)["joint_velocity"].as_f64().unwrap();
    assert!((v - 0.4).abs() < 1e-3, "velocity actuator: {v}");

    // By name: the others keep theirs. Undo restores the controls.
    let h0 = c.hash(s).await;
    c.call("set_actuator_controls", set(json!({"drive": -0.2}))).await;
    c.step(s, 500).await;
    let st = c.call("get_joint_states", json!({"sim_id": s, "object_id": id, "joint_indices": [0, 2]})).await;
    assert!((joint(&st, 1)["joint_velocity"].as_f64().unwrap() + 0.2).abs() < 1e-3, "{st}");
    assert!((joint(&st, 0)["joint_position"].as_f64().unwrap() - q).abs() < 1e-3, "servo kept its control: {st}");
    c.call("undo", json!({"sim_id": s, "count": 2})).await;
    assert_eq!(c.hash(s).await, h0, "undo");

    // The last call driving a joint wins: a motor takes the cart over, the actuator takes it back.
    c.call(
        "set_joint_motor_control",
        json!({"sim_id": s, "object_id": id, "joint_index": 2, "control_mode": "VELOCITY_CONTROL", "target_velocity": -1, "force": 1000}),
    )
    .await;
    c.step(s, 200).await;
    let v = |st: Value| st["joint_velocity"].as_f64().unwrap();
    let cart = json!({"sim_id": s, "object_id": id, "joint_index": 2});
    assert!((v(c.call("get_joint_state", cart.clone()).await) + 1.0).abs() < 1e-2, "the motor drives the cart");
    c.call("set_actuator_controls", set(json!({"drive": 0.4}))).await;
    c.step(s, 500).await;
    let st = c.call("get_joint_state", cart).await;
    assert!((v(st.clone()) - 0.4).abs() < 1e-3, "the actuator drives the cart again: {st}");
    assert_eq!(st["motor_torque"].as_f64(), Some(0.0), "the motor is gone: {st}");
}
