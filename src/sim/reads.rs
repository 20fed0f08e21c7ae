//! The read-only tools of a simulation, computed from a world and the log's position, from
//! their typed parameters (`mcp::params`). One place, so the MCP adapters answer and `replay`
//! re-checks a recorded read identically (replay compares the blake3 of each read's result
//! JSON with the one the log recorded); `Read` names every read a log can hold.

use serde_json::Value;

use crate::command::object_not_found;
use crate::outputs::{
    CameraImage, Contacts, DynamicsInfo, IkSolution, JointInfo, JointState, LinkState, NumJoints,
    ObjectState, RayBatch, RayHit, SimulationInfo, VisibleObject,
};
use crate::seeing::framing;
use crate::seeing::sensing::camera::Mat4;
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::{contacts, rays, render};
use crate::params::{self, CameraImage as CameraParams, CollisionPair, DynamicsRef, InverseKinematics, JointRef, ObjectRef, RayTest, RayTestBatch, SimRef};
use crate::params::{Fork, GetTrajectory, HistoryPage, LinkRef, RenderAnimation, Save};
use crate::value::{r32, r32s, Args, Refusal};
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
    /// The event version whose rules compute the result: `EVENT_VERSION` live, the recorded
    /// event's when `replay` re-checks it (a read recorded under older rules is re-run under
    /// them; see `camera_image`).
    pub rules: u32,
}

/// get_object_state.
pub fn object_state(cx: &ReadContext, p: &ObjectRef) -> Result<ObjectState, Refusal> {
    let id = p.object_id.0;
    cx.world
        .object_state(id)
        .ok_or_else(|| object_not_found(id, cx.world.simulation_id()))
}

/// get_dynamics_info.
pub fn dynamics_info(cx: &ReadContext, p: &DynamicsRef) -> Result<DynamicsInfo, Refusal> {
    let id = p.object_id.0;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let link = crate::params::lenient::link_index(p.link_index)?;
    w.check_link(id, link)?;
    w.dynamics_info(id, link).ok_or_else(|| object_not_found(id, w.simulation_id()))
}

fn robot_read<T>(
    cx: &ReadContext,
    p: &JointRef,
    f: impl FnOnce(&World, u32, usize) -> Option<T>,
) -> Result<T, Refusal> {
    let id = p.object_id.0;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let i = w.check_joint(id, p.joint_index.get())?;
    f(w, id, i).ok_or_else(|| object_not_found(id, w.simulation_id()))
}

/// get_num_joints (0 for primitives).
pub fn num_joints(cx: &ReadContext, p: &ObjectRef) -> Result<NumJoints, Refusal> {
    let id = p.object_id.0;
    if !cx.world.has_object(id) {
        return Err(object_not_found(id, cx.world.simulation_id()));
    }
    Ok(NumJoints { num_joints: cx.world.link_count(id) })
}

/// get_joint_info.
pub fn joint_info(cx: &ReadContext, p: &JointRef) -> Result<JointInfo, Refusal> {
    robot_read(cx, p, |w, id, i| w.joint_info(id, i))
}

/// get_joint_state.
pub fn joint_state(cx: &ReadContext, p: &JointRef) -> Result<JointState, Refusal> {
    robot_read(cx, p, |w, id, i| w.joint_state(id, i))
}

/// A list given per movable joint must have one value per movable joint.
fn per_joint(name: &str, list: &Option<crate::params::lenient::NumList>, n: usize) -> Result<Option<Vec<f64>>, Refusal> {
    match list {
        Some(l) if l.0.len() != n => {
            Err(format!("{name} must have one value per movable joint ({n}); got {}", l.0.len()))
        }
        other => Ok(other.as_ref().map(|l| l.0.clone())),
    }
}

/// get_link_state: link −1 is the base.
pub fn link_state(cx: &ReadContext, p: &LinkRef) -> Result<LinkState, Refusal> {
    let id = p.object_id.0;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let link = p.link_index.get();
    let link = i32::try_from(link).map_err(|_| format!("link_index must be -1 (base) or a link index; got {link}"))?;
    w.check_link(id, link)?;
    w.link_state(id, link).ok_or_else(|| object_not_found(id, w.simulation_id()))
}

/// get_sensor_data.
pub fn sensor_data(cx: &ReadContext, p: &params::SensorsRef) -> Result<crate::outputs::SensorData, Refusal> {
    let id = p.object_id.0;
    if !cx.world.has_object(id) {
        return Err(object_not_found(id, cx.world.simulation_id()));
    }
    let names: Option<Vec<String>> = p.names.as_ref().map(|ns| ns.iter().map(|n| n.0.clone()).collect());
    cx.world.sensor_data(id, names.as_deref())
}

