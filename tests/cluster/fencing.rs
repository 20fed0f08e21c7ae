//! A paused owner cannot write behind its successor's back. Node A owns a simulation and is
//! streaming calls when it is frozen (SIGSTOP) for at least 3 s; node B takes the simulation
//! over and changes it; A is thawed (SIGCONT). A must then refuse calls on the simulation
//! ("is owned by node"), answering nothing stale, and the log must hold no event of A's after
//! B's takeover — not even the call A had in hand when it froze.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::common::Client;
use crate::nats::NatsCluster;
use crate::nodes::{shared_workspace, attempt, event_args, events, export_and_verify, owned_elsewhere, signal, Node, Outcome};
use physics_mcp::log::sqlite::Event;

/// The lease both nodes run with, in ms.
const LEASE_MS: &str = "1000";
/// A stays frozen at least this long (three leases).
const FROZEN_AT_LEAST: Duration = Duration::from_secs(3);
/// B must have taken over within this after the freeze.
const TAKEOVER_WITHIN: Duration = Duration::from_secs(20);
/// Long enough for a call that waited out the freeze to be answered.
const CALL_LIMIT: Duration = Duration::from_secs(30);
/// x of the box B adds when it takes over; A's stream uses x >= 10.
const B_TAG: f64 = -7.0;
/// The first x of A's stream.
const A_TAG: f64 = 10.0;

/// An add_box whose position's x tells which call it was.
fn tagged_box(sim: &str, x: f64) -> Value {
    json!({"sim_id": sim, "dimensions": [0.05, 0.05, 0.05], "position": [x, 0, 0.1], "mass": 0})
}

/// The x an add_box event was tagged with.
fn tag(e: &Event) -> Option<f64> {
    (e.tool == "add_box").then(|| event_args(e)["position"][0].as_f64()).flatten()
}

/// A's stream: tagged add_boxes back to back (so the freeze most likely catches A inside a
/// call, between its lease check and its append), until `stop`; every call's tag and outcome,
/// in order, with when it was sent.
async fn stream_on_a(c: Client, sim: String, stop: Arc<Mutex<bool>>) -> Vec<(f64, Instant, Outcome)> {
    let mut calls = Vec::new();
    for i in 0.. {
        if *stop.lock().unwrap() {
            break;
        }
        let x = A_TAG + i as f64;
        let sent = Instant::now();
        let outcome = attempt(&c, "add_box", tagged_box(&sim, x), CALL_LIMIT).await;
        calls.push((x, sent, outcome));
    }
    calls
}

