//! physics-mcp patch 1 (PATCHES.md): the tree-sparse path computes what the dense path
//! computes — the same mass matrix, free accelerations, constraint solves and jacobians, to
//! f32 rounding — on a fixed-base revolute chain and on a free-floating tree with spherical,
//! prismatic and revolute joints and a massless spacer link; and whole simulations under
//! either path stay together.

use super::Multibody;
use crate::alloc_prelude::*;
use alloc::format;
use crate::dynamics::MultibodyDynamics;
use crate::math::{DVector, Real};
use crate::prelude::*;

/// A fixed base and a 7-link revolute chain with offset centres of mass and anisotropic
/// inertias (a KUKA-like arm), position motors on every joint.
pub(super) fn chain() -> PhysicsWorld {
    let mut world = PhysicsWorld::new();
    world.gravity = Vector::new(0.0, 0.0, -9.81);
    let base = world.insert_body(RigidBodyBuilder::fixed());
    let mut parent = base;
    for i in 0..7 {
        let mprops = MassProperties::new(
            Vector::new(0.01 * i as Real, -0.02, 0.05),
            3.0 - 0.3 * i as Real,
            Vector::new(0.02, 0.03 + 0.002 * i as Real, 0.015),
        );
        let body = world.insert_body(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(0.0, 0.0, 0.3 * (i + 1) as Real))
                .additional_mass_properties(mprops),
        );
        let axis = if i % 2 == 0 { Vector::Z } else { Vector::Y };
        let joint = RevoluteJointBuilder::new(axis)
            .local_anchor1(Vector::new(0.0, 0.0, 0.3))
            .local_anchor2(Vector::ZERO)
            .motor_position(0.3, 1.0e4, 1.0e2)
            .motor_max_force(100.0)
            .limits([-2.0, 2.0]);
        world.insert_multibody_joint(parent, body, joint).unwrap();
        parent = body;
    }
    world
}

/// A free-floating tree: a root with a spherical shoulder, a prismatic slide, two revolute
/// branches, and a massless spacer link between two revolute joints (MJCF's multi-joint
/// bodies).
pub(super) fn tree() -> PhysicsWorld {
    let mut world = PhysicsWorld::new();
    world.gravity = Vector::new(0.0, 0.0, -9.81);
    let body = |world: &mut PhysicsWorld, at: Vector, mass: Real| {
        let mprops = MassProperties::new(Vector::new(0.02, 0.0, -0.03), mass, Vector::new(0.05, 0.04, 0.03) * mass);
        world.insert_body(RigidBodyBuilder::dynamic().translation(at).additional_mass_properties(mprops))
    };
    let root = body(&mut world, Vector::new(0.0, 0.0, 1.0), 5.0);
    let upper = body(&mut world, Vector::new(0.3, 0.0, 1.0), 2.0);
    let slide = body(&mut world, Vector::new(0.6, 0.0, 1.0), 1.0);
    let spacer = body(&mut world, Vector::new(-0.3, 0.0, 1.0), 0.0);
    let leg = body(&mut world, Vector::new(-0.3, 0.0, 0.6), 1.5);
    let foot = body(&mut world, Vector::new(-0.3, 0.0, 0.2), 0.5);
    let other = body(&mut world, Vector::new(0.0, 0.3, 1.0), 0.8);
    let j = &mut world;
    j.insert_multibody_joint(root, upper, SphericalJointBuilder::new().local_anchor1(Vector::new(0.15, 0.0, 0.0)).local_anchor2(Vector::new(-0.15, 0.0, 0.0))).unwrap();
    j.insert_multibody_joint(upper, slide, PrismaticJointBuilder::new(Vector::X).local_anchor1(Vector::new(0.15, 0.0, 0.0)).local_anchor2(Vector::new(-0.15, 0.0, 0.0)).limits([-0.1, 0.1])).unwrap();
    j.insert_multibody_joint(root, spacer, RevoluteJointBuilder::new(Vector::X).local_anchor1(Vector::new(-0.3, 0.0, 0.0))).unwrap();
    j.insert_multibody_joint(spacer, leg, RevoluteJointBuilder::new(Vector::Y).local_anchor2(Vector::new(0.0, 0.0, 0.4))).unwrap();
    j.insert_multibody_joint(leg, foot, RevoluteJointBuilder::new(Vector::Y).local_anchor1(Vector::new(0.0, 0.0, -0.2)).local_anchor2(Vector::new(0.0, 0.0, 0.2)).motor_velocity(1.0, 10.0)).unwrap();
    j.insert_multibody_joint(root, other, RevoluteJointBuilder::new(Vector::Z).local_anchor1(Vector::new(0.0, 0.15, 0.0)).local_anchor2(Vector::new(0.0, -0.15, 0.0))).unwrap();
    world
}

