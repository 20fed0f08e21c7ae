//! MCP prompts (docs/tools.md "Resources and prompts"): short, ready-made workflows an agent can start
//! from — a drop test, a robot-arm reach, replaying a session. Each is text naming the tools in
//! the order to call them, with the facts to check, so a client that offers prompts as slash
//! commands gets a working session in one pick.

use rmcp::model::{ErrorData, GetPromptResult, JsonObject, ListPromptsResult, Prompt, PromptArgument, PromptMessage,
                  Role};

/// One prompt: its name, what it is for, its arguments (name, description, required) and the
/// text it expands to, with `{arg}` replaced by the argument (or its default).
struct Workflow {
    name: &'static str,
    description: &'static str,
    arguments: &'static [(&'static str, &'static str, Option<&'static str>)],
    text: &'static str,
}

const WORKFLOWS: [Workflow; 3] = [
    Workflow {
        name: "drop-test",
        description: "Drop a body onto the ground and check it comes to rest where physics says.",
        arguments: &[
            ("shape", "box, sphere, cylinder or capsule (default box)", Some("box")),
            ("height", "drop height of the body's centre in metres (default 2)", Some("2")),
        ],
        text: "Run a drop test with the physics-mcp tools.\n\
1. create_simulation {} and note its simulation_id.\n\
2. add_box with dimensions [20, 20, 0.5] (half-extents), position [0, 0, -0.5] and mass 0: a static ground whose top is z = 0.\n\
3. Add a {shape} of mass 1 (a box: dimensions [0.2, 0.2, 0.2], half-extents; a sphere: radius 0.2; a cylinder or capsule: radius 0.2, height 0.4) at position [0, 0, {height}].\n\
4. step_simulation with steps 720 (3 s at 1/240 s).\n\
5. get_object_state of the body: it should be at rest (speed below 0.01 m/s) with its centre half its extent along z above the ground: 0.2 m for the box, sphere and cylinder, 0.4 m for the capsule (its height is the straight part; add the radius).\n\
6. Report the rest height, the expected height and the difference. If something is off, get_history shows every call; undo goes back.",
    },
    Workflow {
        name: "robot-arm-reach",
        description: "Load an arm from URDF, solve inverse kinematics for a target and drive the joints there with motors.",
        arguments: &[
            ("urdf", "URDF file in the workspace (default: generate one with generate_revolute_joint)", None),
            ("target", "end-effector target position as \"x, y, z\" in metres", Some("0.4, 0.2, 0.8")),
        ],
        text: "Make a robot arm reach a target with the physics-mcp tools.\n\
1. create_simulation {} and load_urdf \"plane.urdf\" (built in) for a ground.\n\
2. load_urdf the arm ({urdf}) with use_fixed_base true. (No URDF? generate_revolute_joint writes a two-link one into the workspace; load the urdf_path it returns.)\n\
3. get_num_joints, then get_joint_info for each joint: note the movable ones (not fixed), their limits, and the last link's index (the end effector).\n\
4. calculate_inverse_kinematics with end_effector_link_index = that link and target_position [{target}]. Check position_error (metres) is small; if the target is out of reach the error says by how much.\n\
5. For each movable joint, set_joint_motor_control with control_mode POSITION_CONTROL and target_position = the answer (joint_positions are in PyBullet order, one per movable joint).\n\
6. step_simulation 480 steps, then get_joint_state of each joint: joint_position should match the answer within 0.01 rad; motor_torque shows the effort holding the arm against gravity.\n\
7. get_camera_image (width 320, height 240) to look at the result.",
    },
    Workflow {
        name: "replay-a-session",
        description: "Inspect, verify and branch a simulation's recorded history.",
        arguments: &[("sim_id", "the simulation to look at (default: list_simulations and pick one)", None)],
        text: "Walk through a simulation's recorded history with the physics-mcp tools.\n\
1. Simulation: {sim_id}. (Unsure? list_simulations.)\n\
2. get_history (since_seq 0, limit 100, then page on with since_seq = the last seq): every call, its arguments, what it did (a read: what it returned), and the state hash after it (its first 12 hex; detail \"full\" gives all 64).\n\
3. verify_simulation: refolds the whole log in a fresh world and checks every hash; ok must be true.\n\
4. fork_simulation at an interesting seq (at_seq) to branch a copy from that moment, then change the copy (different forces, another step count) and compare get_object_state of both.\n\
5. undo / redo on the original move along its history; get_simulation_info's state_hash begins with the hash the history shows for that point.\n\
6. save_simulation writes the session to a file; anyone can replay it bit for bit with `physics-mcp replay FILE` on the command line.",
    },
];

/// prompts/list.
pub(super) fn list() -> ListPromptsResult {
    let prompts = WORKFLOWS
        .iter()
        .map(|w| {
            let args = w
                .arguments
                .iter()
                .map(|(name, description, _default)| {
                    PromptArgument::new(*name).with_description(*description).with_required(false)
                })
                .collect();
            Prompt::new(w.name, Some(w.description), Some(args))
        })
        .collect();
    ListPromptsResult::with_all_items(prompts)
}

/// prompts/get: the workflow's text with its arguments filled in.
pub(super) fn get(name: &str, arguments: Option<&JsonObject>) -> Result<GetPromptResult, ErrorData> {
    let w = WORKFLOWS.iter().find(|w| w.name == name).ok_or_else(|| {
        let names: Vec<&str> = WORKFLOWS.iter().map(|w| w.name).collect();
        ErrorData::invalid_params(format!("Unknown prompt {name}; the prompts are {}", names.join(", ")), None)
    })?;
    let mut text = w.text.to_string();
    for (arg, description, default) in w.arguments {
        let given = arguments.and_then(|a| a.get(*arg)).map(|v| match v {
            serde_json::Value::String(s) => s.clone(),
            other => other.to_string(),
        });
        let value = given.or(default.map(str::to_string)).unwrap_or_else(|| format!("not given: {description}"));
        text = text.replace(&format!("{{{arg}}}"), &value);
    }
    Ok(GetPromptResult::new(vec![PromptMessage::new_text(Role::User, text)]).with_description(w.description))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_placeholder_is_an_argument_and_gets_filled() {
        for w in &WORKFLOWS {
            let r = get(w.name, None).unwrap();
            let text = serde_json::to_string(&r.messages).unwrap();
            for (arg, _, _) in w.arguments {
                assert!(w.text.contains(&format!("{{{arg}}}")), "{} never uses {arg}", w.name);
            }
            assert!(!text.contains("{shape}") && !text.contains("{height}") && !text.contains("{target}"));
            assert!(!text.contains("{urdf}") && !text.contains("{sim_id}"), "{text}");
        }
        assert!(get("nope", None).is_err());
    }
}
