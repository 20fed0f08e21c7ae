//! URDF robots in the world: insertion as a rapier multibody (reduced coordinates, like
//! PyBullet's btMultiBody), joint reads, motors and their applied torque.
//!
//! Every link is a rapier body whose position is the URDF link frame (the joint frame of its
//! parent joint) and whose mass properties are the URDF inertial. Joints are multibody joints
//! whose free axis (AngX / LinX) is the URDF axis, so a joint coordinate is exactly the URDF
//! joint position. Joints start free: multibody joints' built-in damping is set to the URDF
//! `<dynamics damping>` (0 by default), not rapier's default 0.1.

use std::collections::BTreeMap;

use rapier3d::glamx::{Mat3, Quat, Vec3};
use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

use super::urdf::{part_shape, JointKind, JointSpec, Part, RobotModel};
use super::{DynamicsExtras, Object, ObjectKind, World, DEFAULT_DAMPING, DEFAULT_FRICTION};
use crate::command::{Blob, ControlMode, MotorSpec};
use crate::outputs::{JointInfo, JointState, JointValue, UrdfLoaded};
use crate::value::{r32, r32s, Refusal};

/// The `force` a motor gets when neither the call nor the URDF gives one (PyBullet's habit).
pub const DEFAULT_MOTOR_FORCE: f32 = 500.0;
/// Damping factor that makes rapier's velocity motor a hard constraint (bounded by max force),
/// as Bullet's motor is: the constraint mixing term becomes ~1e-7.
const HARD_MOTOR: f32 = 1.0e9;

/// A motor in force on a joint, with its effort resolved.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Motor {
    /// As set_joint_motor_control gave it.
    pub spec: MotorSpec,
    /// Max effort (POSITION/VELOCITY) or applied torque (TORQUE).
    pub force: f32,
}

/// One link of a robot (PyBullet link i = the child of joint i).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct RobotLink {
    /// URDF link name.
    pub name: String,
    /// Its rapier body.
    pub body: RigidBodyHandle,
    /// Its colliders.
    pub colliders: Vec<ColliderHandle>,
    /// The joint to its parent, as written.
    pub joint: JointSpec,
    /// The motor, if one was set.
    pub motor: Option<Motor>,
    /// Torque (or force) the motor applied in the last step.
    pub motor_torque: f32,
    /// RGBA from the URDF material.
    pub color: Option<[f32; 4]>,
    /// Properties stored for PyBullet fidelity.
    pub extras: DynamicsExtras,
}

/// A loaded robot: what the tools report and what motors need, beside rapier's sets.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Robot {
    /// The path the client gave.
    pub file_path: String,
    /// blake3 of the URDF text (its blob in the log).
    pub urdf_hash: String,
    /// blake3 of each mesh, by the name written in the URDF.
    pub mesh_hashes: BTreeMap<String, String>,
    /// `<robot name>`.
    pub name: String,
    /// Whether the base was fixed to the world by the call.
    pub fixed_base: bool,
    /// The base link's name.
    pub base_name: String,
    /// The base's colliders.
    pub base_colliders: Vec<ColliderHandle>,
    /// Links in PyBullet order.
    pub links: Vec<RobotLink>,
}

impl Robot {
    /// Indices of the joints that move (IK and motors act on these), in PyBullet order.
    pub fn movable(&self) -> Vec<usize> {
        (0..self.links.len()).filter(|i| self.links[*i].joint.kind.movable()).collect()
    }

    /// The first ball joint (index, name), if the robot has one: the tools that work in joint
    /// space with one number per joint (IK, Jacobians, mass matrix, inverse dynamics, reaction
    /// wrenches) refuse such a robot instead of treating the ball joint as fixed.
    pub fn ball_joint(&self) -> Option<(usize, &str)> {
        self.links.iter().position(|l| l.joint.kind == JointKind::Spherical).map(|i| (i, self.links[i].joint.name.as_str()))
    }

    /// The refusal of `tool` on this robot (object `id`) when it has a ball joint.
    pub fn ball_joint_refusal(&self, id: u32, tool: &str) -> Result<(), Refusal> {
        match self.ball_joint() {
            Some((i, name)) => Err(format!("object_id {id} has a ball joint (joint {i}, {name}); {tool} supports robots of hinge and slide joints only")),
            None => Ok(()),
        }
    }
}

/// Why joint `joint_index` (`spec`) cannot take what needs one scalar coordinate: a fixed joint
/// has none (`fixed_why` says so, as before ball joints existed), a ball joint three.
pub(crate) fn not_scalar(joint_index: u32, spec: &JointSpec, fixed_why: &str) -> Refusal {
    match spec.kind {
        JointKind::Spherical => format!("joint_index {joint_index} is a ball joint ({}); only hinge and slide joints take one value", spec.name),
        _ => format!("joint_index {joint_index} is a fixed joint ({}); {fixed_why}", spec.name),
    }
}

impl Robot {
    /// The body of link `link_index` (−1 = the base, whose body is `base`).
    pub fn link_body(&self, base: RigidBodyHandle, link_index: i32) -> Option<RigidBodyHandle> {
        if link_index < 0 {
            Some(base)
        } else {
            self.links.get(link_index as usize).map(|l| l.body)
        }
    }
}

