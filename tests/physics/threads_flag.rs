//! `--threads N` (docs/tools.md "Scale"): every world the server makes steps on the one pool
//! of N threads — created, stepped, undone, redone, forked, loaded, kept from a sweep, and
//! recovered after a restart — because rapier drops the pool when a world is serialised, and a
//! world without it would step elsewhere. In-process, the pool's size is asserted on each, and
//! that a step really runs on one of its threads; over HTTP, servers on 1 and 3 threads answer
//! the same scenario with the same hashes, and a bad `--threads` is refused at start.

use crate::common;

use std::path::Path;
use std::sync::{Arc, Mutex};

use common::Server;
use physics_mcp::command::{Command, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry, SharedSim};
use physics_mcp::sim::sweep::{Control, Observe, Request};
use physics_mcp::value::Args;
use serde_json::{json, Value};

const THREADS: usize = 3;

fn registry(dir: &Path) -> Registry {
    Registry::open(common::config(dir)).expect("registry")
}

fn args(v: Value) -> Args {
    serde_json::from_value(v).unwrap()
}

fn add_box(sim: &SharedSim, z: f32, mass: f32) {
    let cmd = Command::AddBody {
        shape: Shape::Box { half_extents: [0.5, 0.5, 0.1] },
        position: [0.0, 0.0, z],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass,
        color: None,
        collides: true,
    };
    lock_sim(sim).change("add_box", &Args::new(), Ok(cmd), &Limits::default(), &mut |_| true).expect("add_box");
}

/// The pool size `sim` steps on, after checking that a step of it runs on a `physics-step-*`
/// thread (the pool `--threads` builds), not on the caller's.
fn stepping_threads(what: &str, sim: &SharedSim) -> usize {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let record = seen.clone();
    let mut observe = move |_: &physics_mcp::world::World| {
        let (n, name) = (rapier3d::rayon::current_num_threads(), std::thread::current().name().unwrap_or("").to_string());
        record.lock().unwrap().push(format!("{name} of {n}"));
    };
    let mut s = lock_sim(sim);
    let step = Ok(Command::step(2));
    s.change_observed("step_simulation", &Args::new(), step, &Limits::default(), &mut |_| true, &mut observe).expect("step");
    let names = seen.lock().unwrap().clone();
    let on_pool = |n: &String| n.starts_with("physics-step-") && n.ends_with(&format!(" of {THREADS}"));
    assert!(!names.is_empty() && names.iter().all(on_pool), "{what}: stepped on {names:?}");
    s.world().num_threads()
}

#[test]
fn every_world_the_server_makes_steps_on_the_threads_pool() {
    physics_mcp::cli::step_on_threads(THREADS).unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("ws")).unwrap();
    let expect = THREADS;
    {
        let reg = registry(dir.path());
        let root = Command::CreateSimulation { simulation_id: "a".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
        reg.create(root, &Args::new()).expect("create");
        let a = reg.get("a").unwrap();
        add_box(&a, -0.1, 0.0);
        add_box(&a, 0.5, 1.0);
        assert_eq!(stepping_threads("created", &a), expect);
        lock_sim(&a).undo(&Args::new(), 1).expect("undo");
        assert_eq!(stepping_threads("undone", &a), expect);
        lock_sim(&a).undo(&Args::new(), 1).expect("undo");
        lock_sim(&a).redo(&Args::new(), 1).expect("redo");
        assert_eq!(stepping_threads("redone", &a), expect);

        reg.fork("a", None, ("f".into(), None), &Args::new()).expect("fork");
        assert_eq!(stepping_threads("forked", &reg.get("f").unwrap()), expect);

        lock_sim(&a).save(&args(json!({"sim_id": "a", "file_path": "a.json"})), &reg).expect("save");
        let loaded = reg.load(&args(json!({"file_path": "a.json"})), "l".into(), &mut |_, _| {}).expect("load");
        assert_eq!(stepping_threads("loaded", &reg.get(&loaded.simulation_id).unwrap()), expect);

        let request = Request {
            variants: vec![vec![], vec![]],
            sent: vec![json!([]), json!([])],
            steps: 5,
            observe: Observe { object_ids: None, include_velocities: false, every: None, measure: Vec::new(), fields: None },
            keep: true,
            full: true,
            rank_by: None,
        };
        let swept = reg.sweep("a", &Args::new(), request, || Box::new(|_| true) as Control, (2, usize::MAX), None).expect("sweep");
        for v in &swept.variants {
            let kept = reg.get(v.simulation_id.as_deref().unwrap()).unwrap();
            assert_eq!(stepping_threads("kept from a sweep", &kept), expect);
        }
    }
    // A restart: the simulation is recovered from its log (snapshot + fold).
    let reg = registry(dir.path());
    assert_eq!(stepping_threads("recovered", &reg.get("a").unwrap()), expect);
}

