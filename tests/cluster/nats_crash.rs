//! One of the three NATS servers (the leader of the simulation's log stream) is killed with -9
//! while a client streams calls to a node: calls may fail during the election, but they succeed
//! again within 30 s, and every call that was acknowledged is in the exported log, which replays.

use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use rand::Rng;
use serde_json::json;

use crate::common::hard::{rng, seed};
use crate::ledger::{ground, Ledger, Stream};
use crate::nats::NatsCluster;
use crate::nodes::{shared_workspace, attempt, events, export_and_verify, signal, Node, Outcome};

/// Calls acknowledged before the kill, to be sure the stream runs at full speed when it comes.
const WARM_UP: usize = 30;
/// Calls that must succeed after the kill before the test stops streaming.
const AFTER: usize = 40;
/// Calls must succeed again within this after the kill.
const RECOVER_WITHIN: Duration = Duration::from_secs(30);
/// One call's bound: past it the call counts as unknown (its node may be waiting on NATS).
const CALL_LIMIT: Duration = Duration::from_secs(15);

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn calls_resume_after_a_nats_server_dies_and_none_acknowledged_is_lost() {
    let mut rng = rng(seed());
    let mut nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let node = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let c = node.client().await;
    let sim = c.new_sim(json!({})).await;
    let (mut stream, mut ledger) = (Stream::new(&sim), Ledger::default());
    ground(&c, &sim, &mut ledger).await;
    for _ in 0..WARM_UP {
        let (tool, args) = stream.next_call();
        let outcome = attempt(&c, tool, args.clone(), CALL_LIMIT).await;
        assert!(matches!(outcome, Outcome::Ok(_)), "{tool} {args} before any kill: {outcome:?}");
        ledger.record(tool, &outcome);
    }

    // kill -9, from a timer while calls are in flight, the server leading the simulation's log
    // stream (a new stream leader must be elected before an append can succeed).
    let victim = nats.busiest_stream_leader();
    let meta = if nats.meta_leader() == victim { ", also the JetStream meta leader" } else { "" };
    eprintln!("killing nats server {} (the log stream's leader{meta})", nats.name(victim));
    let killed_at: Arc<OnceLock<Instant>> = Arc::default();
    let (pid, when, at) = (nats.pid(victim), Duration::from_millis(rng.gen_range(50..500)), killed_at.clone());
    let timer = std::thread::spawn(move || {
        std::thread::sleep(when);
        signal(pid, "KILL");
        at.set(Instant::now()).unwrap();
    });

    let (mut after, mut failed, mut recovered) = (0, 0, None);
    while after < AFTER {
        let (tool, args) = stream.next_call();
        let started = Instant::now();
        let outcome = attempt(&c, tool, args, CALL_LIMIT).await;
        ledger.record(tool, &outcome);
        let kill = killed_at.get().copied();
        match (&outcome, kill) {
            (Outcome::Ok(_), Some(k)) if started > k => {
                after += 1;
                recovered.get_or_insert(k.elapsed());
            }
            (Outcome::Ok(_), _) => {}
            (_, _) => {
                // Refused or unanswered during the election: allowed. Say the first few, and
                // back off a little as a client would.
                failed += 1;
                if failed <= 3 {
                    eprintln!("{tool} failed: {outcome:?}");
                }
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
        if let (Some(k), None) = (kill, recovered) {
            assert!(k.elapsed() < RECOVER_WITHIN, "no call succeeded within {RECOVER_WITHIN:?} of the kill ({failed} failed)");
        }
    }
    timer.join().unwrap();
    nats.kill9(victim);
    eprintln!("calls succeeded again {:?} after the kill; {failed} failed meanwhile; {} acknowledged in all", recovered.unwrap(), ledger.acked());

    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    // Export once every stream has its new leader: `export` is an operator's command, and what
    // is judged here is what the cluster kept, not whether a command retries through elections.
    nats.wait_ready();
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.live_urls(), &sim, out.path(), "nats_crash");
    ledger.assert_in_log(&events(&file));
    assert_eq!(summary["final_hash"], info["state_hash"], "the exported log's final state is the simulation's");
}
