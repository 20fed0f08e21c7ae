//! One simulation may step on several threads (rapier's `parallel`, the
//! server's `--threads N`) because every state hash is bit-identical to the single-threaded
//! build for 1, 2 and 4 threads, snapshot → restore → continue included, with the pool handed
//! back after the restore.
//!
//! Three scenes — the 1000-box pile (benches/pile.rs), 64 free two-link URDF arms falling in
//! stacks (multibodies in contact), 64 revolute box pairs plus spherical, fixed and prismatic
//! chains (impulse joints) — are stepped in chunks, hashing after each, snapshotted half way,
//! restored and continued, and compared with `tests/fixtures/threads_reference.json`: the
//! hashes the single-threaded build (before `parallel` was enabled) recorded. Every `replays/`
//! log is refolded on 1, 2 and 4 threads too. A divergence is reported by scene, thread count
//! and the first hash that differs.
//!
//! The reference was recorded before engine rules existed, so the scenes are built under rule
//! 1 for it (`engine::EngineRule::Upstream`, whose arithmetic the vendored rapier keeps bit for
//! bit). Rules 2 and 3 change only multibodies' arithmetic, so each rule's own reference
//! (`tests/fixtures/threads_reference_rule2.json`, `threads_reference_rule3.json`, recorded by
//! the build that introduced the rule and never re-recorded either) holds the arms scene, on 1,
//! 2 and 4 threads alike. Rule 4 changes only how the step's one-step forces reach rapier, so
//! its reference (`threads_reference_rule4.json`) is of the arms with half of them driven by
//! torque control.

// A test may read its fixture and the environment; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../../benches/pile.rs"]
mod pile;

use std::collections::BTreeMap;
use std::path::PathBuf;

use physics_mcp::command::{Command, ConstraintSpec, ConstraintType, Shape};
use physics_mcp::engine::EngineRule;
use physics_mcp::world::World;

/// Steps per chunk; a hash is taken after each.
const CHUNK: u64 = 50;

/// One scene: how it is built and how many steps it runs.
struct Scene {
    name: &'static str,
    build: fn(EngineRule) -> World,
    steps: u64,
}

fn scenes() -> Vec<Scene> {
    vec![
        Scene { name: "pile_1000_boxes", build: pile::pile_world_under, steps: 500 },
        Scene { name: "urdf_arms_64", build: pile::arms_world_under, steps: 400 },
        Scene { name: "constraints_64_pairs_and_chains", build: constraints, steps: 400 },
    ]
}

fn step(w: &mut World, n: u64) {
    w.apply(&Command::step(n), &mut |_| true);
}

fn apply(w: &mut World, c: Command) -> serde_json::Value {
    w.apply(&c, &mut |_| true).to_value()
}

fn ground(w: &mut World) {
    apply(
        w,
        Command::AddBody {
            shape: Shape::Box { half_extents: [20.0, 20.0, 0.5] },
            position: [0.0, 0.0, -0.5],
            orientation: [0.0, 0.0, 0.0, 1.0],
            mass: 0.0,
            color: None,
            collides: true,
        },
    );
}

fn body(w: &mut World, half: [f32; 3], p: [f32; 3], mass: f32) -> u32 {
    let out = apply(
        w,
        Command::AddBody {
            shape: Shape::Box { half_extents: half },
            position: p,
            orientation: [0.0, 0.0, 0.0, 1.0],
            mass,
            color: None,
            collides: true,
        },
    );
    out["object_id"].as_u64().unwrap() as u32
}

fn joint(w: &mut World, parent: u32, child: Option<u32>, kind: ConstraintType, axis: [f32; 3], pf: [f32; 3], cf: [f32; 3]) {
    let spec = ConstraintSpec {
        parent_id: parent,
        child_id: child,
        joint_type: kind,
        joint_axis: axis,
        parent_frame_position: pf,
        child_frame_position: cf,
        parent_frame_orientation: [0.0, 0.0, 0.0, 1.0],
        child_frame_orientation: [0.0, 0.0, 0.0, 1.0],
    };
    let out = apply(w, Command::CreateConstraint { spec });
    assert!(out.get("constraint_id").is_some(), "{out}");
}

