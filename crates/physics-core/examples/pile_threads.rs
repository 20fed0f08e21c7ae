//! Pile step time on 1 vs 2 (or more) threads, for the `threads` evaluation (README "Threads"):
//! `cargo run --release -p physics-core --features threads --example pile_threads -- 1 2`.
//! The 1000-box pile of benches/pile.rs (a 10×10×10 grid of 0.1 m half-extent boxes, jittered
//! and turned by a fixed sequence instead of benches' ChaCha, which this crate does not depend
//! on), 100 settling steps, then 300 timed steps per thread count from the same snapshot; the
//! final state hashes must agree.

// A benchmark reads the clock and its arguments; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::sync::Arc;
use std::time::Instant;

use physics_core::command::{Command, Shape};
use physics_core::world::World;

fn main() {
    let counts: Vec<usize> = std::env::args().skip(1).map(|a| a.parse().expect("thread counts")).collect();
    let root = Command::CreateSimulation { simulation_id: "pile".into(), gravity: [0.0, 0.0, -9.81], gui: false };
    let (mut w, _) = World::create(&root).unwrap();
    let ground = Command::AddBody {
        shape: Shape::Box { half_extents: [20.0, 20.0, 0.5] },
        position: [0.0, 0.0, -0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 0.0,
        color: None,
    };
    w.apply(&ground, &mut |_| true);
    let mut seed = 20261122u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 40) as f32) / ((1u64 << 24) as f32)
    };
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                let p = [i as f32 * 0.25 + 0.04 * next() - 0.02, j as f32 * 0.25 + 0.04 * next() - 0.02, 0.5 + k as f32 * 0.25];
                let a = [2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0];
                let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-6);
                let (s, c) = (next() * std::f32::consts::PI).sin_cos();
                let q = [a[0] / n * s, a[1] / n * s, a[2] / n * s, c];
                let m = (q.iter().map(|x| x * x).sum::<f32>()).sqrt();
                let body = Command::AddBody {
                    shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] },
                    position: p,
                    orientation: q.map(|x| x / m),
                    mass: 1.0,
                    color: None,
                };
                w.apply(&body, &mut |_| true);
            }
        }
    }
    w.apply(&Command::StepSimulation { steps: 100 }, &mut |_| true);
    let snap = w.snapshot();
    let mut first: Option<(f64, String)> = None;
    for n in counts {
        let pool = Arc::new(rapier3d::rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap());
        let mut r = World::restore("pile", false, &snap).unwrap();
        r.set_thread_pool(Some(pool));
        let t = Instant::now();
        r.apply(&Command::StepSimulation { steps: 300 }, &mut |_| true);
        let ms = t.elapsed().as_secs_f64() * 1000.0 / 300.0;
        let hash = r.state_hash();
        let (base, same) = match &first {
            None => (ms, true),
            Some((b, h)) => (*b, *h == hash),
        };
        println!("REPORT pile step, {n} threads: {ms:.3} ms/step, {:.2}x the first count's time, hash {} ({})", ms / base, &hash[..16], if same { "same" } else { "DIFFERENT" });
        first.get_or_insert((ms, hash));
    }
}
