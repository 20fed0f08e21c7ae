//! Issue 14 benchmarks (`cargo bench --bench mjcf`; `scripts/mjcf_bench.py` runs it beside
//! MuJoCo's own figures for the same models): load_mjcf of Gymnasium's humanoid.xml (the
//! world's work: parse the spliced text with rapier3d-mjcf, build the robot), and 1000 steps of
//! ant.xml on its floor at MuJoCo's own timestep (0.01 s). `REPORT` lines carry the figures.

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::command::{Blob, Command};
use physics_mcp::world::World;

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mjcf").join(name)).unwrap()
}

fn world_with(name: &str, bytes: &[u8]) -> World {
    let root = Command::CreateSimulation { simulation_id: "mjcf".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None };
    let (mut w, _) = World::create(&root).unwrap();
    let load = Command::LoadMjcf {
        file_path: name.into(),
        mjcf: Blob::new(bytes.to_vec()),
        meshes: Default::default(),
        position: [0.0; 3],
        orientation: [0.0, 0.0, 0.0, 1.0],
        fixed_base: false,
        keyframe: None,
        parsed: Default::default(),
    };
    let out = w.apply(&load, &mut |_| true);
    assert!(matches!(out, physics_mcp::outputs::Outcome::MjcfLoaded(_)), "{name} loads: {:?}", out.to_value());
    w
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench_mjcf(c: &mut Criterion) {
    let humanoid = fixture("humanoid.xml");
    let ant = fixture("ant.xml");
    let mut g = c.benchmark_group("mjcf");
    g.sample_size(20).measurement_time(Duration::from_secs(10));
    let mut loads = Vec::new();
    g.bench_function("load_humanoid", |b| {
        b.iter(|| {
            let t = Instant::now();
            let w = world_with("humanoid.xml", &humanoid);
            loads.push(t.elapsed().as_secs_f64());
            w
        })
    });
    let mut steps = Vec::new();
    g.bench_function("ant_1000_steps_at_0.01", |b| {
        b.iter(|| {
            let mut w = world_with("ant.xml", &ant);
            w.apply(&Command::SetTimestep { timestep: 0.01, timestep_given: Some(0.01) }, &mut |_| true);
            let t = Instant::now();
            w.apply(&Command::StepSimulation { steps: 1000 }, &mut |_| true);
            steps.push(t.elapsed().as_secs_f64() / 1000.0);
            w
        })
    });
    g.finish();
    println!("REPORT mjcf load humanoid.xml: {:.2} ms", median(loads) * 1e3);
    println!("REPORT mjcf ant.xml step at 0.01 s: {:.4} ms/step", median(steps) * 1e3);
}

criterion_group!(benches, bench_mjcf);
criterion_main!(benches);