/// 64 box pairs joined by revolute constraints tumbling onto the ground in a heap, and 8
/// chains of 8 boxes hanging from the world by spherical joints, linked by fixed, spherical
/// and prismatic constraints, swinging into the heap.
fn constraints(rule: EngineRule) -> World {
    let mut w = World::create(&pile::root_under("constraints", rule)).unwrap().0;
    ground(&mut w);
    for n in 0..64u32 {
        let (i, j, k) = ((n % 4) as f32, ((n / 4) % 4) as f32, (n / 16) as f32);
        let p = [i * 0.35, j * 0.35, 0.3 + k * 0.3];
        let a = body(&mut w, [0.1, 0.05, 0.05], p, 1.0);
        let b = body(&mut w, [0.1, 0.05, 0.05], [p[0] + 0.2, p[1], p[2] + 0.05], 0.5);
        let axis = if n % 2 == 0 { [0.0, 1.0, 0.0] } else { [0.0, 0.0, 1.0] };
        joint(&mut w, a, Some(b), ConstraintType::Revolute, axis, [0.1, 0.0, 0.025], [-0.1, 0.0, -0.025]);
    }
    for c in 0..8u32 {
        let top = [-0.5 + 0.3 * c as f32, 1.8, 1.6];
        let mut prev = body(&mut w, [0.04, 0.04, 0.04], top, 0.3);
        joint(&mut w, prev, None, ConstraintType::Spherical, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [top[0], top[1] + 0.1, top[2]]);
        for k in 1..8u32 {
            let next = body(&mut w, [0.04, 0.04, 0.04], [top[0], top[1] - 0.12 * k as f32, top[2]], 0.3);
            let kind = match (c + k) % 3 {
                0 => ConstraintType::Fixed,
                1 => ConstraintType::Spherical,
                _ => ConstraintType::Prismatic,
            };
            joint(&mut w, prev, Some(next), kind, [0.0, 1.0, 0.0], [0.0, -0.06, 0.0], [0.0, 0.06, 0.0]);
            prev = next;
        }
    }
    w
}

/// How a world steps: on the stepping thread's pool (`None`) or on a pool of its own, handed
/// back after every restore.
type Pool = Option<std::sync::Arc<rapier3d::rayon::ThreadPool>>;

fn with_pool(w: &mut World, pool: &Pool) {
    w.set_thread_pool(pool.clone());
    // (Without a pool of its own the count is the process's, which another test here changes.)
    if let Some(p) = pool {
        assert_eq!(w.num_threads(), p.current_num_threads());
    }
}

fn pool_of(threads: usize) -> std::sync::Arc<rapier3d::rayon::ThreadPool> {
    std::sync::Arc::new(rapier3d::rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap())
}

/// The scene's hashes: after building, after every chunk, the snapshot's content hash at the
/// half-way chunk, then after every chunk continued from that snapshot restored. Under state
/// hash v1, which the reference was recorded with (its snapshots are then written as then).
fn run(scene: &Scene, pool: &Pool) -> Vec<String> {
    run_under(scene, pool, EngineRule::Upstream)
}

/// [`run`] with the scene built under the engine rule `rule`.
fn run_under(scene: &Scene, pool: &Pool, rule: EngineRule) -> Vec<String> {
    let mut w = (scene.build)(rule).with_hash_rules(physics_mcp::world::HashRules::V1);
    with_pool(&mut w, pool);
    let mut hashes = vec![format!("built {}", w.state_hash())];
    let chunks = scene.steps / CHUNK;
    let mut snapshot = None;
    for c in 1..=chunks {
        step(&mut w, CHUNK);
        hashes.push(format!("step {} {}", c * CHUNK, w.state_hash()));
        if c == chunks / 2 {
            let bytes = w.snapshot();
            hashes.push(format!("snapshot {} {}", c * CHUNK, physics_mcp::digest::content_hash(&bytes)));
            snapshot = Some(bytes);
        }
    }
    let mut r = World::restore(w.simulation_id(), false, &snapshot.unwrap()).unwrap();
    with_pool(&mut r, pool);
    for c in chunks / 2 + 1..=chunks {
        step(&mut r, CHUNK);
        hashes.push(format!("restored step {} {}", c * CHUNK, r.state_hash()));
    }
    hashes
}

fn reference_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/threads_reference.json")
}

fn reference() -> BTreeMap<String, Vec<String>> {
    serde_json::from_slice(&std::fs::read(reference_path()).expect("tests/fixtures/threads_reference.json")).unwrap()
}

/// The first index where `a` and `b` differ, if any.
fn first_difference(a: &[String], b: &[String]) -> Option<usize> {
    (0..a.len().max(b.len())).find(|&i| a.get(i) != b.get(i))
}