/// The world's one multibody, its velocities set to a fixed pseudo-random pattern and its
/// bodies' velocities and poses brought up to date, with a force and torque on every link.
pub(super) fn prepared(mut world: PhysicsWorld) -> (Multibody, RigidBodySet) {
    // One step computes the bodies' mass properties (from `additional_mass_properties`).
    world.step();
    let mut mb = world.multibody_joints.multibodies().next().unwrap().clone();
    mb.forward_kinematics(&world.bodies, true);
    mb.update_rigid_bodies(&mut world.bodies, true);
    for (i, v) in mb.velocities.iter_mut().enumerate() {
        *v = ((i * 7919 % 13) as Real - 6.0) * 0.25;
    }
    mb.update_velocities(&mut world.bodies);
    for (k, link) in mb.links().enumerate() {
        let rb = &mut world.bodies[link.rigid_body_handle()];
        rb.forces.force = Vector::new(1.0 + k as Real, -2.0, -9.81 * rb.mass());
        rb.forces.torque = Vector::new(0.1, 0.2 * k as Real, -0.3);
    }
    (mb, world.bodies)
}

/// Both paths' dynamics of `mb` at `dt`: (dense, tree).
fn both(mb: &Multibody, bodies: &RigidBodySet, dt: Real) -> (Multibody, Multibody) {
    let mut dense = mb.clone();
    dense.forward_kinematics_for(bodies, false, MultibodyDynamics::Dense);
    dense.update_mass_matrix(dt, bodies);
    dense.update_acceleration(dt, bodies);
    let mut tree = mb.clone();
    tree.forward_kinematics_for(bodies, false, MultibodyDynamics::TreeSparse);
    tree.tree_update_dynamics(dt, bodies);
    assert!(tree.tree_dynamics_active() && !dense.tree_dynamics_active());
    (dense, tree)
}

fn assert_close(what: &str, a: &[Real], b: &[Real], rel: Real) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    let scale = a.iter().chain(b).fold(1.0e-6 as Real, |m, x| m.max(x.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= rel * scale, "{what}[{i}]: dense {x} vs tree {y} (scale {scale})\ndense {a:?}\ntree  {b:?}");
    }
}

