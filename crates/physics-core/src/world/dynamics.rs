//! A robot's rigid-body dynamics in f64 from its model, independent of the engine's internal
//! matrices (which rapier keeps in f32 and the engine-speed work rewrites): the joint reaction
//! wrench (get_joint_state's `reaction_forces`, MJCF force/torque sensors), the Jacobian, the
//! joint-space mass matrix and inverse dynamics, all from one recursive Newton–Euler pass.
//!
//! The kinematic chain is the one IK walks (`ik.rs`): URDF joints from their written origin and
//! axis, MJCF joints from the engine's joint frames. Each link's mass, centre of mass and
//! inertia are read off its body (the URDF `<inertial>` or MJCF body, as `change_dynamics` left
//! it). The base is treated as fixed where it is (its velocity is not part of the model), as
//! PyBullet's calculate* calls treat a fixed base.

use rapier3d::glamx::{DMat3, DQuat, DVec3};
use rapier3d::prelude::RigidBodyHandle;

use super::ik::JointFrames;
use super::urdf::JointKind;
use super::{ObjectKind, World};

/// One link of the chain as the dynamics needs it.
#[derive(Clone, Debug)]
pub struct DynLink {
    /// Parent link (−1: the base).
    pub parent: i32,
    /// How the joint to the parent moves.
    pub kind: JointKind,
    /// Index among the movable joints (the columns of a Jacobian), if it moves.
    pub movable: Option<usize>,
    /// Joint frame in the parent link's frame.
    pub parent_frame: (DVec3, DQuat),
    /// Joint frame in this link's frame (identity for a URDF joint).
    pub child_frame: (DVec3, DQuat),
    /// The joint axis in the joint frame.
    pub axis: DVec3,
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass in the link frame.
    pub com: DVec3,
    /// Inertia about the centre of mass, link-frame axes.
    pub inertia: DMat3,
}

/// A robot's chain with its base pose and the world's gravity.
#[derive(Clone, Debug)]
pub struct RobotDynamics {
    /// World pose of the base link frame.
    pub base: (DVec3, DQuat),
    /// Links in PyBullet order (a parent before its children).
    pub links: Vec<DynLink>,
    /// Number of movable joints.
    pub dofs: usize,
}

/// Pose, velocity and acceleration of one link in the world (from `RobotDynamics::kinematics`).
#[derive(Clone, Copy, Debug, Default)]
pub struct LinkMotion {
    /// Link frame origin.
    pub pos: DVec3,
    /// Link frame orientation.
    pub rot: DQuat,
    /// Angular velocity.
    pub omega: DVec3,
    /// Velocity of the frame origin.
    pub vel: DVec3,
    /// Angular acceleration.
    pub alpha: DVec3,
    /// Acceleration of the frame origin.
    pub acc: DVec3,
    /// World position of the joint to the parent.
    pub joint_pos: DVec3,
    /// World direction of that joint's axis.
    pub joint_axis: DVec3,
}

impl LinkMotion {
    fn velocity_at(&self, x: DVec3) -> DVec3 {
        self.vel + self.omega.cross(x - self.pos)
    }

    /// Acceleration of the point `x` (world) moving with the link.
    pub fn acceleration_at(&self, x: DVec3) -> DVec3 {
        let r = x - self.pos;
        self.acc + self.alpha.cross(r) + self.omega.cross(self.omega.cross(r))
    }

    /// World position of the centre of mass `com` (link frame).
    pub fn com_world(&self, com: DVec3) -> DVec3 {
        self.pos + self.rot * com
    }
}

/// What the Newton–Euler pass gives per link: the wrench the parent exerts on the link through
/// its joint (carrying the whole subtree), in the world frame.
#[derive(Clone, Debug)]
pub struct JointWrenches {
    /// Each link's motion.
    pub motion: Vec<LinkMotion>,
    /// Force through each joint (world).
    pub force: Vec<DVec3>,
    /// Moment through each joint about the joint's position (world).
    pub moment: Vec<DVec3>,
    /// The generalized force per movable joint (the wrench along its axis).
    pub tau: Vec<f64>,
}

