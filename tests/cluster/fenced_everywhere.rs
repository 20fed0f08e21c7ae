//! Every operation on a simulation is decided under a lease checked when the work runs, not
//! only when the call was admitted. Node A holds a simulation; a long
//! read (verify_simulation of a 600-box world) holds its lock; another call queues behind it on
//! A; A is frozen (SIGSTOP) past its lease while node B takes the simulation over and changes
//! it; A is thawed. The queued call must then neither answer from A's stale state (a read) nor
//! undo B's acknowledged change (a destroy). And a kept sweep whose sweeping node is frozen past
//! its lease must not name forks that are gone.

use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::common::Client;
use crate::nats::NatsCluster;
use crate::nodes::{attempt, listed_ids, shared_workspace, signal, Node, Outcome};

/// The lease the nodes run with (as in the runs).
const LEASE: [&str; 2] = ["--lease-ms", "2000"];
/// A call that waits out a frozen owner is answered well within this.
const CALL_LIMIT: Duration = Duration::from_secs(60);
/// Boxes in the world verify_simulation refolds.
const BOXES: usize = 600;
/// Where B moves object 1 while A is frozen.
const MOVED_TO: [f64; 3] = [40.0, 40.0, 3.0];

/// A world whose verify_simulation takes a while: `BOXES` boxes drifting in zero gravity (so
/// none falls asleep and every refolded step costs), stepped.
async fn heavy_world(c: &Client) -> String {
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let calls: Vec<Value> = (0..BOXES)
        .flat_map(|i| {
            let (x, y) = ((i % 25) as f64 * 0.3 - 3.6, (i / 25) as f64 * 0.3 - 3.6);
            [
                json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [x, y, 1.0], "mass": 1.0}}),
                json!({"tool": "set_object_velocity", "arguments": {"object_id": i, "linear_velocity": [-y * 0.05, x * 0.05, 0.01]}}),
            ]
        })
        .collect();
    c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    // Stepped until verifying it takes a few seconds on this machine (nothing is judged by
    // how long: it only has to outlast the queueing and the freeze below).
    for _ in 0..30 {
        c.step(&sim, 20_000).await;
        let started = Instant::now();
        c.call("verify_simulation", json!({"sim_id": sim})).await;
        if started.elapsed() > VERIFY_AT_LEAST {
            break;
        }
    }
    sim
}

/// How long verifying the heavy world should take, at least: it must outlast the 1.7 s of A's
/// running time before the freeze, with room (a world verified sooner is stepped further by
/// `queued_behind_a_freeze`). Once the boxes drift apart a step costs little, so the world
/// grows by 20,000 steps at a time: reaching this took 30 rounds of 2,000 (a minute) before.
const VERIFY_AT_LEAST: Duration = Duration::from_secs(3);

/// Thaws a frozen process when dropped, so a failing test does not leave its node stopped.
struct ThawOnDrop(u32);

impl Drop for ThawOnDrop {
    fn drop(&mut self) {
        let _ = std::process::Command::new("kill").args(["-CONT", &self.0.to_string()]).status();
    }
}

