//! Scale benchmarks (`cargo bench --bench scale`), each pair measured side by side in one
//! run and reported as a ratio:
//! - the 1000-box pile built through MCP over HTTP (the real release binary, one rmcp client):
//!   1,001 add_box calls one by one vs the same calls in one `batch`;
//! - run_sweep of 16 variants × 1,000 steps of a 100-box scene, in-process through
//!   `Registry::sweep`: one worker vs one worker per core;
//! - one step of the 1000-box pile and of the 64 URDF arms (settled 100 steps, in-process) on 1
//!   vs 2 threads (`--threads`), 7 paired rounds of 100 steps each, checking both end in the same
//!   state hash: once as a live simulation steps (two twins, each restored once and stepped on
//!   through the rounds: what step_simulation on a server's simulation costs), and once as the
//!   first 100 steps after a restore (what a step right after load, fork, undo or a restart costs).

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "pile.rs"]
mod pile;

use std::sync::Arc;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::sim::apply::{Call, Planned};
use physics_mcp::command::{Command, DynamicsChange, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::sim::sweep::{Control, Observe, Request};
use physics_mcp::value::Args;
use rapier3d::rayon::ThreadPoolBuilder;
use pile::raw_pile;
use serde_json::{json, Value};

/// Paired rounds per comparison (the REPORT lines give medians and the median ratio).
const ROUNDS: usize = 5;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Paired timings (ms) of two ways to do one thing, measured round by round.
#[derive(Default)]
struct Paired {
    a: Vec<f64>,
    b: Vec<f64>,
}

impl Paired {
    fn push(&mut self, a: f64, b: f64) {
        self.a.push(a);
        self.b.push(b);
    }

    /// "A x ms, B y ms, speed-up r (medians of n paired rounds; min m)", the REPORT form.
    fn report(&self, a_name: &str, b_name: &str, decimals: usize) -> String {
        let ratios: Vec<f64> = self.a.iter().zip(&self.b).map(|(a, b)| a / b).collect();
        let min = ratios.iter().cloned().fold(f64::MAX, f64::min);
        let (a, b, n) = (median(self.a.clone()), median(self.b.clone()), self.a.len());
        format!("{a_name} {a:.decimals$} ms, {b_name} {b:.decimals$} ms, speed-up {:.2}x (medians of {n} paired rounds; min {min:.2}x)", median(ratios))
    }
}

/// The pile as `{tool, arguments}` calls, as a client sends them.
fn pile_calls() -> Vec<Value> {
    raw_pile()
        .into_iter()
        .map(|cmd| {
            let Command::AddBody { shape: Shape::Box { half_extents }, position, orientation, mass, .. } = cmd else { unreachable!() };
            json!({"tool": "add_box", "arguments": {"dimensions": half_extents, "position": position, "orientation": orientation, "mass": mass}})
        })
        .collect()
}

fn bench_pile_build_over_http(c: &mut Criterion) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let server = common::Server::start(dir.path(), &[]);
    let client = rt.block_on(server.client());
    let calls = pile_calls();
    let mut paired = Paired::default();
    for _ in 0..ROUNDS {
        let a = rt.block_on(client.new_sim(json!({})));
        let t = Instant::now();
        rt.block_on(async {
            for call in &calls {
                let mut args = call["arguments"].clone();
                args["sim_id"] = json!(a);
                client.call("add_box", args).await;
            }
        });
        let single = t.elapsed().as_secs_f64() * 1e3;
        let b = rt.block_on(client.new_sim(json!({})));
        let t = Instant::now();
        let out = rt.block_on(client.call("batch", json!({"sim_id": b, "calls": calls})));
        let batch = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(out["state_hash"].as_str().unwrap(), rt.block_on(client.hash(&a)), "batch and one-by-one differ");
        for s in [a, b] {
            rt.block_on(client.call("destroy_simulation", json!({"sim_id": s})));
        }
        paired.push(single, batch);
    }
    println!(
        "REPORT pile build over MCP/HTTP (1,001 add_box, one rmcp client, release server): {}",
        paired.report("one call per box", "one batch", 1)
    );
    c.bench_function("batch_pile_build_http", |bench| {
        bench.iter(|| {
            let b = rt.block_on(client.new_sim(json!({})));
            rt.block_on(client.call("batch", json!({"sim_id": b, "calls": calls})));
            rt.block_on(client.call("destroy_simulation", json!({"sim_id": b})));
        })
    });
}

