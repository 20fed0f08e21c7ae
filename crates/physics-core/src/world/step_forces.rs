//! The one-step forces the step loop writes (joint efforts of MJCF actuators and torque-control
//! motors, and the clearing of every one-step force after a step), through one door so the
//! engine rule decides how they reach rapier: rules 1–3 through `RigidBodySet::get_mut`, which
//! marks the body modified; rule 4 through the vendored rapier's `one_step_forces` when the
//! body is awake or not dynamic, which does not (`engine::EngineRule::QuietStepForces`).

use super::World;
use rapier3d::dynamics::{OneStepForces, RigidBody, RigidBodyHandle};
use rapier3d::math::{AngVector, Vector};

/// The writes a step's forces make, on either door. Adding wakes the body; clearing does not
/// (as the step loop always called them).
pub(super) trait StepWrench {
    fn add_force(&mut self, force: Vector);
    fn add_force_at_point(&mut self, force: Vector, point: Vector);
    fn add_torque(&mut self, torque: AngVector);
    /// Clears the body's one-step force and torque.
    fn clear(&mut self);
}

impl StepWrench for RigidBody {
    fn add_force(&mut self, force: Vector) {
        RigidBody::add_force(self, force, true);
    }
    fn add_force_at_point(&mut self, force: Vector, point: Vector) {
        RigidBody::add_force_at_point(self, force, point, true);
    }
    fn add_torque(&mut self, torque: AngVector) {
        RigidBody::add_torque(self, torque, true);
    }
    fn clear(&mut self) {
        self.reset_forces(false);
        self.reset_torques(false);
    }
}

impl StepWrench for OneStepForces<'_> {
    fn add_force(&mut self, force: Vector) {
        OneStepForces::add_force(self, force);
    }
    fn add_force_at_point(&mut self, force: Vector, point: Vector) {
        OneStepForces::add_force_at_point(self, force, point);
    }
    fn add_torque(&mut self, torque: AngVector) {
        OneStepForces::add_torque(self, torque);
    }
    fn clear(&mut self) {
        self.reset_forces();
        self.reset_torques();
    }
}

impl World {
    /// Runs `write` on `body`'s one-step forces through the door the world's engine rule picks
    /// (module documentation); nothing for an unknown body.
    pub(super) fn step_forces(&mut self, body: RigidBodyHandle, write: impl FnOnce(&mut dyn StepWrench)) {
        let bodies = &mut self.physics.bodies;
        if self.engine_rule.quiet_step_forces() {
            if let Some(mut quiet) = bodies.one_step_forces(body) {
                return write(&mut quiet);
            }
        }
        if let Some(b) = bodies.get_mut(body) {
            write(b);
        }
    }
}
