//! Seeded property tests over random sequences of tool calls:
//! folding twice gives the same hashes; stopping (restart = snapshot + refold) at a random
//! point and continuing equals an uninterrupted run; undo k then redo k restores the hash; a
//! fork at seq s then the same calls reproduces the original's hashes; after every call the
//! kept (incremental) state hash equals one recomputed from nothing.
//!
//! The seed comes from `PHYSICS_SEED` (a decimal u64) or a fixed default; every failure prints
//! `seed=…` so it replays exactly: `PHYSICS_SEED=… cargo test --test properties`.
//!
//! Each property runs 64 random sequences by default (CI); `PHYSICS_MCP_SOAK=1` runs 1024.

use std::path::Path;

use physics_mcp::command::{Command, DynamicsChange, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry, SharedSim};
use physics_mcp::value::Args;
use proptest::prelude::*;
use proptest::test_runner::{Config as RunnerConfig, RngAlgorithm, TestRng, TestRunner};

/// One random tool call.
#[derive(Clone, Debug)]
enum Op {
    AddBox([f32; 3], f32),
    AddSphere([f32; 3]),
    Step(u64),
    Force(u32, [f32; 3]),
    Torque(u32, [f32; 3]),
    Pose(u32, [f32; 3]),
    Velocity(u32, [f32; 3]),
    Friction(u32, f32),
    Remove(u32),
    Undo(u64),
    Redo(u64),
}

fn xyz(r: f32) -> impl Strategy<Value = [f32; 3]> {
    [-r..r, -r..r, 0.2f32..2.0]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => (xyz(1.0), 0.0f32..3.0).prop_map(|(p, m)| Op::AddBox(p, m)),
        2 => xyz(1.0).prop_map(Op::AddSphere),
        4 => (1u64..40).prop_map(Op::Step),
        2 => (0u32..6, xyz(20.0)).prop_map(|(i, f)| Op::Force(i, f)),
        1 => (0u32..6, xyz(5.0)).prop_map(|(i, t)| Op::Torque(i, t)),
        1 => (0u32..6, xyz(1.0)).prop_map(|(i, p)| Op::Pose(i, p)),
        1 => (0u32..6, xyz(2.0)).prop_map(|(i, v)| Op::Velocity(i, v)),
        1 => (0u32..6, 0.0f32..1.0).prop_map(|(i, f)| Op::Friction(i, f)),
        1 => (0u32..6).prop_map(Op::Remove),
        1 => (1u64..4).prop_map(Op::Undo),
        1 => (1u64..4).prop_map(Op::Redo),
    ]
}

fn registry(dir: &Path) -> Registry {
    Registry::open(crate::common::config(dir))
    .expect("registry")
}

fn new_sim(reg: &Registry, id: &str) -> SharedSim {
    let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).expect("create");
    let sim = reg.get(id).expect("get");
    let ground = Command::AddBody {
        shape: Shape::Box { half_extents: [5.0, 5.0, 0.5] },
        position: [0.0, 0.0, -0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 0.0,
        color: None,
        collides: true,
    };
    lock_sim(&sim).change("add_box", &Args::new(), Ok(ground), &Limits::default(), &mut |_| true).expect("ground");
    sim
}

/// Applies one op (refusals are part of the behaviour) and returns the state hash after it,
/// having checked that the kept hash is the one a full recompute gives.
fn run(sim: &SharedSim, op: &Op) -> String {
    let hash = apply(sim, op);
    let s = lock_sim(sim);
    assert_eq!(s.world().state_hash(), s.world().state_hash_from_scratch(), "the kept hash drifted after {op:?}");
    assert_eq!(s.world().state_hash(), hash, "the recorded hash is the world's after {op:?}");
    hash
}

fn apply(sim: &SharedSim, op: &Op) -> String {
    let mut s = lock_sim(sim);
    let a = Args::new();
    let l = Limits::default();
    let ident = [0.0, 0.0, 0.0, 1.0];
    let cmd = match *op {
        Op::AddBox(position, mass) => Command::AddBody {
            shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] }, position, orientation: ident, mass, color: None,
            collides: true,
        },
        Op::AddSphere(position) => Command::AddBody {
            shape: Shape::Sphere { radius: 0.1 }, position, orientation: ident, mass: 1.0, color: None,
            collides: true,
        },
        Op::Step(steps) => Command::step(steps),
        Op::Force(object_id, force) => Command::ApplyForce { object_id, force, position: None, link_index: -1 },
        Op::Torque(object_id, torque) => Command::ApplyTorque { object_id, torque, link_index: -1 },
        Op::Pose(object_id, position) => Command::SetObjectPose { object_id, position, orientation: [0.0, 0.6, 0.0, 0.8] },
        Op::Velocity(object_id, v) => Command::SetObjectVelocity { object_id, linear_velocity: Some(v), angular_velocity: None },
        Op::Friction(object_id, f) => Command::ChangeDynamics {
            object_id, link_index: -1, change: DynamicsChange { lateral_friction: Some(f), ..Default::default() },
        },
        Op::Remove(object_id) => Command::RemoveObject { object_id },
        Op::Undo(k) => {
            let _ = s.undo(&a, k);
            return s.state_hash().to_string();
        }
        Op::Redo(k) => {
            let _ = s.redo(&a, k);
            return s.state_hash().to_string();
        }
    };
    let _ = s.change("op", &a, Ok(cmd), &l, &mut |_| true);
    s.state_hash().to_string()
}

/// Random sequences per property: enough by default that CI explores, many more on a soak run.
#[allow(clippy::disallowed_methods)] // a test reads its soak flag from the environment
fn cases() -> u32 {
    if std::env::var("PHYSICS_MCP_SOAK").is_ok_and(|v| v == "1") {
        1024
    } else {
        64
    }
}