fn check(world: PhysicsWorld, name: &str) {
    let (mb, bodies) = prepared(world);
    let n = mb.ndofs();
    assert!(n > 0);
    for dt in [1.0 / 240.0, 0.01] {
        let (dense, tree) = both(&mb, &bodies, dt);
        let what = |s: &str| format!("{name} dt={dt}: {s}");
        // Real masses (a world computes them on its first step), so `M` is far from its
        // damping-only diagonal.
        assert!(dense.augmented_mass[(n - 1, n - 1)] > 0.01, "{name}: {}", dense.augmented_mass);
        assert_close(&what("mass matrix"), dense.augmented_mass.as_slice(), tree.augmented_mass.as_slice(), 1.0e-5);
        // The augmented (gyroscopic/coriolis) system and M itself, on every unit vector.
        for k in 0..n {
            let mut e = DVector::zeros(n);
            e[k] = 1.0;
            let (mut x_dense, mut x_tree) = (e.clone(), e.clone());
            dense.acc_inv_augmented_mass.solve_mut(&mut x_dense);
            tree.tree.solve_acc_for_tests(x_tree.as_mut_slice());
            assert_close(&what(&format!("augmented⁻¹·e{k}")), x_dense.as_slice(), x_tree.as_slice(), 1.0e-4);
            let (mut x_dense, mut x_tree) = (e.clone(), e.clone());
            dense.inv_augmented_mass.solve_mut(&mut x_dense);
            tree.tree_solve_along(k, x_tree.as_mut_slice());
            assert_close(&what(&format!("M⁻¹·e{k}")), x_dense.as_slice(), x_tree.as_slice(), 1.0e-4);
        }
        assert_close(&what("free accelerations"), dense.accelerations.as_slice(), tree.accelerations.as_slice(), 1.0e-4);
        // Contact-style jacobians of every link: J, M⁻¹·J, J·M⁻¹·J and J·v.
        for link in 0..mb.num_links() {
            let (force, torque) = (Vector::new(0.3, -0.5, 0.8), Vector::new(-0.2, 0.1, 0.4));
            let (mut jd, mut jt) = (DVector::zeros(2 * n), DVector::zeros(2 * n));
            let (mut id, mut it) = (0, 0);
            let rd = dense.fill_jacobians(link, force, torque, &mut id, &mut jd);
            let rt = tree.fill_jacobians(link, force, torque, &mut it, &mut jt);
            assert_eq!(id, it);
            assert_close(&what(&format!("link {link} jacobians")), jd.as_slice(), jt.as_slice(), 1.0e-4);
            assert_close(&what(&format!("link {link} J·M⁻¹·J, J·v")), &[rd.0, rd.1], &[rt.0, rt.1], 1.0e-4);
        }
        // A loop-closure-style relative jacobian between the last two links.
        let (a, b) = (mb.num_links() - 2, mb.num_links() - 1);
        let (mut jd, mut jt) = (DVector::zeros(2 * n), DVector::zeros(2 * n));
        let (mut id, mut it) = (0, 0);
        let (f, t) = (Vector::new(0.0, 1.0, 0.5), Vector::new(0.3, 0.0, -0.1));
        dense.fill_relative_jacobians(a, f, t, b, -f, -t, &mut id, &mut jd);
        tree.fill_relative_jacobians(a, f, t, b, -f, -t, &mut it, &mut jt);
        assert_close(&what("relative jacobians"), jd.as_slice(), jt.as_slice(), 1.0e-4);
    }
}

#[test]
fn the_tree_path_matches_the_dense_path_on_a_fixed_base_chain() {
    check(chain(), "chain");
}

#[test]
fn the_tree_path_matches_the_dense_path_on_a_free_tree_with_a_massless_spacer() {
    check(tree(), "tree");
}

/// Whole simulations: 2 s of each scene under either path (motors, limits, gravity, the
/// free tree tumbling with no ground) stay within 1 mm of each other.
#[test]
fn simulations_under_either_path_stay_together_for_two_seconds() {
    for (name, build) in [("chain", chain as fn() -> PhysicsWorld), ("tree", tree)] {
        let run = |dynamics: MultibodyDynamics| {
            let mut world = build();
            world.integration_parameters.dt = 1.0 / 240.0;
            world.integration_parameters.multibody_dynamics = dynamics;
            for _ in 0..480 {
                world.step();
            }
            world.bodies.iter().map(|(_, b)| b.translation()).collect::<Vec<_>>()
        };
        let (dense, tree) = (run(MultibodyDynamics::Dense), run(MultibodyDynamics::TreeSparse));
        for (i, (a, b)) in dense.iter().zip(&tree).enumerate() {
            assert!((*a - *b).length() < 1.0e-3, "{name}: body {i} at {a:?} (dense) vs {b:?} (tree)");
        }
        assert_ne!(dense, tree, "{name}: the paths computed the very same bits (is the tree path in effect?)");
    }
}
