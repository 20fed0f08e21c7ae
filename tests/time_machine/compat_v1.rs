//! docs/log-format.md "Compatibility of logs and files": a data directory and a saved file written by the build before event
//! version 2 (`tests/fixtures/datadir_v1`, made by commit 237147f) keep working — every log
//! replays with every recorded state hash checked, every simulation recovers at start under
//! its id and verifies, the saved file loads to its recorded hash, and all of them go on.
//! Among them are step_simulation calls cancelled part way, which that build logged as the
//! steps asked: one of them had no snapshot at the step, so that build itself skipped it
//! as corrupt at its next start.

use crate::common;

use std::path::{Path, PathBuf};

use common::Server;
use physics_mcp::log::sqlite::Kind;
use serde_json::json;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/datadir_v1")
}

/// A private copy of the fixture (the server writes to its data directory).
fn copy_fixture(to: &Path) {
    for sub in ["data", "workspace"] {
        std::fs::create_dir_all(to.join(sub)).unwrap();
        for e in std::fs::read_dir(fixture().join(sub)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), to.join(sub).join(e.file_name())).unwrap();
        }
    }
}

fn logs(data: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sqlite"))
        .collect();
    v.sort();
    v
}

/// The state hash the log's head reflects (the last root, change or move event's).
fn head_hash(log: &Path) -> String {
    let events = physics_mcp::log::replay::events(log).unwrap();
    let last = events.iter().rev().find(|e| e.kind.is_state_changing() || e.kind == Kind::Move).unwrap();
    last.state_hash.clone()
}

#[test]
fn every_v1_log_replays_with_every_hash_checked() {
    let dir = tempfile::tempdir().unwrap();
    copy_fixture(dir.path());
    let files = logs(&dir.path().join("data"));
    assert_eq!(files.len(), 7);
    let mut cancelled = 0;
    for f in &files {
        let summary = physics_mcp::log::replay::replay(f, None, |_, _| {})
            .unwrap_or_else(|e| panic!("{} does not replay: {e}", f.display()));
        assert_eq!(summary.final_hash, head_hash(f), "{}", f.display());
        let events = physics_mcp::log::replay::events(f).unwrap();
        assert!(events.iter().all(|e| e.version == 1), "the fixture is all version 1");
        cancelled += events
            .iter()
            .filter(|e| e.tool == "step_simulation" && e.kind == Kind::Change && !e.inherited)
            .filter(|e| {
                let field = |text: Option<&str>, k: &str| serde_json::from_str::<serde_json::Value>(text.unwrap()).unwrap()[k].as_u64();
                field(e.result.as_deref(), "steps_taken") < field(e.command.as_deref(), "steps")
            })
            .count();
    }
    assert_eq!(cancelled, 3, "the three cancelled steps are in the fixture");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_v1_data_directory_recovers_verifies_and_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    copy_fixture(dir.path());
    let files = logs(&dir.path().join("data"));
    let server = Server::start(dir.path(), &[]);
    let skipped: Vec<String> = server.stderr.lock().unwrap().iter().filter(|l| l.contains("skipping")).cloned().collect();
    assert!(skipped.is_empty(), "{skipped:?}");
    let c = server.client().await;
    let listed = c.call("list_simulations", json!({})).await;
    assert_eq!(listed["simulations"].as_array().unwrap().len(), files.len());
    let mut after = Vec::new();
    for f in &files {
        let id = f.file_stem().unwrap().to_str().unwrap().to_string();
        assert_eq!(c.hash(&id).await, head_hash(f), "{id} recovers to its recorded head");
        let v = c.call("verify_simulation", json!({"sim_id": id})).await;
        assert_eq!(v["ok"], true, "{id}: {v}");
        // And it goes on: a change on top of the old chain, remembered across kill -9.
        c.call("add_sphere", json!({"sim_id": id, "radius": 0.1, "position": [3, 3, 3]})).await;
        let stepped = c.step(&id, 30).await;
        let hash = c.hash(&id).await;
        after.push((id, hash, stepped["current_time"].clone()));
    }
    // Values are now reported as set, even for what the old build recorded as 3.4999998.
    let a = "a2039bab-d66e-42bc-ac47-e38dccc80aba";
    let box_mass = c.call("get_dynamics_info", json!({"sim_id": a, "object_id": 1})).await["mass"].clone();
    let link_mass = c.call("get_dynamics_info", json!({"sim_id": a, "object_id": 4, "link_index": 2})).await["mass"].clone();
    assert_eq!((box_mass, link_mass), (json!(3.5), json!(3.5)));
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    for (id, hash, time) in &after {
        assert_eq!(&c.hash(id).await, hash, "{id} after kill -9");
        let info = c.call("get_simulation_info", json!({"sim_id": id})).await;
        assert_eq!(&info["current_time"], time, "{id}: time is reported the same after a restart");
        let v = c.call("verify_simulation", json!({"sim_id": id})).await;
        assert_eq!(v["ok"], true, "{id}: {v}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_file_saved_by_the_v1_build_loads_to_its_recorded_hash() {
    let dir = tempfile::tempdir().unwrap();
    copy_fixture(dir.path());
    // Not the data directory that wrote it: its MAC key is not ours, so the load refolds.
    std::fs::remove_dir_all(dir.path().join("data")).unwrap();
    let saved: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("workspace/saved_v1.json")).unwrap()).unwrap();
    let recorded = saved["history"]["events"].as_array().unwrap().last().unwrap()["state_hash"].clone();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let loaded = c.call("load_simulation", json!({"file_path": "saved_v1.json"})).await;
    assert_eq!(loaded["state_hash"], recorded);
    let id = loaded["simulation_id"].as_str().unwrap();
    // The old file's readable fields (an f32 timestep, the summed clock, robots by file_path
    // alone) are accepted; the world goes on and can be forked at an inherited event.
    c.step(id, 10).await;
    let first_step = saved["history"]["events"].as_array().unwrap().iter().find(|e| e["tool"] == "step_simulation").unwrap();
    let fork = c.call("fork_simulation", json!({"sim_id": id, "at_seq": first_step["seq"]})).await;
    assert_eq!(fork["state_hash"], first_step["state_hash"]);
    // And the same file loads again on the server whose key wrote it, from its snapshot.
    drop(c);
    server.kill();
    copy_fixture(dir.path());
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let loaded = c.call("load_simulation", json!({"file_path": "saved_v1.json"})).await;
    assert_eq!(loaded["state_hash"], recorded);
}