fn pose_f64(pos: [f64; 3], rot: [f64; 4]) -> Pose {
    Pose::from_parts(
        Vector::new(pos[0] as f32, pos[1] as f32, pos[2] as f32),
        Rotation::from_xyzw(rot[0] as f32, rot[1] as f32, rot[2] as f32, rot[3] as f32).normalize(),
    )
}

/// A model file's joint axis that normalises: its squared length finite and not (nearly) zero.
/// `[0, -1e308, 1]` has finite parts but normalises to zero, and a zero axis fills the joint's
/// frame with NaN, on which the engine's joint solver panics at the next step. Checked at the
/// edge (`Command::within_extent`), so logs that loaded such a model fold as they always did.
pub(crate) fn axis_refusal(joint: &str, axis: [f64; 3]) -> Result<(), Refusal> {
    let squared: f64 = axis.iter().map(|x| x * x).sum();
    match squared.is_finite() && squared > 1e-18 {
        true => Ok(()),
        false => Err(format!("joint {joint} has an axis with no finite, non-zero length to normalise")),
    }
}

/// Rotation taking the joint frame's x axis onto the URDF axis (rapier moves along AngX/LinX).
fn axis_frame(axis: [f64; 3]) -> Rotation {
    let a = Vec3::new(axis[0] as f32, axis[1] as f32, axis[2] as f32).normalize();
    Quat::from_rotation_arc(Vec3::X, a)
}

fn collider(part: &Part) -> ColliderBuilder {
    // The model builder proved every hull exists; a tiny ball is an unreachable fallback.
    let (shape, pose) = part_shape(part).unwrap_or_else(|| (SharedShape::ball(0.01), Pose::IDENTITY));
    ColliderBuilder::new(shape)
        .position(pose)
        .density(0.0)
        .friction(DEFAULT_FRICTION)
        .restitution(0.0)
        .friction_combine_rule(CoefficientCombineRule::Multiply)
        .restitution_combine_rule(CoefficientCombineRule::Multiply)
}

fn generic_joint(spec: &JointSpec) -> GenericJoint {
    let origin = pose_f64(spec.origin_pos, spec.origin_rot);
    let locked = match spec.kind {
        JointKind::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
        JointKind::Revolute | JointKind::Continuous => JointAxesMask::LOCKED_REVOLUTE_AXES,
        JointKind::Prismatic => JointAxesMask::LOCKED_PRISMATIC_AXES,
        JointKind::Spherical => JointAxesMask::LOCKED_SPHERICAL_AXES,
    };
    let frame = if spec.kind.movable() { Pose::from_rotation(axis_frame(spec.axis)) } else { Pose::IDENTITY };
    let mut b = GenericJointBuilder::new(locked)
        .local_frame1(origin * frame)
        .local_frame2(frame)
        .contacts_enabled(false);
    if spec.limited() {
        let axis = if spec.kind == JointKind::Prismatic { JointAxis::LinX } else { JointAxis::AngX };
        b = b.limits(axis, [spec.lower as f32, spec.upper as f32]);
    }
    b.build()
}

/// The rapier axis a joint moves along.
fn joint_axis(kind: JointKind) -> JointAxis {
    if kind == JointKind::Prismatic {
        JointAxis::LinX
    } else {
        JointAxis::AngX
    }
}

