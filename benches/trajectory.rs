//! Issue 11 benchmark (`cargo bench --bench trajectory`): get_trajectory's core (lend the
//! chain from the log, re-simulate from the snapshot at the interval's start, sample every
//! 10 steps) over 1000 steps of the 1000-box collapsing pile, side by side with stepping
//! those 1000 steps on a world already restored. SPEC target: ≤ 1.10 × stepping + 5 ms.
//! Prints a `REPORT` line with the median of per-iteration ratios (both timed back to back).
//!
//! Second group: the same interval at the end of a long history. The pile takes 1,001 add_box
//! events, so the short history is 1,003 events (pile, step 100, step 1000) and the long one
//! adds 19,000 set_camera events before the steps (20,003 events). SPEC target: the long one
//! costs ≤ 1.2 × the short one — looking back depends on the interval, not on what came before.

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "pile.rs"]
mod pile;

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::command::Command;
use physics_mcp::log::fold;
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::seeing::trajectory::{self, Request};
use physics_mcp::value::Args;
use physics_mcp::world::World;
use pile::{pile_commands, root};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Builds simulation `id` in `reg`: the pile, `padding` set_camera events, 100 steps (the
/// interval starts at the snapshot they leave), then 1000 steps; returns (from, to).
fn build(reg: &Registry, id: &str, padding: usize) -> (u64, u64) {
    reg.create(root(id), &Args::new()).unwrap();
    let s = reg.get(id).unwrap();
    let mut sim = lock_sim(&s);
    let (a, l) = (Args::new(), Limits::default());
    for cmd in pile_commands() {
        sim.change("add_box", &a, Ok(cmd), &l, &mut |_| true).unwrap();
    }
    for i in 0..padding {
        let cam = Command::SetCamera { distance: 3.0 + (i % 7) as f32, yaw: 30.0, pitch: -20.0, target: [0.0; 3] };
        sim.change("set_camera", &a, Ok(cam), &l, &mut |_| true).unwrap();
    }
    // 100 steps × 1001 bodies is a snapshot's worth of work: the interval starts at one.
    sim.change("step_simulation", &a, Ok(Command::step(100)), &l, &mut |_| true).unwrap();
    let from = sim.log().head_seq();
    assert!(sim.log().snapshot_at(from).unwrap().is_some(), "a snapshot at the interval's start");
    sim.change("step_simulation", &a, Ok(Command::step(1000)), &l, &mut |_| true).unwrap();
    (from, sim.log().head_seq())
}

/// get_trajectory's core on `id` over (from, to]: lend under the lock, sample without it.
fn look_back(reg: &Registry, id: &str, from: u64, to: u64, req: &Request) -> f64 {
    let s = reg.get(id).unwrap();
    let t = Instant::now();
    let lent = {
        let sim = lock_sim(&s);
        fold::lend(sim.log(), sim.id(), Some(from), Some(to)).unwrap()
    };
    let traj = trajectory::sample_interval(&lent, req).unwrap();
    let took = t.elapsed().as_secs_f64();
    assert_eq!(traj.samples, 101);
    took
}

fn registry(dir: &std::path::Path) -> Registry {
    Registry::open(common::config(dir))
    .unwrap()
}

fn bench_trajectory(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let reg = registry(dir.path());
    let (from, to) = build(&reg, "pile", 0);
    let s = reg.get("pile").unwrap();
    let snapshot = lock_sim(&s).log().snapshot_at(from).unwrap().unwrap().0;
    let req = Request { every: Some(10), object_ids: None, include_velocities: false };
    // Each iteration times both, back to back, so the ratio holds on a machine whose load
    // drifts (the REPORT line is the median of per-iteration ratios).
    let mut g = c.benchmark_group("trajectory_pile_1000_steps");
    g.sample_size(10).measurement_time(Duration::from_secs(60));
    let (mut stepped, mut sampled, mut ratios) = (vec![], vec![], vec![]);
    g.bench_function("step_1000_then_get_trajectory_every_10", |b| {
        b.iter(|| {
            let mut w = World::restore("pile", false, &snapshot).unwrap();
            let t = Instant::now();
            w.apply(&Command::step(1000), &mut |_| true);
            let st = t.elapsed().as_secs_f64();
            let tr = look_back(&reg, "pile", from, to, &req);
            stepped.push(st);
            sampled.push(tr);
            ratios.push(tr / st);
            w
        })
    });
    g.finish();
    let (st, tr) = (median(stepped), median(sampled));
    println!(
        "REPORT trajectory: stepping 1000 steps {:.1} ms, get_trajectory every=10 {:.1} ms, ratio {:.3} (median of paired runs; target ≤ 1.10 × stepping + 5 ms = {:.1} ms)",
        st * 1e3,
        tr * 1e3,
        median(ratios),
        (1.10 * st + 0.005) * 1e3
    );
}

fn bench_long_history(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let reg = registry(dir.path());
    let short = build(&reg, "short", 0);
    let long = build(&reg, "long", 19_000);
    let req = Request { every: Some(10), object_ids: None, include_velocities: false };
    let mut g = c.benchmark_group("trajectory_after_history");
    g.sample_size(10).measurement_time(Duration::from_secs(40));
    let (mut at_short, mut at_long, mut ratios) = (vec![], vec![], vec![]);
    g.bench_function("after_1003_then_after_20003_events", |b| {
        b.iter(|| {
            let a = look_back(&reg, "short", short.0, short.1, &req);
            let b = look_back(&reg, "long", long.0, long.1, &req);
            at_short.push(a);
            at_long.push(b);
            ratios.push(b / a);
        })
    });
    g.finish();
    println!(
        "REPORT trajectory history: same interval after 1,003 events {:.1} ms, after 20,003 events {:.1} ms, ratio {:.3} (median of paired runs; target ≤ 1.2)",
        median(at_short) * 1e3,
        median(at_long) * 1e3,
        median(ratios)
    );
}

criterion_group!(benches, bench_trajectory, bench_long_history);
criterion_main!(benches);
