//! Primitive bodies: creation, poses, velocities, one-step forces, dynamics properties, reads.

use rapier3d::prelude::*;

use super::{DynamicsExtras, Object, ObjectKind, World, DEFAULT_DAMPING, DEFAULT_FRICTION};
use crate::command::{Command, DynamicsChange, Shape};
use crate::outputs::{DynamicsChanged, DynamicsInfo, Message, ObjectAdded, ObjectState, ObjectSummary};
use crate::value::{r32, r32s};

/// Result of a body command, before it becomes JSON.
#[derive(serde::Serialize)]
#[serde(untagged)]
pub(super) enum BodyOutcome {
    Added(ObjectAdded),
    Changed(DynamicsChanged),
    Message(Message),
}

fn v3(a: [f32; 3]) -> Vector {
    Vector::from_array(a)
}

fn quat(q: [f32; 4]) -> Rotation {
    Rotation::from_xyzw(q[0], q[1], q[2], q[3])
}

/// The collider for a shape; cylinders and capsules are turned from rapier's y axis to z.
fn collider_for(shape: &Shape) -> ColliderBuilder {
    let y_to_z = Pose::from_rotation(Rotation::from_rotation_x(std::f32::consts::FRAC_PI_2));
    match *shape {
        Shape::Box { half_extents: h } => ColliderBuilder::cuboid(h[0], h[1], h[2]),
        Shape::Sphere { radius } => ColliderBuilder::ball(radius),
        Shape::Cylinder { radius, height } => {
            ColliderBuilder::cylinder(height / 2.0, radius).position(y_to_z)
        }
        Shape::Capsule { radius, height } => ColliderBuilder::capsule_z(height / 2.0, radius),
    }
}

