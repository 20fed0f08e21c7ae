//! A call reaches its owner whatever its size, and a call that cannot succeed is not retried as
//! if it might. A 10,000-call batch (≈ 2 MB, over NATS's 1 MiB
//! message limit) sent to a node that does not own the simulation is forwarded and answered as
//! on the owner. A `sim_id` that cannot name a simulation (not a valid NATS key) is answered
//! "not found", as embedded, without holding up the node: a destroy of another simulation
//! sent meanwhile is answered too.

use std::time::Duration;

use serde_json::{json, Value};

use crate::common::Server;
use crate::nats::NatsCluster;
use crate::nodes::{attempt, shared_workspace, Node, Outcome};

/// The most calls one batch holds.
const CALLS: usize = 10_000;
/// Ample for any call here; a call that waits past it has hung.
const CALL_LIMIT: Duration = Duration::from_secs(120);

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_batch_over_a_message_is_forwarded_to_its_owner() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let b = Node::start(root.path(), "b", &nats, &workspace, &[]);
    let ca = a.client().await;
    let sim = ca.new_sim(json!({})).await;
    let calls: Vec<Value> = (0..CALLS)
        .map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.05, 0.05, 0.05], "position": [(i % 100) as f64 * 0.2, (i / 100) as f64 * 0.2, 1.0], "orientation": [0.0, 0.0, 0.0, 1.0], "mass": 1.0}}))
        .collect();
    let request = json!({"sim_id": sim, "calls": calls});
    assert!(request.to_string().len() > 1 << 20, "the batch is meant to be over 1 MiB");
    let cb = b.client().await;
    let done = match attempt(&cb, "batch", request, CALL_LIMIT).await {
        Outcome::Ok(v) => v,
        other => panic!("the batch sent to node b for node a's simulation: {other:?}"),
    };
    assert_eq!(done["results"].as_array().map(Vec::len), Some(CALLS));
    let history = ca.call("get_history", json!({"sim_id": sim, "limit": 1})).await;
    assert_eq!(history["head_seq"], done["head_seq"], "the owner has the batch: {history}");
    ca.call("get_object_state", json!({"sim_id": sim, "object_id": CALLS - 1})).await;
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn an_id_that_names_nothing_is_not_found_at_once() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let b = Node::start(root.path(), "b", &nats, &workspace, &[]);
    let embedded = Server::start(&root.path().join("embedded"), &[]);
    let e = embedded.client().await;
    let ca = a.client().await;
    let other = ca.new_sim(json!({})).await;
    for bad in ["no such sim", ".", "a.b", "x*", "", &"y".repeat(65)] {
        let args = json!({"sim_id": bad, "object_id": 0});
        let want = e.try_call("get_object_state", args.clone()).await.expect_err("embedded refuses");
        let cb = b.client().await;
        let asked = tokio::spawn(async move { attempt(&cb, "get_object_state", args, CALL_LIMIT).await });
        if bad == "no such sim" {
            // A destroy of another simulation, sent meanwhile, is not held up by it.
            tokio::time::sleep(Duration::from_millis(200)).await;
            match attempt(&ca, "destroy_simulation", json!({"sim_id": other}), CALL_LIMIT).await {
                Outcome::Ok(_) => {}
                o => panic!("a destroy sent while {bad:?} was asked for: {o:?}"),
            }
        }
        match asked.await.unwrap() {
            Outcome::Refused(got) => assert_eq!(got, want, "sim_id {bad:?}: the cluster node and an embedded server differ"),
            o => panic!("sim_id {bad:?}: {o:?}"),
        }
    }
}
