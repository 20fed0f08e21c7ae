//! Every recorded session in `replays/` refolds to its recorded hashes (state, results,
//! snapshots) — so a change that alters physics or the encoding fails here until the logs are
//! re-recorded on purpose (`bash replays/record.sh`). The CLI names the first divergence.

use std::process::Command;

use crate::common::recorded_logs as recorded;

fn cli(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_physics-mcp")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn every_recorded_session_replays_to_its_recorded_hashes() {
    let files = recorded();
    assert!(files.len() >= 6, "replays/ holds {} logs", files.len());
    let (mut moves, mut forks, mut refusals, mut loads, mut robots) = (0, 0, 0, 0, 0);
    for f in &files {
        let summary = physics_mcp::log::replay::replay(f, None, |_, _| {})
            .unwrap_or_else(|e| panic!("{} does not replay: {e}", f.display()));
        let events = physics_mcp::log::replay::events(f).unwrap();
        let last = events.iter().rev().find(|e| e.kind.is_state_changing() || e.kind == physics_mcp::log::sqlite::Kind::Move).unwrap();
        assert_eq!(summary.final_hash, events.last().unwrap().state_hash, "{}", f.display());
        assert!(summary.state_events >= 4 && summary.snapshots_checked >= 1, "{}: {summary:?}", f.display());
        // The world the refold ends with is the one the last state-changing (or undo/redo)
        // event recorded: the head did not move after it.
        assert_eq!(summary.final_hash, last.state_hash, "{}", f.display());
        moves += events.iter().filter(|e| e.kind == physics_mcp::log::sqlite::Kind::Move).count();
        forks += events.iter().filter(|e| e.inherited).count().min(1);
        refusals += events.iter().filter(|e| !e.ok).count();
        loads += events.iter().filter(|e| e.tool == "load_simulation" && !e.inherited).count();
        // Robots replay from the URDFs stored in the log (the recording's workspace is gone).
        robots += events.iter().filter(|e| e.tool == "load_urdf" && e.ok).count();
        // And in a fresh process, through the CLI.
        let (ok, stdout, stderr) = cli(&["replay", f.to_str().unwrap(), "--json"]);
        assert!(ok, "{}: {stdout} {stderr}", f.display());
        let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
        assert_eq!(v["summary"]["final_hash"], serde_json::json!(summary.final_hash));
    }
    assert!(
        moves >= 4 && forks >= 1 && refusals >= 3 && loads >= 1 && robots >= 2,
        "coverage: {moves} moves, {forks} forks, {refusals} refusals, {loads} loads, {robots} robots"
    );
}

