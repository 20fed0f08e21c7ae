//! Robots at engine speed (engine rule 3 against rule 2; `cargo bench --bench robot_steps`): ms per step, in
//! process, of the scenes `scripts/robot_bench.py` measures over MCP and beside PyBullet and
//! MuJoCo, under each engine rule (`engine::EngineRule`):
//! - `kuka` and `panda`: pybullet_data's `kuka_iiwa/model.urdf` and `franka_panda/panda.urdf`
//!   (with their meshes, fixed base) on the built-in plane, every movable joint on a position
//!   motor holding 0.3 (rad or m) with force 100, 2,400 steps of 1/240 s in one command;
//! - every Gymnasium model of `tests/fixtures/mjcf` at its own timestep, 1,000 steps, nothing
//!   driving the joints (as `benches/mjcf.rs`).
//!
//! `REPORT robot_steps <scene> rule <n>: <median> ms/step (min <min>, <steps> steps, <runs> runs)`
//! lines carry the figures, and `HASH robot_steps <scene> rule <n>: <state hash> after <steps> steps`
//! lines the final state. `ROBOT_BENCH_DATA` is pybullet_data's directory (the KUKA and the
//! Panda are skipped without it); `ROBOT_BENCH_SCENES` (comma-separated, default all),
//! `ROBOT_BENCH_RULES` (default `2,3`; rule 1 on request), `ROBOT_BENCH_STEPS` (overrides both step counts) and
//! `ROBOT_BENCH_RUNS` (default 5) narrow a run, e.g. under callgrind
//! (`valgrind --tool=callgrind --toggle-collect='*step_here*' target/release/deps/robot_steps-*`).
//! One thread, as PyBullet and MuJoCo step.

// A benchmark reads the clock, its files and its environment; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

use std::path::Path;
use std::time::Instant;

use physics_mcp::command::{Command, ControlMode, MotorSpec};
use physics_mcp::engine::EngineRule;
use physics_mcp::files::{Reader, Sandbox};
use physics_mcp::world::World;
use serde_json::json;

#[path = "../tests/common/gymnasium.rs"]
mod gymnasium;
#[path = "../tests/common/mjcf_command.rs"]
mod mjcf_command;

/// Builds one scene's world under an engine rule.
type SceneBuilder = Box<dyn Fn(EngineRule) -> World>;

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn apply(w: &mut World, c: &Command) -> serde_json::Value {
    w.apply(c, &mut |_| true).to_value()
}

fn world(rule: EngineRule) -> World {
    let root = Command::CreateSimulation {
        simulation_id: "robot_steps".into(),
        gravity: [0.0, 0.0, -9.81],
        gui: false,
        name: None,
        engine_rule: Some(rule),
    };
    World::create(&root).unwrap().0
}

/// A pybullet_data robot on the plane, every movable joint holding 0.3 with force 100.
fn robot_world(data: &Path, urdf: &str, rule: EngineRule) -> World {
    let mut w = world(rule);
    let sandbox = Sandbox { workspace: data.canonicalize().unwrap(), data_dir: "/nonexistent-robot-steps-data".into() };
    let load = |file: &str, fixed: bool| {
        let args = json!({"sim_id": "robot_steps", "file_path": file, "use_fixed_base": fixed});
        physics_mcp::files::urdf::decide_load_urdf(&mut Reader::new(&sandbox), args.as_object().unwrap()).unwrap()
    };
    apply(&mut w, &load("plane.urdf", true));
    let id = apply(&mut w, &load(urdf, true))["object_id"].as_u64().unwrap() as u32;
    let spec = MotorSpec {
        mode: ControlMode::PositionControl,
        target_position: 0.3,
        target_velocity: 0.0,
        force: Some(100.0),
        position_gain: 0.1,
        velocity_gain: 1.0,
    };
    let movable = w.robot(id).unwrap().movable();
    let motors = movable.iter().map(|j| (*j as u32, spec.clone())).collect();
    let out = apply(&mut w, &Command::SetJointMotors { object_id: id, motors });
    assert!(out.get("message").is_some(), "{out}");
    w
}

fn mjcf_world(model: &str, rule: EngineRule) -> World {
    let mut w = world(rule);
    let bytes = gymnasium::fixture(model);
    let dt = gymnasium::model_timestep(&bytes);
    let out = apply(&mut w, &mjcf_command::load_mjcf(model, &bytes, false));
    assert!(out.get("object_id").is_some(), "{model}: {out}");
    apply(&mut w, &Command::SetTimestep { timestep: dt as f32, timestep_given: Some(dt) });
    w
}

/// (median, min) ms/step of `steps` steps in one command, each run from a fresh world, and the
/// last run's final state hash (every run ends in the same state: a change meant to keep the
/// bits is checked by comparing it across builds).
fn cost(build: &dyn Fn() -> World, steps: u64, runs: usize) -> (f64, f64, String) {
    let mut hash = String::new();
    let mut per_step: Vec<f64> = (0..runs)
        .map(|_| {
            let mut w = build();
            let t = Instant::now();
            apply(&mut w, &Command::step(steps));
            let ms = t.elapsed().as_secs_f64() * 1e3 / steps as f64;
            hash = w.state_hash();
            ms
        })
        .collect();
    per_step.sort_by(f64::total_cmp);
    (per_step[per_step.len() / 2], per_step[0], hash)
}

fn main() {
    physics_mcp::world::set_step_threads(1);
    let wanted: Option<Vec<String>> = std::env::var("ROBOT_BENCH_SCENES").ok().map(|s| s.split(',').map(str::to_owned).collect());
    let wants = |name: &str| wanted.as_ref().is_none_or(|w| w.iter().any(|x| x == name));
    let rules: Vec<EngineRule> = std::env::var("ROBOT_BENCH_RULES")
        .unwrap_or_else(|_| "2,3".into())
        .split(',')
        .map(|r| EngineRule::try_from(r.trim().parse::<u32>().expect("ROBOT_BENCH_RULES: numbers")).expect("a known rule"))
        .collect();
    let runs = env_or("ROBOT_BENCH_RUNS", 5);
    let data = std::env::var_os("ROBOT_BENCH_DATA").map(std::path::PathBuf::from);
    let mut scenes: Vec<(String, u64, SceneBuilder)> = Vec::new();
    for (name, urdf) in [("kuka", "kuka_iiwa/model.urdf"), ("panda", "franka_panda/panda.urdf")] {
        match (&data, wants(name)) {
            (Some(d), true) => {
                let d = d.clone();
                scenes.push((name.into(), 2400, Box::new(move |rule| robot_world(&d, urdf, rule))));
            }
            (None, true) => println!("SKIP robot_steps {name}: ROBOT_BENCH_DATA (pybullet_data's directory) is not set"),
            _ => {}
        }
    }
    for model in gymnasium::MODELS {
        if wants(model) {
            scenes.push((model.into(), 1000, Box::new(move |rule| mjcf_world(model, rule))));
        }
    }
    for (name, steps, build) in &scenes {
        let steps = std::env::var("ROBOT_BENCH_STEPS").ok().and_then(|s| s.parse().ok()).unwrap_or(*steps);
        for rule in &rules {
            let (median, min, hash) = cost(&|| build(*rule), steps, runs);
            println!("REPORT robot_steps {name} rule {}: {median:.4} ms/step (min {min:.4}, {steps} steps, {runs} runs)", *rule as u32);
            println!("HASH robot_steps {name} rule {}: {hash} after {steps} steps", *rule as u32);
        }
    }
}