/// The same calls on two servers, one stepping on 1 thread and one on 3: a pile of boxes
/// built by a batch, stepped, undone, stepped again, forked, swept, and after a kill -9 and
/// a restart stepped once more. Every hash agrees.
#[tokio::test(flavor = "multi_thread")]
async fn one_and_three_threads_give_the_same_hashes_over_mcp() {
    let mut calls = vec![json!({"tool": "add_box", "arguments": {"dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0}})];
    for i in 0..5 {
        for k in 0..20 {
            let p = [i as f64 * 0.3 - 0.6, 0.05 * k as f64 - 0.5, 0.3 + k as f64 * 0.22];
            calls.push(json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": p, "orientation": [0, 0, 0.0998, 0.995]}}));
        }
    }
    let mut hashes = Vec::new();
    for threads in ["1", "3"] {
        let dir = tempfile::tempdir().unwrap();
        let server = Server::start(dir.path(), &["--threads", threads]);
        let c = server.client().await;
        let sim = c.new_sim(json!({})).await;
        c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
        let mut seen = vec![c.step(&sim, 120).await["current_time"].clone()];
        seen.push(json!(c.hash(&sim).await));
        c.call("undo", json!({"sim_id": sim})).await;
        c.step(&sim, 60).await;
        seen.push(json!(c.hash(&sim).await));
        let fork = c.call("fork_simulation", json!({"sim_id": sim})).await;
        let fork_id = fork["simulation_id"].as_str().unwrap().to_string();
        c.step(&fork_id, 30).await;
        seen.push(json!(c.hash(&fork_id).await));
        let sweep = c
            .call("run_sweep", json!({"sim_id": sim, "steps": 40, "variants": [[], [{"tool": "change_dynamics", "arguments": {"object_id": 3, "lateral_friction": 0.1}}]]}))
            .await;
        seen.push(sweep["variants"].as_array().unwrap().iter().map(|v| v["state_hash"].clone()).collect());
        drop(c);
        server.kill();
        let server = Server::start(dir.path(), &["--threads", threads]);
        let c = server.client().await;
        c.step(&sim, 30).await;
        seen.push(json!(c.hash(&sim).await));
        hashes.push(seen);
    }
    let flat: Vec<&Value> = hashes[0][1..].iter().flat_map(|v| v.as_array().map_or(vec![v], |a| a.iter().collect())).collect();
    assert!(flat.len() == 6 && flat.iter().all(|h| h.as_str().is_some_and(|h| h.len() == 64)), "{flat:?}");
    assert_eq!(hashes[0], hashes[1], "1 thread vs 3 threads");
}

#[test]
fn a_bad_thread_count_is_refused_at_start() {
    let (ok, stderr) = Server::start_failure(&["--threads", "0", "serve"]);
    assert!(!ok, "--threads 0 started");
    assert!(stderr.contains("--threads"), "{stderr}");
}

/// Simulations stepped at the same time, each step on 2 threads, all finish and agree. rapier's
/// step waits, outside rayon, for a task it spawned on its own pool, so steps sharing one pool
/// can hold every worker while their tasks queue behind them (run_sweep's variants did, on one
/// shared pool, before each calling thread got its own); the timeout turns a hang into a
/// failure.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn simulations_stepped_at_once_on_two_threads_each_all_finish() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--threads", "2"]);
    let mut calls = vec![json!({"tool": "add_box", "arguments": {"dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0}})];
    for k in 0..150 {
        let p = [(k % 10) as f64 * 0.25 - 1.2, (k / 10) as f64 * 0.05, 0.3 + (k / 10) as f64 * 0.22];
        calls.push(json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": p}}));
    }
    let mut sims = Vec::new();
    for _ in 0..4 {
        let c = server.client().await;
        let sim = c.new_sim(json!({})).await;
        c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
        sims.push((c, sim));
    }
    let steps: Vec<_> = sims.into_iter().map(|(c, sim)| {
        tokio::spawn(async move {
            for _ in 0..3 {
                c.step(&sim, 500).await;
            }
            c.hash(&sim).await
        })
    }).collect();
    let all = async {
        let mut hashes = Vec::new();
        for s in steps {
            hashes.push(s.await.unwrap());
        }
        hashes
    };
    let hashes = tokio::time::timeout(std::time::Duration::from_secs(300), all)
        .await
        .expect("simultaneous steps on 2 threads each did not finish in 300 s");
    assert!(hashes.windows(2).all(|w| w[0] == w[1]), "the same calls ended in different states: {hashes:?}");
}

/// Steps called from rayon workers at once all finish. A step called on a worker of another
/// rayon pool (here the global one, through `rayon::scope`, as animations once re-simulated)
/// waits for its stepping pool by running other queued jobs — possibly another caller's whole
/// re-simulation, whose steps then need a stepping pool of their own: with one pool per thread
/// they shared it and hung (found by review). Free-falling boxes keep rapier's deferred BVH
/// task firing every step. The timeout only turns a hang into a failure.
#[test]
fn steps_called_from_rayon_workers_at_once_all_finish() {
    use physics_mcp::world::World;
    physics_mcp::cli::step_on_threads(THREADS).unwrap();
    let falling = |seed: usize| {
        let root = Command::CreateSimulation { simulation_id: format!("f{seed}"), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
        let (mut w, _) = World::create(&root).unwrap();
        for i in 0..30 {
            let position = [(i % 6) as f32 * 0.3, (i / 6) as f32 * 0.3, seed as f32];
            let body = Command::AddBody { shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] }, position, orientation: [0.0, 0.0, 0.0, 1.0], mass: 1.0, color: None, collides: true };
            w.apply(&body, &mut |_| true);
        }
        w
    };
    let (done, finished) = std::sync::mpsc::channel();
    for caller in 0..6 {
        let done = done.clone();
        let mut w = falling(caller);
        std::thread::spawn(move || {
            rapier3d::rayon::scope(|_| {
                for _ in 0..5 {
                    w.apply(&Command::step(400), &mut |_| true);
                }
            });
            done.send(w.state_hash()).unwrap();
        });
    }
    drop(done);
    for _ in 0..6 {
        finished.recv_timeout(std::time::Duration::from_secs(300)).expect("steps called from rayon workers at once did not finish in 300 s");
    }
}
