//! MJCF ball joints and `<contact><pair>` (event version 9) against MuJoCo itself
//! (tests/reference/mjcf_ball_pair.json, written by scripts/mjcf_ball_pair_reference.py), over
//! MCP/HTTP on one server:
//! - tests/fixtures/mjcf/ball_pendulum.xml (a lopsided pendulum on a ball joint, a hinged tip
//!   below it) swinging and twisting in 3D from its `tilted` keyframe: the ball joint's
//!   quaternion [x, y, z, w] and angular velocity (child frame) from get_joint_state, and the
//!   hinge's, as MuJoCo's qpos/qvel; the same under engine rule 1 (in process);
//! - tests/fixtures/mjcf/pair_slide.xml (a box sent at 2 m/s over a plane whose pair friction,
//!   0.2, differs from the geoms' own, 1): where it slides to, as in MuJoCo;
//! - the tools that need one number per joint refuse a ball joint, naming the parameter; a load
//!   recorded before event version 9 refuses a ball joint and lists the pair in `ignored`;
//! - get_simulation_info and get_joint_info list an MJCF model's equality constraints and
//!   tendons, and whether each is built (event version 9; absent for older loads).

use crate::common;

use std::path::Path;

use common::{Client, Server};
use physics_mcp::command::Command;
use physics_mcp::engine::EngineRule;
use physics_mcp::world::World;
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/mjcf_ball_pair.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mjcf").join(name)).unwrap()
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

/// How far the ball joint's quaternion components (and the hinge, rad) may be from MuJoCo's
/// over the first second of the swing; angular velocities (rad/s, peaks near 3) get ten times
/// that. Both integrate the same rigid-body dynamics at 2 ms (MuJoCo's Euler on f64, rapier's
/// reduced-coordinate multibody on f32).
const BALL_TOLERANCE: f64 = 0.01;

/// How far the box's x (m) may be from MuJoCo's while it slides 1 m and stops: at friction 1
/// (the geoms' own) it would stop within 0.21 m.
const SLIDE_TOLERANCE_M: f64 = 0.03;

/// The largest difference between a quaternion and MuJoCo's (either sign: q and −q are one
/// rotation).
fn quat_gap(ours: &[f64], theirs: &[f64]) -> f64 {
    let gap = |s: f64| ours.iter().zip(theirs).map(|(a, b)| (a - s * b).abs()).fold(0.0, f64::max);
    gap(1.0).min(gap(-1.0))
}

#[tokio::test(flavor = "multi_thread")]
async fn ball_joints_and_contact_pairs_move_as_in_mujoco() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    ball_pendulum_swings_as_mujoco(&c, &r["ball_pendulum"]).await;
    pair_friction_slows_the_box_as_mujoco(&c, &r["pair_slide"]).await;
    ball_pendulum_under_engine_rule_1(&r["ball_pendulum"]);
    older_loads_refuse_ball_joints_and_ignore_pairs();
    equality_and_tendons_are_listed_with_whether_they_are_built();
    tendon_defaults_are_listed_and_an_unbuilt_world_constraint_adds_no_world_body();
}

