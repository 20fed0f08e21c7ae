//! Every tool declares an `outputSchema` that its results validate against (docs/tools.md "Conventions"): a scenario on the real server calls every listed tool successfully once
//! and validates each `structuredContent` with an independent JSON Schema validator. Both
//! schemas of every tool are plain JSON Schema 2020-12 (no `$schema`, `title` or non-standard
//! `format`).

use crate::common;

use std::collections::{BTreeMap, BTreeSet};

use common::{Client, Server};
use rmcp::model::Tool;
use serde_json::{json, Value};

/// The `format` values JSON Schema 2020-12 defines.
const STANDARD_FORMATS: &[&str] = &[
    "date-time", "date", "time", "duration", "email", "idn-email", "hostname", "idn-hostname",
    "ipv4", "ipv6", "uri", "uri-reference", "iri", "iri-reference", "uuid", "uri-template",
    "json-pointer", "relative-json-pointer", "regex",
];

/// Where in `schema` (a JSON pointer) a string-valued `$schema`, `title` or non-standard
/// `format` appears. A property *named* title or format has an object value, so it passes.
fn boilerplate(schema: &Value, at: &str, found: &mut Vec<String>) {
    match schema {
        Value::Object(map) => {
            for (k, v) in map {
                let here = format!("{at}/{k}");
                match (k.as_str(), v) {
                    ("$schema" | "title", Value::String(_)) => found.push(here),
                    ("format", Value::String(f)) if !STANDARD_FORMATS.contains(&f.as_str()) => {
                        found.push(format!("{here} = {f}"))
                    }
                    _ => boilerplate(v, &here, found),
                }
            }
        }
        Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                boilerplate(v, &format!("{at}/{i}"), found);
            }
        }
        _ => {}
    }
}

/// Calls tools and validates each success against the tool's declared output schema.
struct Checker<'a> {
    client: &'a Client,
    schemas: BTreeMap<String, Value>,
    checked: BTreeSet<String>,
}

impl Checker<'_> {
    /// Calls `tool`, requires success, validates `structuredContent`, returns it.
    async fn call(&mut self, tool: &str, args: Value) -> Value {
        let result = self.client.call(tool, args).await;
        let schema = &self.schemas[tool];
        let validator = jsonschema::validator_for(schema)
            .unwrap_or_else(|e| panic!("{tool}: its outputSchema is not a valid schema: {e}"));
        let errors: Vec<String> = validator.iter_errors(&result).map(|e| format!("{} at {}", e, e.instance_path())).collect();
        assert!(errors.is_empty(), "{tool}: result does not validate against its outputSchema: {errors:?}\nresult: {result}");
        self.checked.insert(tool.to_string());
        result
    }
}

fn id(v: &Value, field: &str) -> Value {
    v[field].clone()
}

/// Every tool's input and output schema, as listed.
async fn listed(client: &Client) -> Vec<Tool> {
    client.service.list_all_tools().await.expect("tools/list")
}