impl World {
    /// Inserts a robot built from `model` with its base at `pose`; returns its object id.
    pub(super) fn insert_robot(
        &mut self,
        model: RobotModel,
        file_path: &str,
        blobs: (&Blob, &BTreeMap<String, Blob>),
        pose: Pose,
        fixed_base: bool,
    ) -> UrdfLoaded {
        let mut world_pose: Vec<Pose> = Vec::with_capacity(model.links.len());
        let mut bodies = Vec::with_capacity(model.links.len());
        let mut colliders = Vec::with_capacity(model.links.len());
        for (i, link) in model.links.iter().enumerate() {
            let p = match &link.joint {
                None => pose,
                Some(j) => world_pose[(j.parent + 1) as usize] * pose_f64(j.origin_pos, j.origin_rot),
            };
            world_pose.push(p);
            let root_fixed = i == 0 && (fixed_base || link.mass == 0.0);
            let ty = if root_fixed { RigidBodyType::Fixed } else { RigidBodyType::Dynamic };
            let inertia = Mat3::from_cols_array_2d(&link.inertia.map(|c| c.map(|x| x as f32)));
            let com = Vector::new(link.com[0] as f32, link.com[1] as f32, link.com[2] as f32);
            // Articulations never sleep: rapier would freeze a slow pendulum at its turning
            // point (its sleep test is a plain velocity threshold), and motors must act.
            let mut rb = RigidBodyBuilder::new(ty)
                .can_sleep(false)
                .pose(p)
                .linear_damping(DEFAULT_DAMPING)
                .angular_damping(DEFAULT_DAMPING);
            if link.mass > 0.0 {
                rb = rb.additional_mass_properties(MassProperties::with_inertia_matrix(com, link.mass as f32, inertia));
            }
            let body = self.physics.insert_body(rb);
            let cs: Vec<ColliderHandle> = link
                .parts
                .iter()
                .map(|part| self.physics.insert_collider(collider(part), Some(body)))
                .collect();
            // Mass properties are otherwise only folded in at the next step; reads after
            // load_urdf must already see the URDF's inertials.
            let set = &self.physics.colliders;
            if let Some(b) = self.physics.bodies.get_mut(body) {
                b.recompute_mass_properties_from_colliders(set);
            }
            bodies.push(body);
            colliders.push(cs);
        }
        let mut links = Vec::new();
        let mut link_masses = Vec::new();
        for (i, link) in model.links.iter().enumerate().skip(1) {
            let Some(spec) = &link.joint else { continue };
            link_masses.push(link.mass as f32);
            let parent = bodies[(spec.parent + 1) as usize];
            self.physics.multibody_joints.insert(parent, bodies[i], generic_joint(spec), true);
            links.push(RobotLink {
                name: link.name.clone(),
                body: bodies[i],
                colliders: colliders[i].clone(),
                joint: spec.clone(),
                motor: None,
                motor_torque: 0.0,
                color: link.color,
                extras: DynamicsExtras::default(),
            });
        }
        self.configure_multibody(&links);
        let base = &model.links[0];
        let robot = Robot {
            file_path: file_path.to_string(),
            urdf_hash: blobs.0.hash.clone(),
            mesh_hashes: blobs.1.iter().map(|(k, b)| (k.clone(), b.hash.clone())).collect(),
            name: model.name.clone(),
            fixed_base,
            base_name: base.name.clone(),
            base_colliders: colliders[0].clone(),
            links,
        };
        let num_joints = robot.links.len();
        let id = self.tables.next_object_id;
        self.tables.next_object_id += 1;
        for (link, mass) in (0u32..).zip(link_masses).filter(|(_, m)| *m > 0.0) {
            self.tables.as_given.link_masses.insert((id, link), mass);
        }
        self.tables.objects.insert(
            id,
            Object {
                body: bodies[0],
                collider: colliders[0].first().copied().unwrap_or_else(ColliderHandle::invalid),
                kind: ObjectKind::Robot { robot: Box::new(robot) },
                color: base.color,
                mass: base.mass as f32,
                extras: DynamicsExtras::default(),
            },
        );
        UrdfLoaded {
            landed: None,
            object_id: id,
            file_path: file_path.to_string(),
            position: r32s(pose.translation.to_array()),
            num_joints,
        }
    }

    /// Multibody joints get rapier's default damping (0.1 on angular axes); a URDF joint is
    /// free unless its `<dynamics damping>` says otherwise, and a free base is undamped here
    /// too (its bodies keep PyBullet's 0.04 as reported values). A robot's links do not
    /// collide with each other (PyBullet's default without URDF_USE_SELF_COLLISION).
    fn configure_multibody(&mut self, links: &[RobotLink]) {
        self.configure_multibody_joints(links, &[], false);
    }

    /// One multibody setup for URDF and MJCF robots: rapier's default damping cleared, each
    /// link's joint damping per DoF, `armatures[k]` (when given and > 0) on link k's mass
    /// diagonal, and self-contacts as the model format wants them.
    pub(crate) fn configure_multibody_joints(&mut self, links: &[RobotLink], armatures: &[f32], self_contacts: bool) {
        let mbs = &mut self.physics.multibody_joints;
        let mut seen = std::collections::BTreeSet::new();
        for (k, l) in links.iter().enumerate() {
            let Some(id) = mbs.rigid_body_link(l.body).copied() else { continue };
            let Some(mb) = mbs.get_multibody_mut(id.multibody) else { continue };
            if seen.insert(format!("{:?}", id.multibody)) {
                mb.damping_mut().fill(0.0);
                mb.set_self_contacts_enabled(self_contacts);
            }
            let Some(link) = mb.link(id.id) else { continue };
            let (start, n) = (link.assembly_id(), link.joint().ndofs());
            if n > 0 {
                mb.damping_mut().rows_mut(start, n).fill(l.joint.damping as f32);
                let armature = armatures.get(k).copied().unwrap_or(0.0);
                if armature > 0.0 {
                    mb.armature_mut().rows_mut(start, n).fill(armature);
                }
            }
        }
    }

    /// The robot an object is, if it is one.
    pub fn robot(&self, id: u32) -> Option<&Robot> {
        self.tables.objects.get(&id)?.kind.robot()
    }

    fn robot_mut(&mut self, id: u32) -> Option<&mut Robot> {
        self.tables.objects.get_mut(&id)?.kind.robot_mut()
    }

    /// The standard out-of-range sentence unless `joint_index` names a joint of `id`.
    pub fn check_joint(&self, id: u32, joint_index: i64) -> Result<usize, Refusal> {
        let n = self.link_count(id);
        if joint_index >= 0 && (joint_index as usize) < n {
            Ok(joint_index as usize)
        } else {
            Err(format!("Joint index {joint_index} out of range: object {id} has {n} joints"))
        }
    }

    /// Checks a motor command: the joint exists and moves, and the values make sense.
    pub fn check_motor(&self, id: u32, joint_index: u32, m: &MotorSpec) -> Result<(), Refusal> {
        let i = self.check_joint(id, joint_index as i64)?;
        let robot = self.robot(id).ok_or_else(|| format!("Joint index {joint_index} out of range: object {id} has 0 joints"))?;
        if !robot.links[i].joint.kind.movable() {
            return Err(not_scalar(joint_index, &robot.links[i].joint, "it cannot have a motor"));
        }
        if m.force.is_some_and(|f| m.mode != ControlMode::TorqueControl && f < 0.0) {
            return Err("force must be >= 0 for POSITION_CONTROL and VELOCITY_CONTROL (it is the maximum effort)".into());
        }
        Ok(())
    }

