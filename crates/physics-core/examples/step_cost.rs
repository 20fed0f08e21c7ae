//! What a step costs on 1, 2, … threads (README "Threads"):
//! `cargo run --release -p physics-core --example step_cost -- 1 2`.
//! Two worlds: the 1000-box pile of benches/pile.rs (a 10×10×10 grid of 0.1 m half-extent
//! boxes, jittered and turned by a fixed sequence instead of benches' ChaCha, which this crate
//! does not depend on; 100 settling steps, then 300 timed steps in one command), and one box
//! on the ground (20,000 steps in one command, then 2,000 commands of one step: the hand-over
//! to the pool is paid per command). The final hashes of every thread count must agree.

// A benchmark reads the clock and its arguments; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::time::Instant;

use physics_core::command::{Command, Shape};
use physics_core::world::World;

fn apply(w: &mut World, c: &Command) {
    w.apply(c, &mut |_| true);
}

fn add_box(w: &mut World, half: f32, position: [f32; 3], orientation: [f32; 4], mass: f32) {
    let body = Command::AddBody { shape: Shape::Box { half_extents: [half, half, half] }, position, orientation, mass, color: None, collides: true };
    apply(w, &body);
}

fn ground() -> World {
    let root = Command::CreateSimulation { simulation_id: "cost".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_core::engine::ENGINE_RULE) };
    let (mut w, _) = World::create(&root).unwrap();
    let ground = Command::AddBody {
        shape: Shape::Box { half_extents: [20.0, 20.0, 0.5] },
        position: [0.0, 0.0, -0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 0.0,
        color: None,
        collides: true,
    };
    apply(&mut w, &ground);
    w
}

fn pile() -> World {
    let mut w = ground();
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
                add_box(&mut w, 0.1, p, q.map(|x| x / m), 1.0);
            }
        }
    }
    apply(&mut w, &Command::step(100));
    w
}

/// Makes every step from now on run on `n` threads.
fn use_threads(n: usize) {
    physics_core::world::set_step_threads(n);
}

/// Microseconds per unit of `units` for `work`.
fn timed(units: u64, work: impl FnOnce()) -> f64 {
    let t = Instant::now();
    work();
    t.elapsed().as_secs_f64() * 1e6 / units as f64
}

fn main() {
    let counts: Vec<usize> = std::env::args().skip(1).map(|a| a.parse().expect("thread counts")).collect();
    let pile_snapshot = pile().snapshot();
    let mut hashes: Option<(String, String)> = None;
    for n in counts {
        use_threads(n);
        let mut p = World::restore("cost", false, &pile_snapshot).unwrap();
        let pile_us = timed(300, || apply(&mut p, &Command::step(300)));
        let mut t = ground();
        add_box(&mut t, 0.1, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0], 1.0);
        let long_us = timed(20_000, || apply(&mut t, &Command::step(20_000)));
        let short_us = timed(2_000, || (0..2_000).for_each(|_| apply(&mut t, &Command::step(1))));
        let now = (p.state_hash(), t.state_hash());
        let same = hashes.as_ref().is_none_or(|h| *h == now);
        hashes.get_or_insert(now);
        println!(
            "REPORT {n} thread(s): pile {:.3} ms/step; one box {long_us:.2} µs/step in one command, {short_us:.2} µs per 1-step command; hashes {}",
            pile_us / 1000.0,
            if same { "same" } else { "DIFFERENT" }
        );
    }
}