/// calculate_inverse_kinematics.
pub fn inverse_kinematics(cx: &ReadContext, p: &InverseKinematics) -> Result<IkSolution, Refusal> {
    let id = p.object_id.0;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    if let Some(r) = w.robot(id) {
        r.ball_joint_refusal(id, "calculate_inverse_kinematics")?;
    }
    let n = w.link_count(id);
    let ee = p.end_effector_link_index.get();
    if ee < 0 || ee as usize >= n {
        return Err(format!("end_effector_link_index {ee} out of range: object {id} has {n} links"));
    }
    let movable = w.robot(id).map_or(0, |r| r.movable().len());
    let lower = per_joint("lower_limits", &p.lower_limits, movable)?;
    let upper = per_joint("upper_limits", &p.upper_limits, movable)?;
    per_joint("joint_ranges", &p.joint_ranges, movable)?;
    let rest = per_joint("rest_poses", &p.rest_poses, movable)?;
    let target_orientation = p.target_orientation.as_ref().map(|q| q.0);
    w.inverse_kinematics(id, ee as usize, p.target_position.0, target_orientation, lower, upper, rest)
        .ok_or_else(|| object_not_found(id, w.simulation_id()))
}

/// get_simulation_info.
pub fn simulation_info(cx: &ReadContext) -> Result<SimulationInfo, Refusal> {
    let w = cx.world;
    Ok(SimulationInfo {
        simulation_id: w.simulation_id().to_string(),
        name: w.name().map(str::to_string),
        gravity: r32s(w.gravity()),
        timestep: w.timestep_given(),
        current_time: w.current_time(),
        steps: w.steps(),
        gui_enabled: w.gui(),
        objects: w.object_summaries(),
        constraints: w.constraint_summaries(),
        head_seq: cx.head_seq,
        last_seq: cx.last_seq,
        state_hash: cx.state_hash.to_string(),
    })
}

/// Every read a simulation's log can hold, with its parameters: parsed once, answered by an
/// exhaustive match. A tool that is not a read is an error, never silently skipped.
#[derive(Debug, Clone)]
pub enum Read {
    /// get_object_state.
    ObjectState(ObjectRef),
    /// get_dynamics_info.
    DynamicsInfo(DynamicsRef),
    /// get_simulation_info.
    SimulationInfo(SimRef),
    /// get_num_joints.
    NumJoints(ObjectRef),
    /// get_joint_info.
    JointInfo(JointRef),
    /// get_joint_state.
    JointState(JointRef),
    /// calculate_inverse_kinematics.
    InverseKinematics(InverseKinematics),
    /// ray_test.
    RayTest(RayTest),
    /// ray_test_batch.
    RayTestBatch(RayTestBatch),
    /// get_all_collisions.
    AllCollisions(SimRef),
    /// get_collisions_for_pair.
    CollisionsForPair(CollisionPair),
    /// get_camera_image.
    CameraImage(CameraParams),
    /// get_history: its result depends on the log, not the world.
    History(HistoryPage),
    /// verify_simulation: its result depends on the log, not the world.
    Verify(SimRef),
    /// save_simulation: its result names a file.
    Save(Save),
    /// fork_simulation (the parent's event): its result names a fresh simulation.
    Fork(Fork),
    /// get_trajectory: its result is re-simulated from the log, not read off the world.
    Trajectory(GetTrajectory),
    /// render_animation: its result is re-simulated from the log, not read off the world.
    Animation(RenderAnimation),
    /// get_link_state.
    LinkState(LinkRef),
    /// run_sweep (the swept simulation's event): its result comes from forks, not this world.
    Sweep(Box<params::Sweep>),
    /// get_joint_states.
    JointStates(params::JointsRef),
    /// get_link_states.
    LinkStates(params::LinksRef),
    /// get_sensor_data.
    SensorData(params::SensorsRef),
    /// calculate_jacobian.
    Jacobian(params::JacobianQuery),
    /// calculate_mass_matrix.
    MassMatrix(params::MassMatrixQuery),
    /// calculate_inverse_dynamics.
    InverseDynamics(params::InverseDynamicsQuery),
    /// get_aabb.
    Aabb(params::AabbQuery),
    /// get_overlapping_objects.
    Overlapping(params::OverlapQuery),
    /// get_closest_points.
    ClosestPoints(params::ClosestPointsQuery),
}

