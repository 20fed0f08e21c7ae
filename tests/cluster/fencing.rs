//! A paused owner cannot write behind its successor's back. Node A owns a simulation and is
//! streaming calls when it is frozen (SIGSTOP) for at least 3 s; node B takes the simulation
//! over and changes it; A is thawed (SIGCONT). A must then answer nothing stale — with routing
//! its calls on the simulation are forwarded to B, the new owner, and land exactly once in B's
//! log — and no append A had prepared as owner may land: not even the call A had in hand when
//! it froze (its fate is a refusal that wrote nothing, or an answer whose one event is in the
//! log). The exported log replays, its events strictly in sequence.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::common::Client;
use crate::nats::NatsCluster;
use crate::nodes::{attempt, event_args, events, export_and_verify, shared_workspace, signal, stopped_answering, Node, Outcome};
use physics_mcp::log::sqlite::{Event, Kind};

/// The lease both nodes run with, in ms.
const LEASE_MS: &str = "1000";
/// A stays frozen at least this long (three leases).
const FROZEN_AT_LEAST: Duration = Duration::from_secs(3);
/// B must have taken over within this after the freeze.
const TAKEOVER_WITHIN: Duration = Duration::from_secs(20);
/// Long enough for a call that waited out the freeze to be answered.
const CALL_LIMIT: Duration = Duration::from_secs(30);
/// x of the first box B adds when it takes over (each further attempt 1 lower); A's stream
/// uses x >= 10.
const B_TAG: f64 = -7.0;
/// The first x of A's stream.
const A_TAG: f64 = 10.0;
/// The radius of the sphere the thawed A is asked to add (found in the log by it).
const LATE_RADIUS: f64 = 0.123;

/// An add_box whose position's x tells which call it was.
fn tagged_box(sim: &str, x: f64) -> Value {
    json!({"sim_id": sim, "dimensions": [0.05, 0.05, 0.05], "position": [x, 0, 0.1], "mass": 0})
}

/// The x an add_box event was tagged with.
fn tag(e: &Event) -> Option<f64> {
    (e.tool == "add_box").then(|| event_args(e)["position"][0].as_f64()).flatten()
}

/// One call of a tagged stream: its tag, when it was sent and answered, and its outcome.
struct Sent {
    x: f64,
    sent: Instant,
    answered: Instant,
    outcome: Outcome,
}

/// A's stream: tagged add_boxes back to back (so the freeze most likely catches A inside a
/// call, between its lease check and its append), until `stop`.
async fn stream_on_a(c: Client, sim: String, stop: Arc<Mutex<bool>>) -> Vec<Sent> {
    let mut calls = Vec::new();
    for i in 0.. {
        if *stop.lock().unwrap() {
            break;
        }
        let x = A_TAG + i as f64;
        let sent = Instant::now();
        let outcome = attempt(&c, "add_box", tagged_box(&sim, x), CALL_LIMIT).await;
        calls.push(Sent { x, sent, answered: Instant::now(), outcome });
    }
    calls
}

/// B's takeover: a tagged add_box, which waits while the frozen A's lease holds and is then
/// answered by B. A "stopped answering" refusal (B forwarded the call to the frozen A) leaves
/// its fate unknown: tried again with the next tag. Returns B's client and every attempt.
async fn take_over(b: &Node, sim: &str, frozen_at: Instant) -> (Client, Vec<Sent>) {
    let c = b.client().await;
    let mut attempts = Vec::new();
    loop {
        let x = B_TAG - attempts.len() as f64;
        let sent = Instant::now();
        let outcome = attempt(&c, "add_box", tagged_box(sim, x), CALL_LIMIT).await;
        let done = match &outcome {
            Outcome::Ok(_) => true,
            Outcome::Refused(e) if stopped_answering(e) => false,
            other => panic!("B answered its takeover call with {other:?}"),
        };
        attempts.push(Sent { x, sent, answered: Instant::now(), outcome });
        if done {
            return (c, attempts);
        }
        assert!(frozen_at.elapsed() < TAKEOVER_WITHIN, "B had not taken over {TAKEOVER_WITHIN:?} after A froze");
    }
}

/// Thaws a frozen process when dropped, so a failing test does not leave its node stopped
/// (its sockets open, its clients waiting) while the test unwinds.
struct ThawOnDrop(u32);

impl Drop for ThawOnDrop {
    fn drop(&mut self) {
        let _ = std::process::Command::new("kill").args(["-CONT", &self.0.to_string()]).status();
    }
}

/// "1.2ms before" / "3s after": when `t` was, next to `mark`.
fn relative(t: Instant, mark: Instant) -> String {
    match t.checked_duration_since(mark) {
        Some(d) => format!("{d:?} after"),
        None => format!("{:?} before", mark - t),
    }
}

