//! MJCF equality constraints and fixed tendons (event version 8), against MuJoCo itself
//! (tests/reference/mjcf_equality.json, written by scripts/mjcf_equality_reference.py from the
//! hand-written tests/fixtures/mjcf/equality_mix.xml), over MCP/HTTP on one server:
//! - the Panda's hand as Menagerie writes it: one `<general>` actuator on the fixed tendon
//!   "split" opens, closes and half-opens both fingers, which `<equality><joint>` keeps equal;
//! - a parallelogram closed by `<connect>` and a pendulum bent rigid by `<weld relpose>` swing
//!   as in MuJoCo (RMS per joint within a stated tolerance);
//! - a load recorded before event version 8 (`constraints` false) builds none of them and lists
//!   them in `ignored`, as it always did.

use crate::common;

use std::path::Path;

use common::{Client, Server};
use physics_mcp::command::{Blob, Command};
use physics_mcp::world::World;
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/mjcf_equality.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// RMS tolerance per joint against MuJoCo's trajectory, rad for the hinges (MuJoCo's equality
/// constraints are soft, `solref` 0.02 s, where rapier's are rigid: MuJoCo's weld sags 0.0014
/// rad below its relpose; the integrators differ) and m for the fingers (range 0.04 m).
/// Measured 29 November 2026: a, bar, b ≤ 0.0010, p 0.0020, t 0.0014, fingers 0.0001.
fn tolerance(joint: &str) -> f64 {
    match joint {
        "finger_joint1" | "finger_joint2" => 0.001,
        _ => 0.01,
    }
}

/// The two fingers stay within this of each other (m) at every sample: the coupling is rigid.
const FINGERS_EQUAL_M: f64 = 1e-4;

#[tokio::test(flavor = "multi_thread")]
async fn equalities_and_tendon_actuators_follow_mujoco() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    let (rms, states) = drive(&c, &r).await;
    let names: Vec<&str> = r["joints"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
    eprintln!("REPORT RMS per joint against MuJoCo: {:?}", names.iter().zip(&rms).map(|(n, x)| format!("{n} {x:.4}")).collect::<Vec<_>>());
    for (name, x) in names.iter().zip(&rms) {
        assert!(*x <= tolerance(name), "{name}: RMS {x} over {}", tolerance(name));
    }
    let worst = states.iter().map(|q| (q[5] - q[6]).abs()).fold(0.0, f64::max);
    assert!(worst <= FINGERS_EQUAL_M, "fingers differ by up to {worst} m");
    let (open, closed, half) = (states[49][5], states[99][5], states[149][5]);
    assert!(open > 0.035 && closed < 0.003 && (half - 0.02).abs() < 0.002, "fingers open {open}, closed {closed}, half {half}");
    older_loads_build_none();
    bounded_counts_and_names(&c, &server).await;
}

/// A model of more than `MAX_MODEL_ELEMENTS` actuators is refused at the edge, naming
/// file_path; an unknown sensor name is refused listing a bounded few of the model's sensors.
async fn bounded_counts_and_names(c: &Client, server: &Server) {
    let model = |actuators: usize, sensors: usize| {
        let a: String = (0..actuators).map(|k| format!("<motor name=\"m{k}\" joint=\"j\"/>")).collect();
        let s: String = (0..sensors).map(|k| format!("<jointpos name=\"s{k}\" joint=\"j\"/>")).collect();
        format!(
            r#"<mujoco><worldbody><body name="a"><joint name="j" type="hinge"/><geom type="sphere" size="0.1" mass="1"/></body></worldbody>
            <actuator>{a}</actuator><sensor>{s}</sensor></mujoco>"#
        )
    };
    let most = physics_mcp::limits::MAX_MODEL_ELEMENTS;
    std::fs::write(server.workspace.join("many_actuators.xml"), model(most + 1, 1)).unwrap();
    std::fs::write(server.workspace.join("many_sensors.xml"), model(1, 20)).unwrap();
    let sim = c.new_sim(json!({})).await;
    let refused = c.try_call("load_mjcf", json!({"sim_id": sim, "file_path": "many_actuators.xml"})).await.unwrap_err();
    assert!(refused.contains(&format!("file_path has {} actuators; a model may have at most {most}", most + 1)), "{refused}");
    // Contact pairs are bounded as the other elements are.
    let pairs: String = (0..=most).map(|_| r#"<pair geom1="g" geom2="g"/>"#).collect();
    let many_pairs = format!(
        r#"<mujoco><worldbody><body name="a"><joint name="j" type="hinge"/><geom name="g" type="sphere" size="0.1" mass="1"/></body></worldbody>
        <contact>{pairs}</contact></mujoco>"#
    );
    std::fs::write(server.workspace.join("many_pairs.xml"), many_pairs).unwrap();
    let refused = c.try_call("load_mjcf", json!({"sim_id": sim, "file_path": "many_pairs.xml"})).await.unwrap_err();
    assert!(refused.contains(&format!("file_path has {} contact pairs; a model may have at most {most}", most + 1)), "{refused}");
    // One tendon listing a joint `most` times under two actuators: its terms are bounded too.
    let terms: String = (0..most).map(|_| r#"<joint joint="j" coef="1"/>"#).collect();
    let tendon = format!(
        r#"<mujoco><worldbody><body name="a"><joint name="j" type="hinge"/><geom type="sphere" size="0.1" mass="1"/></body></worldbody>
        <tendon><fixed name="t">{terms}</fixed></tendon><actuator><motor tendon="t"/><motor tendon="t"/></actuator></mujoco>"#
    );
    std::fs::write(server.workspace.join("long_tendon.xml"), tendon).unwrap();
    let refused = c.try_call("load_mjcf", json!({"sim_id": sim, "file_path": "long_tendon.xml"})).await.unwrap_err();
    assert!(refused.contains(&format!("list {} joint terms in all; a model may have at most {most}", 3 * most)), "{refused}");
    // A joint coupling whose joints' refs would overflow the offset in f32 is not built (listed).
    let coupled = r#"<mujoco><worldbody><body name="a"><joint name="j1" type="hinge" ref="3e38"/><geom type="sphere" size="0.1" mass="1"/>
        <body name="b" pos="0 0 -0.3"><joint name="j2" type="hinge" ref="-3e38"/><geom type="sphere" size="0.1" mass="1"/></body></body></worldbody>
        <equality><joint name="c" joint1="j1" joint2="j2" polycoef="0 1 0 0 0"/></equality></mujoco>"#;
    std::fs::write(server.workspace.join("huge_ref.xml"), coupled).unwrap();
    let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "huge_ref.xml"})).await;
    assert!(loaded["ignored"].to_string().contains("ref must be within"), "{loaded}");
    let stepped = c.call("step_simulation", json!({"sim_id": sim, "steps": 10})).await;
    assert!(stepped.get("time").is_some(), "{stepped}");
    let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "many_sensors.xml"})).await;
    let id = loaded["object_id"].as_u64().unwrap();
    let refused = c.try_call("get_sensor_data", json!({"sim_id": sim, "object_id": id, "names": ["nope"]})).await.unwrap_err();
    assert!(refused.contains("names lists no sensor \"nope\"") && refused.contains("and 12 more") && !refused.contains("s19"), "{refused}");
}

