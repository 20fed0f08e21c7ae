//! One client cannot sink the others (docs/guarantees.md "Isolation"): each attack a client can
//! make with a small request is refused quickly or made harmless — a huge unknown parameter
//! name, hundreds of calls parked on one busy simulation, a batch of reads whose reply would
//! be hundreds of megabytes, a batch of step calls each due a snapshot, a sweep of many forks,
//! and a refused call that would have created folders.

use std::sync::Arc;

use crate::common;

use common::Server;
use serde_json::{json, Value};

/// `n` static boxes in a row (calls for a batch).
fn boxes(n: usize, mass: f64) -> Vec<Value> {
    (0..n)
        .map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [(i % 100) as f64 * 0.3, (i / 100) as f64 * 0.3, 0.1], "mass": mass}}))
        .collect()
}

/// The server's peak resident memory so far, in KiB (Linux's VmHWM).
fn peak_rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc status");
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).expect("VmHWM");
    line.split_whitespace().nth(1).and_then(|n| n.parse().ok()).expect("a number of kB")
}

#[tokio::test(flavor = "multi_thread")]
async fn a_four_megabyte_parameter_name_is_refused_in_one_short_sentence() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let mut args = serde_json::Map::new();
    args.insert("x".repeat(4_150_000), json!(1));
    let why = c.try_call("generate_revolute_joint", Value::Object(args)).await.unwrap_err();
    assert!(why.len() < 1024, "the refusal repeats the name: {} bytes", why.len());
    assert!(why.starts_with("Unknown parameter `xxxx") && why.contains("(4150000 characters)"), "{why}");
    // A near miss still gets its suggestion.
    let sim = c.new_sim(json!({})).await;
    let why = c.try_call("step_simulation", json!({"sim_id": sim, "step": 1})).await.unwrap_err();
    assert!(why.contains("did you mean `steps`"), "{why}");
}