#[allow(clippy::disallowed_methods)] // a test reads its seed from the environment
fn seeded_runner(cases: u32) -> (TestRunner, u64) {
    let seed: u64 = std::env::var("PHYSICS_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(20261122);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = RunnerConfig { cases, failure_persistence: None, ..RunnerConfig::default() };
    (TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &bytes)), seed)
}

fn check(name: &str, body: impl Fn(Vec<Op>, usize) -> Result<(), TestCaseError>) {
    let (mut runner, seed) = seeded_runner(cases());
    let strategy = (proptest::collection::vec(op(), 4..24), any::<prop::sample::Index>());
    if let Err(e) = runner.run(&strategy, |(ops, at)| body(ops.clone(), at.index(ops.len()))) {
        panic!("{name} failed with seed={seed} (rerun: PHYSICS_SEED={seed}): {e}");
    }
}

#[test]
fn folding_twice_gives_the_same_hashes_and_a_refold_of_the_log_agrees() {
    check("fold twice", |ops, _| {
        let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let (r1, r2) = (registry(d1.path()), registry(d2.path()));
        let (a, b) = (new_sim(&r1, "a"), new_sim(&r2, "b"));
        let ha: Vec<String> = ops.iter().map(|o| run(&a, o)).collect();
        let hb: Vec<String> = ops.iter().map(|o| run(&b, o)).collect();
        prop_assert_eq!(&ha, &hb);
        // A fresh process folding the log (recovery) reaches the same state.
        drop((a, b));
        drop(r1);
        let r1 = registry(d1.path());
        let again = lock_sim(&r1.get("a").unwrap()).state_hash().to_string();
        prop_assert_eq!(Some(&again), ha.last());
        Ok(())
    });
}

#[test]
fn stopping_at_a_random_point_and_continuing_equals_an_uninterrupted_run() {
    check("restart mid-run", |ops, at| {
        let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let r1 = registry(d1.path());
        let a = new_sim(&r1, "s");
        let whole: Vec<String> = ops.iter().map(|o| run(&a, o)).collect();
        let r2 = registry(d2.path());
        let b = new_sim(&r2, "s");
        let mut parts: Vec<String> = ops[..at].iter().map(|o| run(&b, o)).collect();
        drop(b);
        drop(r2); // "restart": the next registry recovers from snapshot + refold
        let r2 = registry(d2.path());
        let b = r2.get("s").unwrap();
        parts.extend(ops[at..].iter().map(|o| run(&b, o)));
        prop_assert_eq!(whole, parts);
        Ok(())
    });
}

#[test]
fn undo_k_then_redo_k_restores_the_hash() {
    check("undo/redo", |ops, _| {
        let d = tempfile::tempdir().unwrap();
        let r = registry(d.path());
        let s = new_sim(&r, "s");
        for o in &ops {
            run(&s, o);
        }
        let mut sim = lock_sim(&s);
        let before = sim.state_hash().to_string();
        let available = sim.log().chain_to(sim.log().head_seq()).unwrap().len() as u64 - 1;
        for k in 1..=available.min(5) {
            sim.undo(&Args::new(), k).map_err(TestCaseError::fail)?;
            sim.redo(&Args::new(), k).map_err(TestCaseError::fail)?;
            prop_assert_eq!(sim.state_hash(), before.as_str());
            prop_assert_eq!(sim.world().state_hash(), before.clone());
        }
        Ok(())
    });
}

#[test]
fn a_fork_at_seq_s_then_the_same_calls_reproduces_the_originals_hashes() {
    check("fork", |ops, at| {
        let d = tempfile::tempdir().unwrap();
        let r = registry(d.path());
        let s = new_sim(&r, "orig");
        for o in &ops[..at] {
            run(&s, o);
        }
        let head = lock_sim(&s).log().head_seq();
        // Undo/redo may legitimately differ after a fork (a fork cannot undo past its own
        // root and starts with nothing to redo), so the continuation is made of changes.
        let cont: Vec<Op> = ops[at..].iter().filter(|o| !matches!(o, Op::Undo(_) | Op::Redo(_))).cloned().collect();
        let rest: Vec<String> = cont.iter().map(|o| run(&s, o)).collect();
        r.fork("orig", Some(head), ("fork".into(), None), &Args::new()).map_err(TestCaseError::fail)?;
        let f = r.get("fork").unwrap();
        let again: Vec<String> = cont.iter().map(|o| run(&f, o)).collect();
        prop_assert_eq!(rest, again);
        Ok(())
    });
}

#[test]
fn save_then_load_then_continue_equals_continue() {
    check("save/load", |ops, at| {
        let d = tempfile::tempdir().unwrap();
        let r = registry(d.path());
        let s = new_sim(&r, "orig");
        for o in &ops[..at] {
            run(&s, o);
        }
        let mut args = Args::new();
        args.insert("file_path".into(), serde_json::json!("prop/save.json"));
        lock_sim(&s).save(&args, &r).map_err(TestCaseError::fail)?;
        r.load(&args, "loaded".into(), &mut |_, _| {}).map_err(TestCaseError::fail)?;
        let l = r.get("loaded").unwrap();
        let (hl, hs) = (lock_sim(&l).state_hash().to_string(), lock_sim(&s).state_hash().to_string());
        prop_assert_eq!(hl, hs);
        let cont: Vec<Op> = ops[at..].iter().filter(|o| !matches!(o, Op::Undo(_) | Op::Redo(_))).cloned().collect();
        let a: Vec<String> = cont.iter().map(|o| run(&s, o)).collect();
        let b: Vec<String> = cont.iter().map(|o| run(&l, o)).collect();
        prop_assert_eq!(a, b);
        Ok(())
    });
}
