//! An all-or-nothing batch of the most calls one request may hold (10,000) on a cluster node:
//! one commit far over NATS's 1 MiB max payload, so it goes to the object store and one small
//! message commits it. Acknowledged, it is in the log whole — the exported log replays, with
//! every call's event — and after the node is killed, the next call (sent to another node)
//! waits for the takeover and is answered by that node, which has the batch whole.

use serde_json::{json, Value};

use crate::nats::NatsCluster;
use crate::nodes::{attempt, events, export_and_verify, shared_workspace, Node, Outcome};

/// The calls in the batch (the most `batch` takes).
const CALLS: usize = 10_000;
/// The first call after the owner's kill is answered within this: the lease (1 s), and a
/// rebuild of 10,001 events with a refold (12.7 s in a debug build, docs/cluster.md).
const TAKEOVER_WITHIN: std::time::Duration = std::time::Duration::from_secs(60);

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_ten_thousand_call_batch_is_one_commit_that_survives_its_owner() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let mut a = Node::start(root.path(), "a", &nats, &workspace, &["--lease-ms", "1000"]);
    let b = Node::start(root.path(), "b", &nats, &workspace, &["--lease-ms", "1000"]);
    let ca = a.client().await;
    let sim = ca.new_sim(json!({})).await;
    let calls: Vec<Value> = (0..CALLS)
        .map(|i| json!({"tool": "add_sphere", "arguments": {"radius": 0.05, "position": [(i % 100) as f64 * 0.2, (i / 100) as f64 * 0.2, 1.0]}}))
        .collect();
    let done = ca.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    assert_eq!(done["results"].as_array().map(Vec::len), Some(CALLS), "one result per call");
    let (head, hash) = (done["head_seq"].as_u64().expect("head_seq"), done["state_hash"].clone());

    // The owner dies; the next call, sent to the other node, waits for the lease to lapse and is
    // answered by that node, which has taken the whole batch over (rebuilt from the cluster).
    a.kill9();
    let cb = b.client().await;
    let started = std::time::Instant::now();
    let last = json!({"sim_id": sim, "object_id": CALLS - 1});
    match attempt(&cb, "get_object_state", last, TAKEOVER_WITHIN).await {
        Outcome::Ok(_) => {}
        other => panic!("the call sent to node b after its owner was killed was answered with {other:?} after {:?}", started.elapsed()),
    }
    let listed = cb.call("list_simulations", json!({})).await;
    let entry = listed["simulations"].as_array().unwrap().iter().find(|s| s["simulation_id"] == json!(sim)).cloned();
    assert_eq!(entry.map(|e| e["objects"].clone()), Some(json!(CALLS)), "the node that took it over has every object");

    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "big_batch");
    assert_eq!(summary["final_hash"], hash, "the exported log folds to the hash the batch reported");
    let changes = events(&file).iter().filter(|e| e.tool == "add_sphere" && e.ok).count();
    assert_eq!(changes, CALLS, "every call of the batch is an event of the log");
    eprintln!("10,000-call batch: head {head}, taken over in {:?}", started.elapsed());
}