/// Without a pool of its own a world steps on the test thread's stepping pool (of the process's
/// count: 1, or what the replays test below sets meanwhile) and reproduces the reference: hashes
/// recorded by the build before rapier's `parallel` was enabled (commit 07251e2), the
/// single-threaded engine the `replays/` logs were made by. The file is never re-recorded: it is
/// what later builds are measured against.
#[test]
fn the_reference_hashes_of_the_single_threaded_build_are_reproduced() {
    let now: BTreeMap<String, Vec<String>> = scenes().iter().map(|s| (s.name.to_string(), run(s, &None))).collect();
    let recorded = reference();
    for (name, hashes) in &now {
        let expected = &recorded[name];
        if let Some(i) = first_difference(expected, hashes) {
            panic!("{name}: this build differs from the reference at {:?} vs {:?}", expected.get(i), hashes.get(i));
        }
        // The restore → continue part equals the uninterrupted run.
        for h in hashes.iter().filter(|h| h.starts_with("restored ")) {
            assert!(hashes.contains(&h["restored ".len()..].to_string()), "{name}: {h} differs from the uninterrupted run");
        }
    }
}

/// Every thread count against the single-threaded build's reference and against its own
/// one-thread run; prints every divergence (the report) and fails if there is any.
#[test]
fn every_thread_count_reproduces_the_single_threaded_build() {
    let recorded = reference();
    let mut divergences = Vec::new();
    for scene in scenes() {
        let mut one_thread = None;
        for threads in [1usize, 2, 4] {
            let hashes = run(&scene, &Some(pool_of(threads)));
            let expected = &recorded[scene.name];
            let mut line = format!("THREADS {} threads={threads}: ", scene.name);
            match first_difference(expected, &hashes) {
                None => line += "identical to the default build",
                Some(i) => {
                    line += &format!("differs from the default build first at {:?} (expected {:?})", hashes.get(i), expected.get(i));
                    divergences.push(line.clone());
                }
            }
            let one: &Vec<String> = one_thread.get_or_insert_with(|| hashes.clone());
            if let Some(i) = first_difference(one, &hashes) {
                line += &format!("; differs from 1 thread of this build first at {:?}", hashes.get(i));
                divergences.push(format!("{} threads={threads} vs 1 thread at {:?}", scene.name, hashes.get(i)));
            }
            for h in hashes.iter().filter(|h| h.starts_with("restored ")) {
                if !hashes.contains(&h["restored ".len()..].to_string()) {
                    line += &format!("; restore → continue differs at {h:?}");
                    divergences.push(format!("{} threads={threads}: restore → continue differs at {h:?}", scene.name));
                    break;
                }
            }
            println!("{line}");
        }
    }
    assert!(divergences.is_empty(), "{} divergences:\n{}", divergences.len(), divergences.join("\n"));
}

/// Every `replays/` log refolds to its recorded hashes with 1, 2 and 4 threads per step
/// (`set_step_threads`, what `--threads` sets). The only test here that sets the count, and
/// the others' worlds have pools of their own, which win over it.
#[test]
fn every_replay_log_refolds_on_1_2_and_4_threads() {
    let logs = crate::common::recorded_logs();
    assert!(logs.len() >= 6, "replays/ holds {} logs", logs.len());
    for threads in [1usize, 2, 4] {
        physics_mcp::world::set_step_threads(threads);
        for log in &logs {
            let summary = physics_mcp::log::replay::replay(log, None, |_, _| {})
                .unwrap_or_else(|e| panic!("{} does not refold on {threads} threads: {e}", log.display()));
            assert!(summary.events > 0, "{}: {summary:?}", log.display());
        }
    }
    physics_mcp::world::set_step_threads(1);
}

/// The scene rules 2 and 3 change (multibodies) and each rule's reference, recorded by the build
/// that introduced the rule: written when missing (then the test says so and passes), never
/// re-recorded.
fn rule_reference_path(rule: EngineRule) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/fixtures/threads_reference_rule{}.json", rule as u32))
}

/// Rule 2 (the tree-sparse multibody path) is as thread-independent as rule 1: the 64 arms on
/// 1, 2 and 4 threads, snapshot → restore → continue included, reproduce its recorded
/// reference, and they differ from rule 1's (the rule is in effect).
#[test]
fn rule_2_reproduces_its_reference_on_1_2_and_4_threads() {
    rule_reproduces_its_reference(EngineRule::TreeMultibody);
}

/// Rule 3 (rule 2 with mass matrices factorised once per step) likewise, against its own
/// reference (`threads_reference_rule3.json`), and it differs from rules 1 and 2.
#[test]
fn rule_3_reproduces_its_reference_on_1_2_and_4_threads() {
    rule_reproduces_its_reference(EngineRule::TreeMultibodyPerStep);
}