#[tokio::test(flavor = "multi_thread")]
async fn calls_parked_on_a_busy_simulation_are_bounded_and_hold_up_no_other() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-waiting", "8"]);
    let c = Arc::new(server.client().await);
    let busy = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": busy, "calls": boxes(100, 1.0)})).await;
    // A step that runs for many seconds (the server is killed at the end of the test).
    let stepping = {
        let (c, busy) = (c.clone(), busy.clone());
        tokio::spawn(async move { c.try_call("step_simulation", json!({"sim_id": busy, "steps": 1_000_000})).await })
    };
    // Until the step holds the simulation, a read answers at once.
    loop {
        let c2 = server.client().await;
        let parked = tokio::spawn({
            let busy = busy.clone();
            async move { c2.try_call("get_history", json!({"sim_id": busy})).await }
        });
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
        if !parked.is_finished() {
            break;
        }
    }
    let mut parked = tokio::task::JoinSet::new();
    for _ in 0..40 {
        let (c, busy) = (c.clone(), busy.clone());
        parked.spawn(async move { c.try_call("get_history", json!({"sim_id": busy})).await });
    }
    // Past the bound, refused at once, saying who holds it (the calls in the queue wait for
    // the step, so only the refusals are awaited).
    let mut refused = 0;
    while refused < 32 {
        match parked.join_next().await.expect("a parked call").expect("its task") {
            Err(why) => {
                assert!(why.contains(&format!("Simulation {busy} is busy with step_simulation")) && why.contains("--max-waiting 8"), "{why}");
                refused += 1;
            }
            Ok(_) => panic!("a parked call was answered while the step ran"),
        }
    }
    // Everything else goes on while the step runs.
    let other = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": other, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    c.step(&other, 10).await;
    let listed = c.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"].as_array().unwrap().len(), 2, "{listed}");
    assert!(!stepping.is_finished(), "the long step ended before the other calls were answered: the test proves nothing");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_of_reads_over_the_reply_budget_is_refused_before_it_runs() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": sim, "calls": boxes(500, 0.0)})).await;
    let before = common::hard::fingerprint(&c, &sim).await;
    let reads: Vec<Value> = (0..200).map(|_| json!({"tool": "get_simulation_info", "arguments": {}})).collect();
    let why = c.try_call("batch", json!({"sim_id": sim, "calls": reads})).await.unwrap_err();
    assert!(why.contains("200 get_simulation_info reads of 500 objects") && why.contains("at most") && why.contains("fit in one batch"), "{why}");
    common::hard::assert_unchanged(&c, &sim, &before, "a batch of reads priced over the budget").await;
    // Reads that the price lets through but whose results pass the budget stop at the first
    // that would: the sentence names it.
    let one = c.call("get_simulation_info", json!({"sim_id": sim})).await.to_string().len();
    let n = (1 << 20) / one + 2;
    assert!(n * 500 * 60 < (1 << 20), "{n} reads of {one} bytes are refused by their price already");
    let before = common::hard::fingerprint(&c, &sim).await;
    let reads: Vec<Value> = (0..n).map(|_| json!({"tool": "get_simulation_info", "arguments": {}})).collect();
    let why = c.try_call("batch", json!({"sim_id": sim, "calls": reads})).await.unwrap_err();
    assert!(why.contains("(get_simulation_info) was refused") && why.contains("send calls[.."), "{why}");
    common::hard::assert_unchanged(&c, &sim, &before, "a batch of reads over the budget").await;
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_of_step_calls_takes_one_snapshot_not_one_per_call() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": sim, "calls": boxes(2_000, 0.0)})).await;
    let snapshots = || {
        let path = server.data.join(format!("{sim}.sqlite"));
        let db = rusqlite::Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY).unwrap();
        db.query_row("SELECT count(*) FROM snapshots", [], |r| r.get::<_, i64>(0)).unwrap()
    };
    let before = snapshots();
    // Each call's 60 steps × 2,000 bodies is past the snapshot interval on its own.
    let steps: Vec<Value> = (0..40).map(|_| json!({"tool": "step_simulation", "arguments": {"steps": 60}})).collect();
    let out = c.call("batch", json!({"sim_id": sim, "calls": steps})).await;
    assert_eq!(out["results"].as_array().unwrap().len(), 40);
    assert_eq!(snapshots() - before, 1, "a batch writes one snapshot at its end");
    // The log folds to the same hash from that snapshot and from the start.
    let verified = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(verified["ok"], json!(true), "{verified}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_sweep_holds_one_fork_per_worker_not_one_per_variant() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": sim, "calls": boxes(1_000, 1.0)})).await;
    c.step(&sim, 1).await;
    let start = peak_rss_kib(server.pid());
    let variants: Vec<Value> = (0..96).map(|i| json!([{"tool": "set_object_velocity", "arguments": {"object_id": 0, "linear_velocity": [i as f64 * 0.01, 0, 0]}}])).collect();
    let out = c.call("run_sweep", json!({"sim_id": sim, "variants": variants, "steps": 1, "observe": {"object_ids": [0]}})).await;
    assert_eq!(out["variants"].as_array().unwrap().len(), 96);
    let grew_mib = (peak_rss_kib(server.pid()) - start) / 1024;
    // 96 forks of this world held at once come to ~450 MiB; one per worker to a few dozen.
    assert!(grew_mib < 150, "the sweep's peak memory grew by {grew_mib} MiB");
    // Kept forks are priced too: more than fit are refused before any runs.
    let server2 = Server::start(&dir.path().join("b"), &["--max-request-bytes", "20000000"]);
    let c2 = server2.client().await;
    let sim2 = c2.new_sim(json!({})).await;
    c2.call("batch", json!({"sim_id": sim2, "calls": boxes(1_000, 1.0)})).await;
    let few: Vec<Value> = (0..4).map(|_| json!([])).collect();
    let why = c2.try_call("run_sweep", json!({"sim_id": sim2, "variants": few, "steps": 1, "keep": true})).await.unwrap_err();
    assert!(why.contains("keep at most") && why.contains("--max-request-bytes"), "{why}");
    assert_eq!(c2.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), 1);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_refused_call_creates_no_folder() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    c.step(&sim, 5).await;
    let why = c.try_call("render_animation", json!({"sim_id": sim, "to_seq": 99999, "output_path": "anim/deep/a.gif"})).await.unwrap_err();
    assert!(why.contains("99999"), "{why}");
    let why = c.try_call("get_camera_image", json!({"sim_id": sim, "width": 0, "height": 10, "output_path": "pics/deep/a.png"})).await.unwrap_err();
    assert!(why.contains("width"), "{why}");
    assert!(!server.workspace.join("anim").exists() && !server.workspace.join("pics").exists(), "a refused call made folders");
    // Accepted, the same call makes its folders.
    c.call("get_camera_image", json!({"sim_id": sim, "width": 16, "height": 12, "output_path": "pics/deep/a.png"})).await;
    assert!(server.workspace.join("pics/deep/a.png").exists());
}
