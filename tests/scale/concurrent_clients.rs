//! Load: 20 concurrent clients (own MCP sessions) × 1,000 seeded mixed calls —
//! reads, steps, adds, forces, poses, undo/redo, forks (destroyed again) and saves — over 5
//! shared simulations. Zero errors other than intended refusals (undo/redo with nothing left,
//! a read of an object an undo removed); afterwards every simulation verifies, its log holds
//! exactly the state-changing calls that were acknowledged, and every undo/redo reply's
//! head and hash are the logged event's. `PHYSICS_LOAD_CLIENTS` / `PHYSICS_LOAD_CALLS`
//! scale it; `seed=` is printed and `PHYSICS_SEED` replays the call mix.

use crate::common;

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::hard::{rng, seed};
use common::{Client, Server};
use rand::Rng;
use serde_json::{json, Value};

fn env_or(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// What one client saw.
#[derive(Default)]
struct Tally {
    /// Acknowledged state-changing calls per simulation.
    changes: BTreeMap<String, usize>,
    /// (simulation, head_seq, state_hash) from undo/redo replies.
    moves: Vec<(String, u64, String)>,
    /// Intended refusals.
    refused: usize,
    /// get_object_state latencies (s).
    reads: Vec<f64>,
}

/// The refusals the call mix can provoke on purpose; anything else is an error.
fn intended(tool: &str, why: &str) -> bool {
    match tool {
        "undo" | "redo" => why.starts_with("count must be from 1 to 0 "),
        "get_object_state" | "set_object_pose" | "apply_force" => why.contains("not found"),
        _ => false,
    }
}

async fn client_run(c: Client, sims: Arc<Vec<String>>, who: usize, calls: usize, seed: u64) -> Tally {
    let mut r = rng(seed ^ (who as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut t = Tally::default();
    for j in 0..calls {
        let sim = sims[r.gen_range(0..sims.len())].clone();
        let obj = r.gen_range(0..6);
        let roll = r.gen_range(0..100);
        let (tool, args, changes) = match roll {
            0..=29 => ("get_object_state", json!({"sim_id": sim, "object_id": obj}), false),
            30..=39 => ("get_simulation_info", json!({"sim_id": sim}), false),
            40..=59 => ("step_simulation", json!({"sim_id": sim, "steps": r.gen_range(1..6)}), true),
            60..=67 => ("add_box", json!({"sim_id": sim, "position": [r.gen_range(-1.0..1.0), r.gen_range(-1.0..1.0), 1.5], "dimensions": [0.05, 0.05, 0.05]}), true),
            68..=72 => ("apply_force", json!({"sim_id": sim, "object_id": obj.max(1), "force": [0, 0, 5]}), true),
            73..=76 => ("set_object_pose", json!({"sim_id": sim, "object_id": obj.max(1), "position": [0, 0, 1]}), true),
            77..=86 => ("undo", json!({"sim_id": sim}), true),
            87..=97 => ("redo", json!({"sim_id": sim}), true),
            // Forks copy the log and saves write it whole: 1 % each keeps them in the mix
            // without making the run quadratic in the history's length.
            98 => ("fork_simulation", json!({"sim_id": sim}), false),
            _ => ("save_simulation", json!({"sim_id": sim, "file_path": format!("load/c{who}_{j}.json")}), false),
        };
        let started = Instant::now();
        let res = c.try_call(tool, args.clone()).await;
        if tool == "get_object_state" {
            t.reads.push(started.elapsed().as_secs_f64());
        }
        match res {
            Ok(v) => {
                if changes {
                    *t.changes.entry(sim.clone()).or_default() += 1;
                }
                if matches!(tool, "undo" | "redo") {
                    t.moves.push((sim.clone(), v["head_seq"].as_u64().unwrap(), v["state_hash"].as_str().unwrap().to_string()));
                }
                if tool == "fork_simulation" {
                    let fork = v["simulation_id"].as_str().unwrap();
                    c.call("destroy_simulation", json!({"sim_id": fork})).await;
                }
            }
            Err(why) if intended(tool, &why) => t.refused += 1,
            Err(why) => panic!("client {who} call {j}: {tool} {args} was refused: {why}"),
        }
    }
    t
}

/// Every event of `sim`'s log up to now, oldest first (pages of 1,000; each page is itself
/// logged as a read, so the end is the last seq before the first page).
async fn all_events(c: &Client, sim: &str) -> Vec<Value> {
    let end = c.call("get_simulation_info", json!({"sim_id": sim})).await["last_seq"].as_u64().unwrap();
    let mut out: Vec<Value> = Vec::new();
    while out.last().and_then(|e| e["seq"].as_u64()).unwrap_or(0) < end {
        let since = out.last().and_then(|e| e["seq"].as_u64()).unwrap_or(0);
        let page = c.call("get_history", json!({"sim_id": sim, "since_seq": since, "limit": 1000, "detail": "full"})).await;
        out.extend(page["events"].as_array().unwrap().iter().filter(|e| e["seq"].as_u64() <= Some(end)).cloned());
    }
    out
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 - 1.0) * p).round() as usize]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn twenty_clients_a_thousand_calls_each_lose_and_invent_nothing() {
    let seed = seed();
    let (clients, calls) = (env_or("PHYSICS_LOAD_CLIENTS", 20), env_or("PHYSICS_LOAD_CALLS", 1000));
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let setup = server.client().await;
    let mut sims = Vec::new();
    for _ in 0..5 {
        let sim = setup.new_sim(json!({})).await;
        setup.ground(&sim).await;
        for k in 0..5 {
            setup.call("add_box", json!({"sim_id": sim, "position": [k as f64 * 0.3, 0, 0.5], "dimensions": [0.1, 0.1, 0.1]})).await;
        }
        sims.push(sim);
    }
    let roots: BTreeMap<String, usize> = sims.iter().map(|s| (s.clone(), 6)).collect();
    let sims = Arc::new(sims);
    let started = Instant::now();
    let mut tasks = Vec::new();
    for who in 0..clients {
        let c = server.client().await;
        tasks.push(tokio::spawn(client_run(c, sims.clone(), who, calls, seed)));
    }
    let mut total = Tally::default();
    for task in tasks {
        let t = tokio::time::timeout(Duration::from_secs(1800), task).await.expect("bounded").expect("client task");
        for (s, n) in t.changes {
            *total.changes.entry(s).or_default() += n;
        }
        total.moves.extend(t.moves);
        total.refused += t.refused;
        total.reads.extend(t.reads);
    }
    let took = started.elapsed().as_secs_f64();
    eprintln!(
        "load: {clients} clients x {calls} calls in {took:.1} s ({:.0} calls/s), {} intended refusals; get_object_state p50 {:.2} ms, p99 {:.2} ms",
        (clients * calls) as f64 / took,
        total.refused,
        percentile(&mut total.reads, 0.5) * 1e3,
        percentile(&mut total.reads, 0.99) * 1e3
    );

    for sim in sims.iter() {
        let events = all_events(&setup, sim).await;
        let logged = events.iter().filter(|e| matches!(e["kind"].as_str(), Some("change" | "move"))).count();
        let acked = roots[sim] + total.changes.get(sim).copied().unwrap_or(0);
        assert_eq!(logged, acked, "{sim}: the log holds exactly the acknowledged state-changing calls");
        let hash_at: BTreeMap<u64, &str> = events.iter().map(|e| (e["seq"].as_u64().unwrap(), e["state_hash"].as_str().unwrap())).collect();
        for (_, head, hash) in total.moves.iter().filter(|(s, _, _)| s == sim) {
            assert_eq!(hash_at.get(head).copied(), Some(hash.as_str()), "{sim}: a reply's head {head} and hash are the logged event's");
        }
        let v = setup.call("verify_simulation", json!({"sim_id": sim})).await;
        assert_eq!(v["ok"], true, "{sim}: {v}");
    }
    let listed = setup.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"].as_array().unwrap().len(), 5, "every fork was destroyed: {listed}");
}
