//! physics-mcp patch 3 (PATCHES.md): `MultibodyDynamics::TreeSparsePerStep` factorises each
//! multibody's mass matrices once per step and recomputes only the free accelerations in the
//! later substeps. Checked here: a substep's accelerations at the step's own state are the full
//! update's, bit for bit; away from it the factorisation stays the step's while the forces
//! follow the state; and whole simulations stay within `PER_STEP_TOLERANCE_M` of patch 1's
//! per-substep path for 2 s, while a deliberately wrong rule (the first step's mass matrix kept
//! forever) does not — so the tolerance can fail.

use super::tree_tests::{chain, prepared, tree};
use crate::dynamics::MultibodyDynamics;
use crate::math::Real;
use crate::prelude::*;

/// Largest distance (m) of any body from where the per-substep path puts it, at any step of
/// 2 s (the same bound physics-mcp's tests/physics/engine_rules.rs states for its robots).
const PER_STEP_TOLERANCE_M: Real = 1.0e-3;

#[test]
fn a_substep_keeps_the_steps_factorisation_and_follows_the_forces() {
    for (name, world) in [("chain", chain()), ("tree", tree())] {
        let (mut mb, mut bodies) = prepared(world);
        let dt = 1.0 / 240.0;
        mb.forward_kinematics_for(&bodies, false, MultibodyDynamics::TreeSparsePerStep);
        mb.tree_update_dynamics(dt, &bodies);
        let (full_acc, full_mass) = (mb.accelerations.clone(), mb.augmented_mass.clone());
        // At the step's own state, the substep's accelerations are the full update's.
        mb.tree_update_substep_acceleration(dt, &bodies);
        assert_eq!(mb.accelerations, full_acc, "{name}: substep accelerations at the step's state");
        // A quarter step later (velocities integrated into the poses): the factorisation and
        // `M` are the step's, the accelerations those of the new state's forces.
        mb.integrate(dt);
        mb.forward_kinematics_for(&bodies, false, MultibodyDynamics::TreeSparsePerStep);
        mb.update_rigid_bodies_internal(&mut bodies, true, false, false);
        mb.update_velocities(&mut bodies);
        let mut fresh = mb.clone();
        mb.tree_update_substep_acceleration(dt, &bodies);
        assert_eq!(mb.augmented_mass, full_mass, "{name}: the step's M is kept");
        fresh.tree_update_dynamics(dt, &bodies);
        assert_ne!(fresh.augmented_mass, full_mass, "{name}: the configuration moved");
        assert_ne!(mb.accelerations, full_acc, "{name}: the forces follow the new state");
        let scale = fresh.accelerations.amax().max(1.0);
        let gap = (&mb.accelerations - &fresh.accelerations).amax();
        assert!(gap <= 1.0e-2 * scale, "{name}: accelerations {gap} from a full update (scale {scale})");
    }
}

/// Max distance of any body between two runs, at every step of 2 s at 1/240 s.
fn max_gap(build: fn() -> PhysicsWorld, a: MultibodyDynamics, b: MultibodyDynamics, freeze_b: bool) -> Real {
    let start = |dynamics: MultibodyDynamics| {
        let mut world = build();
        world.integration_parameters.dt = 1.0 / 240.0;
        world.integration_parameters.multibody_dynamics = dynamics;
        world
    };
    let (mut wa, mut wb) = (start(a), start(b));
    let mut gap: Real = 0.0;
    for step in 0..480 {
        wa.step();
        wb.step();
        if step == 0 && freeze_b {
            for (_, mb) in wb.multibody_joints.multibodies.iter_mut() {
                mb.tree.mass_frozen_for_tests = true;
            }
        }
        for ((_, p), (_, q)) in wa.bodies.iter().zip(wb.bodies.iter()) {
            gap = gap.max((p.translation() - q.translation()).length());
        }
    }
    gap
}

#[test]
fn simulations_under_the_per_step_path_stay_with_the_per_substep_path_for_two_seconds() {
    for (name, build) in [("chain", chain as fn() -> PhysicsWorld), ("tree", tree)] {
        let (substep, step) = (MultibodyDynamics::TreeSparse, MultibodyDynamics::TreeSparsePerStep);
        let gap = max_gap(build, substep, step, false);
        let wrong = max_gap(build, substep, step, true);
        std::println!("PER_STEP {name}: {gap:.3e} m from the per-substep path; the first mass matrix kept: {wrong:.3e} m");
        assert!(gap > 0.0, "{name}: the paths computed the very same bits (is patch 3 in effect?)");
        assert!(gap <= PER_STEP_TOLERANCE_M, "{name}: {gap} m from the per-substep path");
        if name == "chain" {
            assert!(wrong > PER_STEP_TOLERANCE_M, "{name}: a wrong rule is only {wrong} m away: the tolerance cannot fail");
        }
    }
}