/// Loads the fixture at its keyframe, holds the reference's control schedule, and returns each
/// joint's RMS difference from MuJoCo's samples and our samples.
async fn drive(c: &Client, r: &Value) -> (Vec<f64>, Vec<Vec<f64>>) {
    let sim = c.new_sim(json!({})).await;
    let loaded = c
        .call("load_mjcf", json!({"sim_id": sim, "file_path": "mjcf/equality_mix.xml", "use_model_options": true, "keyframe": "start"}))
        .await;
    let ignored = loaded["ignored"].to_string();
    assert!(!ignored.contains("<equality>") && !ignored.contains("<tendon>") && !ignored.contains("not built"), "{ignored}");
    assert_eq!(loaded["actuators"][0]["name"], "gripper", "{loaded}");
    let id = loaded["object_id"].as_u64().unwrap();
    let every = r["every"].as_u64().unwrap();
    let n = r["joints"].as_array().unwrap().len();
    let joints: Vec<usize> = (0..n).collect();
    let mut calls = Vec::new();
    for s in r["schedule"].as_array().unwrap() {
        calls.push(json!({"tool": "set_actuator_controls", "arguments": {"object_id": id, "controls": [s["ctrl"]]}}));
        for _ in 0..s["steps"].as_u64().unwrap() / every {
            calls.push(json!({"tool": "step_simulation", "arguments": {"steps": every}}));
            calls.push(json!({"tool": "get_joint_states", "arguments": {"object_id": id, "joint_indices": joints}}));
        }
    }
    let out = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let states: Vec<Vec<f64>> = out["results"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|x| x.get("joint_states"))
        .map(|s| (0..n).map(|j| s[j]["joint_position"].as_f64().unwrap()).collect())
        .collect();
    let samples = r["samples"].as_array().unwrap();
    assert_eq!(states.len(), samples.len());
    let mut sq = vec![0.0; n];
    for (ours, theirs) in states.iter().zip(samples) {
        for j in 0..n {
            sq[j] += (ours[j] - theirs["qpos"][j].as_f64().unwrap()).powi(2);
        }
    }
    (sq.iter().map(|s| (s / samples.len() as f64).sqrt()).collect(), states)
}

/// A load as recorded before event version 8 (`constraints` false): nothing of the equality
/// block or the tendon is built and both stay in `ignored`, as they always did.
fn older_loads_build_none() {
    let bytes = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mjcf/equality_mix.xml")).unwrap();
    let mut load = common::mjcf_command::load_mjcf("equality_mix.xml", &bytes, false);
    if let Command::LoadMjcf { constraints, mjcf, .. } = &mut load {
        *constraints = false;
        *mjcf = Blob::new(bytes.clone());
    }
    let root = Command::CreateSimulation { simulation_id: "v7".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    let (mut w, _) = World::create(&root).unwrap();
    let out = w.apply(&load, &mut |_| true).to_value();
    let ignored = out["ignored"].to_string();
    assert!(ignored.contains("<equality>: equality constraints are not simulated") && ignored.contains("<tendon>: fixed tendons are not simulated"), "{ignored}");
    assert!(ignored.contains("actuator gripper: tendon split transmissions are not simulated"), "{ignored}");
    assert_eq!(out["actuators"].as_array().map_or(0, Vec::len), 0, "{out}");
}
