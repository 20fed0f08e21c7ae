//! physics-mcp patch 8: one-step forces on an awake body without marking it modified.
//!
//! A program that drives bodies with forces every step (actuators, controllers) reaches them
//! through [`RigidBodySet::get_mut`], which puts the body in the modified set. The next step
//! then treats it as a user change: [`IslandManager`](crate::dynamics::IslandManager) bumps its
//! active-set epoch, and every cache keyed on that epoch (the solver's contact graph and body
//! table, the joint assembly and colouring) is rebuilt from scratch, every step. A force on a
//! body that is already awake changes none of what those caches hold: it sets no
//! [`RigidBodyChanges`](crate::dynamics::RigidBodyChanges) flag, and its wake-up only restarts
//! the body's sleep timer. [`RigidBodySet::one_step_forces`] hands out exactly those writes for
//! such a body, untracked.

use crate::dynamics::{RigidBody, RigidBodyHandle, RigidBodySet};
use crate::math::{AngVector, Vector};

/// The force and torque writes of one body that need no modification tracking (see the module
/// documentation). Each method is the [`RigidBody`] method of the same name; adding always
/// wakes (restarts the sleep timer of) the body, clearing never does.
pub struct OneStepForces<'a> {
    body: &'a mut RigidBody,
}

impl<'a> OneStepForces<'a> {
    /// The same writes on a body the caller already holds mutably (reached through
    /// [`RigidBodySet::get_mut`], so tracked): one interface for both doors.
    pub fn on(body: &'a mut RigidBody) -> Self {
        Self { body }
    }

    /// [`RigidBody::add_force`] with `wake_up`.
    pub fn add_force(&mut self, force: Vector) {
        self.body.add_force(force, true);
    }

    /// [`RigidBody::add_force_at_point`] with `wake_up`.
    pub fn add_force_at_point(&mut self, force: Vector, point: Vector) {
        self.body.add_force_at_point(force, point, true);
    }

    /// [`RigidBody::add_torque`] with `wake_up`.
    pub fn add_torque(&mut self, torque: AngVector) {
        self.body.add_torque(torque, true);
    }

    /// [`RigidBody::reset_forces`] without waking.
    pub fn reset_forces(&mut self) {
        self.body.reset_forces(false);
    }

    /// [`RigidBody::reset_torques`] without waking.
    pub fn reset_torques(&mut self) {
        self.body.reset_torques(false);
    }
}

impl RigidBodySet {
    /// The body's one-step force writes without marking it modified, when that changes
    /// nothing the next step's user-change handling would act on: the body is enabled and
    /// either dynamic and awake (a wake-up only restarts its sleep timer) or not dynamic (adding
    /// does nothing, clearing wakes nothing). `None` for a sleeping dynamic body, a disabled
    /// body or an unknown handle: use [`RigidBodySet::get_mut`], which wakes it properly.
    pub fn one_step_forces(&mut self, handle: RigidBodyHandle) -> Option<OneStepForces<'_>> {
        let body = self.get_mut_internal(handle)?;
        let quiet = body.is_enabled() && (!body.is_dynamic() || !body.is_sleeping());
        quiet.then_some(OneStepForces { body })
    }
}

#[cfg(all(test, feature = "dim3"))]
mod one_step_forces_tests {
    use crate::dynamics::RigidBodyBuilder;
    use crate::geometry::ColliderBuilder;
    use crate::math::Vector;
    use crate::pipeline::PhysicsWorld;

    /// A ball resting on a fixed floor, awake after one step.
    fn world() -> (PhysicsWorld, crate::dynamics::RigidBodyHandle) {
        let mut w = PhysicsWorld::new();
        w.gravity = Vector::new(0.0, 0.0, -9.81);
        let floor = w.bodies.insert(RigidBodyBuilder::fixed());
        w.colliders.insert_with_parent(ColliderBuilder::cuboid(5.0, 5.0, 0.5), floor, &mut w.bodies);
        let ball = w.bodies.insert(RigidBodyBuilder::dynamic().translation(Vector::new(0.0, 0.0, 0.7)));
        w.colliders.insert_with_parent(ColliderBuilder::ball(0.2), ball, &mut w.bodies);
        w.step();
        (w, ball)
    }

    /// An awake body's forces written untracked leave the active-set epoch alone (the
    /// solver's caches are kept) and act exactly as through `get_mut`; a floor's write is a
    /// no-op either way; a sleeping or disabled body is refused so `get_mut` wakes it.
    #[test]
    fn one_step_forces_act_without_a_new_epoch() {
        let (mut quiet, ball) = world();
        let (mut marked, _) = world();
        for _ in 0..3 {
            let (epoch, marked_epoch) = (quiet.islands.active_set_epoch, marked.islands.active_set_epoch);
            let mut f = quiet.bodies.one_step_forces(ball).expect("an awake dynamic body");
            f.add_force_at_point(Vector::new(3.0, 0.0, 0.0), Vector::new(0.0, 0.1, 0.7));
            f.add_torque(Vector::new(0.0, 0.0, 0.5));
            marked.bodies.get_mut(ball).unwrap().add_force_at_point(Vector::new(3.0, 0.0, 0.0), Vector::new(0.0, 0.1, 0.7), true);
            marked.bodies.get_mut(ball).unwrap().add_torque(Vector::new(0.0, 0.0, 0.5), true);
            quiet.step();
            marked.step();
            assert_eq!(quiet.islands.active_set_epoch, epoch, "an untracked force started a new epoch");
            assert_ne!(marked.islands.active_set_epoch, marked_epoch, "get_mut no longer starts an epoch: the test shows nothing");
            assert_eq!(quiet.bodies[ball].angvel(), marked.bodies[ball].angvel());
            assert_eq!(quiet.bodies[ball].translation(), marked.bodies[ball].translation());
            let mut f = quiet.bodies.one_step_forces(ball).unwrap();
            f.reset_forces();
            f.reset_torques();
            let b = marked.bodies.get_mut(ball).unwrap();
            b.reset_forces(false);
            b.reset_torques(false);
        }
        assert_eq!(quiet.bodies[ball].user_force(), Vector::ZERO);
        assert_eq!(quiet.bodies[ball].user_torque(), Vector::ZERO);
        quiet.bodies.get_mut(ball).unwrap().sleep();
        assert!(quiet.bodies.one_step_forces(ball).is_none(), "a sleeping body must wake through get_mut");
        quiet.bodies.get_mut(ball).unwrap().wake_up(true);
        quiet.bodies.get_mut(ball).unwrap().set_enabled(false);
        assert!(quiet.bodies.one_step_forces(ball).is_none(), "a disabled body");
        let floor = quiet.bodies.iter().find(|(_, b)| b.is_fixed()).unwrap().0;
        assert!(quiet.bodies.one_step_forces(floor).is_some(), "a fixed body: adding does nothing");
    }
}
