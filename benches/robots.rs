//! Issue 4 benchmark (`cargo bench --bench robots`): inverse kinematics on the 7-joint KUKA
//! LBR iiwa 14 fixture — µs per call and the accuracy table over 500 random reachable targets
//! (forward kinematics of random in-limit configurations), every query from the all-zeros
//! pose, position-only and with orientation. Prints `REPORT` lines; criterion times one call.

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::world::{ik, World};
use rand::{Rng, SeedableRng};
use rapier3d::glamx::{DQuat, DVec3};

type Target = ([f32; 3], Option<[f32; 4]>);

fn iiwa() -> (World, u32) {
    let mut w = common::empty_world("bench");
    let id = common::load_fixture(&mut w, "iiwa14.urdf", [0.0; 3], true);
    (w, id)
}

fn targets(w: &World, id: u32, orientation: bool) -> Vec<Target> {
    let joints: Vec<_> = w.robot(id).unwrap().links.iter().map(|l| l.joint.clone()).collect();
    let movable = w.robot(id).unwrap().movable();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261122);
    (0..500)
        .map(|_| {
            let q: Vec<f64> = movable.iter().map(|i| rng.gen_range(joints[*i].lower..=joints[*i].upper)).collect();
            let (p, r): (DVec3, DQuat) = ik::link_pose(&joints, DVec3::ZERO, DQuat::IDENTITY, 7, &q);
            let rot = orientation.then_some([r.x as f32, r.y as f32, r.z as f32, r.w as f32]);
            ([p.x as f32, p.y as f32, p.z as f32], rot)
        })
        .collect()
}

fn table(w: &World, id: u32, name: &str, ts: &[Target]) {
    let t0 = Instant::now();
    let answers: Vec<_> = ts
        .iter()
        .map(|(p, r)| w.inverse_kinematics(id, 7, *p, *r, None, None, Some(vec![0.0; 7])).unwrap())
        .collect();
    let us = t0.elapsed().as_secs_f64() * 1e6 / ts.len() as f64;
    let share = |f: &dyn Fn(&physics_mcp::outputs::IkSolution) -> bool| {
        100.0 * answers.iter().filter(|a| f(a)).count() as f64 / answers.len() as f64
    };
    let iters = answers.iter().map(|a| a.iterations).sum::<usize>() as f64 / answers.len() as f64;
    let mut sorted: Vec<f64> = answers.iter().map(|a| a.position_error).collect();
    sorted.sort_by(f64::total_cmp);
    println!(
        "REPORT IK {name}: {us:.1} us/call mean, {iters:.1} iterations mean; position error < 0.01 mm {:.1} %, < 0.1 mm {:.1} %, < 1 mm {:.1} %, < 1 cm {:.1} %; with orientation < 0.01 rad and < 1 mm {:.1} %; median error {:.2e} m, worst {:.2e} m",
        share(&|a| a.position_error < 1e-5),
        share(&|a| a.position_error < 1e-4),
        share(&|a| a.position_error < 1e-3),
        share(&|a| a.position_error < 1e-2),
        share(&|a| a.position_error < 1e-3 && a.orientation_error < 0.01),
        sorted[sorted.len() / 2],
        sorted[sorted.len() - 1],
    );
}

fn bench_ik(c: &mut Criterion) {
    let (w, id) = iiwa();
    let position = targets(&w, id, false);
    let pose = targets(&w, id, true);
    table(&w, id, "position-only, 500 targets from zeros", &position);
    table(&w, id, "position+orientation, 500 targets from zeros", &pose);
    let mut g = c.benchmark_group("ik_iiwa14");
    let mut i = 0;
    g.bench_function("position_only", |b| {
        b.iter(|| {
            i = (i + 1) % position.len();
            let (p, r) = position[i];
            w.inverse_kinematics(id, 7, p, r, None, None, Some(vec![0.0; 7]))
        })
    });
    g.bench_function("position_and_orientation", |b| {
        b.iter(|| {
            i = (i + 1) % pose.len();
            let (p, r) = pose[i];
            w.inverse_kinematics(id, 7, p, r, None, None, Some(vec![0.0; 7]))
        })
    });
    g.finish();
}

criterion_group!(benches, bench_ik);
criterion_main!(benches);
