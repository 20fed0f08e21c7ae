//! Small sharp edges: a hostile log never panics the CLI, a corrupt event
//! kind is an error (the file is skipped, not served with the event silently reinterpreted),
//! and a destroyed simulation refuses late writers without recreating its files.

use crate::common;

use common::config;
use std::path::{Path, PathBuf};
use std::process::Command as Process;

use physics_mcp::command::{Command, Shape};
use physics_mcp::limits::Limits;
use physics_mcp::sim::{lock_sim, Registry};
use physics_mcp::value::Args;


fn sphere() -> Command {
    Command::AddBody {
        shape: Shape::Sphere { radius: 0.1 },
        position: [0.0, 0.0, 1.0],
        orientation: [0.0, 0.0, 0.0, 1.0],
        mass: 1.0,
        color: None,
        collides: true,
    }
}

/// A data directory holding simulation `id` with a sphere, a few steps and one read event;
/// returns the log's path once the registry has closed it.
fn make_log(dir: &Path, id: &str) -> PathBuf {
    let reg = Registry::open(config(dir)).unwrap();
    let root = Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).unwrap();
    let shared = reg.get(id).unwrap();
    {
        let mut sim = lock_sim(&shared);
        let (a, l) = (Args::new(), Limits::default());
        sim.change("add_sphere", &a, Ok(sphere()), &l, &mut |_| true).unwrap();
        sim.change("step_simulation", &a, Ok(Command::step(3)), &l, &mut |_| true).unwrap();
        sim.read("get_simulation_info", &a, |s| Ok(s.state_hash().to_string())).unwrap();
        sim.flush();
    }
    let path = reg.config().data_dir.join(format!("{id}.sqlite"));
    drop(shared);
    drop(reg);
    path
}

/// Files in `dir` whose name starts with `id`.
fn files_of(dir: &Path, id: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(id))
        .collect()
}

#[test]
fn history_of_a_log_with_a_non_ascii_hash_does_not_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_log(dir.path(), "hist");
    let conn = rusqlite::Connection::open(&path).unwrap();
    conn.pragma_update(None, "ignore_check_constraints", 1).unwrap();
    // Byte 12 falls inside the sixth 'é': byte slicing there panics.
    let hash = format!("a{}", "é".repeat(20));
    conn.execute("UPDATE events SET state_hash = ?1 WHERE seq = 1", [&hash]).unwrap();
    drop(conn);
    let out = Process::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("history").arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "history failed: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let prefix: String = hash.chars().take(12).collect();
    assert!(stdout.contains(&prefix), "the first 12 characters are shown:\n{stdout}");
}

#[test]
fn an_unknown_event_kind_is_corruption_and_the_file_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let path = make_log(dir.path(), "kind");
    let conn = rusqlite::Connection::open(&path).unwrap();
    // The schema's CHECK refuses such a row; a damaged or hostile file need not obey it.
    conn.pragma_update(None, "ignore_check_constraints", 1).unwrap();
    let n = conn.execute("UPDATE events SET kind = 'bogus' WHERE kind = 'read'", []).unwrap();
    assert_eq!(n, 1);
    drop(conn);
    let err = physics_mcp::log::replay::events(&path).unwrap_err().to_string();
    assert!(err.contains("bogus"), "the error names the bad kind: {err}");
    let reg = Registry::open(config(dir.path())).unwrap();
    let e = reg.get("kind").err().expect("a log with an unknown event kind must not be served");
    // a damaged log is named as such (it used to answer "not found").
    assert!(e.starts_with("Simulation kind is damaged: "), "{e}");
    assert!(path.exists(), "the corrupt file is left for inspection");
}

#[test]
fn a_destroyed_simulation_refuses_late_writers_and_stays_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let reg = std::sync::Arc::new(Registry::open(config(dir.path())).unwrap());
    let root = Command::CreateSimulation { simulation_id: "gone".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    reg.create(root, &Args::new()).unwrap();
    let (a, l) = (Args::new(), Limits::default());
    // A handle taken before the destroy, as a request in flight holds one.
    let late = reg.get("gone").unwrap();
    lock_sim(&late).change("add_sphere", &a, Ok(sphere()), &l, &mut |_| true).unwrap();
    // A long step is running while destroy_simulation is called: destroy waits for it.
    let stepping = {
        let sim = late.clone();
        std::thread::spawn(move || {
            lock_sim(&sim)
                .change("step_simulation", &Args::new(), Ok(Command::step(20_000)), &Limits::default(), &mut |_| true)
                .map(|_| ())
        })
    };
    while late.try_lock().is_ok() && !stepping.is_finished() {
        std::thread::yield_now();
    }
    reg.destroy("gone").unwrap();
    stepping.join().unwrap().unwrap();
    let data = reg.config().data_dir.clone();
    assert!(files_of(&data, "gone").is_empty(), "{:?}", files_of(&data, "gone"));

    let not_found = "Simulation gone not found".to_string();
    let mut sim = lock_sim(&late);
    assert_eq!(sim.change("add_sphere", &a, Ok(sphere()), &l, &mut |_| true).unwrap_err(), not_found);
    assert_eq!(sim.change("add_sphere", &a, Err("bad radius".into()), &l, &mut |_| true).unwrap_err(), not_found);
    assert_eq!(sim.read("get_simulation_info", &a, |s| Ok(s.state_hash().to_string())).unwrap_err(), not_found);
    assert_eq!(sim.refuse("add_box", &a, "anything".into()), not_found);
    assert_eq!(sim.undo(&a, 1).unwrap_err(), not_found);
    assert_eq!(sim.redo(&a, 1).unwrap_err(), not_found);
    let save: Args = serde_json::from_value(serde_json::json!({"file_path": "late.json"})).unwrap();
    assert_eq!(sim.save(&save, &reg).unwrap_err(), not_found);
    sim.flush();
    drop(sim);
    assert_eq!(reg.fork("gone", None, ("child".into(), None), &a).unwrap_err(), not_found);
    drop(late);
    assert!(files_of(&data, "gone").is_empty(), "late writers recreated {:?}", files_of(&data, "gone"));
    assert!(!reg.config().workspace.join("late.json").exists());
    assert!(reg.get("gone").is_err());
}
