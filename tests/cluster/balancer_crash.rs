//! The owner dies behind a load balancer: a client streams calls round-robin over three nodes
//! (a session on each; most calls reach a node that does not own the simulation and are
//! forwarded to the one that does), and the owner — whichever node holds the lease, read from
//! the lease bucket — is killed -9 mid-stream, 20 times (`PHYSICS_BALANCER_KILLS`; `.ci/run`
//! sets 10 to save CI a minute), then restarted so three nodes stay up.
//! After each kill the balancer sends to the two live nodes only, and every call sent after the
//! kill must be answered: it waits for the dead owner's lease to lapse and is served by the
//! node that takes the simulation over (no refusal, no retry). A call in flight at the kill may
//! be lost (it was on the owner) or refused with "stopped answering" (it was forwarded to the
//! owner): its fate is unknown. No acknowledged call may be missing from the exported log.
//! The time from the kill to the first answer to a call sent after it (the lease lapsing, the
//! takeover, the call) is printed as p50/p99.

use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use rand::Rng;
use serde_json::json;

use crate::common::hard::{rng, seed};
use crate::common::Client;
use crate::ledger::{ground, Ledger, Stream};
use crate::nats::{Leases, NatsCluster};
use crate::nodes::{attempt, events, export_and_verify, percentile_ms, shared_workspace, stopped_answering, wait_exited, Node, Outcome};

/// Owner kills, unless `PHYSICS_BALANCER_KILLS` says how many.
const ROUNDS: usize = 20;
/// The lease every node runs with, in ms.
const LEASE_MS: &str = "1000";
/// The nodes behind the balancer.
const NODES: [&str; 3] = ["a", "b", "c"];
/// A call's bound: a call to a live node is answered within it, a call that waits for a dead
/// owner's lease (1 s) to lapse and for the takeover included.
const CALL_LIMIT: Duration = Duration::from_secs(15);
/// Calls answered after each kill before the round ends (each live node gets several).
const ANSWERED_AFTER_KILL: usize = 6;

/// The index of the node named `name`.
fn index_of(nodes: &[Node], name: &str) -> usize {
    nodes.iter().position(|n| n.name == name).unwrap_or_else(|| panic!("the lease holder {name:?} is none of the nodes"))
}