    /// set_joint_motor_control: replaces the joint's motor (acts from the next step on).
    pub(super) fn set_motor(&mut self, id: u32, joint_index: u32, spec: &MotorSpec) -> String {
        let Some(robot) = self.robot_mut(id) else { return String::new() };
        let Some(link) = robot.links.get_mut(joint_index as usize) else { return String::new() };
        let effort = link.joint.effort as f32;
        let force = spec.force.unwrap_or(if effort > 0.0 { effort } else { DEFAULT_MOTOR_FORCE });
        link.motor = Some(Motor { spec: spec.clone(), force });
        let (body, kind) = (link.body, link.joint.kind);
        self.release_actuators(id, joint_index);
        if spec.mode == ControlMode::TorqueControl {
            self.with_mb_link(body, |joint| {
                joint.data.motor_axes.remove(joint_axis(kind).into());
            });
        }
        self.physics.wake_up(body, true);
        format!("Motor of joint {joint_index} of object {id} set to {}", spec.mode.name())
    }

    /// Removes joint `joint_index`'s motor (set_actuator_controls took the joint over): the
    /// engine's motor on its axis is off and its torque reads 0. A joint without one is left
    /// as it is.
    pub(super) fn remove_motor(&mut self, id: u32, joint_index: u32) {
        let Some(link) = self.robot_mut(id).and_then(|r| r.links.get_mut(joint_index as usize)) else { return };
        if link.motor.take().is_none() {
            return;
        }
        link.motor_torque = 0.0;
        let (body, kind) = (link.body, link.joint.kind);
        self.with_mb_link(body, |joint| {
            joint.data.motor_axes.remove(joint_axis(kind).into());
        });
    }

    fn with_mb_link(&mut self, body: RigidBodyHandle, f: impl FnOnce(&mut rapier3d::dynamics::MultibodyJoint)) {
        let mbs = &mut self.physics.multibody_joints;
        let Some(id) = mbs.rigid_body_link(body).copied() else { return };
        if let Some(link) = mbs.get_multibody_mut(id.multibody).and_then(|mb| mb.link_mut(id.id)) {
            f(&mut link.joint);
        }
    }

    /// Checks a reset_joint_state: the joint exists and moves.
    pub fn check_reset_joint(&self, id: u32, joint_index: u32) -> Result<(), Refusal> {
        let i = self.check_joint(id, joint_index as i64)?;
        let robot = self.robot(id).ok_or_else(|| format!("Joint index {joint_index} out of range: object {id} has 0 joints"))?;
        if robot.links[i].joint.kind.movable() {
            Ok(())
        } else {
            Err(not_scalar(joint_index, &robot.links[i].joint, "it has no position to reset"))
        }
    }

    /// reset_joint_state: sets one joint's coordinate and velocity, then moves every body of
    /// the multibody to the new configuration (poses by forward kinematics, velocities from
    /// the body Jacobians) so reads see it before the next step, as in PyBullet.
    pub(super) fn reset_joint(&mut self, id: u32, joint_index: u32, value: f32, velocity: f32) -> String {
        let Some(link) = self.robot(id).and_then(|r| r.links.get(joint_index as usize)) else { return String::new() };
        let (body, kind) = (link.body, link.joint.kind);
        let (q, _) = self.joint_coordinates(body, kind);
        let mbs = &mut self.physics.multibody_joints;
        let Some(lid) = mbs.rigid_body_link(body).copied() else { return String::new() };
        let Some(mb) = mbs.get_multibody_mut(lid.multibody) else { return String::new() };
        // The root's pose (and whether it is free, which shifts every dof index) comes from
        // its body, as set_object_pose leaves it.
        mb.forward_kinematics(&self.physics.bodies, true);
        let Some(l) = mb.link_mut(lid.id) else { return String::new() };
        let dof = l.assembly_id();
        l.joint.apply_displacement(&[value - q]);
        mb.generalized_velocity_mut()[dof] = velocity;
        mb.forward_kinematics(&self.physics.bodies, true);
        mb.update_rigid_bodies(&mut self.physics.bodies, true);
        let v = mb.generalized_velocity().clone_owned();
        let velocities: Vec<(RigidBodyHandle, Vector, Vector)> = mb
            .links()
            .map(|l| {
                let j = mb.body_jacobian(l.link_id()) * &v;
                (l.rigid_body_handle(), Vector::new(j[0], j[1], j[2]), Vector::new(j[3], j[4], j[5]))
            })
            .collect();
        for (h, lin, ang) in velocities {
            if let Some(b) = self.physics.bodies.get_mut(h) {
                if b.is_dynamic() {
                    b.set_linvel(lin, true);
                    b.set_angvel(ang, true);
                }
            }
        }
        format!("Joint {joint_index} of object {id} reset")
    }

