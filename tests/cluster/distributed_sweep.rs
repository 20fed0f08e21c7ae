//! run_sweep on a cluster spreads its variants over the live nodes (each node pulls variants
//! from one shared work queue, one per free core) and answers bit for bit as an embedded
//! server does: the same state hashes, poses, velocities and ranking. Then the same sweep again
//! with a node that is not the swept simulation's owner killed (kill -9) half-way: its variants
//! are redelivered to the other nodes and the answer is still the embedded one; the forks it
//! keeps are exactly one per variant, each a real simulation with the variant's state; a kept
//! sweep with a refused variant leaves none of its forks behind. Last,
//! another node stopped with SIGTERM half-way through a sweep exits cleanly within the shutdown
//! deadline, giving its variants back, and the answer is still the embedded one.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rand::Rng;
use serde_json::{json, Value};

use crate::common::hard::{rng, seed};
use crate::common::{Client, Server};
use crate::nats::NatsCluster;
use crate::nodes::{assert_no_ambient_cluster, listed_ids, owned_elsewhere, shared_workspace, Node};

/// Variants per sweep.
const VARIANTS: usize = 32;
/// Steps each variant takes after its calls.
const STEPS: u64 = 400;
/// Falling boxes in the scene (objects 1..=BOXES; 0 is the ground).
const BOXES: u64 = 6;
/// What the nodes log: warnings, and one line per variant run.
const RUST_LOG: (&str, &str) = ("RUST_LOG", "warn,physics_mcp::sweep=info");
/// Room for the kept variants beside the swept simulation (the default is 32).
const MAX_SIMS: &str = "100";

/// A ground and a few boxes falling from different heights, stepped a little.
async fn scene(c: &Client) -> String {
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})).await;
    for k in 0..BOXES {
        let p = [0.3 * k as f64 - 0.75, 0.1 * k as f64, 0.5 + 0.35 * k as f64];
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.15, 0.1], "position": p, "mass": 1.0 + k as f64})).await;
    }
    c.step(&sim, 30).await;
    sim
}

/// `VARIANTS` variants from `seed`: each moves one box and throws it.
fn variants(seed: u64) -> Vec<Value> {
    let mut r = rng(seed);
    (0..VARIANTS)
        .map(|i| {
            let object = 1 + i as u64 % BOXES;
            let position = [r.gen_range(-1.0..1.0), r.gen_range(-1.0..1.0), r.gen_range(0.3..2.0)];
            let velocity = [r.gen_range(-2.0..2.0), r.gen_range(-2.0..2.0), r.gen_range(0.0..4.0)];
            json!([
                {"tool": "set_object_pose", "arguments": {"object_id": object, "position": position}},
                {"tool": "set_object_velocity", "arguments": {"object_id": object, "linear_velocity": velocity, "angular_velocity": [0, 0, r.gen_range(-3.0..3.0)]}}
            ])
        })
        .collect()
}

/// The sweep's arguments.
fn sweep(sim: &str, variants: &[Value], keep: bool) -> Value {
    json!({"sim_id": sim, "variants": variants, "steps": STEPS, "keep": keep,
        "observe": {"object_ids": [1, 2, 3, 4, 5, 6], "include_velocities": true},
        "rank_by": {"object_id": 3, "metric": "displacement"}})
}

/// A sweep's reply without the kept forks' ids (which differ between servers by nature).
fn without_fork_ids(reply: &Value) -> Value {
    let mut r = reply.clone();
    for v in r["variants"].as_array_mut().expect("variants") {
        v.as_object_mut().unwrap().remove("simulation_id");
    }
    r
}

/// The variant runs the nodes logged so far: (node, sweep id, variant index), one per line
/// `variant I of sweep S ran on node N`.
fn runs(logs: &[(String, Arc<Mutex<Vec<String>>>)]) -> Vec<(String, String, usize)> {
    let mut out = Vec::new();
    for (name, lines) in logs {
        for line in lines.lock().unwrap().iter() {
            let Some(rest) = line.split("variant ").nth(1) else { continue };
            let words: Vec<&str> = rest.split_whitespace().collect();
            if let [index, "of", "sweep", sweep, "ran", "on", "node", node, ..] = words.as_slice() {
                assert_eq!(node, name, "{line}");
                out.push((name.clone(), sweep.to_string(), index.parse().unwrap()));
            }
        }
    }
    out
}