impl World {
    /// Applies a command that acts on bodies.
    pub(super) fn apply_body_command(&mut self, cmd: &Command) -> BodyOutcome {
        match cmd {
            Command::AddBody {
                shape,
                position,
                orientation,
                mass,
                color,
                collides,
            } => BodyOutcome::Added(self.add_body(shape, *position, *orientation, *mass, *color, *collides)),
            Command::SetObjectPose {
                object_id,
                position,
                orientation,
            } => {
                let pose = Pose::from_parts(v3(*position), quat(*orientation));
                if self.robot(*object_id).is_some() {
                    if let Some(base) = self.body_handle(*object_id) {
                        self.set_robot_pose(base, pose);
                    }
                } else if let Some(b) = self.body_mut(*object_id) {
                    b.set_position(pose, true);
                }
                BodyOutcome::Message(Message::new(format!("Object {object_id} pose set")))
            }
            Command::ApplyForce {
                object_id,
                force,
                position,
                link_index,
            } => {
                if let Some(b) = self.part_mut(*object_id, *link_index) {
                    match position {
                        Some(p) => b.add_force_at_point(v3(*force), v3(*p), true),
                        None => b.add_force(v3(*force), true),
                    }
                }
                self.tables.pending_wrench.insert(*object_id);
                BodyOutcome::Message(Message::new(format!(
                    "Force applied to object {object_id} for the next step"
                )))
            }
            Command::ApplyTorque {
                object_id,
                torque,
                link_index,
            } => {
                if let Some(b) = self.part_mut(*object_id, *link_index) {
                    b.add_torque(v3(*torque), true);
                }
                self.tables.pending_wrench.insert(*object_id);
                BodyOutcome::Message(Message::new(format!(
                    "Torque applied to object {object_id} for the next step"
                )))
            }
            Command::SetObjectVelocity {
                object_id,
                linear_velocity,
                angular_velocity,
            } => {
                if let Some(b) = self.body_mut(*object_id) {
                    if let Some(v) = linear_velocity {
                        b.set_linvel(v3(*v), true);
                    }
                    if let Some(w) = angular_velocity {
                        b.set_angvel(v3(*w), true);
                    }
                }
                self.set_robot_base_velocity(*object_id, *linear_velocity, *angular_velocity);
                BodyOutcome::Message(Message::new(format!("Object {object_id} velocity set")))
            }
            Command::ChangeDynamics {
                object_id,
                change,
                link_index,
            } => {
                self.change_dynamics(*object_id, *link_index, change);
                BodyOutcome::Changed(DynamicsChanged {
                    landed: None,
                    message: format!("Dynamics of object {object_id} changed"),
                    changed: change.names().into_iter().map(String::from).collect(),
                })
            }
            Command::RemoveObject { object_id } => {
                self.remove_constraints_of(*object_id);
                if let Some(obj) = self.tables.objects.remove(object_id) {
                    match &obj.kind {
                        ObjectKind::Robot { robot } => self.remove_robot_bodies(obj.body, robot),
                        ObjectKind::Mjcf { robot, mjcf } => {
                            self.remove_robot_bodies(obj.body, robot);
                            if let Some(h) = mjcf.world_body {
                                self.physics.remove_body(h);
                            }
                        }
                        ObjectKind::Primitive { .. } => {
                            self.physics.remove_body(obj.body);
                        }
                    }
                }
                self.tables.pending_wrench.remove(object_id);
                self.tables.as_given.link_masses.retain(|(id, _), _| id != object_id);
                self.tables.filters.forget(*object_id);
                self.tables.joint_sensors.retain(|(id, _)| id != object_id);
                self.tables.joint_trajectories.retain(|(id, _), _| id != object_id);
                self.tables.actuation.remove(object_id);
                self.tables.mjcf_sensors.remove(object_id);
                self.tables.transmissions.retain(|(id, _), _| id != object_id);
                self.tables.contact_pairs.remove(object_id);
                self.tables.mjcf_elements.remove(object_id);
                BodyOutcome::Message(Message::new(format!("Object {object_id} removed")))
            }
            Command::CreateSimulation { .. }
            | Command::ForkSimulation { .. }
            | Command::LoadSimulation { .. }
            | Command::StepSimulation { .. }
            | Command::SetTimestep { .. }
            | Command::LoadUrdf { .. }
            | Command::LoadMjcf { .. }
            | Command::SetJointMotor { .. }
            | Command::SetJointMotors { .. }
            | Command::SetCollisionFilter { .. }
            | Command::SetCollisionPair { .. }
            | Command::ResetJointState { .. }
            | Command::EnableJointForceTorqueSensor { .. }
            | Command::SetJointTrajectory { .. }
            | Command::SetActuatorControls { .. }
            | Command::CreateConstraint { .. }
            | Command::RemoveConstraint { .. }
            | Command::SetDebugVisualization { .. }
            | Command::SetCamera { .. } => {
                BodyOutcome::Message(Message::new("not a body command"))
            }
        }
    }

    fn add_body(
        &mut self,
        shape: &Shape,
        position: [f32; 3],
        orientation: [f32; 4],
        mass: f32,
        color: Option<[f32; 4]>,
        collides: bool,
    ) -> ObjectAdded {
        let body_type = if mass > 0.0 {
            RigidBodyType::Dynamic
        } else {
            RigidBodyType::Fixed
        };
        let body = RigidBodyBuilder::new(body_type)
            .pose(Pose::from_parts(v3(position), quat(orientation)))
            .linear_damping(DEFAULT_DAMPING)
            .angular_damping(DEFAULT_DAMPING);
        let mut collider = collider_for(shape)
            .mass(if mass > 0.0 { mass } else { 1.0 })
            .friction(DEFAULT_FRICTION)
            .restitution(0.0)
            .friction_combine_rule(CoefficientCombineRule::Multiply)
            .restitution_combine_rule(CoefficientCombineRule::Multiply);
        let id = self.tables.next_object_id;
        if !collides {
            // A marker: in no group, touching none; rays and the camera still see it.
            collider = collider.collision_groups(InteractionGroups::none());
            self.tables.filters.markers.insert(id);
        }
        let (body, collider) = self.physics.insert(body, collider);
        self.tables.next_object_id += 1;
        self.tables.objects.insert(
            id,
            Object {
                body,
                collider,
                kind: ObjectKind::Primitive {
                    shape: shape.clone(),
                },
                color,
                mass,
                extras: DynamicsExtras::default(),
            },
        );
        ObjectAdded {
            landed: None,
            object_id: id,
            shape: shape.name().to_string(),
            position: r32s(position),
        }
    }