/// A registry in `dir` holding a 100-box scene (a 5×5×4 stack on a ground), its id.
fn sweep_scene(dir: &std::path::Path) -> (Registry, String) {
    let reg = Registry::open(common::config(dir)).unwrap();
    let id = "sweep-scene".to_string();
    reg.create(Command::CreateSimulation { simulation_id: id.clone(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) }, &Args::new()).unwrap();
    let sim = reg.get(&id).unwrap();
    let mut s = lock_sim(&sim);
    let add = |s: &mut physics_mcp::sim::Sim, half: [f32; 3], position: [f32; 3], mass: f32| {
        let cmd = Command::AddBody { shape: Shape::Box { half_extents: half }, position, orientation: [0.0, 0.0, 0.0, 1.0], mass, color: None, collides: true };
        s.change("add_box", &Args::new(), Ok(cmd), &Limits::default(), &mut |_| true).unwrap();
    };
    add(&mut s, [10.0, 10.0, 0.5], [0.0, 0.0, -0.5], 0.0);
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..4 {
                add(&mut s, [0.1, 0.1, 0.1], [i as f32 * 0.3, j as f32 * 0.3, 0.1 + k as f32 * 0.21], 1.0);
            }
        }
    }
    drop(s);
    (reg, id)
}

/// 16 variants: the ground's friction, one value per variant.
fn sweep_request(id: &str) -> Request {
    let variants = (0..16)
        .map(|v| {
            let change = DynamicsChange { lateral_friction: Some(0.1 + 0.1 * v as f32), ..Default::default() };
            let mut args = Args::new();
            args.insert("sim_id".into(), json!(id));
            vec![Call {
                tool: "change_dynamics".into(),
                args,
                planned: Planned::Change(Ok(Command::ChangeDynamics { object_id: 0, link_index: -1, change })),
            }]
        })
        .collect();
    // Embedded: no node decides the calls again from what a client sent.
    Request { variants, sent: Vec::new(), steps: 1000, observe: Observe::default(), keep: false, full: true, rank_by: None }
}

fn run_sweep(reg: &Registry, id: &str, workers: usize) -> f64 {
    let t = Instant::now();
    let out = reg
        .sweep(id, &Args::new(), sweep_request(id), || Box::new(|_| true) as Control, (workers, usize::MAX), None)
        .unwrap();
    assert_eq!(out.variants.len(), 16);
    t.elapsed().as_secs_f64() * 1e3
}

fn bench_sweep_workers(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let (reg, id) = sweep_scene(dir.path());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut paired = Paired::default();
    for _ in 0..ROUNDS {
        paired.push(run_sweep(&reg, &id, 1), run_sweep(&reg, &id, cores));
    }
    println!(
        "REPORT run_sweep 16 variants x 1,000 steps of a 100-box scene (in-process): {}",
        paired.report("1 worker", &format!("{cores} workers"), 0)
    );
    let mut g = c.benchmark_group("run_sweep_16x1000_100_boxes");
    g.sample_size(10);
    g.bench_function("workers_1", |b| b.iter(|| run_sweep(&reg, &id, 1)));
    g.bench_function(format!("workers_{cores}"), |b| b.iter(|| run_sweep(&reg, &id, cores)));
    g.finish();
}

