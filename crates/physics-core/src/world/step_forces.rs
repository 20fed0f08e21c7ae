//! The one-step forces the step loop writes (joint efforts of MJCF actuators and torque-control
//! motors, and the clearing of every one-step force after a step), through one door so the
//! engine rule decides how they reach rapier: rules 1–3 through `RigidBodySet::get_mut`, which
//! marks the body modified; rule 4 through the vendored rapier's `one_step_forces` when the
//! body is awake or not dynamic, which does not (`engine::EngineRule::QuietStepForces`).

use super::World;
use rapier3d::dynamics::{OneStepForces, RigidBodyHandle};

impl World {
    /// Runs `write` on `body`'s one-step forces through the door the world's engine rule picks
    /// (module documentation); nothing for an unknown body.
    pub(super) fn step_forces(&mut self, body: RigidBodyHandle, write: impl FnOnce(&mut OneStepForces)) {
        let bodies = &mut self.physics.bodies;
        if self.engine_rule.quiet_step_forces() {
            if let Some(mut quiet) = bodies.one_step_forces(body) {
                return write(&mut quiet);
            }
        }
        if let Some(b) = bodies.get_mut(body) {
            write(&mut OneStepForces::on(b));
        }
    }
}

/// Clears a body's one-step force and torque (after a step), without waking it.
pub(super) fn clear(forces: &mut OneStepForces) {
    forces.reset_forces();
    forces.reset_torques();
}