    fn change_dynamics(&mut self, id: u32, link_index: i32, c: &DynamicsChange) {
        let Some((bh, colliders)) = self.part(id, link_index) else {
            return;
        };
        let Some(obj) = self.tables.objects.get_mut(&id) else {
            return;
        };
        let is_link = link_index >= 0;
        let e = match (obj.kind.robot_mut(), is_link) {
            (Some(robot), true) => match robot.links.get_mut(link_index as usize) {
                Some(l) => &mut l.extras,
                None => return,
            },
            _ => &mut obj.extras,
        };
        let set = |dst: &mut f32, src: Option<f32>| {
            if let Some(v) = src {
                *dst = v;
            }
        };
        set(&mut e.rolling_friction, c.rolling_friction);
        set(&mut e.spinning_friction, c.spinning_friction);
        set(&mut e.contact_stiffness, c.contact_stiffness);
        set(&mut e.contact_damping, c.contact_damping);
        let robot = obj.kind.robot().is_some();
        match (c.mass, is_link) {
            (Some(m), false) => obj.mass = m,
            (Some(m), true) => {
                self.tables.as_given.link_masses.insert((id, link_index as u32), m);
            }
            (None, _) => {}
        }
        for ch in &colliders {
            if let Some(col) = self.physics.colliders.get_mut(*ch) {
                if let Some(f) = c.lateral_friction {
                    col.set_friction(f);
                }
                if let Some(r) = c.restitution {
                    col.set_restitution(r);
                }
                if let (Some(m), false) = (c.mass.filter(|m| *m > 0.0), robot) {
                    col.set_mass(m);
                }
            }
        }
        let colliders_set = &self.physics.colliders;
        if let Some(b) = self.physics.bodies.get_mut(bh) {
            if let Some(d) = c.linear_damping {
                b.set_linear_damping(d);
            }
            if let Some(d) = c.angular_damping {
                b.set_angular_damping(d);
            }
            if let Some(m) = c.mass {
                let wanted = if m > 0.0 {
                    RigidBodyType::Dynamic
                } else {
                    RigidBodyType::Fixed
                };
                if b.body_type() != wanted {
                    b.set_body_type(wanted, true);
                }
                if robot && m > 0.0 {
                    // URDF links carry their inertial as additional mass properties: scale
                    // them (inertia with mass) so the shape of the distribution is kept.
                    let mut scaled = b.mass_properties().local_mprops;
                    let old = if scaled.mass() > 0.0 { scaled.mass() } else { 1.0 };
                    scaled.inv_mass = 1.0 / m;
                    scaled.inv_principal_inertia *= old / m;
                    b.set_additional_mass_properties(scaled, true);
                }
                b.recompute_mass_properties_from_colliders(colliders_set);
                b.wake_up(true);
            }
        }
    }

    /// Clears forces and torques that were to act for one step only.
    pub(super) fn clear_pending_wrench(&mut self) {
        let pending = std::mem::take(&mut self.tables.pending_wrench);
        for id in pending {
            self.clear_robot_forces(id);
            if let Some(h) = self.body_handle(id) {
                self.step_forces(h, super::step_forces::clear);
            }
        }
    }

    /// The body of object `id` (a robot's base link), if the object exists.
    pub(super) fn body_handle(&self, id: u32) -> Option<RigidBodyHandle> {
        self.tables.objects.get(&id).map(|o| o.body)
    }

    fn body_mut(&mut self, id: u32) -> Option<&mut RigidBody> {
        let h = self.body_handle(id)?;
        self.physics.bodies.get_mut(h)
    }

    /// Number of links (beyond the base) an object has: 0 for primitives.
    pub fn link_count(&self, id: u32) -> usize {
        self.tables.objects.get(&id).and_then(|o| o.kind.robot()).map_or(0, |r| r.links.len())
    }

    /// The body and colliders of an object's base (−1) or of one of its links.
    pub(super) fn part(&self, id: u32, link_index: i32) -> Option<(RigidBodyHandle, Vec<ColliderHandle>)> {
        let obj = self.tables.objects.get(&id)?;
        match (obj.kind.robot(), link_index) {
            (Some(robot), i) if i >= 0 => {
                let l = robot.links.get(i as usize)?;
                Some((l.body, l.colliders.clone()))
            }
            (Some(robot), _) => Some((obj.body, robot.base_colliders.clone())),
            (None, _) => Some((obj.body, vec![obj.collider])),
        }
    }

