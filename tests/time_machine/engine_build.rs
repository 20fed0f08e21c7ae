//! docs/log-format.md "Compatibility of logs and files": every root event records the engine build (a crate
//! → version map of the result-affecting crates, rapier3d's with its features); roots written
//! before builds were recorded, and roots that recorded rapier3d alone, read as the build of
//! their time (rapier3d 0.36.1 with serde-serialize and enhanced-determinism, plus the frozen
//! lock of the other crates); `replay` of a log made by another engine build says so before
//! anything else, naming the crates that differ.

use crate::common;

use common::config;
use std::path::{Path, PathBuf};
use std::process::Command as Process;

use physics_mcp::command::{Command, Shape};
use physics_mcp::engine::{build_map, differences, lock, ENGINE_BUILD, UNRECORDED_ENGINE_BUILD};
use physics_mcp::limits::Limits;
use physics_mcp::log::replay::engine_builds;
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::value::Args;
use serde_json::{json, Value};


fn args(v: Value) -> Args {
    v.as_object().unwrap().clone()
}

/// Creates `id` with a sphere, stepped 20 times.
fn simulation(reg: &Registry, id: &str) {
    let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).unwrap();
    let shared = reg.get(id).unwrap();
    let mut sim = lock_sim(&shared);
    let (a, l) = (Args::new(), Limits::default());
    let add = Command::AddBody {
        shape: Shape::Sphere { radius: 0.1 },
        position: [0.0, 0.0, 1.0],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 1.0,
        color: None,
        collides: true,
    };
    sim.change("add_sphere", &a, Ok(add), &l, &mut |_| true).unwrap();
    sim.change("step_simulation", &a, Ok(Command::step(20)), &l, &mut |_| true).unwrap();
}

#[test]
fn new_roots_of_create_fork_and_load_record_this_build() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let reg = Registry::open(cfg.clone()).unwrap();
    simulation(&reg, "made");
    reg.fork("made", None, ("forked".into(), None), &args(json!({"sim_id": "made"}))).unwrap();
    {
        let shared = reg.get("made").unwrap();
        let mut sim = lock_sim(&shared);
        sim.save(&args(json!({"sim_id": "made", "file_path": "made.json"})), &reg).unwrap();
    }
    reg.load(&args(json!({"file_path": "made.json"})), "loaded".into(), &mut |_, _| {}).unwrap();

    let saved = engine_builds(&cfg.workspace.join("made.json")).unwrap();
    assert_eq!(saved.roots.len(), 1, "{saved:?}");
    for id in ["made", "forked", "loaded"] {
        let builds = engine_builds(&cfg.data_dir.join(format!("{id}.sqlite"))).unwrap();
        // create: its own root; fork and load: the inherited root and their own.
        assert_eq!(builds.roots.len(), if id == "made" { 1 } else { 2 }, "{id}: {builds:?}");
        for b in builds.roots.iter().chain(&saved.roots) {
            assert!(b.recorded, "{id}: root {} records no build", b.seq);
            assert_eq!(b.engine, ENGINE_BUILD, "{id}: root {}", b.seq);
        }
        assert!(!builds.differs && builds.warning().is_none(), "{id}: {builds:?}");
    }
}

fn replays() -> Vec<PathBuf> {
    let logs = common::recorded_logs();
    assert!(logs.len() >= 10, "the recorded replays are missing");
    logs
}

#[test]
fn roots_of_old_logs_read_as_todays_build() {
    for log in replays() {
        let builds = engine_builds(&log).unwrap();
        assert!(!builds.roots.is_empty(), "{}", log.display());
        // Logs recorded before builds were recorded (all but the newest recordings) read as
        // that time's build; a recording made since names the build that made it (this one).
        if let Some(b) = builds.roots.iter().find(|b| b.recorded) {
            // Warned about exactly when that build's crates differ from this one's.
            let same = differences(&b.engine, ENGINE_BUILD).is_empty();
            assert_eq!(builds.warning().is_none(), same, "{}: {:?}", log.display(), builds.warning());
            continue;
        }
        for b in &builds.roots {
            assert_eq!(b.engine, UNRECORDED_ENGINE_BUILD, "{}", log.display());
        }
        // Compared as maps: with the lock of their time (today's) no warning, else one.
        let same = differences(UNRECORDED_ENGINE_BUILD, ENGINE_BUILD).is_empty();
        assert_eq!(builds.warning().is_none(), same, "{}: {:?}", log.display(), builds.warning());
    }
}

fn replay(file: &Path, extra: &[&str]) -> (bool, String) {
    let out = Process::new(env!("CARGO_BIN_EXE_physics-mcp"))
        .arg("replay")
        .arg(file)
        .args(extra)
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8(out.stdout).unwrap())
}

/// A log of this build whose single root is then made to record `engine` (`None`: nothing,
/// as before builds were recorded). The directory lives as long as the returned guard.
fn log_recording(engine: Option<&str>) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let reg = Registry::open(cfg.clone()).unwrap();
    simulation(&reg, "other");
    drop(reg);
    let log = cfg.data_dir.join("other.sqlite");
    let conn = rusqlite::Connection::open(&log).unwrap();
    let n = conn.execute("UPDATE events SET engine = ?1 WHERE kind = 'root'", [engine]).unwrap();
    assert_eq!(n, 1);
    (dir, log)
}