    /// Sets a ball joint's rotation (a keyframe's quaternion, at load: the robot at rest), then
    /// moves every body of the multibody to the new configuration, as [`World::reset_joint`]
    /// does for one value.
    pub(super) fn reset_ball_joint(&mut self, id: u32, joint_index: u32, target: Rotation) {
        let Some(link) = self.robot(id).and_then(|r| r.links.get(joint_index as usize)) else { return };
        let body = link.body;
        let mbs = &mut self.physics.multibody_joints;
        let Some(lid) = mbs.rigid_body_link(body).copied() else { return };
        let Some(mb) = mbs.get_multibody_mut(lid.multibody) else { return };
        mb.forward_kinematics(&self.physics.bodies, true);
        let Some(l) = mb.link_mut(lid.id) else { return };
        let dof = l.assembly_id();
        // `apply_displacement` turns the rotation by exp(d) on the left: d = log(target · current⁻¹).
        let d = (target * l.joint.joint_rot().inverse()).to_scaled_axis();
        l.joint.apply_displacement(&[d.x, d.y, d.z]);
        mb.generalized_velocity_mut().rows_mut(dof, 3).fill(0.0);
        mb.forward_kinematics(&self.physics.bodies, true);
        mb.update_rigid_bodies(&mut self.physics.bodies, true);
        let roots: Vec<RigidBodyHandle> = mb.links().map(|l| l.rigid_body_handle()).collect();
        for h in roots {
            if let Some(b) = self.physics.bodies.get_mut(h) {
                if b.is_dynamic() {
                    b.set_linvel(Vector::ZERO, true);
                    b.set_angvel(Vector::ZERO, true);
                }
            }
        }
    }

    /// get_link_state: link −1 is the base; otherwise the link's frame, its centre of mass and
    /// inertial frame (rotated by the principal-axes frame get_dynamics_info reports), and the
    /// velocity of its centre of mass.
    pub fn link_state(&self, id: u32, link_index: i32) -> Option<crate::outputs::LinkState> {
        let base = self.body_handle(id)?;
        let h = match self.robot(id) {
            Some(r) => r.link_body(base, link_index)?,
            None => base,
        };
        let b = self.physics.bodies.get(h)?;
        let p = b.position();
        let (_, inertia_orn) = super::bodies::reported_inertia(&b.mass_properties().local_mprops);
        let com_rot = p.rotation * Rotation::from_array(inertia_orn);
        Some(crate::outputs::LinkState {
            link_world_position: r32s(p.translation.to_array()),
            link_world_orientation: r32s(p.rotation.to_array()),
            com_world_position: r32s(b.center_of_mass().to_array()),
            com_world_orientation: r32s(com_rot.to_array()),
            linear_velocity: r32s(b.linvel().to_array()),
            angular_velocity: r32s(b.angvel().to_array()),
        })
    }

    /// Joint position and velocity (rad, rad/s or m, m/s) of a link's parent joint (zeros for a
    /// fixed or ball joint: [`World::ball_joint_state`] reads the latter).
    pub fn joint_coordinates(&self, body: RigidBodyHandle, kind: JointKind) -> (f32, f32) {
        let mbs = &self.physics.multibody_joints;
        let Some(id) = mbs.rigid_body_link(body) else { return (0.0, 0.0) };
        let Some(mb) = mbs.get_multibody(id.multibody) else { return (0.0, 0.0) };
        let Some(link) = mb.link(id.id) else { return (0.0, 0.0) };
        let q = match kind {
            JointKind::Revolute | JointKind::Continuous => link.joint().coords()[3],
            JointKind::Prismatic => link.joint().coords()[0],
            JointKind::Fixed | JointKind::Spherical => return (0.0, 0.0),
        };
        let v = mb.joint_velocity(link);
        (q, if v.is_empty() { 0.0 } else { v[0] })
    }

    /// A ball joint's state as PyBullet's `getJointStateMultiDof` and MuJoCo's qpos/qvel give
    /// it: the child's rotation relative to its parent-side joint frame as a quaternion
    /// [x, y, z, w] (MuJoCo's ball qpos, reordered), and its angular velocity relative to the
    /// parent in the child's joint frame (MuJoCo's qvel). Rapier keeps the rotation and an
    /// angular velocity in the parent-side frame; the latter is rotated into the child's.
    pub fn ball_joint_state(&self, body: RigidBodyHandle) -> ([f32; 4], [f32; 3]) {
        let mbs = &self.physics.multibody_joints;
        let none = ([0.0, 0.0, 0.0, 1.0], [0.0; 3]);
        let Some(id) = mbs.rigid_body_link(body) else { return none };
        let Some(mb) = mbs.get_multibody(id.multibody) else { return none };
        let Some(link) = mb.link(id.id) else { return none };
        let rot = link.joint().joint_rot();
        let v = mb.joint_velocity(link);
        if v.len() < 3 {
            return none;
        }
        let in_child = rot.inverse() * Vector::new(v[0], v[1], v[2]);
        (rot.to_array(), in_child.to_array())
    }

