//! MJCF benchmarks (`cargo bench --bench mjcf`; `scripts/mjcf_bench.py` runs it beside MuJoCo's
//! own figures for the same models): load_mjcf of Gymnasium's humanoid.xml (the
//! world's work: parse the spliced text with rapier3d-mjcf, build the robot), and the per-step
//! cost of every Gymnasium model in `tests/fixtures/mjcf` at the model's own `<option
//! timestep>` (MuJoCo's 0.002 s when absent), single thread, from the file's pose (MuJoCo's
//! qpos0), for the same number of steps MuJoCo is timed over. `REPORT` lines carry the figures:
//! `REPORT mjcf <model> step at <dt> s: <median> ms/step (min <min>, <steps> steps, <runs> runs)`.
//!
//! `MJCF_BENCH_STEPS` (default 1000), `MJCF_BENCH_RUNS` (default 7) and `MJCF_BENCH_MODELS`
//! (comma-separated file stems; default all) narrow a run, e.g. for a profiler.
//! `MJCF_BENCH_DRIVE=torque` (or `velocity`) first gives every joint a motor — torque control
//! of 0 N·m, as Gymnasium's actuators are torque motors, or velocity control toward 0 with
//! 1 N·m — so our per-step motor work is in the figure; the default drives nothing.
//! `MJCF_BENCH_USE_MODEL_OPTIONS=1` loads with `use_model_options` (the model's gravity too,
//! e.g. pusher's 0; the timestep is the model's either way).

// A benchmark reads the clock, its files and its environment; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::command::{Command, ControlMode, MotorSpec};
use physics_mcp::world::World;

#[path = "../tests/common/gymnasium.rs"]
mod gymnasium;
use gymnasium::{fixture, model_timestep, MODELS};
#[path = "../tests/common/mjcf_command.rs"]
mod mjcf_command;

fn world_with(name: &str, bytes: &[u8]) -> World {
    let root = Command::CreateSimulation { simulation_id: "mjcf".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    let (mut w, _) = World::create(&root).unwrap();
    let load = mjcf_command::load_mjcf(name, bytes, std::env::var("MJCF_BENCH_USE_MODEL_OPTIONS").is_ok_and(|v| v == "1"));
    let out = w.apply(&load, &mut |_| true);
    assert!(matches!(out, physics_mcp::outputs::Outcome::MjcfLoaded(_)), "{name} loads: {:?}", out.to_value());
    w
}

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// ms/step of `steps` steps of a freshly loaded model at its own timestep: (median, min) of `runs`.
fn step_cost(name: &str, bytes: &[u8], dt: f64, steps: u64, runs: usize) -> (f64, f64) {
    let mut per_step = Vec::new();
    for _ in 0..runs {
        let mut w = world_with(name, bytes);
        w.apply(&Command::SetTimestep { timestep: dt as f32, timestep_given: Some(dt) }, &mut |_| true);
        drive(&mut w);
        let t = Instant::now();
        w.apply(&Command::step(steps), &mut |_| true);
        per_step.push(t.elapsed().as_secs_f64() / steps as f64);
    }
    let min = per_step.iter().copied().fold(f64::INFINITY, f64::min);
    (median(per_step) * 1e3, min * 1e3)
}

/// Gives every joint of object 0 the motor `MJCF_BENCH_DRIVE` names (none by default).
fn drive(w: &mut World) {
    let (mode, force) = match std::env::var("MJCF_BENCH_DRIVE").as_deref() {
        Ok("torque") => (ControlMode::TorqueControl, 0.0),
        Ok("velocity") => (ControlMode::VelocityControl, 1.0),
        _ => return,
    };
    let spec = MotorSpec { mode, target_position: 0.0, target_velocity: 0.0, force: Some(force), position_gain: 0.1, velocity_gain: 1.0 };
    let motors = (0..w.link_count(0) as u32).map(|j| (j, spec.clone())).collect();
    w.apply(&Command::SetJointMotors { object_id: 0, motors }, &mut |_| true);
}

fn bench_mjcf(c: &mut Criterion) {
    // MuJoCo steps on one thread; so do we here (the server's default, `--threads 1`).
    physics_mcp::world::set_step_threads(1);
    let steps = env_or("MJCF_BENCH_STEPS", 1000) as u64;
    let runs = env_or("MJCF_BENCH_RUNS", 7);
    let only: Option<Vec<String>> = std::env::var("MJCF_BENCH_MODELS").ok().map(|v| v.split(',').map(str::to_string).collect());
    if only.is_none() {
        let humanoid = fixture("humanoid");
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
        g.finish();
        println!("REPORT mjcf load humanoid.xml: {:.2} ms", median(loads) * 1e3);
    }
    for model in MODELS {
        if only.as_ref().is_some_and(|o| !o.iter().any(|m| m == model)) {
            continue;
        }
        let file = format!("{model}.xml");
        let bytes = fixture(model);
        let dt = model_timestep(&bytes);
        let (med, min) = step_cost(&file, &bytes, dt, steps, runs);
        let drive = match std::env::var("MJCF_BENCH_DRIVE").as_deref() {
            Ok(d @ ("torque" | "velocity")) => format!(", {d} motors"),
            _ => String::new(),
        };
        println!("REPORT mjcf {model} step at {dt} s: {med:.4} ms/step (min {min:.4}, {steps} steps, {runs} runs{drive})");
    }
}

criterion_group!(benches, bench_mjcf);
criterion_main!(benches);