/// Queues `tool` behind a verify_simulation on A, freezes A, has B change object 1 (B takes
/// the simulation over), thaws A; returns the queued call's outcome and B's client.
async fn queued_behind_a_freeze(a: &Node, b: &Node, sim: &str, tool: &'static str, args: Value) -> (Outcome, Client) {
    // The verification must still hold A's lock when the call is queued and A frozen; if it
    // ended sooner (a fast machine), the world is stepped further and it is tried again.
    let (verifying, queued) = loop {
        let verifying = {
            let c = a.client().await;
            let args = json!({"sim_id": sim});
            tokio::spawn(async move { attempt(&c, "verify_simulation", args, CALL_LIMIT).await })
        };
        tokio::time::sleep(Duration::from_millis(1200)).await;
        if verifying.is_finished() {
            a.client().await.step(sim, 2_000).await;
            continue;
        }
        let queued = {
            let c = a.client().await;
            let args = args.clone();
            tokio::spawn(async move { attempt(&c, tool, args, CALL_LIMIT).await })
        };
        tokio::time::sleep(Duration::from_millis(500)).await;
        if queued.is_finished() {
            panic!("{tool} was not queued behind verify_simulation: {:?}", queued.await.unwrap());
        }
        if !verifying.is_finished() {
            break (verifying, queued);
        }
        panic!("verify_simulation ended as {tool} was queued: the world is too small to hold A's lock");
    };
    signal(a.pid(), "STOP");
    let frozen_at = Instant::now();
    let _thaw = ThawOnDrop(a.pid());
    let cb = b.client().await;
    let pose = json!({"sim_id": sim, "object_id": 1, "position": MOVED_TO});
    match attempt(&cb, "set_object_pose", pose, CALL_LIMIT).await {
        Outcome::Ok(_) => eprintln!("B changed the simulation {:?} after A froze", frozen_at.elapsed()),
        other => panic!("B's set_object_pose while A was frozen: {other:?}"),
    }
    signal(a.pid(), "CONT");
    let _ = verifying.await.unwrap();
    (queued.await.unwrap(), cb)
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_read_queued_on_a_node_that_lost_its_lease_answers_the_new_owners_state() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &LEASE);
    let b = Node::start(root.path(), "b", &nats, &workspace, &LEASE);
    let sim = heavy_world(&a.client().await).await;
    let read = json!({"sim_id": sim, "object_id": 1});
    let (outcome, cb) = queued_behind_a_freeze(&a, &b, &sim, "get_object_state", read.clone()).await;
    let state = match outcome {
        Outcome::Ok(v) => v,
        other => panic!("the read queued on A: {other:?}"),
    };
    assert_eq!(state["position"], json!(MOVED_TO), "the read queued on A answered A's state from before B's acknowledged change");
    assert_eq!(state, cb.call("get_object_state", read).await, "the read through A and through B");
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_destroy_queued_on_a_node_that_lost_its_lease_undoes_nothing_acknowledged() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &LEASE);
    let b = Node::start(root.path(), "b", &nats, &workspace, &LEASE);
    let sim = heavy_world(&a.client().await).await;
    let (outcome, cb) = queued_behind_a_freeze(&a, &b, &sim, "destroy_simulation", json!({"sim_id": sim})).await;
    let read = json!({"sim_id": sim, "object_id": 1});
    let ca = a.client().await;
    match outcome {
        // Acknowledged after B's change: every node must then say the simulation is gone, at
        // once (the destroy is the later of the two, and it must be the one that happened).
        Outcome::Ok(_) => {
            for (who, c) in [("B", &cb), ("A", &ca)] {
                match attempt(c, "get_object_state", read.clone(), CALL_LIMIT).await {
                    Outcome::Refused(e) => assert!(e.contains("not found"), "{who} after the acknowledged destroy: {e}"),
                    other => panic!("{who} still serves the simulation after its destroy was acknowledged: {other:?}"),
                }
            }
            let out = tempfile::tempdir().unwrap();
            let o = crate::nodes::cli(&["export", &nats.urls(), &sim, out.path().join("x.sqlite").to_str().unwrap()]);
            assert!(!o.status.success(), "export found a log of a destroyed simulation");
        }
        // Refused: it did nothing, and B's change stands.
        Outcome::Refused(e) => {
            eprintln!("the queued destroy was refused: {e}");
            assert_eq!(cb.call("get_object_state", read).await["position"], json!(MOVED_TO));
        }
        Outcome::Lost(e) => panic!("the queued destroy got no answer: {e}"),
    }
}

