//! The read-only tools of a simulation, computed from a world and the log's position. One
//! place, so the MCP adapters answer and `replay` re-checks a recorded read identically
//! (replay compares the blake3 of each read's result JSON with the one the log recorded).

use serde_json::Value;

use crate::command::object_not_found;
use crate::outputs::{
    DynamicsInfo, IkSolution, JointInfo, JointState, NumJoints, ObjectState, SimulationInfo,
};
use crate::value::{self, r32, r32s, Args, Refusal};
use crate::world::World;

/// Where the log stood when a read was made (get_simulation_info reports it).
pub struct ReadContext<'a> {
    /// The world read.
    pub world: &'a World,
    /// The state-changing event it reflects.
    pub head_seq: u64,
    /// The last event appended before this read.
    pub last_seq: u64,
    /// The world's state hash.
    pub state_hash: &'a str,
}

/// get_object_state.
pub fn object_state(cx: &ReadContext, a: &Args) -> Result<ObjectState, Refusal> {
    let id = value::object_id(a, "object_id")?;
    cx.world
        .object_state(id)
        .ok_or_else(|| object_not_found(id, cx.world.simulation_id()))
}

/// get_dynamics_info.
pub fn dynamics_info(cx: &ReadContext, a: &Args) -> Result<DynamicsInfo, Refusal> {
    let id = value::object_id(a, "object_id")?;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let link = value::link_index(a)?;
    w.check_link(id, link)?;
    w.dynamics_info(id, link).ok_or_else(|| object_not_found(id, w.simulation_id()))
}

fn robot_read<T>(
    cx: &ReadContext,
    a: &Args,
    f: impl FnOnce(&World, u32, usize) -> Option<T>,
) -> Result<T, Refusal> {
    let id = value::object_id(a, "object_id")?;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let i = w.check_joint(id, value::integer(
        "joint_index",
        value::required(a, "joint_index", "a joint index (integer >= 0)")?,
    )?)?;
    f(w, id, i).ok_or_else(|| object_not_found(id, w.simulation_id()))
}

/// get_num_joints (0 for primitives).
pub fn num_joints(cx: &ReadContext, a: &Args) -> Result<NumJoints, Refusal> {
    let id = value::object_id(a, "object_id")?;
    if !cx.world.has_object(id) {
        return Err(object_not_found(id, cx.world.simulation_id()));
    }
    Ok(NumJoints { num_joints: cx.world.link_count(id) })
}

/// get_joint_info.
pub fn joint_info(cx: &ReadContext, a: &Args) -> Result<JointInfo, Refusal> {
    robot_read(cx, a, |w, id, i| w.joint_info(id, i))
}

/// get_joint_state.
pub fn joint_state(cx: &ReadContext, a: &Args) -> Result<JointState, Refusal> {
    robot_read(cx, a, |w, id, i| w.joint_state(id, i))
}

/// calculate_inverse_kinematics.
pub fn inverse_kinematics(cx: &ReadContext, a: &Args) -> Result<IkSolution, Refusal> {
    let id = value::object_id(a, "object_id")?;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let n = w.link_count(id);
    let ee = value::integer(
        "end_effector_link_index",
        value::required(a, "end_effector_link_index", "a link index (integer >= 0)")?,
    )?;
    if ee < 0 || ee as usize >= n {
        return Err(format!("end_effector_link_index {ee} out of range: object {id} has {n} links"));
    }
    let movable = w.robot(id).map_or(0, |r| r.movable().len());
    let target_position = value::req_vec3(a, "target_position")?;
    let target_orientation = value::arg(a, "target_orientation")
        .map(|v| value::quat("target_orientation", v))
        .transpose()?;
    let lower = value::opt_list_of(a, "lower_limits", movable)?;
    let upper = value::opt_list_of(a, "upper_limits", movable)?;
    value::opt_list_of(a, "joint_ranges", movable)?;
    let rest = value::opt_list_of(a, "rest_poses", movable)?;
    w.inverse_kinematics(id, ee as usize, target_position, target_orientation, lower, upper, rest)
        .ok_or_else(|| object_not_found(id, w.simulation_id()))
}

/// get_simulation_info.
pub fn simulation_info(cx: &ReadContext, _a: &Args) -> Result<SimulationInfo, Refusal> {
    let w = cx.world;
    Ok(SimulationInfo {
        simulation_id: w.simulation_id().to_string(),
        gravity: r32s(w.physics.gravity.to_array()),
        timestep: r32(w.timestep()),
        current_time: w.tables.time_s,
        steps: w.tables.steps,
        gui_enabled: w.gui(),
        objects: w.object_summaries(),
        constraints: Vec::new(),
        head_seq: cx.head_seq,
        last_seq: cx.last_seq,
        state_hash: cx.state_hash.to_string(),
    })
}

/// Re-executes a recorded read for replay: Some(result JSON) for the reads replay checks,
/// None for tools whose results depend on more than the world (history, verification,
/// saves, forks' fresh ids, the simulation list).
pub fn replay_read(tool: &str, cx: &ReadContext, a: &Args) -> Option<Result<Value, Refusal>> {
    fn json<T: serde::Serialize>(r: Result<T, Refusal>) -> Result<Value, Refusal> {
        r.and_then(|v| serde_json::to_value(v).map_err(|e| e.to_string()))
    }
    Some(match tool {
        "get_object_state" => json(object_state(cx, a)),
        "get_dynamics_info" => json(dynamics_info(cx, a)),
        "get_simulation_info" => json(simulation_info(cx, a)),
        "get_num_joints" => json(num_joints(cx, a)),
        "get_joint_info" => json(joint_info(cx, a)),
        "get_joint_state" => json(joint_state(cx, a)),
        "calculate_inverse_kinematics" => json(inverse_kinematics(cx, a)),
        _ => return None,
    })
}