/// The value of an answered call (panics with what it got otherwise).
fn answered(what: &str, outcome: Outcome) -> Value {
    match outcome {
        Outcome::Ok(v) => v,
        other => panic!("{what} on the thawed former owner must be forwarded to the new owner and answered; got {other:?}"),
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
    let _thaw = ThawOnDrop(a.pid());
    let (cb, b_calls) = take_over(&b, &sim, frozen_at).await;
    eprintln!("B took over {:?} after the freeze ({} attempts)", frozen_at.elapsed(), b_calls.len());
    tokio::time::sleep(FROZEN_AT_LEAST.saturating_sub(frozen_at.elapsed())).await;
    // A's stream ends with the call it has in hand: its fate is what the thawed A makes of it.
    *stop.lock().unwrap() = true;
    signal(a.pid(), "CONT");
    let thawed_at = Instant::now();
    let a_calls = streaming.await.unwrap();

    // The thawed A answers nothing stale: what it says of the simulation is what B says.
    let info = json!({"sim_id": sim});
    let via_a = answered("get_simulation_info", attempt(&ca, "get_simulation_info", info.clone(), CALL_LIMIT).await);
    let via_b = cb.call("get_simulation_info", info.clone()).await;
    assert_eq!((&via_a["state_hash"], &via_a["head_seq"]), (&via_b["state_hash"], &via_b["head_seq"]), "the thawed A answered a stale state");
    // Its change lands once, through B; its read is B's.
    let late_change = attempt(&ca, "add_sphere", json!({"sim_id": sim, "radius": LATE_RADIUS, "position": [0, 0, 3]}), CALL_LIMIT).await;
    let sphere = answered("add_sphere", late_change);
    let read = json!({"sim_id": sim, "object_id": sphere["object_id"]});
    let late_read = answered("get_dynamics_info", attempt(&ca, "get_dynamics_info", read.clone(), CALL_LIMIT).await);
    assert_eq!(late_read, cb.call("get_dynamics_info", read).await, "get_dynamics_info through the thawed A and through B");

    // The log agrees with what every client was told.
    let now = cb.call("get_simulation_info", info.clone()).await;
    let now_a = answered("get_simulation_info", attempt(&ca, "get_simulation_info", info.clone(), CALL_LIMIT).await);
    assert_eq!(now_a["state_hash"], now["state_hash"], "A and B disagree on the simulation after the thaw");
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "fencing");
    assert_eq!(summary["final_hash"], now["state_hash"]);
    assert_log_fenced(&events(&file), &a_calls, &b_calls, frozen_at, thawed_at);
}

/// The log's verdict. Its events are strictly in sequence (a stale append landing after the
/// takeover would repeat B's sequence numbers or break the hash chain `replay` checked). B's
/// answered takeover call is in it once, and the first of B's tags marks the takeover. Every
/// tagged call of A's and B's is in it at most once; exactly once if it was answered, not at
/// all if it was refused for any reason but "stopped answering". A call A answered before it
/// froze is before the takeover. The thawed A's sphere is in it once, after the takeover.
fn assert_log_fenced(log: &[Event], a_calls: &[Sent], b_calls: &[Sent], frozen_at: Instant, thawed_at: Instant) {
    for w in log.windows(2) {
        assert!(w[0].seq < w[1].seq, "the log's events are out of sequence: seq {} then {}", w[0].seq, w[1].seq);
    }
    let landed = |x: f64| -> Vec<&Event> { log.iter().filter(|e| e.ok && e.kind == Kind::Change && tag(e) == Some(x)).collect() };
    let b_seq = b_calls.iter().flat_map(|c| landed(c.x)).map(|e| e.seq).min().expect("none of B's takeover calls is in the log");
    for (who, calls) in [("A", a_calls), ("B", b_calls)] {
        for c in calls {
            let found = landed(c.x);
            let when = format!("sent {} the freeze, answered {} the thaw", relative(c.sent, frozen_at), relative(c.answered, thawed_at));
            match &c.outcome {
                Outcome::Ok(_) => assert_eq!(found.len(), 1, "{who} acknowledged add_box x = {} ({when}) but the log has it {} times", c.x, found.len()),
                Outcome::Refused(e) if !stopped_answering(e) => {
                    assert!(found.is_empty(), "{who}'s add_box x = {} ({when}) was refused ({e}) yet is in the log at seq {}", c.x, found[0].seq)
                }
                _ => assert!(found.len() <= 1, "{who}'s add_box x = {} ({when}), of unknown fate, is in the log {} times", c.x, found.len()),
            }
            if who == "A" && matches!(c.outcome, Outcome::Ok(_)) && c.answered < frozen_at {
                assert!(found[0].seq < b_seq, "A answered add_box x = {} before it froze, but the log has it at seq {} after B's takeover at seq {b_seq}", c.x, found[0].seq);
            }
        }
    }
    let spheres: Vec<&Event> = log.iter().filter(|e| e.ok && e.tool == "add_sphere" && event_args(e)["radius"].as_f64() == Some(LATE_RADIUS)).collect();
    assert_eq!(spheres.len(), 1, "the thawed A's add_sphere should be in the log once");
    assert!(spheres[0].seq > b_seq, "the thawed A's add_sphere is at seq {} before B's takeover at seq {b_seq}", spheres[0].seq);

    let acked = a_calls.iter().filter(|c| matches!(c.outcome, Outcome::Ok(_))).count();
    eprintln!("A's stream: {} calls, {acked} acknowledged; B took over at seq {b_seq}", a_calls.len());
    // The calls around the freeze: the last one sent before it, and every one after.
    let first = a_calls.iter().rposition(|c| c.sent < frozen_at).unwrap_or(0);
    for c in &a_calls[first..] {
        eprintln!(
            "  A's add_box x = {}, sent {} the freeze, answered {} the thaw: {:?}",
            c.x,
            relative(c.sent, frozen_at),
            relative(c.answered, thawed_at),
            c.outcome
        );
    }
    assert!(a_calls.iter().any(|c| matches!(c.outcome, Outcome::Ok(_)) && c.answered < frozen_at), "A acknowledged none of its stream before the freeze");
}
