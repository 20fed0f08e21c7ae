//! What a destroy leaves, and what a read of a simulation being destroyed does, and
//! what it must not leave behind. An `export` reading a simulation's subject when the simulation
//! is destroyed ends (it hung forever, waiting for messages the purge removed). A destroyed
//! simulation leaves no index entry behind, even right after a change (whose index write is
//! not awaited); no ownership record (nothing per simulation is renewed for it); and none of
//! its commit envelopes in the object store — while the snapshots it shares with a fork stay,
//! so the fork is still served after its parent is gone.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

use crate::nats::{Leases, NatsCluster, NAMESPACE};
use crate::nodes::{attempt, listed_ids, shared_workspace, signal, Node, Outcome};

/// Commits the exported simulation holds (each a message its subject's reader waits for).
const COMMITS: usize = 3000;
/// The most an export may take here before it is judged hung.
const EXPORT_LIMIT: Duration = Duration::from_secs(90);

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn an_export_of_a_simulation_destroyed_while_it_reads_ends() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let c = a.client().await;
    let sim = c.new_sim(json!({})).await;
    // Many commits (one message each), made by a few clients at once.
    let writers: Vec<_> = (0..3)
        .map(|_| {
            let sim = sim.clone();
            let node = a.server().url.clone();
            tokio::spawn(async move {
                let c = crate::common::Client::connect(&node).await;
                for _ in 0..COMMITS / 3 {
                    c.call("step_simulation", json!({"sim_id": sim, "steps": 1})).await;
                }
            })
        })
        .collect();
    for w in writers {
        w.await.unwrap();
    }
    let out = root.path().join("out.sqlite");
    let mut export = Command::new(crate::common::bin())
        .args(["export", &nats.urls(), &sim, out.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run export");
    // Run in slices of a few milliseconds (SIGCONT, SIGSTOP) until it has begun reading the
    // subject (its bytes read, /proc/PID/io, past what connecting takes) — then, frozen, the
    // simulation is destroyed, and it is thawed: the rest of what it set out to read is gone.
    let subject_bytes = nats.busiest_stream_bytes();
    let started = Instant::now();
    signal(export.id(), "STOP");
    loop {
        if bytes_read(export.id()) > (subject_bytes / 40).max(64 * 1024) {
            break;
        }
        assert!(started.elapsed() < Duration::from_secs(120), "the export never began reading");
        if let Some(status) = export.try_wait().unwrap() {
            let out = export.wait_with_output().unwrap();
            panic!("the export ended ({status}) before it could be caught reading: {}", String::from_utf8_lossy(&out.stderr));
        }
        signal(export.id(), "CONT");
        std::thread::sleep(Duration::from_millis(2));
        signal(export.id(), "STOP");
    }
    match attempt(&c, "destroy_simulation", json!({"sim_id": sim}), Duration::from_secs(60)).await {
        Outcome::Ok(_) => {}
        o => panic!("destroy: {o:?}"),
    }
    signal(export.id(), "CONT");
    let thawed = Instant::now();
    let status = loop {
        if let Some(status) = export.try_wait().unwrap() {
            break status;
        }
        if thawed.elapsed() > EXPORT_LIMIT {
            let _ = export.kill();
            panic!("export still reads {EXPORT_LIMIT:?} after the simulation it reads was destroyed");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    let output = export.wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&output.stderr).into_owned();
    eprintln!("export ended {:?} after the thaw ({status}): {said}", thawed.elapsed());
    if !status.success() {
        assert!(said.contains("no log"), "the export failed for another reason: {said}");
    }
}

/// The reader every takeover, export and sweep materialisation uses, given the end a subject
/// had a moment ago, when the subject was purged since (a destroy between the two): it ends,
/// saying the subject no longer reaches that end (it waited forever for the purged messages).
#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_subject_read_to_an_end_a_destroy_purged_ends() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let c = a.client().await;
    let sim = c.new_sim(json!({})).await;
    for _ in 0..20 {
        c.step(&sim, 1).await;
    }
    let mut config = physics_mcp::cluster::ClusterConfig::new(&nats.urls(), "reader");
    config.serves = false;
    let reader = tokio::task::spawn_blocking(|| physics_mcp::cluster::Cluster::connect(config).expect("connect")).await.unwrap();
    let last = {
        let (reader, sim) = (reader.clone(), sim.clone());
        tokio::task::spawn_blocking(move || reader.last_sequence(&sim)).await.unwrap().unwrap()
    };
    assert!(last > 0);
    c.call("destroy_simulation", json!({"sim_id": sim})).await;
    let read = {
        let sim = sim.clone();
        tokio::task::spawn_blocking(move || reader.records_up_to(&sim, last))
    };
    match tokio::time::timeout(Duration::from_secs(120), read).await {
        Ok(got) => assert!(matches!(got.unwrap(), Ok(None)), "a read to an end that was purged should say it is gone"),
        Err(_) => panic!("a read of {sim}'s subject up to seq {last}, purged since, still waits after 120 s"),
    }
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_destroyed_simulation_leaves_no_index_entry_record_or_envelope() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let a = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let b = Node::start(root.path(), "b", &nats, &workspace, &[]);
    let (ca, cb) = (a.client().await, b.client().await);

    // A change and a destroy back to back, many times: the change's index write (not awaited)
    // must not land after the destroy's removal of the entry.
    let mut gone = Vec::new();
    for _ in 0..40 {
        let sim = ca.new_sim(json!({})).await;
        // Its outcome does not matter (the destroy may come first); its index write does.
        let change = ca.try_call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]}));
        let (_, destroyed) = tokio::join!(change, async {
            tokio::time::sleep(Duration::from_millis(1)).await;
            attempt(&ca, "destroy_simulation", json!({"sim_id": sim}), Duration::from_secs(60)).await
        });
        assert!(matches!(destroyed, Outcome::Ok(_)), "{destroyed:?}");
        gone.push(sim);
    }
    tokio::time::sleep(Duration::from_secs(1)).await;
    let listed = listed_ids(&cb).await;
    let ghosts: Vec<&String> = gone.iter().filter(|id| listed.contains(id)).collect();
    assert!(ghosts.is_empty(), "destroyed simulations still listed by the index: {ghosts:?}");

    // A simulation with a commit too large for a message (its envelope in the object store)
    // and a fork (which copies its snapshots): destroyed, it leaves no envelope and no
    // ownership record, and the fork is still served whole.
    let sim = ca.new_sim(json!({})).await;
    let calls: Vec<Value> = (0..2000).map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.05, 0.05, 0.05], "position": [(i % 50) as f64 * 0.2, (i / 50) as f64 * 0.2, 1.0]}})).collect();
    ca.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let fork = ca.call("fork_simulation", json!({"sim_id": sim}))
        .await["simulation_id"]
        .as_str()
        .unwrap()
        .to_string();
    let envelopes_before = envelopes(&nats).await;
    assert!(!envelopes_before.is_empty(), "the batch's commit should be an envelope in the object store");
    ca.call("destroy_simulation", json!({"sim_id": sim})).await;
    let leases = Leases::open(&nats.urls()).await;
    assert_eq!(leases.holder(&sim).await, None, "a destroyed simulation still has an owner");
    assert!(!leases.has_record(&sim).await, "a destroyed simulation left its ownership record");
    let after = envelopes(&nats).await;
    assert!(after.len() < envelopes_before.len(), "the destroyed simulation's envelope is still in the object store: {after:?}");
    // The fork's snapshots are content-addressed and shared with its parent: they stayed, so
    // the fork is taken over whole by another node once its owner is gone.
    drop(ca);
    let mut a = a;
    a.kill9();
    match attempt(&cb, "verify_simulation", json!({"sim_id": fork}), Duration::from_secs(60)).await {
        Outcome::Ok(v) => assert_eq!(v["ok"], json!(true), "{v}"),
        o => panic!("the fork after its parent's destruction and its owner's death: {o:?}"),
    }
}

/// Bytes process `pid` has read so far (files and sockets: `rchar` of /proc/PID/io).
fn bytes_read(pid: u32) -> u64 {
    let io = std::fs::read_to_string(format!("/proc/{pid}/io")).unwrap_or_default();
    io.lines().find_map(|l| l.strip_prefix("rchar: ")).and_then(|v| v.trim().parse().ok()).unwrap_or(0)
}

/// The names of the commit envelopes (`env/…`) in the namespace's object store.
async fn envelopes(nats: &NatsCluster) -> Vec<String> {
    use futures_util::StreamExt;
    let addrs: Vec<async_nats::ServerAddr> = nats.urls().split(',').map(|u| u.parse().unwrap()).collect();
    let js = async_nats::jetstream::new(async_nats::connect(addrs).await.unwrap());
    let store = js.get_object_store(format!("{NAMESPACE}_objects")).await.unwrap();
    let mut list = store.list().await.unwrap();
    let mut names = Vec::new();
    while let Some(o) = list.next().await {
        let o = o.unwrap();
        if o.name.starts_with("env/") && !o.deleted {
            names.push(o.name);
        }
    }
    names
}
