//! A node that owns a busy simulation dies (kill -9, mid-stream) 20 times; each time the call
//! then sent to the other node waits for the dead owner's lease to lapse and is answered by
//! that node, which has taken the simulation over (routing: no refusal naming the dead owner,
//! no retrying by the client), and no acknowledged call is lost. Takeover time (kill to the
//! survivor's answer) is printed as p50/p99.

use std::time::{Duration, Instant};

use rand::Rng;
use serde_json::json;

use crate::common::hard::{rng, seed};
use crate::common::Client;
use crate::ledger::{ground, Ledger, Stream};
use crate::nats::NatsCluster;
use crate::nodes::{attempt, events, export_and_verify, percentile_ms, shared_workspace, signal, Node, Outcome};

/// Owner kills.
const ROUNDS: usize = 20;
/// The lease both nodes run with, in ms.
const LEASE_MS: &str = "1000";
/// A survivor must have taken over within this long after the kill.
const TAKEOVER_WITHIN: Duration = Duration::from_secs(30);
/// A call to a live node answers within this (a lost call is one that did not); a call that
/// waits for a dead owner's lease to lapse is answered well within it.
const CALL_LIMIT: Duration = Duration::from_secs(15);

/// Streams the ledger's calls to the owner until a call gets no answer, while a timer thread
/// kill -9s the owner `after` from now; returns when the kill happened.
async fn stream_until_killed(c: &Client, pid: u32, after: Duration, stream: &mut Stream, ledger: &mut Ledger) -> Instant {
    let timer = std::thread::spawn(move || {
        std::thread::sleep(after);
        signal(pid, "KILL");
        Instant::now()
    });
    loop {
        let (tool, args) = stream.next_call();
        let outcome = attempt(c, tool, args.clone(), CALL_LIMIT).await;
        if let Outcome::Refused(e) = &outcome {
            panic!("the owner refused {tool} {args}: {e}");
        }
        ledger.record(tool, &outcome);
        if let Outcome::Lost(_) = outcome {
            break;
        }
    }
    timer.join().expect("kill timer")
}

/// Sends the stream's next call to `survivor`, once: it must wait for the dead owner's lease to
/// lapse and then be answered (the survivor took the simulation over). Returns the time from
/// `killed_at` to the answer.
async fn take_over(survivor: &Node, killed_at: Instant, stream: &mut Stream, ledger: &mut Ledger) -> Duration {
    let c = survivor.client().await;
    let (tool, args) = stream.next_call();
    let outcome = attempt(&c, tool, args.clone(), CALL_LIMIT).await;
    let took = killed_at.elapsed();
    match &outcome {
        Outcome::Ok(_) => {}
        other => panic!("node {} answered {tool} {args}, sent after the owner was killed, with {other:?} {took:?} after the kill", survivor.name),
    }
    ledger.record(tool, &outcome);
    assert!(took < TAKEOVER_WITHIN, "node {} took {took:?} after the kill to answer", survivor.name);
    took
}

/// Accepted add_box changes of the log's own (the ground included).
fn boxes_in(events: &[physics_mcp::log::sqlite::Event]) -> usize {
    events.iter().filter(|e| e.ok && !e.inherited && e.tool == "add_box" && e.kind == physics_mcp::log::sqlite::Kind::Change).count()
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_killed_owner_is_taken_over_and_no_acknowledged_call_is_lost() {
    let mut rng = rng(seed());
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let lease = ["--lease-ms", LEASE_MS];
    let mut nodes = [Node::start(root.path(), "a", &nats, &workspace, &lease), Node::start(root.path(), "b", &nats, &workspace, &lease)];

    let first = nodes[0].client().await;
    let sim = first.new_sim(json!({})).await;
    let (mut stream, mut ledger) = (Stream::new(&sim), Ledger::default());
    ground(&first, &sim, &mut ledger).await;
    drop(first);
    let mut takeovers = Vec::new();
    let mut owner = 0;
    for round in 0..ROUNDS {
        let c = nodes[owner].client().await;
        let after = Duration::from_millis(rng.gen_range(200..900));
        let killed_at = stream_until_killed(&c, nodes[owner].pid(), after, &mut stream, &mut ledger).await;
        drop(c);
        nodes[owner].kill9();
        let survivor = 1 - owner;
        let took = take_over(&nodes[survivor], killed_at, &mut stream, &mut ledger).await;
        eprintln!("round {round}: node {} killed, node {} took over in {took:?}", nodes[owner].name, nodes[survivor].name);
        takeovers.push(took);
        nodes[owner].restart();
        owner = survivor;
    }

    let c = nodes[owner].client().await;
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "owner_crash");
    let log = events(&file);
    ledger.assert_in_log(&log);
    let objects = info["objects"].as_array().map_or(0, Vec::len);
    assert_eq!(objects, boxes_in(&log), "objects in the simulation vs add_box changes in its log");
    assert_eq!(summary["final_hash"], info["state_hash"], "the exported log's final state is the simulation's");
    assert!(ledger.acked() >= ROUNDS, "only {} calls were acknowledged in {ROUNDS} rounds", ledger.acked());

    takeovers.sort();
    eprintln!(
        "takeover after kill -9 ({ROUNDS} kills, lease {LEASE_MS} ms): p50 {:.0} ms, p99 {:.0} ms, max {:.0} ms; {} calls acknowledged, {} unknown",
        percentile_ms(&takeovers, 50.0),
        percentile_ms(&takeovers, 99.0),
        percentile_ms(&takeovers, 100.0),
        ledger.acked(),
        ledger.unknown()
    );
}