    fn part_mut(&mut self, id: u32, link_index: i32) -> Option<&mut RigidBody> {
        let (h, _) = self.part(id, link_index)?;
        self.physics.bodies.get_mut(h)
    }

    /// A robot's free base moves through its multibody's root coordinates, not its body.
    fn set_robot_base_velocity(&mut self, id: u32, lin: Option<[f32; 3]>, ang: Option<[f32; 3]>) {
        let Some(base) = self.robot(id).and(self.body_handle(id)) else {
            return;
        };
        let mbs = &mut self.physics.multibody_joints;
        let Some(lid) = mbs.rigid_body_link(base).copied() else { return };
        let Some(mb) = mbs.get_multibody_mut(lid.multibody) else { return };
        if mb.root().joint().ndofs() != 6 {
            return;
        }
        let mut gv = mb.generalized_velocity_mut();
        for k in 0..3 {
            if let Some(v) = lin {
                gv[k] = v[k];
            }
            if let Some(w) = ang {
                gv[3 + k] = w[k];
            }
        }
    }

    /// Checks a `link_index` argument: −1 is the base, 0..n a link of the object.
    pub fn check_link(&self, id: u32, link_index: i32) -> Result<(), crate::value::Refusal> {
        let n = self.link_count(id);
        if link_index == -1 || (link_index >= 0 && (link_index as usize) < n) {
            Ok(())
        } else {
            Err(format!(
                "link_index {link_index} out of range: object {id} has {n} links (use -1 for the base)"
            ))
        }
    }

    /// The rapier body of an object.
    pub fn body(&self, id: u32) -> Option<&RigidBody> {
        let h = self.body_handle(id)?;
        self.physics.bodies.get(h)
    }

    /// get_object_state: pose and velocities of an object's base.
    pub fn object_state(&self, id: u32) -> Option<ObjectState> {
        let b = self.body(id)?;
        let p = b.position();
        Some(ObjectState {
            position: r32s(p.translation.to_array()),
            orientation: r32s(p.rotation.to_array()),
            linear_velocity: r32s(b.linvel().to_array()),
            angular_velocity: r32s(b.angvel().to_array()),
        })
    }

    /// An object's base velocities as the engine holds them (linear, angular; f32): for a
    /// watcher that runs after every step (run_sweep's peak speed) and must not pay
    /// `object_state`'s decimal rounding of every value each time.
    pub fn raw_velocities(&self, id: u32) -> Option<([f32; 3], [f32; 3])> {
        let b = self.body(id)?;
        Some((b.linvel().to_array(), b.angvel().to_array()))
    }

    /// get_dynamics_info: the values in force.
    pub fn dynamics_info(&self, id: u32, link_index: i32) -> Option<DynamicsInfo> {
        let obj = self.tables.objects.get(&id)?;
        let (bh, colliders) = self.part(id, link_index)?;
        let extras = match (obj.kind.robot(), link_index) {
            (Some(robot), i) if i >= 0 => &robot.links.get(i as usize)?.extras,
            _ => &obj.extras,
        };
        let b = self.physics.bodies.get(bh)?;
        let c = colliders.first().and_then(|h| self.physics.colliders.get(*h));
        let friction = c.map_or(DEFAULT_FRICTION, |c| c.friction());
        let restitution = c.map_or(0.0, |c| c.restitution());
        let skin = c.map_or(0.0, |c| c.contact_skin());
        let mp = &b.mass_properties().local_mprops;
        let fixed = b.is_fixed();
        let body_type = match b.body_type() {
            RigidBodyType::Dynamic => "dynamic",
            RigidBodyType::Fixed => "static",
            _ => "kinematic",
        };
        let (diagonal, inertia_orn) = reported_inertia(mp);
        // The mass as set (add_*, the URDF, change_dynamics), not rapier's 1/(1/m).
        let mass_set = match (obj.kind.robot(), link_index) {
            (Some(_), i) if i >= 0 => self.tables.as_given.link_masses.get(&(id, i as u32)).copied(),
            _ => Some(obj.mass),
        };
        Some(DynamicsInfo {
            mass: if fixed { 0.0 } else { r32(mass_set.unwrap_or_else(|| b.mass())) },
            lateral_friction: r32(friction),
            local_inertia_diagonal: r32s(if fixed { [0.0; 3] } else { diagonal }),
            local_inertia_pos: r32s(mp.local_com.to_array()),
            local_inertia_orn: r32s(inertia_orn),
            restitution: r32(restitution),
            rolling_friction: r32(extras.rolling_friction),
            spinning_friction: r32(extras.spinning_friction),
            contact_damping: r32(extras.contact_damping),
            contact_stiffness: r32(extras.contact_stiffness),
            body_type: body_type.to_string(),
            collision_margin: r32(skin),
            linear_damping: r32(b.linear_damping()),
            angular_damping: r32(b.angular_damping()),
        })
    }

