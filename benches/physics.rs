//! Issue 2 benchmarks (`cargo bench`): pile stepping, MCP overhead, get_object_state latency,
//! snapshot/restore phases, log size, and --sync normal vs full.
//!
//! Criterion measures the in-process timings; the HTTP figures come from the real binary
//! (release) driven by rmcp's client, and percentiles are printed as `REPORT` lines.

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "pile.rs"]
mod pile;

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use physics_mcp::command::{Command, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::Sim;
use physics_mcp::log::sqlite::{Event, Kind, Log, SyncMode};
use physics_mcp::log::EventLog;
use physics_mcp::value::Args;
use physics_mcp::world::World;
use pile::{pile_commands, pile_world, raw_pile, root};
use serde_json::{json, Value};

/// How many times the pile's steps 100–400 are run for its median ms/step.
const PILE_RUNS: usize = 5;

fn step(w: &mut World, n: u64) {
    w.apply(&Command::step(n), &mut |_| true);
}

fn bench_pile_steps(c: &mut Criterion) {
    let mut g = c.benchmark_group("pile_1000_boxes");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    {
        let mut w = pile_world();
        step(&mut w, 100);
        let snap = w.snapshot();
        let name = "steps_100_to_400";
        g.bench_function(name, |b| {
            b.iter_batched(
                || World::restore("pile", false, &snap).unwrap(),
                |mut w| step(&mut w, 300),
                BatchSize::PerIteration,
            )
        });
        // Criterion's table aside, a plain figure: the median of several identical runs (one
        // run is at the mercy of whatever else the machine does at that moment).
        let runs: Vec<f64> = (0..PILE_RUNS)
            .map(|_| {
                let mut w = World::restore("pile", false, &snap).unwrap();
                let t = Instant::now();
                step(&mut w, 300);
                t.elapsed().as_secs_f64() * 1e3 / 300.0
            })
            .collect();
        let mut sorted = runs.clone();
        sorted.sort_by(f64::total_cmp);
        println!(
            "REPORT pile {name}: {:.3} ms/step (median of {PILE_RUNS} runs of 300 steps; min {:.3}, max {:.3})",
            percentile(&sorted, 0.5), sorted[0], sorted[sorted.len() - 1]
        );
    }
    g.finish();
}

fn args(v: Value) -> Args {
    v.as_object().cloned().unwrap_or_default()
}

/// A Sim in `dir` holding the pile, built through `Sim::change` like the server does.
fn pile_sim(dir: &std::path::Path, name: &str, sync: SyncMode) -> Sim {
    let (mut sim, _) = Sim::create(&dir.join(format!("{name}.sqlite")), "create_simulation", root(name), &Args::new(), sync).unwrap();
    let limits = Limits::default();
    for c in pile_commands() {
        sim.change("add_box", &Args::new(), Ok(c), &limits, &mut |_| true).unwrap();
    }
    sim
}

fn bench_snapshot_restore(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut w = pile_world();
    step(&mut w, 300);
    let snap = w.snapshot();
    let hash = physics_mcp::digest::content_hash(&snap);
    let mut log = Log::create(&dir.path().join("snap.sqlite"), "snap", SyncMode::Normal).unwrap();
    let mut g = c.benchmark_group("snapshot_1000_bodies");
    g.sample_size(20);
    g.bench_function("serialise", |b| b.iter(|| w.snapshot()));
    g.bench_function("hash", |b| b.iter(|| physics_mcp::digest::content_hash(&snap)));
    let mut seq = 0u64;
    g.bench_function("commit", |b| {
        b.iter(|| {
            seq += 1;
            let e = Event::blank(seq, Kind::Change, "bench", "{}".into());
            log.append(&[e], seq, &[(seq, &snap, &hash)]).unwrap();
        })
    });
    // As snapshots happen in use: one every few hundred events, so the background checkpoint
    // of the previous one has finished. Only the commit itself is timed.
    g.bench_function("commit_after_checkpoint", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                std::thread::sleep(Duration::from_millis(60));
                seq += 1;
                let e = Event::blank(seq, Kind::Change, "bench", "{}".into());
                let t = Instant::now();
                log.append(&[e], seq, &[(seq, &snap, &hash)]).unwrap();
                total += t.elapsed();
            }
            total
        })
    });
    g.bench_function("restore_read", |b| b.iter(|| log.snapshot_at(1).unwrap()));
    g.bench_function("restore_verify", |b| b.iter(|| physics_mcp::digest::content_hash(&snap) == hash));
    g.bench_function("restore_deserialise", |b| b.iter(|| World::restore("pile", false, &snap).unwrap()));
    g.finish();
    println!("REPORT snapshot of 1000 bodies after 300 steps: {} bytes", snap.len());
}