impl RobotDynamics {
    /// Each link's world motion for joint positions, velocities and accelerations (one value per
    /// movable joint), the base moving with `base_acc` (−gravity puts gravity into the forces).
    pub fn kinematics(&self, q: &[f64], qd: &[f64], qdd: &[f64], base_acc: DVec3) -> Vec<LinkMotion> {
        let base = LinkMotion { pos: self.base.0, rot: self.base.1, acc: base_acc, ..Default::default() };
        let mut out: Vec<LinkMotion> = Vec::with_capacity(self.links.len());
        for (i, l) in self.links.iter().enumerate() {
            let parent = if l.parent >= 0 && (l.parent as usize) < i { out[l.parent as usize] } else { base };
            let o = parent.pos + parent.rot * l.parent_frame.0;
            let jr = (parent.rot * l.parent_frame.1).normalize();
            let a = jr * l.axis;
            let (x, v, xa) = match l.movable {
                Some(m) => (q.get(m).copied().unwrap_or(0.0), qd.get(m).copied().unwrap_or(0.0), qdd.get(m).copied().unwrap_or(0.0)),
                None => (0.0, 0.0, 0.0),
            };
            let moving = l.movable.is_some() && l.kind != JointKind::Fixed;
            let mut rot = jr;
            let mut origin = o;
            if moving && l.kind == JointKind::Prismatic {
                origin += a * x;
            } else if moving {
                rot = (rot * DQuat::from_axis_angle(l.axis, x)).normalize();
            }
            let inv = l.child_frame.1.inverse();
            let pos = origin + rot * (inv * -l.child_frame.0);
            let rot = (rot * inv).normalize();
            let mut m = LinkMotion { pos, rot, joint_pos: o, joint_axis: a, ..Default::default() };
            if moving && l.kind == JointKind::Prismatic {
                m.omega = parent.omega;
                m.alpha = parent.alpha;
                m.vel = parent.velocity_at(pos) + a * v;
                m.acc = parent.acceleration_at(pos) + a * xa + 2.0 * parent.omega.cross(a * v);
            } else {
                let (w, dw) = if moving { (a * v, a * xa + parent.omega.cross(a * v)) } else { (DVec3::ZERO, DVec3::ZERO) };
                m.omega = parent.omega + w;
                m.alpha = parent.alpha + dw;
                let r = pos - o;
                m.vel = parent.velocity_at(o) + m.omega.cross(r);
                m.acc = parent.acceleration_at(o) + m.alpha.cross(r) + m.omega.cross(m.omega.cross(r));
            }
            out.push(m);
        }
        out
    }

    /// Recursive Newton–Euler: the wrench through every joint for the given motion under
    /// `gravity` (no contacts or applied forces).
    pub fn newton_euler(&self, q: &[f64], qd: &[f64], qdd: &[f64], gravity: DVec3) -> JointWrenches {
        let motion = self.kinematics(q, qd, qdd, -gravity);
        let n = self.links.len();
        let mut force = vec![DVec3::ZERO; n];
        let mut moment = vec![DVec3::ZERO; n];
        for (i, l) in self.links.iter().enumerate() {
            let m = &motion[i];
            let c = m.com_world(l.com);
            let f = l.mass * m.acceleration_at(c);
            let r = DMat3::from_quat(m.rot);
            let inertia = r * l.inertia * r.transpose();
            let h = inertia * m.alpha + m.omega.cross(inertia * m.omega);
            force[i] = f;
            moment[i] = h + (c - m.joint_pos).cross(f);
        }
        for i in (0..n).rev() {
            let p = self.links[i].parent;
            if p >= 0 && (p as usize) < i {
                let p = p as usize;
                let arm = motion[i].joint_pos - motion[p].joint_pos;
                let (fi, mi) = (force[i], moment[i]);
                force[p] += fi;
                moment[p] += mi + arm.cross(fi);
            }
        }
        let mut tau = vec![0.0; self.dofs];
        for (i, l) in self.links.iter().enumerate() {
            if let Some(k) = l.movable {
                let a = motion[i].joint_axis;
                tau[k] = if l.kind == JointKind::Prismatic { a.dot(force[i]) } else { a.dot(moment[i]) };
            }
        }
        JointWrenches { motion, force, moment, tau }
    }

    /// The joint-space mass matrix at `q` (one Newton–Euler pass per column).
    pub fn mass_matrix(&self, q: &[f64]) -> Vec<Vec<f64>> {
        let zero = vec![0.0; self.dofs];
        let mut cols = Vec::with_capacity(self.dofs);
        for k in 0..self.dofs {
            let mut e = zero.clone();
            e[k] = 1.0;
            cols.push(self.newton_euler(q, &zero, &e, DVec3::ZERO).tau);
        }
        (0..self.dofs).map(|r| (0..self.dofs).map(|c| cols[c][r]).collect()).collect()
    }

    /// The linear and angular Jacobians (3 × dofs, world frame) of the point `local` given in
    /// link `link`'s URDF frame — what PyBullet 3.2.7's calculateJacobian computes, although its
    /// documentation says the centre-of-mass frame.
    pub fn jacobian(&self, q: &[f64], link: usize, local: DVec3) -> ([Vec<f64>; 3], [Vec<f64>; 3]) {
        let zero = vec![0.0; self.dofs];
        let motion = self.kinematics(q, &zero, &zero, DVec3::ZERO);
        let mut lin: [Vec<f64>; 3] = std::array::from_fn(|_| zero.clone());
        let mut ang: [Vec<f64>; 3] = std::array::from_fn(|_| zero.clone());
        if link >= self.links.len() {
            return (lin, ang);
        }
        let x = motion[link].pos + motion[link].rot * local;
        let mut at = link as i32;
        let mut guard = 0;
        while at >= 0 && (at as usize) < self.links.len() && guard <= self.links.len() {
            let l = &self.links[at as usize];
            let m = &motion[at as usize];
            if let Some(k) = l.movable {
                let a = m.joint_axis;
                let (v, w) = if l.kind == JointKind::Prismatic { (a, DVec3::ZERO) } else { (a.cross(x - m.joint_pos), a) };
                for d in 0..3 {
                    lin[d][k] = v[d];
                    ang[d][k] = w[d];
                }
            }
            at = l.parent;
            guard += 1;
        }
        (lin, ang)
    }
}