    /// One summary row per object, by id.
    pub fn object_summaries(&self) -> Vec<ObjectSummary> {
        self.tables
            .objects
            .iter()
            .map(|(id, obj)| {
                let pos = self
                    .physics
                    .bodies
                    .get(obj.body)
                    .map(|b| b.translation().to_array())
                    .unwrap_or_default();
                let (kind, shape, dimensions) = match &obj.kind {
                    ObjectKind::Primitive { shape } => (
                        "primitive",
                        shape.name().to_string(),
                        shape.dimensions().into_iter().map(r32).collect(),
                    ),
                    ObjectKind::Robot { robot } => ("urdf", robot.file_path.clone(), Vec::new()),
                    ObjectKind::Mjcf { robot, .. } => ("mjcf", robot.file_path.clone(), Vec::new()),
                };
                let is_static = self
                    .physics
                    .bodies
                    .get(obj.body)
                    .is_some_and(|b| b.is_fixed());
                ObjectSummary {
                    object_id: *id,
                    kind: kind.into(),
                    shape,
                    dimensions,
                    mass: if is_static { 0.0 } else { r32(obj.mass) },
                    position: r32s(pos),
                    actuators: self.actuation(*id).map(super::actuators::infos).unwrap_or_default(),
                    sensors: self.sensors(*id).map(|s| s.iter().map(|x| x.name.clone()).collect()).unwrap_or_default(),
                    equality: self.tables.mjcf_elements.get(id).map(|e| e.equality.clone()).unwrap_or_default(),
                    tendons: self.tables.mjcf_elements.get(id).map(|e| e.tendons.clone()).unwrap_or_default(),
                }
            })
            .collect()
    }
}

/// The inertia diagonal and its frame as PyBullet reports them. rapier keeps principal axes
/// sorted by its eigen-decomposition, so a tensor that is already diagonal in the body (or URDF
/// inertial) frame comes back permuted under a turned frame — `[Izz, Ixx, Iyy]` at
/// `[0.5, 0.5, 0.5, −0.5]` — where PyBullet says `[Ixx, Iyy, Izz]` at identity. When the tensor
/// in the body frame is diagonal we report it so; otherwise the principal axes and their frame.
/// Computed in f64 so the diagonal comes back exactly as given.
pub(super) fn reported_inertia(mp: &MassProperties) -> ([f32; 3], [f32; 4]) {
    use rapier3d::glamx::{DMat3, DVec3};
    let principal = mp.principal_inertia();
    let frame = mp.principal_inertia_local_frame.as_dquat();
    let p = DVec3::new(principal.x as f64, principal.y as f64, principal.z as f64);
    let m = DMat3::from_quat(frame) * DMat3::from_diagonal(p) * DMat3::from_quat(frame.inverse());
    let off = m.x_axis.y.abs().max(m.x_axis.z.abs()).max(m.y_axis.z.abs());
    if off <= 1e-6 * p.max_element().max(f64::MIN_POSITIVE) {
        ([m.x_axis.x as f32, m.y_axis.y as f32, m.z_axis.z as f32], [0.0, 0.0, 0.0, 1.0])
    } else {
        (principal.to_array(), mp.principal_inertia_local_frame.to_array())
    }
}
