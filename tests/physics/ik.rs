//! Inverse kinematics on the 7-joint KUKA LBR iiwa 14 fixture, in process (the solver is a pure
//! function of the world; the HTTP path is covered in robots.rs): 500 random reachable targets
//! from forward kinematics of random in-limit configurations, every query from the all-zeros
//! pose. Seeded: the seed is printed and `PHYSICS_SEED` replays a run.

use crate::common;

use physics_mcp::world::{ik, World};
use rand::{Rng, SeedableRng};
use rapier3d::glamx::{DQuat, DVec3};

fn iiwa_world() -> (World, u32) {
    let mut w = common::empty_world("ik");
    let id = common::load_fixture(&mut w, "iiwa14.urdf", [0.1, -0.2, 0.3], true);
    (w, id)
}

/// Drives the robot's movable joints to `q` inside rapier (its multibody's own joint
/// coordinates and forward kinematics, which share no code with the solver's `ik::link_pose`)
/// and returns link `link`'s body pose as rapier then places it. Works on copies of the
/// world's rapier sets: the world itself changes only through `World::apply`.
fn rapier_link_pose(w: &World, id: u32, link: usize, q: &[f64]) -> (DVec3, DQuat) {
    let robot = w.robot(id).unwrap().clone();
    let movable: Vec<_> = robot.movable().iter().map(|i| robot.links[*i].body).collect();
    let (mut bodies, mut mbs) = (w.physics().bodies.clone(), w.physics().multibody_joints.clone());
    let mut multibody = None;
    for (body, target) in movable.iter().zip(q) {
        let at = *mbs.rigid_body_link(*body).expect("a robot link is a multibody link");
        multibody = Some(at.multibody);
        let link = mbs.get_multibody_mut(at.multibody).unwrap().link_mut(at.id).unwrap();
        // Revolute joints of this arm: the free coordinate is the angle about the joint's x axis.
        let now = link.joint.coords()[3];
        link.joint.apply_displacement(&[*target as f32 - now]);
    }
    let mb = mbs.get_multibody_mut(multibody.unwrap()).unwrap();
    // The root's pose comes from the base body, where load_urdf placed the robot.
    mb.forward_kinematics(&bodies, true);
    mb.update_rigid_bodies(&mut bodies, false);
    let pose = bodies[robot.links[link].body].position();
    let (t, r) = (pose.translation, pose.rotation);
    (DVec3::new(t.x as f64, t.y as f64, t.z as f64), DQuat::from_xyzw(r.x as f64, r.y as f64, r.z as f64, r.w as f64))
}

#[allow(clippy::disallowed_methods)] // a test reads its seed from the environment
fn seed() -> u64 {
    let s = std::env::var("PHYSICS_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x1ca_7a11);
    println!("seed={s} (PHYSICS_SEED={s} replays this run)");
    s
}

#[test]
fn ik_reaches_random_reachable_targets_within_limits() {
    let (w, id) = iiwa_world();
    let robot = w.robot(id).unwrap().clone();
    let joints: Vec<_> = robot.links.iter().map(|l| l.joint.clone()).collect();
    let movable = robot.movable();
    assert_eq!(movable.len(), 7);
    let ee = 7; // the fixed flange link
    let base = (DVec3::new(0.1f32 as f64, -0.2f32 as f64, 0.3f32 as f64), DQuat::IDENTITY);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed());
    let n = 500;
    let (mut pos_ok, mut pose_ok) = (0, 0);
    let mut worst = 0.0f64;
    for case in 0..2 * n {
        let with_orientation = case >= n;
        let config: Vec<f64> = movable.iter().map(|i| rng.gen_range(joints[*i].lower..=joints[*i].upper)).collect();
        let (p, r) = ik::link_pose(&joints, base.0, base.1, ee, &config);
        let target_rot = with_orientation.then_some([r.x as f32, r.y as f32, r.z as f32, r.w as f32]);
        let target = [p.x as f32, p.y as f32, p.z as f32];
        let zeros = Some(vec![0.0; 7]);
        let sol = w.inverse_kinematics(id, ee, target, target_rot, None, None, zeros.clone()).unwrap();
        let again = w.inverse_kinematics(id, ee, target, target_rot, None, None, zeros).unwrap();
        assert_eq!(sol.joint_positions, again.joint_positions, "same inputs, different answer");
        assert_eq!(sol.joint_positions.len(), 7);
        for (m, v) in sol.joint_positions.iter().enumerate() {
            let j = &joints[movable[m]];
            assert!(*v >= j.lower && *v <= j.upper, "joint {m} = {v} outside [{}, {}]", j.lower, j.upper);
        }
        // The solver's own account of its answer: its forward kinematics agrees with its error.
        let (p1, _) = ik::link_pose(&joints, base.0, base.1, ee, &sol.joint_positions);
        let target_p = DVec3::new(target[0] as f64, target[1] as f64, target[2] as f64);
        assert!(((p1 - target_p).length() - sol.position_error).abs() < 1e-9);
        // Checked independently: rapier places the flange where the solver says when the
        // joints are driven to the answer (f32 poses: agreement to a few µm).
        let (p2, r2) = rapier_link_pose(&w, id, ee, &sol.joint_positions);
        let pos_err = (p2 - target_p).length();
        assert!((pos_err - sol.position_error).abs() < 1e-5, "rapier's flange is {pos_err} m from the target, the solver says {}", sol.position_error);
        if with_orientation {
            let t = DQuat::from_xyzw(r.x as f32 as f64, r.y as f32 as f64, r.z as f32 as f64, r.w as f32 as f64).normalize();
            let ang = t.angle_between(r2);
            if pos_err < 1e-3 && ang < 0.01 {
                pose_ok += 1;
            }
        } else {
            worst = worst.max(pos_err);
            if pos_err < 1e-3 {
                pos_ok += 1;
            }
        }
    }
    println!("REPORT IK position-only: {pos_ok}/{n} under 1 mm (worst {worst:.2e} m); with orientation: {pose_ok}/{n} under 1 mm and 0.01 rad");
    assert!(pos_ok * 100 >= 99 * n, "position targets reached: {pos_ok}/{n}");
    assert!(pose_ok * 100 >= 95 * n, "pose targets reached: {pose_ok}/{n}");
}

#[test]
fn ik_respects_given_limits_and_starts_from_rest_poses() {
    let (w, id) = iiwa_world();
    // A target straight up at the arm's full height is reached at all zeros: from rest poses
    // at zero the solver must not move.
    let joints: Vec<_> = w.robot(id).unwrap().links.iter().map(|l| l.joint.clone()).collect();
    let (p, _) = ik::link_pose(&joints, DVec3::new(0.1f32 as f64, -0.2f32 as f64, 0.3f32 as f64), DQuat::IDENTITY, 7, &[0.0; 7]);
    let target = [p.x as f32, p.y as f32, p.z as f32];
    let sol = w.inverse_kinematics(id, 7, target, None, None, None, Some(vec![0.0; 7])).unwrap();
    assert!(sol.position_error < 1e-6, "{sol:?}");
    // Tight limits given by the caller bind every answer.
    let lower = vec![-0.1; 7];
    let upper = vec![0.1; 7];
    let far = [0.6, 0.3, 0.5];
    let sol = w.inverse_kinematics(id, 7, far, None, Some(lower), Some(upper), None).unwrap();
    assert!(sol.joint_positions.iter().all(|v| (-0.1..=0.1).contains(v)), "{sol:?}");
    assert!(sol.position_error > 0.1, "an unreachable target cannot be reached: {sol:?}");
}

