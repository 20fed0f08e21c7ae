//! The robot reads PyBullet scripts lean on: get_joint_states and get_link_states (the
//! one-at-a-time reads, many in one call, so each answer is bit for bit the single call's),
//! calculate_jacobian, calculate_mass_matrix and calculate_inverse_dynamics (f64, from the
//! robot model: `world/dynamics.rs`). Shared by the MCP adapters and `replay`.

use rapier3d::glamx::DVec3;

use super::reads::{joint_state, link_state, ReadContext};
use crate::command::object_not_found;
use crate::outputs::{InverseDynamics, Jacobian, JointStates, LinkStates, MassMatrix};
use crate::params::lenient::{Int, NumList};
use crate::params::{InverseDynamicsQuery, JacobianQuery, JointRef, JointsRef, LinkRef, LinksRef, MassMatrixQuery};
use crate::value::Refusal;
use crate::world::dynamics::RobotDynamics;

/// A list of indices must name at least one.
fn some<T>(name: &str, list: &[T]) -> Result<(), Refusal> {
    match list.is_empty() {
        true => Err(format!("{name} must name at least one index; got []")),
        false => Ok(()),
    }
}

/// get_joint_states.
pub fn joint_states(cx: &ReadContext, p: &JointsRef) -> Result<JointStates, Refusal> {
    some("joint_indices", &p.joint_indices)?;
    let one = |j: &Int<u32>| JointRef { sim_id: p.sim_id.clone(), object_id: p.object_id.clone(), joint_index: *j };
    let joint_states = p.joint_indices.iter().map(|j| joint_state(cx, &one(j))).collect::<Result<_, _>>()?;
    Ok(JointStates { joint_states })
}

/// get_link_states.
pub fn link_states(cx: &ReadContext, p: &LinksRef) -> Result<LinkStates, Refusal> {
    some("link_indices", &p.link_indices)?;
    let one = |l: &Int<i32>| LinkRef { sim_id: p.sim_id.clone(), object_id: p.object_id.clone(), link_index: *l };
    let link_states = p.link_indices.iter().map(|l| link_state(cx, &one(l))).collect::<Result<_, _>>()?;
    Ok(LinkStates { link_states })
}

/// The robot's model, refused when the object is missing, has no joints or has a ball joint.
fn model(cx: &ReadContext, id: u32, tool: &str) -> Result<RobotDynamics, Refusal> {
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    if let Some(r) = w.robot(id) {
        r.ball_joint_refusal(id, tool)?;
    }
    w.robot_dynamics(id).ok_or_else(|| format!("object_id {id} is not a robot; it has no joints"))
}

/// One value per movable joint.
fn per_dof(name: &str, list: &NumList, dofs: usize) -> Result<Vec<f64>, Refusal> {
    match list.0.len() == dofs {
        true => Ok(list.0.clone()),
        false => Err(format!("{name} must have one value per movable joint ({dofs}); got {}", list.0.len())),
    }
}

/// calculate_jacobian.
pub fn jacobian(cx: &ReadContext, p: &JacobianQuery) -> Result<Jacobian, Refusal> {
    let id = p.object_id.0;
    let m = model(cx, id, "calculate_jacobian")?;
    let n = m.links.len();
    let link = p.link_index.get();
    if link < 0 || link as usize >= n {
        return Err(format!("link_index {link} out of range: object {id} has links 0 to {}", n as i64 - 1));
    }
    let q = per_dof("obj_positions", &p.obj_positions, m.dofs)?;
    per_dof("obj_velocities", &p.obj_velocities, m.dofs)?;
    per_dof("obj_accelerations", &p.obj_accelerations, m.dofs)?;
    let local = DVec3::from_array(p.local_position.0.map(|x| x as f64));
    let (lin, ang) = m.jacobian(&q, link as usize, local);
    Ok(Jacobian { linear_jacobian: lin.to_vec(), angular_jacobian: ang.to_vec() })
}

/// calculate_mass_matrix.
pub fn mass_matrix(cx: &ReadContext, p: &MassMatrixQuery) -> Result<MassMatrix, Refusal> {
    let m = model(cx, p.object_id.0, "calculate_mass_matrix")?;
    let q = per_dof("obj_positions", &p.obj_positions, m.dofs)?;
    Ok(MassMatrix { mass_matrix: m.mass_matrix(&q) })
}

/// calculate_inverse_dynamics: the joint forces for the motion under the world's gravity.
pub fn inverse_dynamics(cx: &ReadContext, p: &InverseDynamicsQuery) -> Result<InverseDynamics, Refusal> {
    let m = model(cx, p.object_id.0, "calculate_inverse_dynamics")?;
    let q = per_dof("obj_positions", &p.obj_positions, m.dofs)?;
    let qd = per_dof("obj_velocities", &p.obj_velocities, m.dofs)?;
    let qdd = per_dof("obj_accelerations", &p.obj_accelerations, m.dofs)?;
    let g = cx.world.gravity();
    let g = DVec3::new(g[0] as f64, g[1] as f64, g[2] as f64);
    Ok(InverseDynamics { joint_forces: m.newton_euler(&q, &qd, &qdd, g).tau })
}
