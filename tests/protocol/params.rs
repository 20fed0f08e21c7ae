//! One parameter model: over HTTP, a misspelled or
//! unknown parameter is refused naming it, scalars and vectors sent as strings are accepted,
//! a value of the wrong type is refused with a sentence naming the parameter, and a refusal
//! changes nothing (state hash and head). Every tool's arguments are parsed as the type its
//! input schema describes: the refusal of an unknown parameter lists the parsed type's
//! parameters, which must be exactly the schema's properties.

use crate::common;

use common::Server;
use serde_json::{json, Value};

#[tokio::test(flavor = "multi_thread")]
async fn unknown_parameters_are_refused_and_strings_are_read_as_their_values() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gravity": "-9.81", "gui": "false"})).await;
    let s = sim.as_str();
    c.ground(s).await;
    c.call("add_sphere", json!({"sim_id": s, "radius": "0.1", "position": "[0, 0, 1]", "mass": "2"})).await;

    // Refused: (tool, arguments, words the sentence must hold).
    let refused: Vec<(&str, Value, Vec<&str>)> = vec![
        ("step_simulation", json!({"sim_id": s, "step": 240}), vec!["`step`", "step_simulation", "`steps`"]),
        ("add_box", json!({"sim_id": s, "dimension": [1, 1, 1], "position": [0, 0, 1]}), vec!["`dimension`", "`dimensions`"]),
        ("get_object_state", json!({"sim_id": s, "object_id": 1, "objectid": 1}), vec!["`objectid`", "`object_id`"]),
        ("apply_force", json!({"sim_id": s, "object_id": 1, "force": [1, 0, 0], "pos": [0, 0, 0]}), vec!["`pos`"]),
        ("set_timestep", json!({"sim_id": s, "timestep": 0.01, "substeps": 2}), vec!["`substeps`"]),
        ("get_simulation_info", json!({"sim_id": s, "verbose": true}), vec!["`verbose`"]),
        ("undo", json!({"sim_id": s, "cout": 1}), vec!["`cout`", "`count`"]),
        ("ray_test", json!({"sim_id": s, "ray_from": [0, 0, 2], "ray_to": [0, 0, -1], "flags": 0}), vec!["`flags`"]),
        ("step_simulation", json!({"sim_id": s, "steps": "abc"}), vec!["steps must be an integer", "\"abc\""]),
        ("step_simulation", json!({"sim_id": s, "steps": "10.5"}), vec!["steps"]),
        ("step_simulation", json!({"sim_id": s, "steps": " 1"}), vec!["steps"]),
        ("step_simulation", json!({"sim_id": s, "steps": [1]}), vec!["steps must be an integer"]),
        ("set_timestep", json!({"sim_id": s, "timestep": "NaN"}), vec!["timestep must be a finite number"]),
        ("set_timestep", json!({"sim_id": s, "timestep": "inf"}), vec!["timestep"]),
        ("add_sphere", json!({"sim_id": s, "radius": "1e39", "position": [0, 0, 1]}), vec!["radius"]),
        ("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": ["0", "0", "1"]}), vec!["position must be 3 finite numbers"]),
        ("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [0, 0, 1], "mass": "heavy"}), vec!["mass must be a finite number", "\"heavy\""]),
        ("add_sphere", json!({"sim_id": s, "radius": 0.1}), vec!["position is required"]),
        ("set_object_pose", json!({"sim_id": s, "object_id": "one", "position": [0, 0, 1]}), vec!["object_id must be an integer"]),
        ("enable_debug_visualization", json!({"sim_id": s, "show_contacts": "yes"}), vec!["show_contacts must be true or false"]),
        ("load_urdf", json!({"sim_id": s, "file_path": 7}), vec!["file_path must be a string"]),
        ("get_camera_image", json!({"sim_id": s, "width": 8, "height": 8, "include_depth": 1}), vec!["include_depth must be true or false"]),
    ];
    for (tool, args, words) in &refused {
        let before = c.call("get_simulation_info", json!({"sim_id": s})).await;
        let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} must be refused"));
        for w in words {
            assert!(err.contains(w), "{tool} {args}: {err:?} should mention {w:?}");
        }
        assert!(!err.contains('\n') && !err.contains('\u{1}') && err.len() < 300, "one clear sentence: {err:?}");
        let after = c.call("get_simulation_info", json!({"sim_id": s})).await;
        assert_eq!(after["state_hash"], before["state_hash"], "{tool} {args} changed the state");
        assert_eq!(after["head_seq"], before["head_seq"], "{tool} {args} moved the head");
    }
    // Tools without a simulation refuse unknown parameters too, and create nothing.
    let listed = |v: Value| v["simulations"].as_array().unwrap().len();
    let n = listed(c.call("list_simulations", json!({})).await);
    for (tool, args, word) in [
        ("create_simulation", json!({"gravty": -9.81}), "`gravty`"),
        ("list_simulations", json!({"all": true}), "`all`"),
        ("compute_projection_matrix", json!({"fov": 60, "aspect": 1, "near_plane": 0.1, "far_plane": 10, "far": 1}), "`far`"),
        ("compute_view_matrix_from_yaw_pitch", json!({"distance": 1, "yaw": 0, "pitch": 0, "target_position": [0, 0, 0], "roll": 5}), "roll must be 0"),
        ("fork_simulation", json!({"sim_id": s, "at": 1}), "`at`"),
        ("destroy_simulation", json!({"sim_id": s, "force": true}), "`force`"),
    ] {
        let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} must be refused"));
        assert!(err.contains(word), "{tool} {args}: {err:?} should mention {word:?}");
    }
    assert_eq!(listed(c.call("list_simulations", json!({})).await), n, "a refused call created or destroyed a simulation");

    // Accepted: scalars, booleans and vectors as strings, integral floats, gravity shorthands.
    let accepted: Vec<(&str, Value)> = vec![
        ("step_simulation", json!({"sim_id": s, "steps": "240"})),
        ("step_simulation", json!({"sim_id": s, "steps": 2.0})),
        ("set_timestep", json!({"sim_id": s, "timestep": "0.005"})),
        ("add_box", json!({"sim_id": s, "dimensions": "[0.1, 0.1, 0.1]", "position": "[0,0,1]", "mass": "0.5", "color": "[1, 0, 0]"})),
        ("apply_force", json!({"sim_id": s, "object_id": "1", "force": "[0, 0, 1]", "link_index": "-1"})),
        ("enable_debug_visualization", json!({"sim_id": s, "show_contacts": "false", "show_frames": "true"})),
        ("get_object_state", json!({"sim_id": s, "object_id": "1"})),
        ("get_dynamics_info", json!({"sim_id": s, "object_id": 1.0})),
        ("get_camera_image", json!({"sim_id": s, "width": "8", "height": "8", "include_depth": "true"})),
        ("compute_view_matrix_from_yaw_pitch", json!({"distance": "2", "yaw": "30", "pitch": "-20", "target_position": "[0, 0, 0]", "up_axis_index": "2", "roll": "0"})),
    ];
    for (tool, args) in &accepted {
        c.try_call(tool, args.clone()).await.unwrap_or_else(|e| panic!("{tool} {args} was refused: {e}"));
    }
    // The string forms mean what the canonical forms mean.
    let a = c.new_sim(json!({"gravity": "[-3.5]", "gui": "true"})).await;
    let b = c.new_sim(json!({"gravity": [0, 0, -3.5], "gui": true})).await;
    let ia = c.call("get_simulation_info", json!({"sim_id": a})).await;
    let ib = c.call("get_simulation_info", json!({"sim_id": b})).await;
    assert_eq!(ia["gravity"], json!([0.0, 0.0, -3.5]));
    assert_eq!((&ia["gravity"], &ia["gui_enabled"]), (&ib["gravity"], &ib["gui_enabled"]));
    assert_eq!(ia["state_hash"], ib["state_hash"]);
}

