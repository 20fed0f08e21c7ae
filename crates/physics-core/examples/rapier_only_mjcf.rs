//! A rapier-only reproduction: Gymnasium's MJCF models stepped by rapier3d alone,
//! loaded by rapier3d-mjcf's own loader, with no physics-mcp code (no World, no event log, no
//! motors, hooks or observers of ours) — so its ms/step, next to `cargo bench --bench mjcf`'s,
//! shows what the engine costs by itself, and its callgrind profile shows where.
//!
//! The world is what the loader gives, with the settings physics-mcp uses where they change the
//! cost: multibody joints (reduced coordinates), gravity −9.81 along z, the model's own
//! `<option timestep>` (MuJoCo's 0.002 s when absent), rapier's default integration parameters
//! (4 solver iterations = 4 substeps per step), one thread, no joint motors and no joint
//! springs (physics-mcp simulates neither: `stiffness` is in `ignored`). What differs from
//! physics-mcp changes which contacts are made, not the multibody work: the floor is the crate's half-space instead of
//! our thin box, contacts follow the crate's symmetric contype/conaffinity rule, and jointless
//! top-level bodies are not merged into the world. ant, pusher, walker2d and inverted_pendulum
//! cost more here than in physics-mcp (not looked into further), while half_cheetah, hopper, humanoid,
//! reacher and swimmer cost the same (docs/benchmarks.md "MJCF models").
//!
//! Two environment variables change the engine's settings for an experiment (docs/benchmarks.md
//! item 8): `RAPIER_ONLY_PER_STEP=1` computes multibodies under engine rule 3's
//! `TreeSparsePerStep` instead of rule 1's `Dense`, and `RAPIER_ONLY_SUBSTEPS=N` takes N substeps a
//! step (`num_solver_iterations`) instead of rapier's 4.
//!
//! ```sh
//! cargo run --release -p physics-core --example rapier_only_mjcf -- [steps] [runs] [model …]
//! valgrind --tool=callgrind --toggle-collect='*PhysicsWorld::step*' \
//!   target/release/examples/rapier_only_mjcf 200 1 half_cheetah
//! ```

// A benchmark reads the clock and files; physics-core's bans are for the world, not this.
#![allow(clippy::disallowed_methods, clippy::disallowed_types)]

use std::path::Path;
use std::time::Instant;

use rapier3d::prelude::*;
use rapier3d_mjcf::{MjcfLoaderOptions, MjcfMultibodyOptions, MjcfRobot};

/// Gymnasium's MuJoCo models: the list the physics-mcp benchmark and rest test use (a list of
/// fixture names, no physics-mcp code).
#[path = "../../../tests/common/gymnasium.rs"]
#[allow(dead_code)]
mod gymnasium;
use gymnasium::MODELS;

/// A fresh rapier world holding the model, and the model's timestep.
fn world(model: &str) -> (PhysicsWorld, f32) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/fixtures/mjcf").join(format!("{model}.xml"));
    let options = MjcfLoaderOptions { skip_plane_geoms: false, disable_joint_motors: true, ..MjcfLoaderOptions::default() };
    let (robot, parsed) = MjcfRobot::from_file(&path, options).expect("the model loads");
    let mut w = PhysicsWorld { gravity: Vector::new(0.0, 0.0, -9.81), ..Default::default() };
    let dt = parsed.option.timestep as f32;
    w.integration_parameters.dt = dt;
    if std::env::var_os("RAPIER_ONLY_PER_STEP").is_some() {
        w.integration_parameters.multibody_dynamics = rapier3d::dynamics::MultibodyDynamics::TreeSparsePerStep;
    }
    if let Some(n) = std::env::var("RAPIER_ONLY_SUBSTEPS").ok().and_then(|n| n.parse().ok()) {
        w.integration_parameters.num_solver_iterations = n;
    }
    robot.insert_using_multibody_joints(
        &mut w.bodies,
        &mut w.colliders,
        &mut w.multibody_joints,
        &mut w.impulse_joints,
        MjcfMultibodyOptions::SKIP_JOINT_MOTORS | MjcfMultibodyOptions::SKIP_JOINT_SPRINGS,
    );
    (w, dt)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps: u32 = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let runs: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(7);
    let named: Vec<&str> = args.iter().skip(2).map(String::as_str).collect();
    let pool = rapier3d::rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("one thread");
    for model in MODELS.iter().filter(|m| named.is_empty() || named.contains(m)) {
        let mut per_step = Vec::new();
        let mut dt = 0.0;
        for _ in 0..runs {
            let (mut w, model_dt) = world(model);
            dt = model_dt;
            let t = Instant::now();
            pool.install(|| (0..steps).for_each(|_| w.step()));
            per_step.push(t.elapsed().as_secs_f64() * 1e3 / f64::from(steps));
        }
        per_step.sort_by(f64::total_cmp);
        println!(
            "REPORT rapier-only {model} step at {dt} s: {:.4} ms/step (min {:.4}, {steps} steps, {runs} runs)",
            per_step[per_step.len() / 2],
            per_step[0]
        );
    }
}