/// Accepted add_box changes of the log's own (the ground included).
fn boxes_in(events: &[physics_mcp::log::sqlite::Event]) -> usize {
    events.iter().filter(|e| e.ok && !e.inherited && e.tool == "add_box" && e.kind == physics_mcp::log::sqlite::Kind::Change).count()
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn owners_killed_behind_a_round_robin_balancer_lose_no_acknowledged_call() {
    let mut rng = rng(seed());
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let lease = ["--lease-ms", LEASE_MS];
    let mut nodes: Vec<Node> = NODES.iter().map(|n| Node::start(root.path(), n, &nats, &workspace, &lease)).collect();
    let mut clients: Vec<Client> = Vec::new();
    for n in &nodes {
        clients.push(n.client().await);
    }
    let leases = Leases::open(&nats.urls()).await;

    let sim = clients[0].new_sim(json!({})).await;
    let (mut stream, mut ledger) = (Stream::new(&sim), Ledger::default());
    ground(&clients[0], &sim, &mut ledger).await;
    let mut first_answers = Vec::new();
    let mut turn = 0usize;
    let mut in_flight_unknown = 0;
    let rounds = std::env::var("PHYSICS_BALANCER_KILLS").ok().and_then(|s| s.parse().ok()).unwrap_or(ROUNDS);
    for round in 0..rounds {
        let owner = index_of(&nodes, &leases.wait_holder(&sim, Duration::from_secs(10)).await);
        // The kill, from a timer while calls stream; `killed_at` is set once the process has
        // exited (its sockets closed: every peer can see it is gone).
        let killed_at: Arc<OnceLock<Instant>> = Arc::default();
        let (pid, after, at) = (nodes[owner].pid(), Duration::from_millis(rng.gen_range(200..900)), killed_at.clone());
        let timer = std::thread::spawn(move || {
            std::thread::sleep(after);
            // Not `signal`, which panics if the process is gone: it is when the test failed
            // (and reaped its nodes) before the timer fired, and a second panic hides the first.
            let sent = std::process::Command::new("kill").args(["-KILL", &pid.to_string()]).status().is_ok_and(|s| s.success());
            if sent {
                wait_exited(pid);
                at.set(Instant::now()).unwrap();
            }
        });

        let (mut answered_after, mut first_answer, mut calls) = (0, None, 0);
        while answered_after < ANSWERED_AFTER_KILL {
            let killed = killed_at.get().copied();
            // (The timer sets `killed_at` before it finishes: asked in this order, no race.)
            assert!(!timer.is_finished() || killed_at.get().is_some(), "round {round}: the owner {} had exited before it was killed", nodes[owner].name);
            let to = turn % NODES.len();
            turn += 1;
            if killed.is_some() && to == owner {
                continue; // the balancer has taken the dead node out
            }
            let (tool, args) = stream.next_call();
            calls += 1;
            let outcome = attempt(&clients[to], tool, args.clone(), CALL_LIMIT).await;
            let node = &nodes[to].name;
            match (&outcome, killed) {
                // Sent after the kill: must be answered.
                (Outcome::Ok(_), Some(k)) => {
                    answered_after += 1;
                    first_answer.get_or_insert(k.elapsed());
                }
                (other, Some(k)) => panic!(
                    "round {round}: node {node} answered {tool} {args}, sent after the owner {} was killed, with {other:?} {:?} after the kill",
                    nodes[owner].name,
                    k.elapsed()
                ),
                // Sent before the kill (or while it happened).
                (Outcome::Ok(_), None) => {}
                (Outcome::Lost(_), None) if to == owner => in_flight_unknown += 1,
                (Outcome::Refused(e), None) if to != owner && stopped_answering(e) => in_flight_unknown += 1,
                (other, None) => panic!("round {round}: node {node} answered {tool} {args} with {other:?} (the owner {} was being killed)", nodes[owner].name),
            }
            ledger.record(tool, &outcome);
        }
        timer.join().expect("kill timer");
        let took = first_answer.expect("an answer after the kill");
        let holder = leases.wait_holder(&sim, Duration::from_secs(10)).await;
        eprintln!("round {round}: owner {} killed, {calls} calls this round, first answer {took:?} after the kill, now held by {holder}", nodes[owner].name);
        assert_ne!(holder, nodes[owner].name, "the killed node holds the lease again");
        first_answers.push(took);
        nodes[owner].kill9();
        nodes[owner].restart();
        clients[owner] = nodes[owner].client().await;
    }

    let c = &clients[turn % NODES.len()];
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "balancer_crash");
    let log = events(&file);
    ledger.assert_in_log(&log);
    let objects = info["objects"].as_array().map_or(0, Vec::len);
    assert_eq!(objects, boxes_in(&log), "objects in the simulation vs add_box changes in its log");
    assert_eq!(summary["final_hash"], info["state_hash"], "the exported log's final state is the simulation's");
    assert!(ledger.acked() >= rounds * ANSWERED_AFTER_KILL, "only {} calls were acknowledged in {rounds} rounds", ledger.acked());

    first_answers.sort();
    eprintln!(
        "first answer after kill -9 of the owner behind a round-robin balancer ({rounds} kills, 3 nodes, lease {LEASE_MS} ms): \
         p50 {:.0} ms, p99 {:.0} ms, max {:.0} ms; {} calls acknowledged, {} unknown ({in_flight_unknown} in flight at a kill)",
        percentile_ms(&first_answers, 50.0),
        percentile_ms(&first_answers, 99.0),
        percentile_ms(&first_answers, 100.0),
        ledger.acked(),
        ledger.unknown()
    );
}