    /// Before a step: aims every position/velocity motor at this step's target velocity and
    /// applies every torque motor. Returns what `record_motor_torques` needs after the step.
    /// Runs every step, so it copies out only each motor's few numbers, never a robot (its
    /// names and lists were 7% of a KUKA step's instructions when it did).
    pub(super) fn drive_motors(&mut self) -> Vec<MotorWatch> {
        let dt = self.timestep();
        let mut watches: Vec<MotorWatch> = Vec::new();
        let mut torque_robots = Vec::new();
        let robots: Vec<(u32, RigidBodyHandle)> = self
            .tables
            .objects
            .iter()
            .filter(|(_, o)| o.kind.robot().is_some_and(|robot| robot.links.iter().any(|l| l.motor.is_some())))
            .map(|(id, o)| (*id, o.body))
            .collect();
        for (id, base) in robots {
            let links = self.robot(id).map_or(0, |r| r.links.len());
            for i in 0..links {
                let Some(m) = self.robot(id).and_then(|robot| DrivenJoint::of(robot, base, i)) else { continue };
                let (q, _) = self.joint_coordinates(m.body, m.kind);
                let s = &m.spec;
                match s.mode {
                    ControlMode::TorqueControl => {
                        self.apply_joint_effort(m.body, m.parent, m.kind, m.axis, m.force);
                        if let Some(l) = self.robot_mut(id).and_then(|r| r.links.get_mut(i)) {
                            l.motor_torque = m.force;
                        }
                        torque_robots.push(id);
                    }
                    ControlMode::PositionControl | ControlMode::VelocityControl => {
                        let mut target = if s.mode == ControlMode::PositionControl {
                            s.position_gain * (s.target_position - q) / dt + s.velocity_gain * s.target_velocity
                        } else {
                            s.target_velocity
                        };
                        if m.vmax > 0.0 {
                            target = target.clamp(-m.vmax, m.vmax);
                        }
                        let axis = joint_axis(m.kind);
                        let force = m.force;
                        self.with_mb_link(m.body, |joint| {
                            joint.data.set_motor_velocity(axis, target, HARD_MOTOR);
                            joint.data.set_motor_max_force(axis, force);
                        });
                        let after = watches.last().map(|w| w.body);
                        if let Some(w) = self.watch(id, i, m.body, force, after) {
                            watches.push(w);
                        }
                    }
                }
            }
        }
        for id in torque_robots {
            self.tables.pending_wrench.insert(id);
        }
        watches
    }

    /// Applies a joint torque (revolute) or force (prismatic) along `axis` (in the child's
    /// frame) as equal and opposite efforts on the child and parent bodies, so only that
    /// joint's coordinate feels it.
    pub(super) fn apply_joint_effort(&mut self, child: RigidBodyHandle, parent: RigidBodyHandle, kind: JointKind, axis: [f64; 3], effort: f32) {
        let Some(c) = self.physics.bodies.get(child) else { return };
        let axis = *c.rotation() * Vector::new(axis[0] as f32, axis[1] as f32, axis[2] as f32);
        let at = c.center_of_mass();
        match kind {
            JointKind::Prismatic => {
                self.step_forces(child, |b| b.add_force(axis * effort));
                self.step_forces(parent, |b| b.add_force_at_point(-axis * effort, at));
            }
            _ => {
                self.step_forces(child, |b| b.add_torque(axis * effort));
                self.step_forces(parent, |b| b.add_torque(-axis * effort));
            }
        }
    }

    /// What `record_motor_torques` needs about a motor on `body`. `after` is the body of the
    /// watch before it: on the same multibody, that watch's generalized impulse serves this one
    /// too, so the velocities are not copied again.
    fn watch(&self, id: u32, link: usize, body: RigidBodyHandle, force: f32, after: Option<RigidBodyHandle>) -> Option<MotorWatch> {
        let mbs = &self.physics.multibody_joints;
        let lid = mbs.rigid_body_link(body)?;
        let mb = mbs.get_multibody(lid.multibody)?;
        let l = mb.link(lid.id)?;
        let reuse = after.is_some_and(|a| self.same_multibody(a, body));
        Some(MotorWatch {
            object: id,
            link,
            body,
            dof: l.assembly_id(),
            force,
            before: (!reuse).then(|| mb.generalized_velocity().iter().copied().collect()),
        })
    }

    /// After a step: the torque each position/velocity motor applied. rapier does not report
    /// multibody motor impulses, so it is recovered from the dynamics: the generalized impulse
    /// the constraints added, M·(Δq̇/dt − q̈_free), at the motor's coordinate, clamped to its
    /// force. Contacts or limits acting on the same coordinate in that step are included.
    pub(super) fn record_motor_torques(&mut self, watches: Vec<MotorWatch>) {
        let dt = self.timestep();
        // The generalized impulse depends only on the multibody (every watch of one multibody
        // saw the same velocities before the step), so it is computed once per multibody and
        // read at each motor's coordinate: the same arithmetic as one solve per motor, so the
        // same torques bit for bit, without a dense L·U product per motor per step (12% of a
        // humanoid's step with every joint velocity-driven; docs/benchmarks.md "MJCF").
        let mut last: Option<rapier3d::na::DVector<f32>> = None;
        for w in watches {
            // A watch without velocities follows one of its multibody (`watch`).
            if let Some(before) = &w.before {
                last = self.generalized_impulse(w.body, before, dt);
            }
            let y = last.as_ref();
            let tau = y.and_then(|y| (w.dof < y.len()).then(|| y[w.dof]));
            let tau = tau.unwrap_or(0.0).clamp(-w.force, w.force);
            if let Some(robot) = self.robot_mut(w.object) {
                if let Some(l) = robot.links.get_mut(w.link) {
                    l.motor_torque = tau;
                }
            }
        }
    }

