//! One scene stepped under one engine rule, for a profiler (docs/benchmarks.md "Robots at engine
//! speed"): `cargo build --release -p physics-core --example rule_steps`, then
//! `valgrind --tool=callgrind --toggle-collect='*step_here*' target/release/examples/rule_steps
//! <scene> <steps> <rule>`. Scenes: `iiwa14` and `panda` (tests/fixtures' meshless URDFs, fixed
//! base, every movable joint on a position motor holding 0.3 with force 100) or a Gymnasium model
//! of tests/fixtures/mjcf at its own timestep (nothing driving it). Prints the wall time per step
//! and the final state hash (the same for any run of one scene, rule and step count). Further
//! arguments, in any order: `noskip` makes every step run each robot's opening forward
//! kinematics, as rapier 0.36.1 did (the vendored rapier's patch 4 skips it when nothing it reads
//! changed; the state hash is the same either way), to measure that skip with one binary;
//! `served` loads a Gymnasium model as load_mjcf does over MCP (its actuators, equality
//! constraints, ball joints and contact pairs built; controls held at 0, so its actuators are
//! driven every step with zero effort). The URDF scenes ignore `served`.

// An example reads its arguments, its files and the clock; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::path::Path;
use std::time::Instant;

use physics_core::command::{Blob, Command, ControlMode, MotorSpec};
use physics_core::engine::EngineRule;
use physics_core::world::World;

fn apply(w: &mut World, c: &Command) -> serde_json::Value {
    w.apply(c, &mut |_| true).to_value()
}

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures")
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = args.first().map_or("iiwa14", String::as_str);
    let steps: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2400);
    let rule = EngineRule::try_from(args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2)).expect("a known rule");
    physics_core::world::set_step_threads(1);
    let flag = |f: &str| args.iter().skip(3).any(|a| a == f);
    let served = flag("served");
    if flag("noskip") {
        rapier3d::dynamics::set_skip_unchanged_multibody_kinematics(false);
    }
    let engine_rule = (rule != EngineRule::Upstream).then_some(rule);
    let root = Command::CreateSimulation { simulation_id: "rule_steps".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule };
    let mut w = World::create(&root).unwrap().0;
    match scene {
        "iiwa14" | "panda" => {
            let file = if scene == "panda" { "panda_dynamics.urdf" } else { "iiwa14.urdf" };
            let text = std::fs::read(fixtures().join(file)).unwrap();
            let load = Command::LoadUrdf {
                file_path: file.into(),
                urdf: Blob::new(text),
                meshes: Default::default(),
                position: [0.0; 3],
                orientation: [0.0, 0.0, 0.0, 1.0],
                fixed_base: true,
                continuous_limits_from_file: true,
                revolute_prismatic_limits_from_file: true,
                inertials_as_pybullet: true,
                parsed: Default::default(),
            };
            let id = apply(&mut w, &load)["object_id"].as_u64().unwrap() as u32;
            let spec = MotorSpec { mode: ControlMode::PositionControl, target_position: 0.3, target_velocity: 0.0, force: Some(100.0), position_gain: 0.1, velocity_gain: 1.0 };
            let motors = w.robot(id).unwrap().movable().iter().map(|j| (*j as u32, spec.clone())).collect();
            apply(&mut w, &Command::SetJointMotors { object_id: id, motors });
        }
        model => {
            let bytes = std::fs::read(fixtures().join("mjcf").join(format!("{model}.xml"))).unwrap();
            let text = String::from_utf8(bytes.clone()).unwrap();
            let dt: f64 = text.split("timestep=\"").nth(1).and_then(|t| t.split('"').next()).map_or(0.002, |t| t.parse().unwrap());
            let load = Command::LoadMjcf {
                file_path: format!("{model}.xml"),
                mjcf: Blob::new(bytes),
                meshes: Default::default(),
                position: [0.0; 3],
                orientation: [0.0, 0.0, 0.0, 1.0],
                fixed_base: false,
                keyframe: None,
                parent_filter: true,
                use_model_options: false,
                actuators: served,
                constraints: served,
                ball_joints_and_pairs: served,
                parsed: Default::default(),
            };
            let out = apply(&mut w, &load);
            assert!(out.get("object_id").is_some(), "{model}: {out}");
            apply(&mut w, &Command::SetTimestep { timestep: dt as f32, timestep_given: Some(dt) });
        }
    }
    let t = Instant::now();
    apply(&mut w, &Command::step(steps));
    let ms = t.elapsed().as_secs_f64() * 1e3 / steps as f64;
    println!("{scene} rule {}: {ms:.4} ms/step over {steps} steps; state hash {}", rule as u32, w.state_hash());
}