/// Boxes moving in the sweep's scene.
const MOVING: usize = 300;
/// Variants of the kept sweep.
const VARIANTS: usize = 4;

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_kept_sweep_whose_node_froze_names_only_forks_that_exist() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let flags = ["--lease-ms", "2000", "--max-sims", "100"];
    let nodes: Vec<Node> = ["a", "b", "c"].iter().map(|n| Node::start(root.path(), n, &nats, &workspace, &flags)).collect();
    let ca = nodes[0].client().await;
    let sim = ca.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let calls: Vec<Value> = (0..MOVING)
        .flat_map(|i| {
            [
                json!({"tool": "add_sphere", "arguments": {"radius": 0.05, "position": [(i % 20) as f64 * 0.5, (i / 20) as f64 * 0.5, 1.0]}}),
                json!({"tool": "set_object_velocity", "arguments": {"object_id": i, "linear_velocity": [0.1, 0.0, 0.0]}}),
            ]
        })
        .collect();
    ca.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let variants: Vec<Value> = (0..VARIANTS)
        .map(|k| json!([{"tool": "set_object_pose", "arguments": {"object_id": k + 1, "position": [-5.0, -5.0 - k as f64, 1.0]}}]))
        .collect();
    let sweep = json!({"sim_id": sim, "variants": variants, "steps": 600, "keep": true});
    let call = tokio::spawn(async move { (attempt(&ca, "run_sweep", sweep, Duration::from_secs(180)).await, ca) });
    tokio::time::sleep(Duration::from_millis(700)).await;
    signal(nodes[0].pid(), "STOP");
    let _thaw = ThawOnDrop(nodes[0].pid());
    tokio::time::sleep(Duration::from_millis(9500)).await;
    signal(nodes[0].pid(), "CONT");
    let (outcome, ca) = call.await.unwrap();
    let reply = match outcome {
        Outcome::Ok(v) => v,
        Outcome::Refused(e) => {
            eprintln!("the sweep was refused: {e}");
            Value::Null
        }
        Outcome::Lost(e) => panic!("the sweep got no answer: {e}"),
    };
    let named: Vec<String> = reply["variants"].as_array().into_iter().flatten().filter_map(|v| v["simulation_id"].as_str().map(str::to_string)).collect();
    eprintln!("the sweep names {} forks", named.len());
    let cb = nodes[1].client().await;
    for id in &named {
        for (who, c) in [("a", &ca), ("b", &cb)] {
            match attempt(c, "get_simulation_info", json!({"sim_id": id}), CALL_LIMIT).await {
                Outcome::Ok(_) => {}
                other => panic!("the sweep's reply names fork {id}, but node {who} answers {other:?}"),
            }
        }
    }
    // And nothing else of it stays: only the swept simulation and the forks the reply names.
    let mut want: Vec<String> = named.iter().cloned().chain([sim.clone()]).collect();
    want.sort();
    let settling = Instant::now();
    loop {
        let mut listed = listed_ids(&cb).await;
        listed.sort();
        if listed == want {
            break;
        }
        assert!(settling.elapsed() < Duration::from_secs(30), "after the sweep the cluster lists {listed:?}, the reply named {want:?}");
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_sweep_survives_its_node_reconnecting_to_another_nats_server() {
    let mut nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let nodes: Vec<Node> = ["a", "b", "c"].iter().map(|n| Node::start(root.path(), n, &nats, &workspace, &LEASE)).collect();
    let ca = nodes[0].client().await;
    let sim = ca.new_sim(json!({})).await;
    ca.ground(&sim).await;
    for k in 0..40 {
        ca.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [(k % 8) as f64 * 0.3, (k / 8) as f64 * 0.3, 0.5 + 0.1 * k as f64]})).await;
    }
    let variants: Vec<Value> = (0..12).map(|k| json!([{"tool": "set_object_pose", "arguments": {"object_id": 1 + k, "position": [0.0, 0.0, 3.0]}}])).collect();
    let args = json!({"sim_id": sim, "variants": variants, "steps": 300});
    let expected = ca.call("run_sweep", args.clone()).await;
    // Again, with node A's NATS server killed mid-sweep: A reconnects to another server, and for
    // a moment nobody listens for the sweep's results — which decides nothing.
    let server = nats.server_of_connection("physics-mcp a").expect("node a's NATS connection");
    let call = tokio::spawn(async move { attempt(&ca, "run_sweep", args, Duration::from_secs(180)).await });
    tokio::time::sleep(Duration::from_millis(600)).await;
    tokio::task::block_in_place(|| {
        nats.kill9(server);
        std::thread::sleep(Duration::from_secs(2));
        nats.restart(server);
    });
    match call.await.unwrap() {
        Outcome::Ok(got) => assert_eq!(got, expected, "the sweep through a reconnect differs"),
        other => panic!("the sweep through node a's reconnect: {other:?}"),
    }
}