/// Milliseconds per step of 100 steps of a settled scene restored from `snapshot`, stepping
/// on `threads`, and the state hash it ends in.
fn steps_on(snapshot: &[u8], threads: usize) -> (f64, String) {
    physics_mcp::cli::step_on_threads(threads).expect("stepping threads");
    let mut w = physics_mcp::world::World::restore("scene", false, snapshot).unwrap();
    assert_eq!(w.num_threads(), threads);
    let t = Instant::now();
    w.apply(&Command::step(100), &mut |_| true);
    (t.elapsed().as_secs_f64() * 1e3 / 100.0, w.state_hash())
}

/// `world` settled 100 steps, then its snapshot's first 100 steps after a restore on 1 vs 2
/// threads: paired rounds, the same final hash each time.
fn after_restore_paired(name: &str, snapshot: &[u8]) -> Paired {
    let mut paired = Paired::default();
    for _ in 0..THREAD_ROUNDS {
        let (a, ha) = steps_on(snapshot, 1);
        let (b, hb) = steps_on(snapshot, 2);
        assert_eq!(ha, hb, "{name}: 1 and 2 threads end in different states");
        paired.push(a, b);
    }
    physics_mcp::cli::step_on_threads(1).expect("a stepping thread");
    paired
}

/// Twins restored once from `snapshot`, one stepping on its own pool of 1 thread and one on 2,
/// stepped on through the same 100 steps each round (which goes first alternates, so neither
/// always finds the caches the other left): the same state hash after every round.
fn live_paired(name: &str, snapshot: &[u8]) -> Paired {
    let mut twins = [1, 2].map(|threads| {
        let pool = ThreadPoolBuilder::new().num_threads(threads).build().expect("a stepping pool");
        let mut w = physics_mcp::world::World::restore("scene", false, snapshot).unwrap();
        w.set_thread_pool(Some(Arc::new(pool)));
        assert_eq!(w.num_threads(), threads);
        w
    });
    let mut paired = Paired::default();
    for round in 0..THREAD_ROUNDS {
        let mut ms = [0.0; 2];
        for i in if round % 2 == 0 { [0, 1] } else { [1, 0] } {
            let t = Instant::now();
            twins[i].apply(&Command::step(100), &mut |_| true);
            ms[i] = t.elapsed().as_secs_f64() * 1e3 / 100.0;
        }
        assert_eq!(twins[0].state_hash(), twins[1].state_hash(), "{name}: 1 and 2 threads differ after round {round}");
        paired.push(ms[0], ms[1]);
    }
    paired
}

/// Both thread comparisons of `world` settled 100 steps, as REPORT lines.
fn report_threads(what: &str, mut world: physics_mcp::world::World, decimals: usize) {
    world.apply(&Command::step(100), &mut |_| true);
    let snapshot = world.snapshot();
    let live = live_paired(what, &snapshot);
    println!("REPORT {what} step, live simulation (in-process, rounds of 100 steps): {}", live.report("1 thread", "2 threads", decimals));
    let restored = after_restore_paired(what, &snapshot);
    println!("REPORT {what} step, first 100 steps after a restore (in-process): {}", restored.report("1 thread", "2 threads", decimals));
}

/// Paired rounds of the thread comparisons.
const THREAD_ROUNDS: usize = 7;

fn bench_pile_threads(c: &mut Criterion) {
    report_threads("pile (1000 boxes)", pile::pile_world(), 2);
    report_threads("64 URDF arms", pile::arms_world(), 3);
    let mut w = pile::pile_world();
    w.apply(&Command::step(100), &mut |_| true);
    let snapshot = w.snapshot();
    let mut g = c.benchmark_group("pile_100_steps_threads");
    g.sample_size(10);
    for threads in [1, 2] {
        g.bench_function(format!("threads_{threads}"), |b| b.iter(|| steps_on(&snapshot, threads)));
    }
    g.finish();
    physics_mcp::cli::step_on_threads(1).expect("a stepping thread");
}

criterion_group!(benches, bench_pile_build_over_http, bench_sweep_workers, bench_pile_threads);
criterion_main!(benches);
