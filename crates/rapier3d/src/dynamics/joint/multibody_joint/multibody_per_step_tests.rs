//! physics-mcp patch 3 (PATCHES.md): `MultibodyDynamics::TreeSparsePerStep` factorises each
//! multibody's mass matrices once per step and recomputes only the free accelerations in the
//! later substeps. Checked here: a substep's accelerations at the step's own state are the full
//! update's, bit for bit; away from it the factorisation stays the step's while the forces
//! follow the state; and whole simulations stay within `PER_STEP_TOLERANCE_M` of patch 1's
//! per-substep path for 2 s, while a deliberately wrong rule (the first step's mass matrix kept
//! forever) ends more than three times that away — so the tolerance can fail.

use super::tree_tests::{chain, prepared, tree};
use crate::dynamics::MultibodyDynamics;
use crate::math::Real;
use crate::prelude::*;

/// Largest distance (m) of any body from where the per-substep path puts it, at any step of
/// 2 s, per scene. Not rounding: the factorisation is up to three quarters of a step old. The
/// chain's motors are stiff (stiffness 1e4 on links of 0.02–0.05 kg·m²: a period of about 3.4
/// steps at 1/240 s) and it starts straight with coaxial joints, so the step's discretisation
/// shows (measured 2.9 cm; dense against per-substep, rounding only: 1.1e-5 m); the free tree
/// 1.2 mm (rounding: 3.8e-6 m). The wrong rule goes 97 cm and 17 cm away.
const PER_STEP_TOLERANCE_M: [(&str, Real); 2] = [("chain", 5.0e-2), ("tree", 5.0e-3)];

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
        // A step later (velocities integrated into the poses): the factorisation and `M` are
        // the first state's, the accelerations those of the new state's forces.
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
        // Close to a full update's, not equal: `M` moved. The chain starts straight, its four
        // z-axis joints coaxial, so `M` is nearly singular there and a 0.006 rad move changes
        // `M⁻¹` by several percent (8% of the largest acceleration, measured).
        let scale = fresh.accelerations.amax().max(1.0);
        let gap = (&mb.accelerations - &fresh.accelerations).amax();
        assert!(gap <= 0.1 * scale, "{name}: accelerations {gap} from a full update (scale {scale})");
    }
}

/// Max distance of any body between two runs, at every step of 2 s at 1/240 s; `freeze_b`: the
/// second run keeps its first step's mass matrix forever (a wrong rule).
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
        let tolerance = PER_STEP_TOLERANCE_M.iter().find(|(n, _)| *n == name).unwrap().1;
        std::println!("PER_STEP {name}: {gap:.3e} m from the per-substep path; the first mass matrix kept: {wrong:.3e} m");
        assert!(gap > 0.0, "{name}: the paths computed the very same bits (is patch 3 in effect?)");
        assert!(gap <= tolerance, "{name}: {gap} m from the per-substep path");
        assert!(wrong > 3.0 * tolerance, "{name}: a wrong rule is only {wrong} m away: the tolerance cannot fail");
    }
}
