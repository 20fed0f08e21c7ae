//! Table-driven refusals: every bad input is an `isError` result that
//! names the parameter, and the simulation's state hash and head are unchanged afterwards.

use crate::common;

use common::Server;
use serde_json::{json, Value};

#[tokio::test(flavor = "multi_thread")]
async fn bad_inputs_are_refused_clearly_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-steps", "1000", "--max-objects", "3", "--max-sims", "2"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    c.step(&sim, 10).await;

    let s = sim.as_str();
    let bx = |extra: Value| {
        let mut base = json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]});
        for (k, v) in extra.as_object().unwrap() {
            base[k] = v.clone();
        }
        base
    };
    let not_found = format!("Object 99 not found in simulation {s}");
    let cases: Vec<(&str, Value, &str)> = vec![
        ("add_box", bx(json!({"position": [1, 2]})), "position must be 3 finite numbers"),
        ("add_box", bx(json!({"position": "[NaN, 0, 0]"})), "position"),
        ("add_box", bx(json!({"position": "[1e999, 0, 0]"})), "position"),
        ("add_box", bx(json!({"position": [1e39, 0, 0]})), "position"),
        ("add_box", bx(json!({"position": ["1", "2", "3"]})), "position"),
        ("add_box", bx(json!({"position": true})), "position"),
        ("add_box", bx(json!({"position": [1, 2, 3, 4]})), "position"),
        ("add_box", json!({"sim_id": s, "position": [0, 0, 1]}), "dimensions is required"),
        ("add_box", bx(json!({"dimensions": [0.5, 0.5, -1]})), "dimensions"),
        ("add_box", bx(json!({"mass": -1})), "mass"),
        ("add_box", bx(json!({"mass": "one"})), "mass"), // "1" is read as 1 (scalars in strings)
        ("add_box", bx(json!({"color": [1, 0, 0, 2]})), "color"),
        ("add_box", bx(json!({"color": [1, 0]})), "color"),
        ("add_box", bx(json!({"orientation": [0, 0, 0, 0]})), "orientation"),
        ("add_sphere", json!({"sim_id": s, "radius": 0, "position": [0, 0, 1]}), "radius"),
        ("add_sphere", json!({"sim_id": s, "radius": -1, "position": [0, 0, 1]}), "radius"),
        ("add_cylinder", json!({"sim_id": s, "radius": 0.1, "height": 0, "position": [0, 0, 1]}), "height"),
        ("add_capsule", json!({"sim_id": s, "radius": "abc", "height": 1, "position": [0, 0, 1]}), "radius"),
        ("get_object_state", json!({"sim_id": s, "object_id": 99}), &not_found),
        ("get_object_state", json!({"sim_id": s, "object_id": -1}), "object_id"),
        ("get_object_state", json!({"sim_id": s, "object_id": 1.5}), "object_id"),
        ("get_object_state", json!({"sim_id": "no-such-sim", "object_id": 0}), "Simulation no-such-sim not found"),
        ("step_simulation", json!({"sim_id": s, "steps": 0}), "steps"),
        ("step_simulation", json!({"sim_id": s, "steps": -5}), "steps"),
        ("step_simulation", json!({"sim_id": s, "steps": 10.5}), "steps"),
        ("step_simulation", json!({"sim_id": s, "steps": 1001}), "--max-steps"),
        ("set_timestep", json!({"sim_id": s, "timestep": 0}), "timestep"),
        ("set_timestep", json!({"sim_id": s, "timestep": -0.01}), "timestep"),
        ("set_object_velocity", json!({"sim_id": s, "object_id": 1}), "linear_velocity"),
        ("set_object_velocity", json!({"sim_id": s, "object_id": 1, "linear_velocity": [1, 2, 3, 4]}), "linear_velocity"),
        ("set_object_pose", json!({"sim_id": s, "object_id": 1, "position": [0, 0, 1], "orientation": [0, 0, 0, 0]}), "orientation"),
        ("apply_force", json!({"sim_id": s, "object_id": 1, "force": [1, 2]}), "force"),
        ("apply_force", json!({"sim_id": s, "object_id": 99, "force": [1, 2, 3]}), "Object 99 not found"),
        ("apply_force", json!({"sim_id": s, "object_id": 1, "force": [1, 2, 3], "link_index": 3}), "link_index"),
        ("apply_torque", json!({"sim_id": s, "object_id": 1, "torque": "[1, 2, inf]"}), "torque"),
        ("change_dynamics", json!({"sim_id": s, "object_id": 1}), "at least one property"),
        ("change_dynamics", json!({"sim_id": s, "object_id": 1, "lateral_friction": -0.5}), "lateral_friction"),
        ("change_dynamics", json!({"sim_id": s, "object_id": 1, "mass": -2}), "mass"),
        ("get_dynamics_info", json!({"sim_id": s, "object_id": 1, "link_index": 0}), "link_index"),
        ("remove_object", json!({"sim_id": s, "object_id": 42}), "Object 42 not found"),
        ("add_box", bx(json!({})), "--max-objects"), // 3rd object is fine, the 4th is refused
    ];
    // Fill the object limit first so the last case hits it.
    c.call("add_box", bx(json!({}))).await;
    let info0 = c.call("get_simulation_info", json!({"sim_id": s})).await;
    for (tool, args, expected) in &cases {
        let before = c.hash(s).await;
        let got = c.try_call(tool, args.clone()).await;
        let msg = match got {
            Err(m) => m,
            Ok(v) => panic!("{tool} {args} was accepted: {v}"),
        };
        assert!(msg.contains(expected), "{tool} {args}: message {msg:?} should mention {expected:?}");
        assert!(!msg.contains('\n') && msg.len() < 300, "not one clear sentence: {msg:?}");
        assert_eq!(c.hash(s).await, before, "{tool} {args} changed the state");
    }
    let info1 = c.call("get_simulation_info", json!({"sim_id": s})).await;
    assert_eq!(info0["head_seq"], info1["head_seq"], "a refusal moved the head");
    assert!(info1["last_seq"].as_u64() > info0["last_seq"].as_u64(), "refusals are logged");

    // Simulation-level refusals leave the list unchanged.
    let list0 = c.call("list_simulations", json!({})).await;
    let e = c.try_call("create_simulation", json!({"gravity": [1, 2]})).await.unwrap_err();
    assert!(e.contains("gravity"), "{e}");
    let e = c.try_call("create_simulation", json!({"gui": "yes"})).await.unwrap_err();
    assert!(e.contains("gui"), "{e}");
    c.new_sim(json!({"gravity": [-9.81]})).await; // 2nd sim: the limit
    let e = c.try_call("create_simulation", json!({})).await.unwrap_err();
    assert!(e.contains("Simulation limit reached: 2 simulations (--max-sims)"), "{e}");
    let e = c.try_call("destroy_simulation", json!({"sim_id": "nope"})).await.unwrap_err();
    assert!(e.contains("Simulation nope not found"), "{e}");
    let list1 = c.call("list_simulations", json!({})).await;
    assert_eq!(list1["simulations"].as_array().unwrap().len(), list0["simulations"].as_array().unwrap().len() + 1);
    // The server is still fine.
    assert_eq!(c.step(s, 1).await["steps_taken"], 1);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_wrongly_typed_request_is_a_tool_error_not_a_protocol_error() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let r = c.raw("add_box", json!({"sim_id": 12, "dimensions": {"a": 1}})).await;
    assert_eq!(r.is_error, Some(true));
}