impl Read {
    /// A read recorded in a log, from its tool name and arguments. Earlier releases ignored
    /// unknown parameters, so they are dropped here rather than refused (`params::parse_recorded`).
    pub fn recorded(tool: &str, a: &Args) -> Result<Read, Refusal> {
        fn p<P: serde::de::DeserializeOwned + schemars::JsonSchema + 'static>(tool: &str, a: &Args) -> Result<P, Refusal> {
            params::parse_recorded(tool, a)
        }
        Ok(match tool {
            "get_object_state" => Read::ObjectState(p(tool, a)?),
            "get_dynamics_info" => Read::DynamicsInfo(p(tool, a)?),
            "get_simulation_info" => Read::SimulationInfo(p(tool, a)?),
            "get_num_joints" => Read::NumJoints(p(tool, a)?),
            "get_joint_info" => Read::JointInfo(p(tool, a)?),
            "get_joint_state" => Read::JointState(p(tool, a)?),
            "calculate_inverse_kinematics" => Read::InverseKinematics(p(tool, a)?),
            "ray_test" => Read::RayTest(p(tool, a)?),
            "ray_test_batch" => Read::RayTestBatch(p(tool, a)?),
            "get_all_collisions" => Read::AllCollisions(p(tool, a)?),
            "get_collisions_for_pair" => Read::CollisionsForPair(p(tool, a)?),
            "get_camera_image" => Read::CameraImage(p(tool, a)?),
            "get_history" => Read::History(p(tool, a)?),
            "verify_simulation" => Read::Verify(p(tool, a)?),
            "save_simulation" => Read::Save(p(tool, a)?),
            "fork_simulation" => Read::Fork(p(tool, a)?),
            "get_trajectory" => Read::Trajectory(p(tool, a)?),
            "render_animation" => Read::Animation(p(tool, a)?),
            "get_link_state" => Read::LinkState(p(tool, a)?),
            "run_sweep" => Read::Sweep(Box::new(p(tool, a)?)),
            "get_joint_states" => Read::JointStates(p(tool, a)?),
            "get_link_states" => Read::LinkStates(p(tool, a)?),
            "get_sensor_data" => Read::SensorData(p(tool, a)?),
            "calculate_jacobian" => Read::Jacobian(p(tool, a)?),
            "calculate_mass_matrix" => Read::MassMatrix(p(tool, a)?),
            "calculate_inverse_dynamics" => Read::InverseDynamics(p(tool, a)?),
            "get_aabb" => Read::Aabb(p(tool, a)?),
            "get_overlapping_objects" => Read::Overlapping(p(tool, a)?),
            "get_closest_points" => Read::ClosestPoints(p(tool, a)?),
            other => return Err(format!("{other} is not a read this server knows")),
        })
    }

    /// Re-executes the read for replay, with no limits (it was accepted once): Some(result
    /// JSON) for the reads whose result is a function of the world, None for those that
    /// depend on more (history, verification, saves, forks' fresh ids).
    pub fn replay(&self, cx: &ReadContext) -> Option<Result<Value, Refusal>> {
        fn json<T: serde::Serialize>(r: Result<T, Refusal>) -> Result<Value, Refusal> {
            r.and_then(|v| serde_json::to_value(v).map_err(|e| e.to_string()))
        }
        Some(match self {
            Read::ObjectState(p) => json(object_state(cx, p)),
            Read::DynamicsInfo(p) => json(dynamics_info(cx, p)),
            Read::SimulationInfo(_) => json(simulation_info(cx)),
            Read::NumJoints(p) => json(num_joints(cx, p)),
            Read::JointInfo(p) => json(joint_info(cx, p)),
            Read::JointState(p) => json(joint_state(cx, p)),
            Read::InverseKinematics(p) => json(inverse_kinematics(cx, p)),
            Read::RayTest(p) => json(ray_test(cx, p)),
            Read::RayTestBatch(p) => json(ray_test_batch(cx, p, usize::MAX)),
            Read::AllCollisions(_) => json(all_collisions(cx)),
            Read::CollisionsForPair(p) => json(collisions_for_pair(cx, p)),
            Read::CameraImage(p) => json(camera_image(cx, p, usize::MAX)),
            Read::LinkState(p) => json(link_state(cx, p)),
            Read::JointStates(p) => json(super::dynamics_reads::joint_states(cx, p)),
            Read::LinkStates(p) => json(super::dynamics_reads::link_states(cx, p)),
            Read::SensorData(p) => json(sensor_data(cx, p)),
            Read::Jacobian(p) => json(super::dynamics_reads::jacobian(cx, p)),
            Read::MassMatrix(p) => json(super::dynamics_reads::mass_matrix(cx, p)),
            Read::InverseDynamics(p) => json(super::dynamics_reads::inverse_dynamics(cx, p)),
            Read::Aabb(p) => json(super::geometry_reads::aabb(cx, p)),
            Read::Overlapping(p) => json(super::geometry_reads::overlapping(cx, p)),
            Read::ClosestPoints(p) => json(super::geometry_reads::closest_points(cx, p)),
            Read::History(_) | Read::Verify(_) | Read::Save(_) | Read::Fork(_) | Read::Trajectory(_) | Read::Animation(_) | Read::Sweep(_) => return None,
        })
    }
}

