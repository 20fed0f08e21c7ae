//! Issue 3 benchmark (`cargo bench --bench time_machine`): on the 1000-box pile, with 20 vs
//! 20,000 further events — undo(1) latency; `Registry::load` of a saved file (the real
//! load_simulation path), with its rebuild part (`world_from_history`: MAC check, restore,
//! refold) also timed alone; log size and snapshot count. Prints `REPORT` lines (and the
//! ratios the issue targets).

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use physics_mcp::command::{Command, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::files::save_format::{world_from_history, SaveFile};
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::value::Args;
use rand::{Rng, SeedableRng};

fn pile(reg: &Registry, id: &str) {
    let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).unwrap();
    let s = reg.get(id).unwrap();
    let mut sim = lock_sim(&s);
    let (a, l) = (Args::new(), Limits::default());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261122);
    let ground = Command::AddBody {
        shape: Shape::Box { half_extents: [20.0, 20.0, 0.5] },
        position: [0.0, 0.0, -0.5],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 0.0,
        color: None,
        collides: true,
    };
    sim.change("add_box", &a, Ok(ground), &l, &mut |_| true).unwrap();
    for i in 0..1000 {
        let (x, y, z) = ((i % 10) as f32 * 0.25, ((i / 10) % 10) as f32 * 0.25, 0.5 + (i / 100) as f32 * 0.25);
        let mut j = || rng.gen_range(-0.02f32..=0.02);
        let p = [x + j(), y + j(), z + j()];
        let angle: f32 = rng.gen_range(0.0..std::f32::consts::TAU);
        let (sn, c) = (angle / 2.0).sin_cos();
        let cmd = Command::AddBody {
            shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] },
            position: p,
            orientation: [0.0, 0.0, sn, c],
            mass: 1.0,
            color: None,
            collides: true,
        };
        sim.change("add_box", &a, Ok(cmd), &l, &mut |_| true).unwrap();
    }
    sim.change("step_simulation", &a, Ok(Command::step(300)), &l, &mut |_| true).unwrap();
}

/// `n` further events: velocity changes on rotating bodies, a one-step advance every 100.
fn more_events(reg: &Registry, id: &str, n: u64) {
    let s = reg.get(id).unwrap();
    let mut sim = lock_sim(&s);
    let (a, l) = (Args::new(), Limits::default());
    for i in 0..n {
        let cmd = if i % 100 == 99 {
            Command::step(1)
        } else {
            let id = 1 + (i % 1000) as u32;
            Command::SetObjectVelocity { object_id: id, linear_velocity: Some([0.0, 0.0, 0.01 * (i % 7) as f32]), angular_velocity: None }
        };
        sim.change("op", &a, Ok(cmd), &l, &mut |_| true).unwrap();
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

struct Figures {
    events: u64,
    undo_ms: f64,
    /// `Registry::load` end to end.
    load_ms: f64,
    /// `world_from_history` alone: the rebuild part of `load_ms`.
    load_b_ms: f64,
    log_bytes: u64,
    snapshots: usize,
}

fn measure(n: u64) -> Figures {
    let dir = tempfile::tempdir().unwrap();
    let reg = Registry::open(common::config(dir.path()))
    .unwrap();
    pile(&reg, "pile");
    more_events(&reg, "pile", n);
    let s = reg.get("pile").unwrap();
    let mut sim = lock_sim(&s);
    let a = Args::new();
    let undo: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            sim.undo(&a, 1).unwrap();
            let ms = t.elapsed().as_secs_f64() * 1e3;
            sim.redo(&a, 1).unwrap();
            ms
        })
        .collect();
    let mut save_args = Args::new();
    save_args.insert("file_path".into(), serde_json::json!("bench.json"));
    sim.save(&save_args, &reg).unwrap();
    sim.flush();
    sim.storage().checkpoint().unwrap();
    let head = sim.log().head_seq();
    let events = sim.log().last_seq();
    let snapshots = sim.log().chain_snapshot_seqs(head).unwrap().len();
    let log_bytes = sim.storage().file_bytes();
    drop(sim);
    let path = reg.config().workspace.join("bench.json");
    let file: SaveFile = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let h = file.history.as_ref().unwrap();
    let want = lock_sim(&s).state_hash().to_string();
    let (mut load_ms, mut b_ms) = (Vec::new(), Vec::new());
    for round in 0..5 {
        // The whole of load_simulation as the server runs it: read, parse, MAC check,
        // restore, refold, cross-check, store the history in a new log, register it.
        let id = format!("loaded{round}");
        let t = Instant::now();
        let loaded = reg.load(&save_args, id.clone(), &mut |_, _| {}).unwrap();
        load_ms.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(loaded.state_hash, want);
        reg.destroy(&id).unwrap();
        // Its rebuild part alone (the same function load calls): MAC check, restore, refold.
        let t = Instant::now();
        let (world, _) = world_from_history(h, reg.mac_key(), reg.limits(), &mut |_, _| {}).unwrap();
        b_ms.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(world.state_hash(), want);
    }
    let (load_ms, load_b_ms) = (median(load_ms), median(b_ms));
    Figures { events, undo_ms: median(undo), load_ms, load_b_ms, log_bytes, snapshots }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let small = measure(20);
    let large = measure(20_000);
    for (name, f) in [("20 events", &small), ("20,000 events", &large)] {
        let bound = 100 + (f.events as f64).log2().ceil() as usize;
        println!(
            "REPORT pile + {name}: {} events in the log; undo(1) {:.1} ms; Registry::load {:.1} ms = (a) read/parse/check/store {:.1} ms + (b) rebuild {:.1} ms (medians of 5; (a) = load − (b), (b) timed alone); log {} bytes; {} snapshots on the chain (bound {bound})",
            f.events, f.undo_ms, f.load_ms, f.load_ms - f.load_b_ms, f.load_b_ms, f.log_bytes, f.snapshots
        );
    }
    println!(
        "REPORT ratios 20,000 vs 20 events: undo(1) {:.2}, load (b) {:.2} (targets <= 1.5); Registry::load {:.2}",
        large.undo_ms / small.undo_ms,
        large.load_b_ms / small.load_b_ms,
        large.load_ms / small.load_ms
    );
}
