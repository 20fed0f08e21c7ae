//! physics-mcp patch 4 (PATCHES.md): skipping a step's opening forward kinematics when
//! `Multibody::kinematics_unchanged` says it would change nothing changes no bit. Each scene
//! (patch 1's fixed-base chain with motors and limits, and its free-floating tree) runs twice
//! under every `MultibodyDynamics` path for 2 s: as the pipeline runs it, and with the record
//! forgotten before every step (so the opening pass always runs, as in rapier 0.36.1). Between
//! steps both receive the same user changes — a joint coordinate displaced, the same followed
//! by the public forward kinematics (physics-mcp's `reset_joint_state`), a generalized velocity
//! set, the root body moved (the fixed base of the chain, the free root of the tree), a link's
//! mass changed, a link body teleported — and after every step every body and the multibody
//! must be the same to the bit. The skip must also have happened: never on a step after a change
//! the pass must see, and on all the other steps but a few (the first, with no record yet, and
//! at most one after a root pose was written).

use super::Multibody;
use super::tree_tests::{chain, tree};
use crate::alloc_prelude::*;
use crate::dynamics::MultibodyDynamics;
use crate::math::Vector;
use crate::prelude::*;
use alloc::format;

fn only_multibody(world: &mut PhysicsWorld) -> &mut Multibody {
    world.multibody_joints.multibodies.iter_mut().next().unwrap().1
}

/// Everything the step computes for the bodies and the multibody, to the bit (`{:?}` prints
/// the shortest decimal that reads back as the same float, so two prints are equal exactly
/// when the bits are, NaN payloads aside).
fn state(world: &PhysicsWorld) -> String {
    let mb = world.multibody_joints.multibodies().next().unwrap();
    format!("{:?}\n{:?}", world.bodies, mb)
}

/// The user change made before step `step`, if any, and whether the opening pass must see it.
fn change(world: &mut PhysicsWorld, step: usize) -> Option<bool> {
    let handles: Vec<RigidBodyHandle> = only_multibody(world).links().map(|l| l.rigid_body_handle()).collect();
    let (root, link2, last) = (handles[0], handles[2], *handles.last().unwrap());
    match step {
        100 => {
            let mb = only_multibody(world);
            let mut disp = vec![0.0; mb.ndofs()];
            let k = mb.ndofs() - 1;
            disp[k] = 0.2;
            mb.apply_displacements(&disp);
            Some(true)
        }
        150 => {
            // physics-mcp's reset_joint_state: coordinates, then the public (dense) forward
            // kinematics and the bodies written with change tracking.
            let n = only_multibody(world).ndofs();
            let mut disp = vec![0.0; n];
            disp[n - 2] = -0.1;
            let bodies = &mut world.bodies;
            let mb = world.multibody_joints.multibodies.iter_mut().next().unwrap().1;
            mb.apply_displacements(&disp);
            mb.forward_kinematics(bodies, true);
            mb.update_rigid_bodies(bodies, true);
            Some(true)
        }
        200 => {
            // Velocities are not an input of forward kinematics: the pass is still skipped.
            let mb = only_multibody(world);
            let n = mb.ndofs();
            mb.generalized_velocity_mut()[n - 1] += 0.5;
            Some(false)
        }
        250 => {
            let mut pose = *world.bodies[root].position();
            pose.translation += Vector::new(0.05, -0.02, 0.1);
            world.bodies[root].set_position(pose, true);
            Some(true)
        }
        300 => {
            world.bodies[link2].set_additional_mass(0.7, true);
            Some(true)
        }
        350 => {
            let mut pose = *world.bodies[last].position();
            pose.translation += Vector::new(0.0, 0.03, 0.0);
            world.bodies[last].set_position(pose, true);
            Some(true)
        }
        _ => None,
    }
}

fn run(build: fn() -> PhysicsWorld, name: &str, dynamics: MultibodyDynamics) {
    let start = || {
        let mut world = build();
        world.integration_parameters.dt = 1.0 / 240.0;
        world.integration_parameters.multibody_dynamics = dynamics;
        world
    };
    let (mut skipping, mut always) = (start(), start());
    let mut skipped = 0;
    let steps = 480;
    for step in 0..steps {
        let expected = change(&mut skipping, step);
        assert_eq!(change(&mut always, step), expected);
        let unchanged = {
            let w = &skipping;
            let mb = w.multibody_joints.multibodies().next().unwrap();
            mb.kinematics_unchanged(&w.bodies, dynamics)
        };
        if expected == Some(true) {
            assert!(!unchanged, "{name} {dynamics:?} step {step}: a change the pass must see was missed");
        }
        if unchanged {
            // The claim itself: the pass, run anyway, writes exactly what is there.
            let mut bodies = skipping.bodies.clone();
            let mut mb = skipping.multibody_joints.multibodies().next().unwrap().clone();
            mb.forward_kinematics_for(&bodies, true, dynamics);
            mb.update_rigid_bodies_internal(&mut bodies, true, false, false);
            let (ran, skipped_state) = (format!("{bodies:?}\n{mb:?}"), state(&skipping));
            assert!(ran == skipped_state, "{name} {dynamics:?} step {step}: the pass would have changed something\nran: {ran}\nthere: {skipped_state}");
        }
        skipped += usize::from(unchanged);
        only_multibody(&mut always).forget_kinematics_record();
        skipping.step();
        always.step();
        let (a, b) = (state(&skipping), state(&always));
        assert!(a == b, "{name} {dynamics:?}: step {step} differs with the opening pass skipped\nskipped: {a}\nalways:  {b}");
    }
    // Every step but the first (no record yet) and the five that changed an input, give or take
    // a step after a root pose was written (a pose whose round trip through the root joint is
    // not the identity to the bit, e.g. a `-0.0` read back as `0.0`, takes one more pass).
    std::println!("KINEMATICS_RECORD {name} {dynamics:?}: opening pass skipped on {skipped} of {steps} steps");
    assert!(skipped + 6 <= steps && skipped + 10 >= steps, "{name} {dynamics:?}: {skipped} of {steps} steps skipped");
}

#[test]
fn skipping_the_opening_forward_kinematics_changes_no_bit() {
    for dynamics in [MultibodyDynamics::Dense, MultibodyDynamics::TreeSparse, MultibodyDynamics::TreeSparsePerStep] {
        run(chain, "chain", dynamics);
        run(tree, "tree", dynamics);
    }
}

/// A deserialized multibody (a restored snapshot) has no record: its first step runs the pass.
#[cfg(feature = "serde-serialize")]
#[test]
fn a_restored_multibody_runs_the_opening_pass() {
    let mut world = tree();
    world.step();
    world.step();
    let dynamics = world.integration_parameters.multibody_dynamics;
    let mb = world.multibody_joints.multibodies().next().unwrap();
    assert!(mb.kinematics_unchanged(&world.bodies, dynamics));
    let restored: Multibody = bincode::deserialize(&bincode::serialize(mb).unwrap()).unwrap();
    assert!(!restored.kinematics_unchanged(&world.bodies, dynamics));
}