/// This binary's rapier3d entry: its version and features.
fn this_rapier() -> String {
    build_map(ENGINE_BUILD)["rapier3d"].clone()
}

#[test]
fn replay_of_a_log_from_another_build_says_so_first() {
    // As this build wrote it: no word about builds, and the JSON says they agree.
    let (_dir, log) = log_recording(Some(ENGINE_BUILD));
    let (ok, out) = replay(&log, &[]);
    assert!(ok && out.starts_with("ok: "), "{out}");
    let (ok, out) = replay(&log, &["--json"]);
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(ok && v["engine_builds"]["differs"] == false, "{out}");
    assert_eq!(v["engine_builds"]["this"], ENGINE_BUILD);

    // Its root claiming another rapier (rapier3d alone, as recorded before the map, so the
    // other crates read as the frozen lock): said on the first line, before the replay's own.
    let other = "rapier3d 9.9.9 (imaginary)";
    let (_dir, log) = log_recording(Some(other));
    let (ok, out) = replay(&log, &[]);
    let mut lines = out.lines();
    let first = lines.next().unwrap_or_default();
    assert!(first.starts_with("engine build differs"), "{out}");
    let named = format!("root event 1 (rapier3d: 9.9.9 (imaginary) → {})", this_rapier());
    assert!(first.contains(&named), "{first}");
    // The physics is the same, so the replay itself still checks out.
    assert!(ok && lines.next().is_some_and(|l| l.starts_with("ok: ")), "{out}");
    let (_, out) = replay(&log, &["--json"]);
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["engine_builds"]["differs"], true, "{out}");
    let differences = json!([{"crate": "rapier3d", "recorded": "9.9.9 (imaginary)", "this": this_rapier()}]);
    assert_eq!(v["engine_builds"]["roots"][0], json!({"seq": 1, "engine": other, "recorded": true, "differences": differences}));
}

#[test]
fn a_root_recording_another_version_of_one_crate_warns_naming_that_crate() {
    let mut map = build_map(ENGINE_BUILD);
    let parry = map.insert("parry3d".into(), "0.0.1".into()).expect("parry3d is recorded");
    let (_dir, log) = log_recording(Some(&lock::encode(&map)));
    let (ok, out) = replay(&log, &[]);
    let first = out.lines().next().unwrap_or_default();
    assert!(first.starts_with("engine build differs"), "{out}");
    assert!(first.contains(&format!("root event 1 (parry3d: 0.0.1 → {parry})")), "{first}");
    assert!(!first.contains("rapier3d:") && ok, "only parry3d differs: {out}");
    let (_, out) = replay(&log, &["--json"]);
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["engine_builds"]["roots"][0]["differences"], json!([{"crate": "parry3d", "recorded": "0.0.1", "this": parry}]));

    // A crate this build records but the root does not, and one only the root has.
    map.insert("parry3d".into(), parry.clone());
    map.remove("tobj");
    map.insert("gone".into(), "1.0.0".into());
    let (_dir, log) = log_recording(Some(&lock::encode(&map)));
    let builds = engine_builds(&log).unwrap();
    let warning = builds.warning().unwrap_or_default();
    assert!(warning.contains("(gone: 1.0.0 → absent; tobj: absent → "), "{warning}");
}

#[test]
fn an_old_recorded_string_reads_as_the_frozen_map_and_does_not_warn() {
    // Today's lock is the frozen one, so rapier3d alone reads as this build: every crate the
    // same but rapier3d, the release this build's vendored patch level covers.
    let (mut old, mut now) = (build_map(UNRECORDED_ENGINE_BUILD), build_map(ENGINE_BUILD));
    let (old_rapier, now_rapier) = (old.remove("rapier3d").unwrap(), now.remove("rapier3d").unwrap());
    assert_eq!(old, now);
    assert!(physics_mcp::engine::rapier_covers(&old_rapier, &now_rapier), "{old_rapier} → {now_rapier}");
    assert!(now_rapier.starts_with("0.36.1+pmcp."), "the vendored rapier: {now_rapier}");
    assert_eq!(physics_mcp::engine::differences(UNRECORDED_ENGINE_BUILD, ENGINE_BUILD), vec![]);
    for engine in [Some(UNRECORDED_ENGINE_BUILD), None] {
        let (_dir, log) = log_recording(engine);
        let (ok, out) = replay(&log, &[]);
        assert!(ok && out.starts_with("ok: "), "{engine:?}: {out}");
        let (_, out) = replay(&log, &["--json"]);
        let v: Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v["engine_builds"]["differs"], false, "{out}");
        let root = json!({"seq": 1, "engine": UNRECORDED_ENGINE_BUILD, "recorded": engine.is_some()});
        assert_eq!(v["engine_builds"]["roots"][0], root, "{out}");
    }
}