/// B's takeover: its tagged add_box, retried while A's lease holds; returns B's client.
async fn take_over(b: &Node, sim: &str, frozen_at: Instant) -> Client {
    let c = b.client().await;
    loop {
        match attempt(&c, "add_box", tagged_box(sim, B_TAG), CALL_LIMIT).await {
            Outcome::Ok(_) => return c,
            Outcome::Refused(e) if owned_elsewhere(&e) => {}
            other => panic!("B answered its takeover call with {other:?}"),
        }
        assert!(frozen_at.elapsed() < TAKEOVER_WITHIN, "B had not taken over {TAKEOVER_WITHIN:?} after A froze");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// "1.2ms before" / "3s after": when `t` was, next to `mark`.
fn relative(t: Instant, mark: Instant) -> String {
    match t.checked_duration_since(mark) {
        Some(d) => format!("{d:?} after"),
        None => format!("{:?} before", mark - t),
    }
}

/// Panics unless `outcome` is a refusal saying another node owns the simulation.
fn assert_owned_elsewhere(what: &str, outcome: &Outcome) {
    match outcome {
        Outcome::Refused(e) if owned_elsewhere(e) => {}
        other => panic!("{what} on the thawed former owner must be refused as owned by another node; got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_thawed_former_owner_neither_answers_stale_nor_writes() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let lease = ["--lease-ms", LEASE_MS];
    let a = Node::start(root.path(), "a", &nats, &workspace, &lease);
    let b = Node::start(root.path(), "b", &nats, &workspace, &lease);
    let ca = a.client().await;
    let sim = ca.new_sim(json!({})).await;
    ca.ground(&sim).await;

    // A streams; freeze it mid-stream.
    let stop = Arc::new(Mutex::new(false));
    let streaming = tokio::spawn(stream_on_a(a.client().await, sim.clone(), stop.clone()));
    tokio::time::sleep(Duration::from_millis(400)).await;
    signal(a.pid(), "STOP");
    let frozen_at = Instant::now();
    let cb = take_over(&b, &sim, frozen_at).await;
    let b_state = cb.call("get_simulation_info", json!({"sim_id": sim})).await;
    tokio::time::sleep(FROZEN_AT_LEAST.saturating_sub(frozen_at.elapsed())).await;
    signal(a.pid(), "CONT");

    // The thawed A: refuses a change and a read on the simulation.
    let late_change = attempt(&ca, "add_sphere", json!({"sim_id": sim, "radius": 0.123, "position": [0, 0, 3]}), CALL_LIMIT).await;
    assert_owned_elsewhere("add_sphere", &late_change);
    let late_read = attempt(&ca, "get_dynamics_info", json!({"sim_id": sim, "object_id": 0}), CALL_LIMIT).await;
    assert_owned_elsewhere("get_dynamics_info", &late_read);
    *stop.lock().unwrap() = true;
    let a_calls = streaming.await.unwrap();

    // B still sees its own state, and the log agrees with what every client was told.
    let now = cb.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(now["state_hash"], b_state["state_hash"], "the simulation changed after B's takeover though only the thawed A was called");
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "fencing");
    assert_eq!(summary["final_hash"], now["state_hash"]);
    assert_log_fenced(&events(&file), &a_calls, frozen_at);
}

/// The log's verdict: B's takeover change is there once; every add_box A acknowledged is before
/// it; nothing tagged by A is after it; and A's thawed calls left no event at all.
fn assert_log_fenced(log: &[Event], a_calls: &[(f64, Instant, Outcome)], frozen_at: Instant) {
    let takeover: Vec<&Event> = log.iter().filter(|e| e.ok && tag(e) == Some(B_TAG)).collect();
    assert_eq!(takeover.len(), 1, "B's takeover add_box should be in the log once");
    let b_seq = takeover[0].seq;
    for e in log {
        if let Some(x) = tag(e).filter(|&x| x >= A_TAG) {
            assert!(e.seq < b_seq, "A's add_box (x = {x}) is at seq {} after B's takeover at seq {b_seq} (ok = {})", e.seq, e.ok);
        }
        assert!(!matches!(e.tool.as_str(), "add_sphere" | "get_dynamics_info"), "the thawed A's {} reached the log at seq {}", e.tool, e.seq);
    }
    for (x, sent, outcome) in a_calls {
        if let Outcome::Ok(_) = outcome {
            let found = log.iter().find(|e| e.ok && tag(e) == Some(*x));
            assert!(
                found.is_some_and(|e| e.seq < b_seq),
                "A acknowledged add_box x = {x} (sent {} the freeze) but the log has it as {found:?}",
                relative(*sent, frozen_at)
            );
        }
    }
    let acked = a_calls.iter().filter(|c| matches!(c.2, Outcome::Ok(_))).count();
    eprintln!("A's stream: {} calls, {acked} acknowledged; B took over at seq {b_seq}", a_calls.len());
    // The calls around the freeze: the last one sent before it, and every one after.
    let first = a_calls.iter().rposition(|c| c.1 < frozen_at).unwrap_or(0);
    for (x, sent, outcome) in &a_calls[first..] {
        eprintln!("  A's add_box x = {x}, sent {} the freeze: {outcome:?}", relative(*sent, frozen_at));
    }
    assert!(acked >= 1, "A acknowledged none of its stream before the freeze");
}
