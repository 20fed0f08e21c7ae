//! Any node answers any call (routing): the equivalence script (equivalence.rs) runs in
//! lockstep against an embedded server and against three cluster nodes whose calls are spread
//! round-robin, as a load balancer with no affinity spreads them — call i to node i mod 3.
//! Simulations are then owned all over the cluster (each is created on the node the call
//! reached, a fork on its parent's owner), so most calls are forwarded to another node; the
//! replies must still be the embedded server's, reply for reply, and every simulation's
//! exported log must replay and be the embedded log, event for event.
//!
//! Twice: with one 2025-11-25 session on each node (a session lives on its node, its calls
//! touch simulations owned anywhere), and with stateless 2026-07-28 requests over plain HTTP
//! (no session at all: every request may land on any node; the embedded side is called the
//! same way, so only the backend differs).

use crate::common::Server;
use crate::equivalence::{assert_exports_match, lockstep};
use crate::lockstep::Side;
use crate::nats::NatsCluster;
use crate::nodes::{shared_workspace, Node};

/// The nodes the calls are spread over.
const NODES: [&str; 3] = ["a", "b", "c"];

/// How the calls reach the servers.
#[derive(Clone, Copy, PartialEq)]
enum Clients {
    /// One MCP session per node (and one on the embedded server).
    Sessions,
    /// Stateless 2026-07-28 requests (to the embedded server too).
    Stateless,
}

/// The script against an embedded server and three nodes called round-robin, then every live
/// simulation exported, replayed and compared with its embedded twin.
async fn round_robin_matches_embedded(clients: Clients) {
    let seed = crate::common::hard::seed();
    let nats = NatsCluster::start();
    let emb_dir = tempfile::tempdir().unwrap();
    let embedded = Server::start(emb_dir.path(), &[]);
    embedded.copy_fixtures();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let nodes: Vec<Node> = NODES.iter().map(|n| Node::start(root.path(), n, &nats, &workspace, &[])).collect();
    // The workspace is shared: one copy serves every node.
    nodes[0].server().copy_fixtures();
    let servers: Vec<&Server> = nodes.iter().map(Node::server).collect();

    let (a, b) = match clients {
        Clients::Sessions => {
            let mut sessions = Vec::new();
            for n in &nodes {
                sessions.push(n.client().await);
            }
            (Side::new("embedded", &embedded, embedded.client().await), Side::round_robin("three nodes, a session on each", &servers, sessions))
        }
        Clients::Stateless => (Side::stateless("embedded, stateless", &[&embedded]), Side::stateless("three nodes, stateless", &servers)),
    };
    let started = std::time::Instant::now();
    let (run, live) = lockstep(a, b, seed).await;
    assert!(run.calls >= 500);
    eprintln!("{} calls round-robin over {} nodes in {:?}", run.calls, NODES.len(), started.elapsed());

    // Every server stops first, so that buffered reads are in the logs (as in equivalence.rs).
    embedded.terminate();
    for mut n in nodes {
        n.terminate();
    }
    assert_exports_match(&nats, &run, &live, emb_dir.path());
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn three_sessions_round_robin_answer_as_embedded() {
    round_robin_matches_embedded(Clients::Sessions).await;
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn stateless_requests_round_robin_answer_as_embedded() {
    round_robin_matches_embedded(Clients::Stateless).await;
}