/// Rule 4 (rule 3 with the step's one-step forces leaving awake bodies unmarked) likewise,
/// against `threads_reference_rule4.json`, on the arms with every other arm's first joint under
/// torque control instead of a velocity motor (the forces rule 4 changes). The same scene under
/// rule 3 ends elsewhere.
#[test]
fn rule_4_reproduces_its_reference_on_1_2_and_4_threads() {
    rule_reproduces_its_reference(EngineRule::QuietStepForces);
    let scene = arms_scene(EngineRule::QuietStepForces);
    let rule3 = run_under(&scene, &Some(pool_of(1)), EngineRule::TreeMultibodyPerStep);
    let rule4 = run_under(&scene, &Some(pool_of(1)), EngineRule::QuietStepForces);
    assert_ne!(rule3.last(), rule4.last(), "rule 4 steps the torque-driven arms exactly as rule 3: the rule is not in effect");
}

/// The 64 arms (`pile::arms_world_under`), with the odd ones' first joint under torque control.
fn torque_driven_arms(rule: EngineRule) -> World {
    use physics_mcp::command::{ControlMode, MotorSpec};
    let mut w = pile::arms_world_under(rule);
    let arms: Vec<u32> = w.objects().filter(|(id, _)| w.robot(*id).is_some()).map(|(id, _)| id).collect();
    for (n, id) in arms.into_iter().enumerate().filter(|(n, _)| n % 2 == 1) {
        let force = if n % 4 == 1 { 0.4 } else { -0.4 };
        let motor = MotorSpec { mode: ControlMode::TorqueControl, target_position: 0.0, target_velocity: 0.0, force: Some(force), position_gain: 0.1, velocity_gain: 1.0 };
        apply(&mut w, Command::SetJointMotor { object_id: id, joint_index: 0, motor });
    }
    w
}

/// The arms scene a rule's reference holds: rule 4's drives half of them by torque control.
fn arms_scene(rule: EngineRule) -> Scene {
    let scene = scenes().into_iter().find(|s| s.name == "urdf_arms_64").unwrap();
    match rule.quiet_step_forces() {
        true => Scene { build: torque_driven_arms, ..scene },
        false => scene,
    }
}

fn rule_reproduces_its_reference(rule: EngineRule) {
    let scene = arms_scene(rule);
    let path = rule_reference_path(rule);
    let runs: Vec<Vec<String>> = [1usize, 2, 4].iter().map(|t| run_under(&scene, &Some(pool_of(*t)), rule)).collect();
    for (hashes, threads) in runs.iter().zip([1, 2, 4]) {
        if let Some(i) = first_difference(&runs[0], hashes) {
            panic!("{rule:?} on {threads} threads differs from 1 thread at {:?} vs {:?}", hashes.get(i), runs[0].get(i));
        }
        for h in hashes.iter().filter(|h| h.starts_with("restored ")) {
            assert!(hashes.contains(&h["restored ".len()..].to_string()), "{rule:?}, {threads} threads: {h} differs from the uninterrupted run");
        }
    }
    // Rule 4's scene is not the one rules 1 and 2 recorded: its own test compares rule 3 on it.
    if !rule.quiet_step_forces() {
        let rule1 = &reference()[scene.name];
        assert_ne!(rule1.last(), runs[0].last(), "{rule:?} steps the arms exactly as rule 1: the rule is not in effect");
    }
    if rule == EngineRule::TreeMultibodyPerStep {
        let rule2: BTreeMap<String, Vec<String>> = serde_json::from_slice(&std::fs::read(rule_reference_path(EngineRule::TreeMultibody)).unwrap()).unwrap();
        assert_ne!(rule2[scene.name].last(), runs[0].last(), "{rule:?} steps the arms exactly as rule 2: the rule is not in effect");
    }
    let now = BTreeMap::from([(scene.name.to_string(), runs[0].clone())]);
    match std::fs::read(&path) {
        Ok(bytes) => {
            let recorded: BTreeMap<String, Vec<String>> = serde_json::from_slice(&bytes).unwrap();
            if let Some(i) = first_difference(&recorded[scene.name], &runs[0]) {
                panic!("{rule:?} differs from its reference at {:?} vs {:?}", runs[0].get(i), recorded[scene.name].get(i));
            }
        }
        Err(_) => {
            std::fs::write(&path, serde_json::to_string_pretty(&now).unwrap() + "\n").unwrap();
            println!("RECORDED {}", path.display());
        }
    }
}