fn bench_log_and_sync(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::default();
    let mut g = c.benchmark_group("commit_state_changing_event");
    g.sample_size(30);
    for sync in [SyncMode::Normal, SyncMode::Full] {
        let name = format!("{sync:?}").to_lowercase();
        let (mut sim, _) = Sim::create(&dir.path().join(format!("sync-{name}.sqlite")), "create_simulation", root(&name), &Args::new(), sync).unwrap();
        let a = args(json!({"object_id": 0, "linear_velocity": [1, 0, 0]}));
        sim.change("add_box", &Args::new(), Ok(pile_commands().remove(1)), &limits, &mut |_| true).unwrap();
        g.bench_function(format!("set_object_velocity_sync_{name}"), |b| {
            b.iter(|| {
                let cmd = Command::SetObjectVelocity { object_id: 0, linear_velocity: Some([1.0, 0.0, 0.0]), angular_velocity: None };
                sim.change("set_object_velocity", &a, Ok(cmd), &limits, &mut |_| true).unwrap()
            })
        });
    }
    g.finish();
    // Log bytes per 1000 events: 500 state-changing (force, then 1 step) and 500 reads, small sim.
    let (mut sim, _) = Sim::create(&dir.path().join("size.sqlite"), "create_simulation", root("size"), &Args::new(), SyncMode::Normal).unwrap();
    sim.change("add_box", &Args::new(), Ok(pile_commands().remove(1)), &limits, &mut |_| true).unwrap();
    sim.storage().checkpoint().unwrap();
    let before = sim.storage().file_bytes();
    // Each event is logged under its own tool name with the arguments a client would send,
    // as the server logs it: the log's size depends on both.
    let force = args(json!({"sim_id": "size", "object_id": 0, "force": [1, 0, 0]}));
    let one_step = args(json!({"sim_id": "size", "steps": 1}));
    let state = args(json!({"sim_id": "size", "object_id": 0}));
    for i in 0..500 {
        let (tool, a, cmd) = if i % 2 == 0 {
            ("apply_force", &force, Command::ApplyForce { object_id: 0, force: [1.0, 0.0, 0.0], position: None, link_index: -1 })
        } else {
            ("step_simulation", &one_step, Command::step(1))
        };
        sim.change(tool, a, Ok(cmd), &limits, &mut |_| true).unwrap();
        sim.read("get_object_state", &state, |s| Ok(s.world().object_state(0))).unwrap();
    }
    sim.flush();
    sim.storage().checkpoint().unwrap();
    let snaps = sim.log().snapshot_seqs().unwrap().len();
    println!(
        "REPORT log bytes per 1000 events (250 apply_force + 250 step_simulation(1) + 500 get_object_state, {snaps} snapshots of a 1-body world included): {}",
        sim.storage().file_bytes().saturating_sub(before)
    );
}