#[tokio::test(flavor = "multi_thread")]
async fn every_tool_declares_an_output_schema_that_its_results_validate_against() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let client = server.client().await;
    let tools = listed(&client).await;

    let mut schemas = BTreeMap::new();
    let mut missing = Vec::new();
    for tool in &tools {
        match &tool.output_schema {
            Some(s) if s.get("type") == Some(&json!("object")) => {
                schemas.insert(tool.name.to_string(), Value::Object((**s).clone()));
            }
            _ => missing.push(tool.name.to_string()),
        }
    }
    assert!(missing.is_empty(), "tools without an object outputSchema: {missing:?}");

    let mut c = Checker { client: &client, schemas, checked: BTreeSet::new() };
    let sim = id(&c.call("create_simulation", json!({"gravity": [0, 0, -9.81], "gui": true})).await, "simulation_id");
    let ground = id(&c.call("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})).await, "object_id");
    let cube = id(&c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [2, 0, 0.2]})).await, "object_id");
    let ball = id(&c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [-2, 0, 1]})).await, "object_id");
    let can = id(&c.call("add_cylinder", json!({"sim_id": sim, "radius": 0.1, "height": 0.4, "position": [0, 2, 0.2]})).await, "object_id");
    c.call("add_capsule", json!({"sim_id": sim, "radius": 0.1, "height": 0.3, "position": [0, -2, 1]})).await;
    c.call("set_timestep", json!({"sim_id": sim, "timestep": 0.004})).await;
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": ball, "position": [-2, 0, 0.5]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": ball, "linear_velocity": [0, 0, 1]})).await;
    c.call("apply_force", json!({"sim_id": sim, "object_id": cube, "force": [0, 0, 5]})).await;
    c.call("apply_torque", json!({"sim_id": sim, "object_id": cube, "torque": [0, 0, 0.1]})).await;
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": cube, "lateral_friction": 0.8, "restitution": 0.1})).await;
    c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": cube})).await;
    c.call("enable_debug_visualization", json!({"sim_id": sim, "show_frames": true})).await;
    c.call("set_camera", json!({"sim_id": sim, "distance": 6, "yaw": 30, "pitch": -30, "target": [0, 0, 0]})).await;

    // A robot: the fixture arm, its joints, a motor, inverse kinematics.
    let arm = id(&c.call("load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "position": [0, 0, 2], "use_fixed_base": true})).await, "object_id");
    c.call("get_num_joints", json!({"sim_id": sim, "object_id": arm})).await;
    c.call("get_joint_info", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    c.call("set_joint_motor_control", json!({"sim_id": sim, "object_id": arm, "joint_index": 0, "control_mode": "POSITION_CONTROL", "target_position": 0.3})).await;
    c.call("set_joint_motor_control_array", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 1], "control_mode": "POSITION_CONTROL", "target_positions": [0.3, 0.1]})).await;
    c.call("set_collision_filter_group_mask", json!({"sim_id": sim, "object_id": ball, "collision_filter_group": 2, "collision_filter_mask": 1})).await;
    c.call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": ball, "object_id_b": arm, "enable_collision": false})).await;
    c.call("step_simulation", json!({"sim_id": sim, "steps": 60})).await;
    c.call("step_simulation", json!({"sim_id": sim, "steps": 5, "sample_every": 2})).await;
    c.call("get_trajectory", json!({"sim_id": sim, "include_velocities": true})).await;
    c.call("render_animation", json!({"sim_id": sim, "width": 32, "height": 24, "every": 50})).await;
    c.call("get_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    c.call("reset_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 1, "target_value": 0.2, "target_velocity": 0.1})).await;
    c.call("get_link_state", json!({"sim_id": sim, "object_id": arm, "link_index": 1})).await;
    c.call("calculate_inverse_kinematics", json!({"sim_id": sim, "object_id": arm, "end_effector_link_index": 1, "target_position": [0.5, 0, 1.6]})).await;
    c.call("enable_joint_force_torque_sensor", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    c.call("get_joint_states", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 1]})).await;
    c.call("get_link_states", json!({"sim_id": sim, "object_id": arm, "link_indices": [-1, 1]})).await;
    let (q, zero) = (json!([0.1, 0.2]), json!([0, 0]));
    c.call("calculate_jacobian", json!({"sim_id": sim, "object_id": arm, "link_index": 1, "local_position": [0, 0, 0.1],
        "obj_positions": q, "obj_velocities": zero, "obj_accelerations": zero})).await;
    c.call("calculate_mass_matrix", json!({"sim_id": sim, "object_id": arm, "obj_positions": q})).await;
    c.call("get_aabb", json!({"sim_id": sim, "object_id": arm, "link_index": 1})).await;
    c.call("get_overlapping_objects", json!({"sim_id": sim, "aabb_min": [-1, -1, 0], "aabb_max": [1, 1, 3]})).await;
    c.call("calculate_inverse_dynamics", json!({"sim_id": sim, "object_id": arm, "obj_positions": q, "obj_velocities": zero, "obj_accelerations": zero})).await;
    c.call("get_closest_points", json!({"sim_id": sim, "body_a": arm, "body_b": ball, "distance": 100})).await;
    c.call("set_joint_trajectory", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 1], "times": [0.5, 1], "positions": [q, zero]})).await;
    c.call("get_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 0})).await;
    let mj = id(&c.call("create_simulation", json!({})).await, "simulation_id");
    let reacher = id(&c.call("load_mjcf", json!({"sim_id": mj, "file_path": "mjcf/reacher.xml"})).await, "object_id");
    c.call("set_actuator_controls", json!({"sim_id": mj, "object_id": reacher, "controls": [0.1, -0.1]})).await;
    let arm = id(&c.call("load_mjcf", json!({"sim_id": mj, "file_path": "mjcf/sensor_arm.xml"})).await, "object_id");
    c.call("get_sensor_data", json!({"sim_id": mj, "object_id": arm})).await;
    c.call("get_joint_info", json!({"sim_id": mj, "object_id": arm, "joint_index": 0})).await;
    c.call("get_simulation_info", json!({"sim_id": mj})).await;
    c.call("generate_revolute_joint", json!({"parent_shape": "box", "child_shape": "cylinder", "parent_dimensions": [0.1, 0.1, 0.1], "child_dimensions": [0.05, 0.3]})).await;
    // Built-in models and workspace files.
    c.call("list_models", json!({"filter": "kuka"})).await;
    c.call("write_file", json!({"path": "agent/box.urdf", "content": "<robot name=\"b\"><link name=\"l\"/></robot>"})).await;
    c.call("list_files", json!({"path": "agent"})).await;

    // Constraints, then sensing on the settled scene.
    let k = id(&c.call("create_constraint", json!({"sim_id": sim, "parent_id": can, "child_id": -1, "joint_type": "fixed"})).await, "constraint_id");
    c.call("remove_constraint", json!({"sim_id": sim, "constraint_id": k})).await;
    c.call("get_object_state", json!({"sim_id": sim, "object_id": cube})).await;
    c.call("ray_test", json!({"sim_id": sim, "ray_from": [2, 0, 3], "ray_to": [2, 0, -3]})).await;
    c.call("ray_test_batch", json!({"sim_id": sim, "rays_from": [[2, 0, 3], [9, 9, 3]], "rays_to": [[2, 0, -3], [9, 9, 2]]})).await;
    let all = c.call("get_all_collisions", json!({"sim_id": sim})).await;
    assert!(!all["contacts"].as_array().unwrap().is_empty(), "the scene must have contacts to validate");
    c.call("get_collisions_for_pair", json!({"sim_id": sim, "obj_a": cube, "obj_b": ground})).await;
    let view = c.call("compute_view_matrix", json!({"camera_eye_position": [4, 4, 3], "camera_target_position": [0, 0, 0], "camera_up_vector": [0, 0, 1]})).await;
    c.call("compute_view_matrix_from_yaw_pitch", json!({"distance": 5, "yaw": 45, "pitch": -30, "target_position": [0, 0, 0]})).await;
    let projection = c.call("compute_projection_matrix", json!({"fov": 60, "aspect": 1.5, "near_plane": 0.01, "far_plane": 100})).await;
    c.call("get_camera_image", json!({"sim_id": sim, "width": 12, "height": 8, "view_matrix": view["view_matrix"],
        "projection_matrix": projection["projection_matrix"], "include_depth": true, "include_segmentation": true})).await;

    // The time machine and persistence.
    c.call("remove_object", json!({"sim_id": sim, "object_id": ball})).await;
    c.call("undo", json!({"sim_id": sim})).await;
    c.call("redo", json!({"sim_id": sim})).await;
    c.call("get_history", json!({"sim_id": sim, "limit": 20})).await;
    let fork = id(&c.call("fork_simulation", json!({"sim_id": sim})).await, "simulation_id");
    c.call("verify_simulation", json!({"sim_id": fork})).await;
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "saves/all_tools.json"})).await;
    let loaded = id(&c.call("load_simulation", json!({"file_path": "saves/all_tools.json"})).await, "simulation_id");
    c.call("get_simulation_info", json!({"sim_id": loaded})).await;
    c.call("list_simulations", json!({})).await;
    c.call("destroy_simulation", json!({"sim_id": fork})).await;

    // Scale: a batch holding a change and a read, a sweep with a trajectory.
    c.call("batch", json!({"sim_id": sim, "calls": [{"tool": "step_simulation", "arguments": {"steps": 2}},
        {"tool": "get_object_state", "arguments": {"object_id": cube}}]})).await;
    c.call("run_sweep", json!({"sim_id": sim, "variants": [[], [{"tool": "apply_force", "arguments": {"object_id": cube, "force": [1, 0, 0]}}]],
        "steps": 4, "observe": {"object_ids": [cube], "every": 2, "include_velocities": true}})).await;

    let names: BTreeSet<String> = tools.iter().map(|t| t.name.to_string()).collect();
    let unchecked: Vec<&String> = names.difference(&c.checked).collect();
    assert!(unchecked.is_empty(), "tools not called by the scenario: {unchecked:?}");
    assert_eq!(c.checked.len(), tools.len(), "every listed tool validated once");
}

#[tokio::test(flavor = "multi_thread")]
async fn input_and_output_schemas_are_plain_json_schema_2020_12() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let client = server.client().await;
    let tools = listed(&client).await;

    let mut found = Vec::new();
    for tool in &tools {
        boilerplate(&Value::Object((*tool.input_schema).clone()), &format!("{}/inputSchema", tool.name), &mut found);
        if let Some(s) = &tool.output_schema {
            boilerplate(&Value::Object((**s).clone()), &format!("{}/outputSchema", tool.name), &mut found);
        }
    }
    assert!(found.is_empty(), "non-plain JSON Schema: {found:#?}");
}