fn d3(v: rapier3d::glamx::Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

impl World {
    /// The f64 dynamics model of robot `id` (None: not a robot).
    pub fn robot_dynamics(&self, id: u32) -> Option<RobotDynamics> {
        let obj = self.tables.objects.get(&id)?;
        let robot = obj.kind.robot()?;
        let mjcf = matches!(obj.kind, ObjectKind::Mjcf { .. });
        let base = self.body(id)?.position();
        let (t, r) = (base.translation, base.rotation);
        let base = (d3(t), DQuat::from_xyzw(r.x as f64, r.y as f64, r.z as f64, r.w as f64).normalize());
        let mut dofs = 0;
        let mut links = Vec::with_capacity(robot.links.len());
        for l in &robot.links {
            let j = &l.joint;
            let movable = j.kind.movable().then(|| {
                dofs += 1;
                dofs - 1
            });
            let frames = if mjcf { self.joint_frames(l.body) } else { None };
            let (parent_frame, child_frame, axis) = match frames {
                Some(JointFrames { parent, child }) => (parent, child, DVec3::X),
                None => (
                    (DVec3::from_array(j.origin_pos), DQuat::from_array(j.origin_rot).normalize()),
                    (DVec3::ZERO, DQuat::IDENTITY),
                    DVec3::from_array(j.axis).normalize(),
                ),
            };
            let (mass, com, inertia) = self.body_inertia(l.body);
            links.push(DynLink { parent: j.parent, kind: j.kind, movable, parent_frame, child_frame, axis, mass, com, inertia });
        }
        Some(RobotDynamics { base, links, dofs })
    }

    /// Mass, centre of mass and inertia (about it, body-frame axes) of a body, in f64.
    fn body_inertia(&self, body: RigidBodyHandle) -> (f64, DVec3, DMat3) {
        let Some(b) = self.physics.bodies.get(body) else { return (0.0, DVec3::ZERO, DMat3::ZERO) };
        let mp = &b.mass_properties().local_mprops;
        let i = mp.reconstruct_inertia_matrix();
        let cols = [i.x_axis, i.y_axis, i.z_axis].map(d3);
        (mp.mass() as f64, d3(mp.local_com), DMat3::from_cols(cols[0], cols[1], cols[2]))
    }

    /// The current positions and velocities of robot `id`'s movable joints, in f64.
    pub fn robot_configuration(&self, id: u32) -> Option<(Vec<f64>, Vec<f64>)> {
        let robot = self.robot(id)?;
        let (q, v) = robot
            .links
            .iter()
            .filter(|l| l.joint.kind.movable())
            .map(|l| {
                let (q, v) = self.joint_coordinates(l.body, l.joint.kind);
                (q as f64, v as f64)
            })
            .unzip();
        Some((q, v))
    }

    /// The reaction wrench of joint `joint` of robot `object`, PyBullet's meaning: the force and
    /// moment the parent exerts on the joint's child link through the joint — carrying the whole
    /// subtree below it — for the current positions and velocities, zero joint accelerations
    /// and the world's gravity (contacts and applied forces are not included), less what the
    /// joint's motor applied along its axis in the last step (reported as its motor torque), as
    /// `[Fx, Fy, Fz, Mx, My, Mz]` with the moment about the child's centre of mass, both in the
    /// child link's frame. None: no such robot or joint. The one computation behind
    /// get_joint_state's `reaction_forces` and MJCF force/torque sensors.
    pub fn joint_reaction_wrench(&self, object: u32, joint: usize) -> Option<[f64; 6]> {
        let model = self.robot_dynamics(object)?;
        let link = model.links.get(joint)?;
        let (q, qd) = self.robot_configuration(object)?;
        let g = d3(self.physics.gravity);
        let w = model.newton_euler(&q, &qd, &vec![0.0; model.dofs], g);
        let m = &w.motion[joint];
        let c = m.com_world(link.com);
        // The joint's own motor carries its share along the axis: PyBullet reports it as the
        // applied motor torque, not as part of the reaction.
        let motor = self.robot(object)?.links.get(joint).map_or(0.0, |l| l.motor_torque as f64);
        let (mut force, mut moment) = (w.force[joint], w.moment[joint]);
        if link.kind == JointKind::Prismatic {
            force -= m.joint_axis * motor;
        } else if link.movable.is_some() {
            moment -= m.joint_axis * motor;
        }
        let moment_at_com = moment + (m.joint_pos - c).cross(force);
        let inv = m.rot.inverse();
        let (f, n) = (inv * force, inv * moment_at_com);
        Some([f.x, f.y, f.z, n.x, n.y, n.z])
    }
}
