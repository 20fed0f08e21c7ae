//! SPEC "Compatibility of logs and files": every root event records the engine build (rapier
//! version and features); roots written before builds were recorded read as today's build
//! (rapier3d 0.36.1 with serde-serialize and enhanced-determinism); `replay` of a log made by
//! another engine build says so before anything else.

mod common;

use common::config;
use std::path::{Path, PathBuf};
use std::process::Command as Process;

use physics_mcp::command::{Command, Shape};
use physics_mcp::engine::{ENGINE_BUILD, UNRECORDED_ENGINE_BUILD};
use physics_mcp::limits::Limits;
use physics_mcp::replay::engine_builds;
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::value::Args;
use serde_json::{json, Value};


fn args(v: Value) -> Args {
    v.as_object().unwrap().clone()
}

/// Creates `id` with a sphere, stepped 20 times.
fn simulation(reg: &Registry, id: &str) {
    let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false };
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
    };
    sim.change("add_sphere", &a, Ok(add), &l, &mut |_| true).unwrap();
    sim.change("step_simulation", &a, Ok(Command::StepSimulation { steps: 20 }), &l, &mut |_| true).unwrap();
}

#[test]
fn new_roots_of_create_fork_and_load_record_this_build() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let reg = Registry::open(cfg.clone()).unwrap();
    simulation(&reg, "made");
    reg.fork("made", None, "forked".into(), &args(json!({"sim_id": "made"}))).unwrap();
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
    let mut logs: Vec<PathBuf> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("replays"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sqlite"))
        .collect();
    logs.sort();
    assert!(logs.len() >= 10, "the recorded replays are missing");
    logs
}

#[test]
fn roots_of_old_logs_read_as_todays_build() {
    for log in replays() {
        let builds = engine_builds(&log).unwrap();
        assert!(!builds.roots.is_empty(), "{}", log.display());
        for b in &builds.roots {
            assert!(!b.recorded, "{}: root {} of an old log records a build", log.display(), b.seq);
            assert_eq!(b.engine, UNRECORDED_ENGINE_BUILD, "{}", log.display());
        }
        if ENGINE_BUILD == UNRECORDED_ENGINE_BUILD {
            assert!(builds.warning().is_none(), "{}: {:?}", log.display(), builds.warning());
        }
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

#[test]
fn replay_of_a_log_from_another_build_says_so_first() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path());
    let reg = Registry::open(cfg.clone()).unwrap();
    simulation(&reg, "other");
    drop(reg);
    let log = cfg.data_dir.join("other.sqlite");

    // As this build wrote it: no word about builds, and the JSON says they agree.
    let (ok, out) = replay(&log, &[]);
    assert!(ok && out.starts_with("ok: "), "{out}");
    let (ok, out) = replay(&log, &["--json"]);
    let v: Value = serde_json::from_str(&out).unwrap();
    assert!(ok && v["engine_builds"]["differs"] == false, "{out}");
    assert_eq!(v["engine_builds"]["this"], ENGINE_BUILD);

    // Its root claiming another build: said on the first line, before the replay's own.
    let other = "rapier3d 9.9.9 (imaginary)";
    let conn = rusqlite::Connection::open(&log).unwrap();
    let n = conn.execute("UPDATE events SET engine = ?1 WHERE kind = 'root'", [other]).unwrap();
    assert_eq!(n, 1);
    drop(conn);
    let (ok, out) = replay(&log, &[]);
    let mut lines = out.lines();
    let first = lines.next().unwrap_or_default();
    assert!(first.starts_with("engine build differs:"), "{out}");
    assert!(first.contains(&format!("root event 1 by {other}")) && first.contains(ENGINE_BUILD), "{first}");
    // The physics is the same, so the replay itself still checks out.
    assert!(ok && lines.next().is_some_and(|l| l.starts_with("ok: ")), "{out}");
    let (_, out) = replay(&log, &["--json"]);
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["engine_builds"]["differs"], true, "{out}");
    assert_eq!(v["engine_builds"]["roots"][0], json!({"seq": 1, "engine": other, "recorded": true}));
}
