//! Every recorded log in `replays/` goes into the cluster (`physics-mcp import`), takes one
//! more change there (10 steps), and comes back out (`physics-mcp export`): the exported log
//! replays, begins with the original's events unchanged, and ends with that one change. An id
//! already in the cluster is refused unless renamed with `--as`.

use std::path::{Path, PathBuf};

use serde_json::json;

use crate::common::recorded_logs;
use crate::nats::NatsCluster;
use crate::nodes::{shared_workspace, events, export_and_verify, import, import_ok, listed_ids, log_sim_id, Node};
use physics_mcp::log::sqlite::{Event, Kind};

/// A log put into the cluster: its file, the id it got there, and whether `--as` renamed it.
struct Imported {
    file: PathBuf,
    id: String,
    renamed: bool,
}

/// What must survive a round trip of one event: everything when the id is kept; with `--as`,
/// all but the fields that name the simulation (arguments, command, results) and a read's
/// result hash (it hashes a result naming the old id, which is not kept: dropped on renaming).
fn kept(e: &Event, renamed: bool) -> serde_json::Value {
    let mut v = json!({
        "seq": e.seq, "kind": e.kind.as_str(), "parent": e.parent, "tool": e.tool, "version": e.version,
        "ok": e.ok, "mutates": e.mutates, "inherited": e.inherited, "state_hash": e.state_hash,
        "engine": e.engine,
    });
    if !(renamed && e.kind == Kind::Read) {
        v["result_hash_present"] = json!(e.result_hash.is_some());
    }
    if !renamed {
        v["arguments"] = json!(e.arguments);
        v["command"] = json!(e.command);
        v["result"] = json!(e.result);
        v["result_hash"] = json!(e.result_hash);
        v["summary"] = json!(e.summary);
    }
    v
}

/// The exported log is the original plus this test's calls: the original's events unchanged,
/// then exactly one change, the 10-step step_simulation.
fn assert_extends(original: &Path, exported: &Path, renamed: bool) {
    let (before, after) = (events(original), events(exported));
    assert!(after.len() > before.len(), "{}: {} events exported, {} imported", original.display(), after.len(), before.len());
    for (x, y) in before.iter().zip(&after) {
        assert_eq!(kept(x, renamed), kept(y, renamed), "{}: event {} changed on the round trip", original.display(), x.seq);
    }
    let changes: Vec<&Event> = after[before.len()..].iter().filter(|e| matches!(e.kind, Kind::Root | Kind::Change | Kind::Move)).collect();
    assert_eq!(changes.len(), 1, "{}: the cluster's new events {:?}", original.display(), &after[before.len()..]);
    assert_eq!(changes[0].tool, "step_simulation");
    assert!(changes[0].ok && !changes[0].inherited);
}

/// Imports every recorded log (renaming an id already taken, should two share one), then
/// checks a second import of the first is refused, then imports every log again renamed with `--as`.
fn import_all(urls: &str) -> Vec<Imported> {
    let mut imported: Vec<Imported> = Vec::new();
    for file in recorded_logs() {
        let id = log_sim_id(&file);
        let renamed = imported.iter().any(|i| i.id == id);
        let id = if renamed { uuid::Uuid::new_v4().to_string() } else { id };
        import_ok(urls, &file, renamed.then_some(id.as_str()));
        imported.push(Imported { file, id, renamed });
    }
    let first = imported[0].file.clone();
    let again = import(urls, &first, None);
    assert!(!again.status.success(), "importing {} twice under the same id was accepted", first.display());
    assert!(!again.stderr.is_empty(), "a refused import says why on stderr");
    // Every log once more under a new id: renaming must hold for each event version (a v3
    // log's results name the simulation and are hash-checked on replay).
    for file in recorded_logs() {
        let fresh = uuid::Uuid::new_v4().to_string();
        import_ok(urls, &file, Some(&fresh));
        imported.push(Imported { file, id: fresh, renamed: true });
    }
    imported
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn every_recorded_log_round_trips_through_the_cluster() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let node = Node::start(root.path(), "a", &nats, &workspace, &[]);
    let urls = nats.urls();
    let imported = import_all(&urls);

    let c = node.client().await;
    let listed = listed_ids(&c).await;
    let out = tempfile::tempdir().unwrap();
    for (i, imp) in imported.iter().enumerate() {
        assert!(listed.contains(&imp.id), "{} (imported as {}) is not listed", imp.file.display(), imp.id);
        let step = c.call("step_simulation", json!({"sim_id": imp.id, "steps": 10})).await;
        assert_eq!(step["steps_taken"], json!(10), "{}", imp.file.display());
        let info = c.call("get_simulation_info", json!({"sim_id": imp.id})).await;
        let (file, summary) = export_and_verify(&urls, &imp.id, out.path(), &format!("round_trip_{i}"));
        assert_eq!(summary["final_hash"], info["state_hash"], "{}", imp.file.display());
        assert_extends(&imp.file, &file, imp.renamed);
    }
    eprintln!("{} logs imported, changed and exported", imported.len());
}