async fn ball_pendulum_swings_as_mujoco(c: &Client, r: &Value) {
    let sim = c.new_sim(json!({})).await;
    let loaded = c
        .call("load_mjcf", json!({"sim_id": sim, "file_path": "mjcf/ball_pendulum.xml", "use_model_options": true, "keyframe": "tilted"}))
        .await;
    assert_eq!(loaded["num_joints"], 2, "{loaded}");
    assert!(!loaded["ignored"].to_string().contains("ball"), "{loaded}");
    let id = loaded["object_id"].as_u64().unwrap();
    let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": 0})).await;
    assert_eq!(info["joint_type"], "spherical", "{info}");
    assert_eq!(info["joint_name"], "shoulder", "{info}");
    // At the keyframe: MuJoCo's qpos, reordered [x, y, z, w].
    let at_key = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 0})).await;
    assert!(quat_gap(&nums(&at_key["joint_position"]), &[0.2705981, 0.2705981, 0.0, 0.9238795]) < 1e-6, "{at_key}");
    let mut calls = Vec::new();
    let mut at = 0;
    let samples = r["samples"].as_array().unwrap();
    for s in samples {
        let step = s["step"].as_u64().unwrap();
        calls.push(json!({"tool": "step_simulation", "arguments": {"steps": step - at}}));
        calls.push(json!({"tool": "get_joint_states", "arguments": {"object_id": id, "joint_indices": [0, 1]}}));
        at = step;
    }
    let out = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let states: Vec<&Value> = out["results"].as_array().unwrap().iter().filter_map(|x| x.get("joint_states")).collect();
    assert_eq!(states.len(), samples.len(), "{out}");
    for (s, st) in samples.iter().zip(states) {
        let (ball, hinge) = (&st[0], &st[1]);
        let q_gap = quat_gap(&nums(&ball["joint_position"]), &nums(&s["ball_xyzw"]));
        let w_gap = nums(&ball["joint_velocity"]).iter().zip(nums(&s["ball_angvel"])).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let h_gap = (hinge["joint_position"].as_f64().unwrap() - s["hinge"].as_f64().unwrap()).abs();
        eprintln!("REPORT ball step {}: quaternion {q_gap:.5}, angular velocity {w_gap:.5}, hinge {h_gap:.5}", s["step"]);
        assert!(q_gap <= BALL_TOLERANCE && h_gap <= BALL_TOLERANCE && w_gap <= 10.0 * BALL_TOLERANCE, "step {}: ours {st}, MuJoCo {s}", s["step"]);
    }
    // One number per joint: refused on the ball joint, naming the parameter.
    let refusals = [
        ("set_joint_motor_control", json!({"sim_id": sim, "object_id": id, "joint_index": 0, "control_mode": "VELOCITY_CONTROL", "target_velocity": 1.0}), "joint_index 0 is a ball joint"),
        ("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 0, "target_value": 0.1}), "joint_index 0 is a ball joint"),
        ("calculate_inverse_kinematics", json!({"sim_id": sim, "object_id": id, "end_effector_link_index": 1, "target_position": [0.1, 0.0, 0.5]}), "object_id"),
        ("calculate_mass_matrix", json!({"sim_id": sim, "object_id": id, "obj_positions": [0.0]}), "has a ball joint"),
        ("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": id, "joint_index": 1}), "has a ball joint"),
    ];
    let before = c.hash(&sim).await;
    for (tool, args, says) in refusals {
        let e = c.try_call(tool, args).await.expect_err(tool);
        assert!(e.contains(says), "{tool}: {e}");
    }
    assert_eq!(c.hash(&sim).await, before, "a refusal changed the world");
    // The hinge below it still takes a motor.
    c.call("set_joint_motor_control", json!({"sim_id": sim, "object_id": id, "joint_index": 1, "control_mode": "VELOCITY_CONTROL", "target_velocity": 0.5})).await;
}

async fn pair_friction_slows_the_box_as_mujoco(c: &Client, r: &Value) {
    let sim = c.new_sim(json!({})).await;
    let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "mjcf/pair_slide.xml", "use_model_options": true})).await;
    assert!(!loaded["ignored"].to_string().contains("pair"), "{loaded}");
    let id = loaded["object_id"].as_u64().unwrap();
    c.step(&sim, r["settle_steps"].as_u64().unwrap()).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": id, "linear_velocity": [2.0, 0.0, 0.0], "angular_velocity": [0.0, 0.0, 0.0]})).await;
    let x0 = c.state(&sim, id).await["position"][0].as_f64().unwrap();
    let mut at = 0;
    for s in r["samples"].as_array().unwrap() {
        let step = s["step"].as_u64().unwrap();
        c.step(&sim, step - at).await;
        at = step;
        let x = c.state(&sim, id).await["position"][0].as_f64().unwrap() - x0;
        let theirs = s["x"].as_f64().unwrap();
        eprintln!("REPORT pair slide step {step}: x ours {x:.4} MuJoCo {theirs:.4}");
        assert!((x - theirs).abs() <= SLIDE_TOLERANCE_M, "step {step}: ours {x}, MuJoCo {theirs}");
    }
}

/// The same swing in process under engine rule 1 (rapier's own dense multibody dynamics):
/// ball joints are above the engine rule.
fn ball_pendulum_under_engine_rule_1(r: &Value) {
    let root = Command::CreateSimulation { simulation_id: "rule1".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(EngineRule::Upstream) };
    let (mut w, _) = World::create(&root).unwrap();
    let mut load = common::mjcf_command::load_mjcf("ball_pendulum.xml", &fixture("ball_pendulum.xml"), true);
    if let Command::LoadMjcf { keyframe, .. } = &mut load {
        *keyframe = Some("tilted".into());
    }
    let out = w.apply(&load, &mut |_| true).to_value();
    let id = out["object_id"].as_u64().unwrap() as u32;
    let mut at = 0;
    for s in r["samples"].as_array().unwrap() {
        let step = s["step"].as_u64().unwrap();
        w.apply(&Command::StepSimulation { steps: step - at, measure: None }, &mut |_| true);
        at = step;
        let st = serde_json::to_value(w.joint_state(id, 0).unwrap()).unwrap();
        let gap = quat_gap(&nums(&st["joint_position"]), &nums(&s["ball_xyzw"]));
        assert!(gap <= BALL_TOLERANCE, "rule 1, step {step}: ours {st}, MuJoCo {s}");
    }
}