    /// Whether two bodies are links of the same multibody.
    fn same_multibody(&self, a: RigidBodyHandle, b: RigidBodyHandle) -> bool {
        let mbs = &self.physics.multibody_joints;
        match (mbs.rigid_body_link(a), mbs.rigid_body_link(b)) {
            (Some(x), Some(y)) => x.multibody == y.multibody,
            _ => false,
        }
    }

    /// M·(Δq̇/dt − q̈_free) of the multibody `body` is a link of, over the step just taken,
    /// from its velocities `before` it (`record_motor_torques`); None when its coordinates
    /// changed shape (each motor's own coordinate is checked by the caller).
    fn generalized_impulse(&self, body: RigidBodyHandle, before: &[f32], dt: f32) -> Option<rapier3d::na::DVector<f32>> {
        let mbs = &self.physics.multibody_joints;
        let lid = mbs.rigid_body_link(body)?;
        let mb = mbs.get_multibody(lid.multibody)?;
        let n = mb.ndofs();
        if before.len() != n {
            return None;
        }
        let v = mb.generalized_velocity();
        let a = mb.generalized_acceleration();
        let x = rapier3d::na::DVector::<f32>::from_fn(n, |i, _| (v[i] - before[i]) / dt - a[i]);
        if self.engine_rule() != crate::engine::EngineRule::Upstream {
            // The tree path keeps the augmented mass matrix itself, in degree-of-freedom order.
            let m = mb.augmented_mass();
            return (m.nrows() == n && m.ncols() == n).then(|| m * x);
        }
        let lu = mb.inv_augmented_mass();
        let mut y = lu.l() * (lu.u() * x);
        lu.p().inv_permute_rows(&mut y);
        Some(y)
    }

    /// get_joint_info.
    pub fn joint_info(&self, id: u32, i: usize) -> Option<JointInfo> {
        let robot = self.robot(id)?;
        let l = robot.links.get(i)?;
        let j = &l.joint;
        Some(JointInfo {
            joint_index: i,
            joint_name: j.name.clone(),
            joint_type: j.kind.name().into(),
            lower_limit: r32(j.lower as f32),
            upper_limit: r32(j.upper as f32),
            max_force: r32(j.effort as f32),
            max_velocity: r32(j.velocity as f32),
            joint_axis: r32s(j.axis.map(|x| x as f32)),
            link_name: l.name.clone(),
            parent_index: j.parent,
            actuators: self
                .actuation(id)
                .map(|a| super::actuators::infos(a).into_iter().filter(|x| x.joint_index as usize == i).collect())
                .unwrap_or_default(),
            equality: self.tables.mjcf_elements.get(&id).map(|e| e.naming(&e.equality, i)).unwrap_or_default(),
            tendons: self.tables.mjcf_elements.get(&id).map(|e| e.naming(&e.tendons, i)).unwrap_or_default(),
        })
    }

    /// get_joint_state.
    pub fn joint_state(&self, id: u32, i: usize) -> Option<JointState> {
        let robot = self.robot(id)?;
        let l = robot.links.get(i)?;
        let (position, velocity) = match l.joint.kind {
            JointKind::Spherical => {
                let (q, w) = self.ball_joint_state(l.body);
                (JointValue::Multi(r32s(q).to_vec()), JointValue::Multi(r32s(w).to_vec()))
            }
            kind => {
                let (q, v) = self.joint_coordinates(l.body, kind);
                (JointValue::Scalar(r32(q)), JointValue::Scalar(r32(v)))
            }
        };
        let sensed = self.tables.joint_sensors.contains(&(id, i as u32));
        let reaction_forces = if sensed { self.joint_reaction_wrench(id, i).unwrap_or_default() } else { [0.0; 6] };
        Some(JointState {
            joint_position: position,
            joint_velocity: velocity,
            reaction_forces,
            motor_torque: r32(l.motor_torque),
            trajectory: self.trajectory_progress(id, i as u32).map(|p| crate::outputs::TrajectoryState {
                elapsed: p.elapsed_s,
                duration: p.duration_s,
                next_waypoint: p.next_waypoint,
            }),
        })
    }