/// Sequential get_object_state round trips on one session (the first 200 warm up); prints
/// p50/p99 under `label`.
fn latency(rt: &tokio::runtime::Runtime, client: &common::Client, label: &str) {
    let sim = rt.block_on(client.new_sim(json!({})));
    rt.block_on(client.ground(&sim));
    rt.block_on(client.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})));
    let q = json!({"sim_id": sim, "object_id": 1});
    let mut lat = Vec::new();
    rt.block_on(async {
        for i in 0..3000 {
            let t = Instant::now();
            client.call("get_object_state", q.clone()).await;
            if i >= 200 {
                lat.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
    });
    lat.sort_by(|a, b| a.total_cmp(b));
    println!(
        "REPORT get_object_state over HTTP (rmcp client on a {label} runtime, stateful, sequential, n={}): p50 {:.3} ms, p99 {:.3} ms",
        lat.len(), percentile(&lat, 0.5), percentile(&lat, 0.99)
    );
}

/// The `sim_change_ms` the server logged for the last call of `tool`.
fn server_time(server: &common::Server, tool: &str) -> f64 {
    let lines = server.stderr.lock().unwrap();
    lines
        .iter()
        .rev()
        .find(|l| l.contains("physics_mcp::timing") && l.contains(tool))
        .and_then(|l| l.split("sim_change_ms=").nth(1))
        .and_then(|v| v.trim().parse().ok())
        .expect("the server logged the call's time")
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

fn bench_over_http(c: &mut Criterion) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let dir = tempfile::tempdir().unwrap();
    // The server logs each call's in-process time (`Sim::change`), so the overhead of MCP over
    // HTTP is measured on the same run, in the same binary and process.
    let server = common::Server::start_with_env(dir.path(), &[], &[("RUST_LOG", "physics_mcp::timing=debug")]);
    let client = rt.block_on(server.client());

    // get_object_state latency: one session, sequential. Measured twice: with the client on a
    // multi-threaded tokio runtime (the usual `#[tokio::main]`) and on a current-thread one.
    let current = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let current_client = current.block_on(server.client());
    latency(&current, &current_client, "current-thread");
    latency(&rt, &client, "multi-thread");
    let sim = rt.block_on(client.new_sim(json!({})));
    rt.block_on(client.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})));
    let q = json!({"sim_id": sim, "object_id": 0});
    c.bench_function("http_get_object_state", |b| b.to_async(&rt).iter(|| client.call("get_object_state", q.clone())));

    // step_simulation(1000) on the 1000-box pile: over MCP/HTTP vs Sim::change in-process.
    // Both runs do bit-identical work (same commands, same hashes), so the ratio is overhead.
    let mut http_ms = Vec::new();
    let mut local_ms = Vec::new();
    let mut ratios = Vec::new();
    for round in 0..3 {
        let s = rt.block_on(client.new_sim(json!({})));
        rt.block_on(async {
            for cmd in raw_pile() {
                let Command::AddBody { shape: Shape::Box { half_extents }, position, orientation, mass, .. } = cmd else { unreachable!() };
                client.call("add_box", json!({"sim_id": s, "dimensions": half_extents, "position": position, "orientation": orientation, "mass": mass})).await;
            }
        });
        // Let background work (WAL checkpoints after the pile's snapshots) finish first, in
        // both runs, so the ratio measures the MCP path and not disk contention.
        std::thread::sleep(Duration::from_secs(3));
        let t = Instant::now();
        rt.block_on(client.step(&s, 1000));
        let round_trip = t.elapsed().as_secs_f64() * 1e3;
        http_ms.push(round_trip);
        std::thread::sleep(Duration::from_millis(200));
        let inside = server_time(&server, "step_simulation");
        println!("REPORT step_simulation(1000) round {round}: client round trip {round_trip:.1} ms, Sim::change inside the server {inside:.1} ms, overhead {:.1} ms, ratio {:.5}", round_trip - inside, round_trip / inside);
        ratios.push(round_trip / inside);
        let http_hash = rt.block_on(client.hash(&s));
        rt.block_on(client.call("destroy_simulation", json!({"sim_id": s})));

        let mut sim = pile_sim(dir.path(), &format!("local{round}"), SyncMode::Normal);
        std::thread::sleep(Duration::from_secs(3));
        let t = Instant::now();
        sim.change("step_simulation", &args(json!({"steps": 1000})), Ok(Command::step(1000)), &Limits::default(), &mut |_| true).unwrap();
        local_ms.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(sim.world().state_hash(), http_hash, "HTTP and in-process runs differ");
    }
    let (h, l) = (http_ms.iter().cloned().fold(f64::MAX, f64::min), local_ms.iter().cloned().fold(f64::MAX, f64::min));
    println!(
        "REPORT step_simulation(1000) on the 1000-box pile: MCP/HTTP {h:.1} ms, in-process Sim::change in this bench process {l:.1} ms, ratio {:.4} (best of 3 each; two different binaries and processes: noisy)",
        h / l
    );
    println!(
        "REPORT MCP overhead ratio (round trip / Sim::change of the same call in the server): worst of 3 {:.5}",
        ratios.iter().cloned().fold(0.0, f64::max)
    );
}

// HTTP latency first: the disk-heavy benchmarks leave background I/O (WAL checkpoints) behind
// that shows up in sub-millisecond percentiles.
criterion_group!(benches, bench_over_http, bench_pile_steps, bench_snapshot_restore, bench_log_and_sync);
criterion_main!(benches);