/// Loads as recorded before event version 9 (`ball_joints_and_pairs` false): a ball joint is
/// refused as it was, and a pair is listed in `ignored`, not built.
fn older_loads_refuse_ball_joints_and_ignore_pairs() {
    let root = Command::CreateSimulation { simulation_id: "v8".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    let (mut w, _) = World::create(&root).unwrap();
    let old = |name: &str| {
        let mut load = common::mjcf_command::load_mjcf(name, &fixture(name), true);
        if let Command::LoadMjcf { ball_joints_and_pairs, .. } = &mut load {
            *ball_joints_and_pairs = false;
        }
        load
    };
    let refused = old("ball_pendulum.xml").validate(&w, &Default::default()).expect_err("a ball joint in a version-8 load");
    assert!(refused.contains("joint shoulder is a ball joint, which is not supported"), "{refused}");
    let out = w.apply(&old("pair_slide.xml"), &mut |_| true).to_value();
    assert!(out["ignored"].to_string().contains("<contact><pair>: explicit contact pairs are not applied"), "{out}");
}

/// equality_mix.xml with its connect switched off: get_simulation_info lists the three equality
/// constraints (the connect not built) and the tendon (built: an actuator drives it), and
/// get_joint_info of a finger names the joint coupling and the tendon through it; a load of
/// event version 8 lists none of them.
fn equality_and_tendons_are_listed_with_whether_they_are_built() {
    let text = String::from_utf8(fixture("equality_mix.xml")).unwrap().replace("<connect name=\"close_loop\"", "<connect name=\"close_loop\" active=\"false\"");
    let load = |v9: bool| {
        let mut load = common::mjcf_command::load_mjcf("equality_mix.xml", text.as_bytes(), true);
        if let Command::LoadMjcf { ball_joints_and_pairs, keyframe, .. } = &mut load {
            *ball_joints_and_pairs = v9;
            *keyframe = Some("start".into());
        }
        load
    };
    let root = Command::CreateSimulation { simulation_id: "listing".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    let (mut w, _) = World::create(&root).unwrap();
    w.apply(&load(true), &mut |_| true);
    w.apply(&load(false), &mut |_| true);
    let objects = serde_json::to_value(w.object_summaries()).unwrap();
    let listed = |k: usize, what: &str| objects[k][what].clone();
    assert_eq!(
        listed(0, "equality"),
        json!([
            {"name": "close_loop", "type": "connect", "built": false},
            {"name": "stiff_knee", "type": "weld", "built": true},
            {"name": "fingers", "type": "joint", "joints": [5, 6], "built": true}
        ]),
        "{objects}"
    );
    assert_eq!(listed(0, "tendons"), json!([{"name": "split", "type": "fixed", "joints": [5, 6], "built": true}]), "{objects}");
    assert!(listed(1, "equality").is_null() && listed(1, "tendons").is_null(), "a version-8 load lists none: {objects}");
    let finger = serde_json::to_value(w.joint_info(0, 6).unwrap()).unwrap();
    assert_eq!((&finger["equality"], &finger["tendons"]), (&json!(["fingers"]), &json!(["split"])), "{finger}");
    assert!(serde_json::to_value(w.joint_info(1, 6).unwrap()).unwrap().get("equality").is_none());
}

/// Event version 9: a tendon attribute set through a `<default>` class is listed in `ignored`
/// (before, silently not simulated), and a free-base model whose world weld is not built
/// (inactive) gets no static world body for it (before, one was added anyway).
fn tendon_defaults_are_listed_and_an_unbuilt_world_constraint_adds_no_world_body() {
    let load = |text: &str, v9: bool| {
        let mut load = common::mjcf_command::load_mjcf("inline.xml", text.as_bytes(), false);
        if let Command::LoadMjcf { ball_joints_and_pairs, .. } = &mut load {
            *ball_joints_and_pairs = v9;
        }
        load
    };
    let tendon = r#"<mujoco><default><tendon stiffness="2"/></default><worldbody>
        <body name="a"><joint name="j1" type="hinge"/><geom size="0.1"/></body>
        <body name="b" pos="1 0 0"><joint name="j2" type="hinge"/><geom size="0.1"/></body></worldbody>
        <tendon><fixed name="t"><joint joint="j1" coef="1"/><joint joint="j2" coef="1"/></fixed></tendon></mujoco>"#;
    let weld = r#"<mujoco><worldbody><body name="f"><freejoint/><geom size="0.1"/></body></worldbody>
        <equality><weld body1="f" active="false"/></equality></mujoco>"#;
    for v9 in [true, false] {
        let root = Command::CreateSimulation { simulation_id: "v".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
        let (mut w, _) = World::create(&root).unwrap();
        let out = w.apply(&load(tendon, v9), &mut |_| true).to_value();
        let listed = out["ignored"].to_string().contains(r#"<default class=\"main\"><tendon>: stiffness not simulated"#);
        assert_eq!(listed, v9, "{out}");
        let bodies = w.physics().bodies.len();
        w.apply(&load(weld, v9), &mut |_| true);
        assert_eq!(w.physics().bodies.len() - bodies, if v9 { 1 } else { 2 }, "version 9: {v9}");
    }
}