#[test]
fn a_tampered_log_fails_naming_the_event_and_diff_finds_it() {
    let src = recorded().into_iter().find(|p| p.ends_with("forces_and_torques.sqlite")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.sqlite");
    std::fs::copy(&src, &bad).unwrap();
    let conn = rusqlite::Connection::open(&bad).unwrap();
    let seq: i64 = conn
        .query_row("SELECT MIN(seq) FROM events WHERE tool = 'apply_force' AND ok = 1", [], |r| r.get(0))
        .unwrap();
    conn.execute(
        "UPDATE events SET command = replace(command, '100.0', '101.0') WHERE seq = ?1",
        [seq],
    )
    .unwrap();
    drop(conn);
    let (ok, _, stderr) = cli(&["replay", bad.to_str().unwrap()]);
    assert!(!ok, "a tampered log replayed");
    assert!(stderr.contains(&format!("DIVERGED at seq {seq} (apply_force)")), "{stderr}");
    let (ok, stdout, _) = cli(&["diff", src.to_str().unwrap(), bad.to_str().unwrap()]);
    assert!(!ok && stdout.contains("first divergence"), "{stdout}");
    let (ok, stdout, _) = cli(&["diff", src.to_str().unwrap(), src.to_str().unwrap()]);
    assert!(ok && stdout.contains("identical"), "{stdout}");
    // --until stops before the tampered event: that prefix is still fine.
    let (ok, _, stderr) = cli(&["replay", bad.to_str().unwrap(), "--until", &(seq - 1).to_string()]);
    assert!(ok, "{stderr}");
    let (ok, stdout, _) = cli(&["history", src.to_str().unwrap()]);
    assert!(ok && stdout.lines().count() >= 10 && stdout.contains("apply_force"), "{stdout}");
}

/// The replays recorded under engine rule 2 (every simulation created from event version 6 on;
/// `mjcf_ball_pair_v9` has version-9 events under rule 2, as a rule-2 simulation continued by
/// this release has).
const RULE_2_LOGS: &[&str] = &["engine_rule_v6", "joint_trajectory_v7", "measures_v8", "mjcf_equality_v8", "mjcf_ball_pair_v9"];
/// The replays recorded under engine rule 3 (every simulation created from event version 9 on).
const RULE_3_LOGS: &[&str] = &["engine_rule_v9"];
/// The replays recorded under engine rule 4 (every simulation created from event version 10 on).
const RULE_4_LOGS: &[&str] = &["engine_rule_v10"];

/// `engine_rule_v6*.sqlite` (recorded by the release that introduced engine rules) and every
/// later replay step their robots under their root's rule at every event (`RULE_2_LOGS` under
/// rule 2; `RULE_3_LOGS`, from event version 9 on, under rule 3; `RULE_4_LOGS`, from version 10
/// on, under rule 4) — the created world, its fork and the saved file loaded again — while
/// every log recorded before rules folds under rule 1 throughout. A load or a fork that fell
/// back to rule 1 would still replay to its own hashes; this test tells them apart.
#[test]
fn rule_2_logs_keep_rule_2_through_forks_and_loads_and_older_logs_keep_rule_1() {
    use physics_mcp::command::BlobSource;
    use physics_mcp::engine::EngineRule;
    use physics_mcp::log::{fold, sqlite::Log};
    let limits = physics_mcp::limits::Limits::default();
    let (mut rule_4_roots, mut rule_3_roots, mut rule_2_roots, mut rule_1_roots) = (0, 0, 0, 0);
    for path in recorded() {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let expected = if RULE_4_LOGS.iter().any(|p| name.starts_with(p)) {
            EngineRule::QuietStepForces
        } else if RULE_3_LOGS.iter().any(|p| name.starts_with(p)) {
            EngineRule::TreeMultibodyPerStep
        } else if RULE_2_LOGS.iter().any(|p| name.starts_with(p)) {
            EngineRule::TreeMultibody
        } else {
            EngineRule::Upstream
        };
        let log = Log::open_read_only(&path).unwrap();
        let blobs: &dyn BlobSource = &log;
        let mut after = std::collections::BTreeMap::new();
        for e in physics_mcp::log::replay::events(&path).unwrap().iter().filter(|e| e.kind.is_state_changing() && e.ok) {
            let mut world = match e.parent.and_then(|p| after.get(&p)) {
                Some(parent) => physics_mcp::world::World::duplicate(parent),
                None => fold::create_root(e, blobs).unwrap().0,
            };
            if e.kind == physics_mcp::log::sqlite::Kind::Change || e.parent.is_some() {
                fold::fold_event(&mut world, e, blobs, &limits, false).unwrap();
            }
            assert_eq!(world.engine_rule(), expected, "{} seq {} ({})", path.display(), e.seq, e.tool);
            if e.kind == physics_mcp::log::sqlite::Kind::Root {
                *match expected {
                    EngineRule::Upstream => &mut rule_1_roots,
                    EngineRule::TreeMultibody => &mut rule_2_roots,
                    EngineRule::TreeMultibodyPerStep => &mut rule_3_roots,
                    EngineRule::QuietStepForces => &mut rule_4_roots,
                } += 1;
            }
            after.insert(e.seq, world);
        }
    }
    assert!(rule_4_roots >= 3 && rule_3_roots >= 3 && rule_2_roots >= 5 && rule_1_roots >= 10, "{rule_4_roots} rule-4, {rule_3_roots} rule-3, {rule_2_roots} rule-2, {rule_1_roots} rule-1 roots");
}
