//! The 1000-box pile of issue 2, shared by the benchmarks that need it (stepping, snapshots,
//! MCP overhead, rays, threads), and the 64 URDF arms the thread tests and benchmarks step.
#![allow(dead_code)]

use physics_mcp::command::{Blob, Command, ControlMode, MotorSpec, Shape};
use physics_mcp::engine::EngineRule;
use physics_mcp::world::World;
use rand::{Rng, SeedableRng};
use serde_json::json;

pub const SEED: u64 = 20261122;

/// The 1000-box pile of the issue: half-extent 0.1 boxes on a 10×10×10 grid, spacing 0.25 m
/// from z = 0.5, jittered ±0.02 m, turned by a seeded random angle, on a static ground.
/// Orientations are as a client would send them (raw axis-angle quaternions); `pile_commands`
/// normalises them exactly as the adapter does, so in-process and HTTP runs are identical.
pub fn pile_commands() -> Vec<Command> {
    raw_pile()
        .into_iter()
        .map(|mut c| {
            if let Command::AddBody { orientation, .. } = &mut c {
                *orientation = physics_mcp::value::quat("orientation", &json!(*orientation)).unwrap();
            }
            c
        })
        .collect()
}

pub fn raw_pile() -> Vec<Command> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let mut cmds = vec![Command::AddBody {
        shape: Shape::Box { half_extents: [20.0, 20.0, 0.5] },
        position: [0.0, 0.0, -0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 0.0,
        color: None,
        collides: true,
    }];
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                let mut jit = || rng.gen_range(-0.02f32..=0.02);
                let p = [i as f32 * 0.25 + jit(), j as f32 * 0.25 + jit(), 0.5 + k as f32 * 0.25 + jit()];
                let axis = [rng.gen_range(-1.0f32..1.0), rng.gen_range(-1.0f32..1.0), rng.gen_range(-1.0f32..1.0)];
                let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt().max(1e-6);
                let angle: f32 = rng.gen_range(0.0..std::f32::consts::TAU);
                let (s, c) = (angle / 2.0).sin_cos();
                cmds.push(Command::AddBody {
                    shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] },
                    position: p,
                    orientation: [axis[0] / n * s, axis[1] / n * s, axis[2] / n * s, c],
                    mass: 1.0,
                    color: None,
                    collides: true,
                });
            }
        }
    }
    cmds
}

/// create_simulation as the server records it today (under `engine::ENGINE_RULE`).
pub fn root(id: &str) -> Command {
    root_under(id, physics_mcp::engine::ENGINE_RULE)
}

/// create_simulation under the engine rule `rule` (rule 1: as recorded before rules were).
pub fn root_under(id: &str, rule: EngineRule) -> Command {
    let engine_rule = (rule != EngineRule::Upstream).then_some(rule);
    Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule }
}

/// The pile, built through `World::create` and `World::apply` as the server builds it.
pub fn pile_world() -> World {
    pile_world_under(physics_mcp::engine::ENGINE_RULE)
}

/// The pile in a world under the engine rule `rule`.
pub fn pile_world_under(rule: EngineRule) -> World {
    let (mut w, _) = World::create(&root_under("pile", rule)).unwrap();
    for c in pile_commands() {
        w.apply(&c, &mut |_| true);
    }
    w
}

fn yaw(a: f32) -> [f32; 4] {
    let (s, c) = (a / 2.0).sin_cos();
    [0.0, 0.0, s, c]
}

/// 64 free-floating two-link arms (multibodies) in 8 stacks of 8, each turned against the one
/// below, falling onto the ground and each other; every other arm's shoulder is velocity-driven.
pub fn arms_world() -> World {
    arms_world_under(physics_mcp::engine::ENGINE_RULE)
}

/// The 64 arms in a world under the engine rule `rule`.
pub fn arms_world_under(rule: EngineRule) -> World {
    let mut w = World::create(&root_under("arms", rule)).unwrap().0;
    w.apply(&raw_pile()[0], &mut |_| true);
    let urdf = std::fs::read(std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/two_link_arm.urdf")).unwrap();
    for s in 0..8 {
        for k in 0..8 {
            let n = s * 8 + k;
            let out = w.apply(
                &Command::LoadUrdf {
                    file_path: "two_link_arm.urdf".into(),
                    urdf: Blob::new(urdf.clone()),
                    meshes: Default::default(),
                    position: [(s % 4) as f32 * 1.2, (s / 4) as f32 * 1.2, 0.1 + 0.08 * k as f32],
                    orientation: yaw(0.7 * k as f32),
                    fixed_base: false,
                    continuous_limits_from_file: true,
                    revolute_prismatic_limits_from_file: true,
                    inertials_as_pybullet: true,
                    parsed: Default::default(),
                },
                &mut |_| true,
            ).to_value();
            let id = out["object_id"].as_u64().unwrap() as u32;
            if n % 2 == 0 {
                let motor = MotorSpec {
                    mode: ControlMode::VelocityControl,
                    target_position: 0.0,
                    target_velocity: if n % 4 == 0 { 2.0 } else { -2.0 },
                    force: Some(5.0),
                    position_gain: 0.1,
                    velocity_gain: 1.0,
                };
                w.apply(&Command::SetJointMotor { object_id: id, joint_index: 0, motor }, &mut |_| true);
            }
        }
    }
    w
}