/// A schema v2 log (before read events recorded what they returned) served from a data
/// directory: it is migrated to v3 on open, its old reads show as "read" in get_history, a new
/// read shows its one-line summary, and it still verifies and replays.
#[tokio::test(flavor = "multi_thread")]
async fn a_v2_log_migrates_and_its_old_reads_say_read() {
    let v2 = Path::new(env!("CARGO_MANIFEST_DIR")).join("replays/markers_filters_motors.sqlite");
    let version = |p: &Path| -> i64 { rusqlite::Connection::open(p).unwrap().query_row("PRAGMA user_version", [], |r| r.get(0)).unwrap() };
    assert_eq!(version(&v2), 2, "the recorded log is schema v2");
    let id: String = rusqlite::Connection::open(&v2)
        .unwrap()
        .query_row("SELECT value FROM meta WHERE key = 'simulation_id'", [], |r| r.get(0))
        .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    let log = data.join(format!("{id}.sqlite"));
    std::fs::copy(&v2, &log).unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(version(&log), 3, "migrated on open");
    let old = c.call("get_history", json!({"sim_id": id, "limit": 1000})).await;
    let reads: Vec<&serde_json::Value> = old["events"].as_array().unwrap().iter().filter(|e| e["kind"] == "read").collect();
    assert!(!reads.is_empty() && reads.iter().all(|e| e["summary"] == "read"), "{reads:?}");
    let info = c.call("get_simulation_info", json!({"sim_id": id})).await;
    let page = c.call("get_history", json!({"sim_id": id, "since_seq": old["last_seq"]})).await;
    let events = page["events"].as_array().unwrap();
    // The first get_history (a read itself), then get_simulation_info.
    let line = events.last().unwrap()["summary"].as_str().unwrap().to_string();
    assert!(line.contains(&format!(" head_seq={} ", info["head_seq"])), "{line}");
    assert!(events[0]["summary"].as_str().unwrap().starts_with("head_seq="), "{}", events[0]);
    assert_eq!(c.call("verify_simulation", json!({"sim_id": id})).await["ok"], true);
    drop(c);
    server.terminate();
    physics_mcp::log::replay::replay(&log, None, |_, _| {}).unwrap_or_else(|e| panic!("the migrated log does not replay: {e}"));
}