    /// calculate_inverse_kinematics: one position per movable joint reaching the target with
    /// link `ee`'s frame, within limits (the URDF's unless given), starting from `rest`
    /// (else the current configuration).
    #[allow(clippy::too_many_arguments)]
    pub fn inverse_kinematics(
        &self,
        id: u32,
        ee: usize,
        target_position: [f32; 3],
        target_orientation: Option<[f32; 4]>,
        lower: Option<Vec<f64>>,
        upper: Option<Vec<f64>>,
        rest: Option<Vec<f64>>,
    ) -> Option<crate::outputs::IkSolution> {
        use rapier3d::glamx::{DQuat, DVec3};
        let robot = self.robot(id)?;
        let base = self.body(id)?.position();
        let joints: Vec<JointSpec> = robot.links.iter().map(|l| l.joint.clone()).collect();
        let movable = robot.movable();
        let limit = |m: usize, upper: bool| {
            let j = &joints[movable[m]];
            if j.limited() { if upper { j.upper } else { j.lower } } else if upper { -1.0 } else { 0.0 }
        };
        let lower = lower.unwrap_or_else(|| (0..movable.len()).map(|m| limit(m, false)).collect());
        let upper = upper.unwrap_or_else(|| (0..movable.len()).map(|m| limit(m, true)).collect());
        let start = rest.unwrap_or_else(|| {
            movable.iter().map(|i| self.joint_coordinates(robot.links[*i].body, joints[*i].kind).0 as f64).collect()
        });
        let t = base.translation;
        let r = base.rotation;
        // MJCF joints: the engine's joint frames (pivot at the joint's `pos`, `ref` folded in).
        let frames: Option<Vec<super::ik::JointFrames>> = match self.tables.objects.get(&id).map(|o| &o.kind) {
            Some(super::ObjectKind::Mjcf { .. }) => robot.links.iter().map(|l| self.joint_frames(l.body)).collect(),
            _ => None,
        };
        let q = super::ik::IkQuery {
            joints: &joints,
            frames: frames.as_deref(),
            base_pos: DVec3::new(t.x as f64, t.y as f64, t.z as f64),
            base_rot: DQuat::from_xyzw(r.x as f64, r.y as f64, r.z as f64, r.w as f64).normalize(),
            end_effector: ee,
            target_pos: DVec3::from_array(target_position.map(|x| x as f64)),
            target_rot: target_orientation
                .map(|o| DQuat::from_xyzw(o[0] as f64, o[1] as f64, o[2] as f64, o[3] as f64).normalize()),
            lower,
            upper,
            start,
        };
        let ans = super::ik::solve(&q);
        Some(crate::outputs::IkSolution {
            joint_positions: ans.q,
            position_error: ans.position_error,
            orientation_error: ans.orientation_error,
            iterations: ans.iterations,
        })
    }

    /// The frames of the multibody joint that attaches `body` to its parent, in f64 (IK).
    pub(super) fn joint_frames(&self, body: RigidBodyHandle) -> Option<super::ik::JointFrames> {
        use rapier3d::glamx::{DQuat, DVec3};
        let mbs = &self.physics.multibody_joints;
        let link = mbs.rigid_body_link(body)?;
        let data = &mbs.get_multibody(link.multibody)?.link(link.id)?.joint.data;
        let d = |p: &Pose| {
            let (t, r) = (p.translation, p.rotation);
            (DVec3::new(t.x as f64, t.y as f64, t.z as f64), DQuat::from_xyzw(r.x as f64, r.y as f64, r.z as f64, r.w as f64).normalize())
        };
        Some(super::ik::JointFrames { parent: d(&data.local_frame1), child: d(&data.local_frame2) })
    }

    /// Moves a robot's base; the links follow through forward kinematics.
    pub(super) fn set_robot_pose(&mut self, base: RigidBodyHandle, pose: Pose) {
        if let Some(b) = self.physics.bodies.get_mut(base) {
            b.set_position(pose, true);
        }
        let mbs = &mut self.physics.multibody_joints;
        let Some(id) = mbs.rigid_body_link(base).copied() else { return };
        if let Some(mb) = mbs.get_multibody_mut(id.multibody) {
            mb.forward_kinematics(&self.physics.bodies, true);
            mb.update_rigid_bodies(&mut self.physics.bodies, true);
        }
    }

    /// Removes every body of a robot (leaves first).
    pub(super) fn remove_robot_bodies(&mut self, base: RigidBodyHandle, robot: &Robot) {
        for l in robot.links.iter().rev() {
            self.physics.remove_body(l.body);
        }
        self.physics.remove_body(base);
    }

    /// Clears one-step forces on every body of a robot.
    pub(super) fn clear_robot_forces(&mut self, id: u32) {
        let Some(robot) = self.robot(id) else { return };
        let bodies: Vec<RigidBodyHandle> = robot.links.iter().map(|l| l.body).collect();
        for h in bodies {
            self.step_forces(h, super::step_forces::clear);
        }
    }
}

/// What `record_motor_torques` needs about one motor: where it is and its multibody's
/// velocities before the step (None: the same multibody as the watch before it).
pub(super) struct MotorWatch {
    object: u32,
    link: usize,
    body: RigidBodyHandle,
    dof: usize,
    force: f32,
    before: Option<Vec<f32>>,
}

/// One motored joint's numbers, copied out of its robot for a step (`drive_motors`).
struct DrivenJoint {
    body: RigidBodyHandle,
    parent: RigidBodyHandle,
    kind: JointKind,
    axis: [f64; 3],
    vmax: f32,
    spec: MotorSpec,
    force: f32,
}

impl DrivenJoint {
    /// Link `i` of `robot` (based at `base`), if a motor drives it.
    fn of(robot: &Robot, base: RigidBodyHandle, i: usize) -> Option<DrivenJoint> {
        let link = robot.links.get(i)?;
        let motor = link.motor.as_ref()?;
        Some(DrivenJoint {
            body: link.body,
            parent: robot.link_body(base, link.joint.parent).unwrap_or(base),
            kind: link.joint.kind,
            axis: link.joint.axis,
            vmax: link.joint.velocity as f32,
            spec: motor.spec.clone(),
            force: motor.force,
        })
    }
}