/// Variant runs per node, of the sweeps not in `before`.
fn per_node(runs: &[(String, String, usize)], before: &[(String, String, usize)]) -> BTreeMap<String, usize> {
    let mut count = BTreeMap::new();
    for (node, sweep, _) in runs {
        if !before.iter().any(|(_, s, _)| s == sweep) {
            *count.entry(node.clone()).or_insert(0) += 1;
        }
    }
    count
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_sweep_spreads_over_the_nodes_and_survives_a_killed_one() {
    assert_no_ambient_cluster();
    let seed = seed();
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let flags = ["--lease-ms", "2000", "--max-sims", MAX_SIMS];
    let mut nodes: Vec<Node> = ["a", "b", "c"]
        .iter()
        .map(|name| Node::start_with_env(root.path(), name, &nats, &workspace, &flags, &[RUST_LOG]))
        .collect();
    let logs: Vec<(String, Arc<Mutex<Vec<String>>>)> = nodes.iter().map(|n| (n.name.clone(), n.stderr())).collect();
    let embedded = Server::start(&root.path().join("embedded"), &["--max-sims", MAX_SIMS]);
    let e = embedded.client().await;
    let a = nodes[0].client().await;
    let (sim_e, sim_a) = (scene(&e).await, scene(&a).await);
    assert_eq!(e.hash(&sim_e).await, a.hash(&sim_a).await, "the same scene");
    let variants = variants(seed);

    // 1. Spread over the nodes, the same answer as one embedded server.
    let plain = e.call("run_sweep", sweep(&sim_e, &variants, false)).await;
    let started = Instant::now();
    let got = a.call("run_sweep", sweep(&sim_a, &variants, false)).await;
    eprintln!("32-variant sweep across 3 nodes: {:?}", started.elapsed());
    assert_eq!(got, plain, "the cluster's sweep differs from the embedded one");
    assert!(plain["ranking"].is_array());
    let first = runs(&logs);
    let spread = per_node(&first, &[]);
    eprintln!("variants run per node: {spread:?}");
    assert_eq!(spread.values().sum::<usize>(), VARIANTS, "each variant ran once: {first:?}");
    assert!(spread.len() > 1, "the variants all ran on one node: {spread:?}");

    // 2. Again, keeping the forks, with node b (not the owner: the scene was made on a)
    // killed after about half the variants ran.
    let expected = e.call("run_sweep", sweep(&sim_e, &variants, true)).await;
    let call = tokio::spawn({
        let args = sweep(&sim_a, &variants, true);
        async move {
            let started = Instant::now();
            let got = a.call("run_sweep", args).await;
            (got, started.elapsed(), a)
        }
    });
    half_way(&logs, first.len()).await;
    nodes[1].kill9();
    let killed_at = runs(&logs).len() - first.len();
    let (got, took, a) = call.await.unwrap();
    eprintln!("kept sweep with node b killed after {killed_at} variant runs: {took:?}");
    assert_eq!(without_fork_ids(&got), without_fork_ids(&expected), "after a node's death the sweep differs from the embedded one");
    let after = per_node(&runs(&logs), &first);
    eprintln!("variant runs per node in the second sweep: {after:?}");
    assert!(after.values().sum::<usize>() >= VARIANTS);

    // One kept fork per variant, no more (a variant run twice kept its fork once), and each
    // holds its variant's state.
    let kept: Vec<String> = got["variants"].as_array().unwrap().iter().map(|v| v["simulation_id"].as_str().unwrap().to_string()).collect();
    let c = nodes[2].client().await;
    let settled = Instant::now();
    loop {
        let listed = listed_ids(&a).await;
        let extra: Vec<&String> = listed.iter().filter(|id| **id != sim_a && !kept.contains(id)).collect();
        if extra.is_empty() && kept.iter().all(|id| listed.contains(id)) {
            break;
        }
        assert!(settled.elapsed() < Duration::from_secs(20), "kept forks {kept:?}, listed {listed:?}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    for (id, v) in kept.iter().zip(got["variants"].as_array().unwrap()) {
        let asked = Instant::now();
        let info = loop {
            let mut refusals = Vec::new();
            let mut answer = None;
            for client in [&a, &c] {
                match client.try_call("get_simulation_info", json!({"sim_id": id})).await {
                    Ok(info) => answer = Some(info),
                    Err(e) => refusals.push(e),
                }
                if answer.is_some() {
                    break;
                }
            }
            if let Some(info) = answer {
                break info;
            }
            // Kept on b: taken over once b's lease lapses.
            assert!(refusals.iter().all(|e| owned_elsewhere(e)) && asked.elapsed() < Duration::from_secs(20), "{id}: {refusals:?}");
            tokio::time::sleep(Duration::from_millis(200)).await;
        };
        assert_eq!(info["state_hash"], v["state_hash"], "kept variant {id}");
    }

    // A kept sweep whose last variant is refused: refused as the embedded server refuses it,
    // and none of the forks its other variants kept is left in the cluster.
    let mut bad = variants.clone();
    bad[VARIANTS - 1] = json!([{"tool": "set_object_velocity", "arguments": {"object_id": 99, "linear_velocity": [1, 0, 0]}}]);
    let want = e.try_call("run_sweep", sweep(&sim_e, &bad, true)).await.expect_err("a variant is refused");
    let refused = a.try_call("run_sweep", sweep(&sim_a, &bad, true)).await.expect_err("a variant is refused");
    assert_eq!(refused.replace(&sim_a, "SIM"), want.replace(&sim_e, "SIM"));
    let mut listed = listed_ids(&a).await;
    listed.sort();
    let mut before: Vec<String> = kept.iter().cloned().chain([sim_a.clone()]).collect();
    before.sort();
    assert_eq!(listed, before, "a refused kept sweep left simulations behind");

    // 3. Node c stopped by SIGTERM half-way through a sweep: it exits cleanly and in time, its
    // variants run elsewhere, the answer is the embedded one.
    let before = runs(&logs);
    let call = tokio::spawn({
        let args = sweep(&sim_a, &variants, false);
        async move { a.call("run_sweep", args).await }
    });
    half_way(&logs, before.len()).await;
    let stopping = Instant::now();
    tokio::task::block_in_place(|| nodes[2].terminate());
    let stopped = stopping.elapsed();
    eprintln!("node c exited {stopped:?} after SIGTERM mid-sweep");
    assert!(stopped < Duration::from_secs(10), "node c took {stopped:?} to exit");
    assert_eq!(call.await.unwrap(), plain, "after a node's SIGTERM the sweep differs from the embedded one");
    eprintln!("variant runs per node in the third sweep: {:?}", per_node(&runs(&logs), &before));
}

/// Waits until half a sweep's variants have run since the nodes logged `before` runs.
async fn half_way(logs: &[(String, Arc<Mutex<Vec<String>>>)], before: usize) {
    let waiting = Instant::now();
    while runs(logs).len() < before + VARIANTS / 2 {
        assert!(waiting.elapsed() < Duration::from_secs(60), "half the variants did not run within 60 s");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}
