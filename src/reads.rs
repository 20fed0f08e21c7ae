//! The read-only tools of a simulation, computed from a world and the log's position. One
//! place, so the MCP adapters answer and `replay` re-checks a recorded read identically
//! (replay compares the blake3 of each read's result JSON with the one the log recorded).

use serde_json::Value;

use crate::command::object_not_found;
use crate::outputs::{
    CameraImage, Contacts, DynamicsInfo, IkSolution, JointInfo, JointState, LinkState, NumJoints,
    ObjectState, RayBatch, RayHit, SimulationInfo, VisibleObject,
};
use crate::sensing::camera::{self, Mat4};
use crate::sensing::scene::Indexed;
use crate::sensing::{contacts, rays, render};
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

/// get_link_state: link −1 is the base.
pub fn link_state(cx: &ReadContext, a: &Args) -> Result<LinkState, Refusal> {
    let id = value::object_id(a, "object_id")?;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let link = value::integer("link_index", value::required(a, "link_index", "a link index (integer >= -1)")?)?;
    let link = i32::try_from(link).map_err(|_| format!("link_index must be -1 (base) or a link index; got {link}"))?;
    w.check_link(id, link)?;
    w.link_state(id, link).ok_or_else(|| object_not_found(id, w.simulation_id()))
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
        timestep: w.timestep_given(),
        current_time: w.current_time(),
        steps: w.tables.steps,
        gui_enabled: w.gui(),
        objects: w.object_summaries(),
        constraints: w.constraint_summaries(),
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
        "get_link_state" => json(link_state(cx, a)),
        "calculate_inverse_kinematics" => json(inverse_kinematics(cx, a)),
        "ray_test" => json(ray_test(cx, a)),
        "ray_test_batch" => json(ray_test_batch(cx, a, usize::MAX)),
        "get_all_collisions" => json(all_collisions(cx, a)),
        "get_collisions_for_pair" => json(collisions_for_pair(cx, a)),
        "get_camera_image" => json(camera_image(cx, a, usize::MAX)),
        _ => return None,
    })
}

/// ray_test.
pub fn ray_test(cx: &ReadContext, a: &Args) -> Result<RayHit, Refusal> {
    let from = value::req_vec3(a, "ray_from")?;
    let to = value::req_vec3(a, "ray_to")?;
    Ok(rays::cast(&Indexed::new(cx.world), from, to))
}

/// ray_test_batch (at most `max_rays` rays).
pub fn ray_test_batch(cx: &ReadContext, a: &Args, max_rays: usize) -> Result<RayBatch, Refusal> {
    let list = |name: &str| value::vec3_list(name, value::required(a, name, "a list of [x, y, z] vectors")?);
    let (from, to) = (list("rays_from")?, list("rays_to")?);
    if from.len() != to.len() {
        return Err(format!(
            "rays_from and rays_to must have the same length; got {} and {}",
            from.len(),
            to.len()
        ));
    }
    if from.is_empty() {
        return Err("rays_from must hold at least one ray; got []".into());
    }
    if from.len() > max_rays {
        return Err(format!("Too many rays: {} in one batch (at most {max_rays}, --max-rays)", from.len()));
    }
    let rays: Vec<_> = from.into_iter().zip(to).collect();
    Ok(RayBatch { results: rays::cast_batch(&Indexed::new(cx.world), &rays) })
}

/// get_all_collisions.
pub fn all_collisions(cx: &ReadContext, _a: &Args) -> Result<Contacts, Refusal> {
    Ok(Contacts { contacts: contacts::contacts(cx.world, None) })
}

/// get_collisions_for_pair.
pub fn collisions_for_pair(cx: &ReadContext, a: &Args) -> Result<Contacts, Refusal> {
    let w = cx.world;
    let (oa, ob) = (value::object_id(a, "obj_a")?, value::object_id(a, "obj_b")?);
    for id in [oa, ob] {
        if !w.has_object(id) {
            return Err(object_not_found(id, w.simulation_id()));
        }
    }
    Ok(Contacts { contacts: contacts::contacts(w, Some((oa, ob))) })
}

/// A rendered image: the structured summary, and the PNG that travels beside it as MCP image
/// content (not part of the recorded result).
#[derive(serde::Serialize)]
pub struct Rendered {
    /// The structured result.
    #[serde(flatten)]
    pub summary: CameraImage,
    /// PNG bytes of the RGB image.
    #[serde(skip)]
    pub png: Vec<u8>,
}

/// A 4×4 matrix argument, or `default` when absent.
fn matrix(a: &Args, name: &str, default: impl FnOnce() -> Mat4) -> Result<Mat4, Refusal> {
    match value::arg(a, name) {
        Some(v) => value::numbers64(name, v, "16 finite numbers (a 4x4 matrix, column-major)"),
        None => Ok(default()),
    }
}

/// get_camera_image (at most `max_px` pixels).
pub fn camera_image(cx: &ReadContext, a: &Args, max_px: usize) -> Result<Rendered, Refusal> {
    let w = cx.world;
    let side = |name: &str| -> Result<u32, Refusal> {
        let v = value::integer(name, value::required(a, name, "an image size in pixels (integer >= 1)")?)?;
        u32::try_from(v)
            .ok()
            .filter(|v| *v >= 1)
            .ok_or_else(|| format!("{name} must be an integer >= 1; got {v}"))
    };
    let (width, height) = (side("width")?, side("height")?);
    let px = width as u64 * height as u64;
    if px > max_px as u64 {
        return Err(format!(
            "Image too large: {width}x{height} = {px} pixels (at most {max_px}, --max-image-px)"
        ));
    }
    let cam = &w.tables.viewer;
    let view = matrix(a, "view_matrix", || {
        let t = cam.target.map(f64::from);
        camera::view_matrix_from_yaw_pitch(t, cam.distance.into(), cam.yaw.into(), cam.pitch.into(), 2)
    })?;
    let proj = matrix(a, "projection_matrix", || camera::default_projection(width, height))?;
    let include_depth = value::bool_or(a, "include_depth", false)?;
    let include_segmentation = value::bool_or(a, "include_segmentation", false)?;
    let frame = render::render(w, width, height, &view, &proj);
    let mut counts = std::collections::BTreeMap::<u32, u64>::new();
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (id, d) in frame.segmentation.iter().zip(&frame.depth) {
        if let Ok(id) = u32::try_from(*id) {
            *counts.entry(id).or_default() += 1;
            lo = lo.min(*d);
            hi = hi.max(*d);
        }
    }
    let far = render::Frame::far_plane(&proj).unwrap_or(0.0);
    let summary = CameraImage {
        width,
        height,
        visible_objects: counts.into_iter().map(|(object_id, pixels)| VisibleObject { object_id, pixels }).collect(),
        depth_range: (lo <= hi).then(|| [r32(lo), r32(hi)]),
        depth: include_depth.then(|| {
            frame.depth.iter().map(|d| if d.is_finite() { r32(*d) } else { far }).collect()
        }),
        segmentation: include_segmentation.then(|| frame.segmentation.clone()),
    };
    Ok(Rendered { png: frame.png()?, summary })
}