/// ray_test.
pub fn ray_test(cx: &ReadContext, p: &RayTest) -> Result<RayHit, Refusal> {
    Ok(rays::ray_test(cx.world, p.ray_from.0, p.ray_to.0))
}

/// ray_test_batch (at most `max_rays` rays).
pub fn ray_test_batch(cx: &ReadContext, p: &RayTestBatch, max_rays: usize) -> Result<RayBatch, Refusal> {
    let (from, to) = (&p.rays_from.0, &p.rays_to.0);
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
    let rays: Vec<_> = from.iter().copied().zip(to.iter().copied()).collect();
    Ok(RayBatch { results: rays::cast_batch(cx.world.scene(), &rays), rays: None, hits: None, output_path: None })
}

/// get_all_collisions.
pub fn all_collisions(cx: &ReadContext) -> Result<Contacts, Refusal> {
    Ok(Contacts { contacts: contacts::contacts(cx.world, None) })
}

/// get_collisions_for_pair.
pub fn collisions_for_pair(cx: &ReadContext, p: &CollisionPair) -> Result<Contacts, Refusal> {
    let w = cx.world;
    let (oa, ob) = (p.obj_a.0, p.obj_b.0);
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

/// The event version from which get_camera_image without a view matrix frames the scene
/// itself until set_camera is called, and reports the camera it used (`seeing::framing`).
pub const CAMERA_FRAMED_SINCE: u32 = 4;

/// The event version from which get_camera_image's depth gives the background as an f32, as
/// every other depth value (17 digits of an f64 far plane made a 64×48 depth image 52 KB).
pub const DEPTH_F32_SINCE: u32 = 6;

/// get_camera_image (at most `max_px` pixels).
pub fn camera_image(cx: &ReadContext, p: &CameraParams, max_px: usize) -> Result<Rendered, Refusal> {
    let w = cx.world;
    let side = |name: &str, v: i64| -> Result<u32, Refusal> {
        u32::try_from(v)
            .ok()
            .filter(|v| *v >= 1)
            .ok_or_else(|| format!("{name} must be an integer >= 1; got {v}"))
    };
    let (width, height) = (side("width", p.width.get())?, side("height", p.height.get())?);
    let px = width as u64 * height as u64;
    if px > max_px as u64 {
        return Err(format!(
            "Image too large: {width}x{height} = {px} pixels (at most {max_px}, --max-image-px){}",
            crate::seeing::fit::hint(width, height, max_px as u64)
        ));
    }
    let asked = framing::Asked { view: p.view_matrix.as_ref().map(|m| m.0), ..Default::default() };
    let (view, camera): (Mat4, _) = if cx.rules < CAMERA_FRAMED_SINCE {
        // Recorded before pictures framed themselves: the set_camera camera, always.
        (asked.view.unwrap_or_else(|| framing::Terms::of_viewer(w.viewer()).view()), None)
    } else if let Some(view) = asked.view {
        (view, Some(framing::choose(&asked, &[], 1.0).1))
    } else {
        let scene = Scene::capture(w);
        let (view, used) = framing::choose(&asked, &[&scene], f64::from(width) / f64::from(height));
        (view, Some(used))
    };
    let proj: Mat4 = match &p.projection_matrix {
        Some(m) => m.0,
        None => framing::lens(camera.as_ref(), width, height),
    };
    let include_depth = p.include_depth.as_ref().is_some_and(|b| b.0);
    let include_segmentation = p.include_segmentation.as_ref().is_some_and(|b| b.0);
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
    let far = if cx.rules >= DEPTH_F32_SINCE { r32(far as f32) } else { far };
    let summary = CameraImage {
        width,
        height,
        visible_objects: counts.into_iter().map(|(object_id, pixels)| VisibleObject { object_id, pixels }).collect(),
        depth_range: (lo <= hi).then(|| [r32(lo), r32(hi)]),
        camera,
        depth: include_depth.then(|| {
            frame.depth.iter().map(|d| if d.is_finite() { r32(*d) } else { far }).collect()
        }),
        segmentation: include_segmentation.then(|| frame.segmentation.clone()),
        png_path: None,
        depth_path: None,
        segmentation_path: None,
    };
    Ok(Rendered { png: frame.png()?, summary })
}
