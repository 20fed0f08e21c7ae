//! Refusals that say what to do next, each followed: the refusal names the way on, that way
//! is taken, and it works — a look-back from an undone branch (to_seq there, or a fork at it),
//! an animation of a fork that has not stepped (the inherited step by its seq), a picture over
//! the pixel limit (the size it names). PyBullet's spellings of a control mode (any case,
//! without `_CONTROL`, its integer constants) are accepted; the modes it has and this server
//! does not are refused naming the one to use. Every refusal changes nothing.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// The state hash and head of `sim`, to check a refusal changed nothing.
async fn mark(c: &Client, sim: &str) -> (Value, Value) {
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    (info["state_hash"].clone(), info["head_seq"].clone())
}

/// `tool` is refused with one sentence holding every one of `words`, and `sim` is unchanged.
async fn refused(c: &Client, sim: &str, tool: &str, args: Value, words: &[&str]) -> String {
    let before = mark(c, sim).await;
    let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} must be refused"));
    for w in words {
        assert!(err.contains(w), "{tool} {args}: {err:?} should say {w:?}");
    }
    assert!(!err.contains('\n') && err.len() < 400, "one sentence: {err:?}");
    assert_eq!(mark(c, sim).await, before, "{tool} {args} changed the simulation");
    err
}

/// The first `WxH` in `text` that is followed by `follows`.
fn size_before(text: &str, follows: &str) -> (u64, u64) {
    let at = text.find(follows).unwrap_or_else(|| panic!("{text:?} names no size"));
    let size = text[..at].trim_end().rsplit(' ').next().unwrap();
    let (w, h) = size.split_once('x').unwrap();
    (w.parse().unwrap(), h.parse().unwrap())
}

#[tokio::test(flavor = "multi_thread")]
async fn each_refusal_names_a_way_on_and_that_way_works() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-image-px", "12000"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    c.ground(s).await;
    c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [0, 0, 1]})).await;
    c.step(s, 30).await;
    let undone = mark(&c, s).await.1.as_u64().unwrap();
    c.call("undo", json!({"sim_id": s})).await;
    c.step(s, 20).await;

    // A look-back from the undone step: to_seq there works, and so does a fork at it.
    let from = undone.to_string();
    let err = refused(&c, s, "get_trajectory", json!({"sim_id": s, "from_seq": undone}), &["from_seq", &format!("to_seq={from}"), &format!("fork_simulation at_seq={from}")]).await;
    assert!(err.contains("another branch"), "{err}");
    let there = c.call("get_trajectory", json!({"sim_id": s, "to_seq": undone})).await;
    assert_eq!(there["to_seq"], json!(undone));
    assert!(there["steps"].as_array().unwrap().last().unwrap().as_u64().unwrap() >= 30, "{there}");
    let fork = c.call("fork_simulation", json!({"sim_id": s, "at_seq": undone})).await;
    let f = fork["simulation_id"].as_str().unwrap().to_string();

    // A fork that has not stepped has nothing of its own to animate; the inherited step does.
    let err = refused(&c, &f, "render_animation", json!({"sim_id": f, "width": 40, "height": 30}), &["Nothing to animate", "step_simulation", &format!("to_seq={undone}")]).await;
    assert!(err.contains(s), "names the parent: {err}");
    let gif = c.call("render_animation", json!({"sim_id": f, "to_seq": undone, "width": 40, "height": 30})).await;
    assert!(gif["frames"].as_u64().unwrap() > 1 && gif["steps"] == json!(30), "{gif}");

    // A picture over the limit names a size that fits, and that size is taken.
    let err = refused(&c, s, "get_camera_image", json!({"sim_id": s, "width": 400, "height": 300}), &["Image too large", "12000"]).await;
    let (w, h) = size_before(&err, "keeps its shape and fits");
    assert!(w * h <= 12_000 && (w as f64 / h as f64 - 4.0 / 3.0).abs() < 0.05, "{w}x{h}");
    let img = c.call("get_camera_image", json!({"sim_id": s, "width": w, "height": h})).await;
    assert_eq!((img["width"].as_u64(), img["height"].as_u64()), (Some(w), Some(h)), "{img}");
    let err = refused(&c, s, "render_animation", json!({"sim_id": s, "width": 400, "height": 300}), &["Image too large", "width"]).await;
    let (w, h) = size_before(&err, "keeps its shape and fits");
    c.call("render_animation", json!({"sim_id": s, "width": w, "height": h})).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn control_modes_are_read_as_pybullet_spells_them() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let robot = c.call("load_urdf", json!({"sim_id": s, "file_path": "kuka_iiwa/model.urdf", "use_fixed_base": true})).await;
    let id = robot["object_id"].clone();
    // Each spelling means the mode: a position target is required exactly when it is position control.
    for mode in [json!("position"), json!("Position_Control"), json!("position control"), json!(2), json!("2")] {
        refused(&c, s, "set_joint_motor_control", json!({"sim_id": s, "object_id": id, "joint_index": 1, "control_mode": mode}), &["target_position is required for POSITION_CONTROL"]).await;
        c.call("set_joint_motor_control", json!({"sim_id": s, "object_id": id, "joint_index": 1, "control_mode": mode, "target_position": 0.3})).await;
    }
    for mode in [json!("velocity"), json!(0), json!("TORQUE"), json!(1)] {
        c.call("set_joint_motor_control", json!({"sim_id": s, "object_id": id, "joint_index": 1, "control_mode": mode, "force": 1})).await;
    }
    c.call("set_joint_motor_control_array", json!({"sim_id": s, "object_id": id, "joint_indices": [0, 1], "control_mode": "position", "target_positions": [0.1, 0.2]})).await;
    for mode in [json!("PD_CONTROL"), json!(3), json!(4)] {
        refused(&c, s, "set_joint_motor_control", json!({"sim_id": s, "object_id": id, "joint_index": 1, "control_mode": mode, "target_position": 0.3}), &["control_mode", "is not supported", "use POSITION_CONTROL"]).await;
    }
    for (mode, words) in [(json!(7), vec!["control_mode must be", "PyBullet's 2, 0 or 1"]), (json!("sideways"), vec!["control_mode must be", "SIDEWAYS_CONTROL"]), (json!(true), vec!["control_mode must be a string"])] {
        refused(&c, s, "set_joint_motor_control", json!({"sim_id": s, "object_id": id, "joint_index": 1, "control_mode": mode, "target_position": 0.3}), &words).await;
    }
}