#[tokio::test(flavor = "multi_thread")]
async fn every_tool_parses_its_arguments_as_the_type_its_schema_describes() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let before = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let tools = c.service.list_all_tools().await.expect("tools/list");
    assert!(tools.len() >= 40, "{} tools", tools.len());
    for tool in &tools {
        let schema = Value::Object((*tool.input_schema).clone());
        assert_eq!(schema["additionalProperties"], json!(false), "{}: schema must refuse unknown parameters", tool.name);
        let mut declared: Vec<String> = schema["properties"].as_object().map(|p| p.keys().cloned().collect()).unwrap_or_default();
        declared.sort();
        // A call with every required parameter missing but sim_id, plus an unknown one: the
        // unknown one is refused first, listing the parameters of the type actually parsed.
        let mut args = json!({"__probe__": 1});
        if declared.iter().any(|k| k == "sim_id") {
            args["sim_id"] = json!(sim);
        }
        let err = c.try_call(&tool.name, args).await.expect_err(&format!("{}: an unknown parameter must be refused", tool.name));
        assert!(err.contains("`__probe__`") && err.contains(tool.name.as_ref()), "{}: {err:?}", tool.name);
        let mut parsed: Vec<String> = match err.split_once("expected one of: ") {
            Some((_, list)) => list.split(", ").map(str::to_string).collect(),
            None => {
                assert!(err.contains("it takes no parameters"), "{}: {err:?}", tool.name);
                Vec::new()
            }
        };
        parsed.sort();
        assert_eq!(parsed, declared, "{}: the parsed parameters differ from the input schema's", tool.name);
    }
    // Nothing the probes did changed the simulation.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!((&info["head_seq"], &info["state_hash"]), (&before["head_seq"], &before["state_hash"]));
}
