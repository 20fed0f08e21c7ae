//! Models read no file behind the log's back: every file a model names (MJCF includes, a
//! sub-model's `<asset><model file>`, meshes) is read by the files layer inside the workspace —
//! regular files only, never blocking on a FIFO — or refused naming the element; a crafted or
//! old log whose model names a file folds up to that event and is then reported damaged,
//! naming the event and the file, without opening it; and every recorded log and every test
//! model's log folds with the workspace gone.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use common::{Client, Server};
use serde_json::{json, Value};

/// A FIFO at `path` (opening it for reading would wait for a writer for ever).
fn fifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(ok.success(), "mkfifo {}", path.display());
}

/// A small valid robot: one hinge.
const ROBOT: &str = r#"<mujoco model="r"><worldbody><body name="root" pos="0 0 1"><joint name="j" type="hinge" axis="0 1 0"/><geom size="0.1"/></body></worldbody></mujoco>"#;

/// `load_mjcf` within 60 s (a call that waits on a FIFO would never answer).
async fn load_mjcf(c: &Client, sim: &str, file: &str) -> Result<Value, String> {
    let call = c.try_call("load_mjcf", json!({"sim_id": sim, "file_path": file}));
    tokio::time::timeout(Duration::from_secs(60), call).await.unwrap_or_else(|_| panic!("load_mjcf {file} did not answer: it waits on a file"))
}

#[tokio::test(flavor = "multi_thread")]
async fn a_model_cannot_make_the_server_read_outside_the_workspace_or_block() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::write(outside.join("robot.xml"), ROBOT.replace("root", "secret_body_name")).unwrap();
    fifo(&outside.join("pipe.xml"));
    let server = Server::start(dir.path(), &[]);
    let ws = &server.workspace;
    let write = |name: &str, text: String| std::fs::write(ws.join(name), text).unwrap();
    let sub_model = |file: &str| {
        format!(r#"<mujoco><asset><model name="m" file="{file}"/></asset><worldbody><body name="root" pos="0 0 1"><geom size="0.1"/><attach model="m" body="secret_body_name" prefix="x_"/></body></worldbody></mujoco>"#)
    };
    write("sub_abs.xml", sub_model(&outside.join("robot.xml").display().to_string()));
    write("sub_rel.xml", sub_model("../outside/robot.xml"));
    write("sub_fifo.xml", sub_model(&outside.join("pipe.xml").display().to_string()));
    write("sub_zero.xml", sub_model("/dev/zero"));
    write("sub_in_ws.xml", sub_model("robot.xml"));
    write("robot.xml", ROBOT.to_string());
    fifo(&ws.join("pipe.xml"));
    std::os::unix::fs::symlink("/dev/zero", ws.join("zero.xml")).unwrap();
    write("include_fifo.xml", r#"<mujoco><include file="pipe.xml"/><worldbody/></mujoco>"#.into());
    write("include_zero.xml", r#"<mujoco><include file="zero.xml"/><worldbody/></mujoco>"#.into());
    write("mesh_fifo.xml", r#"<mujoco><asset><mesh name="m" file="pipe.stl"/></asset><worldbody><body><geom type="mesh" mesh="m"/></body></worldbody></mujoco>"#.into());
    fifo(&ws.join("pipe.stl"));
    std::fs::create_dir_all(ws.join("dir.xml")).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let before = common::hard::fingerprint(&c, &sim).await;
    let cases = [
        ("sub_abs.xml", "<asset><model file="),
        ("sub_rel.xml", "<asset><model file="),
        ("sub_fifo.xml", "<asset><model file="),
        ("sub_zero.xml", "<asset><model file="),
        ("sub_in_ws.xml", "<asset><model file="),
        ("pipe.xml", "not a regular file"),
        ("include_fifo.xml", "not a regular file"),
        ("include_zero.xml", "Access denied"),
        ("zero.xml", "Access denied"),
        ("mesh_fifo.xml", "not a regular file"),
        ("dir.xml", "a directory"),
    ];
    for (file, words) in cases {
        let why = load_mjcf(&c, &sim, file).await.expect_err(&format!("{file} must be refused"));
        assert!(why.contains(words), "{file}: {why:?} should say {words:?}");
        assert!(!why.contains("secret_body_name"), "{file}: the outside file was read: {why}");
        common::hard::assert_unchanged(&c, &sim, &before, file).await;
    }
    // Every refusal is logged as one.
    let history = c.call("get_history", json!({"sim_id": sim, "limit": 100})).await;
    let refused = history["events"].as_array().unwrap().iter().filter(|e| e["tool"] == "load_mjcf" && e["kind"] == "refused").count();
    assert_eq!(refused, cases.len());
}

#[tokio::test(flavor = "multi_thread")]
async fn a_nested_include_is_refused_in_a_sentence_and_logged() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let ws = &server.workspace;
    std::fs::write(ws.join("a.xml"), "<mujoco><worldbody/></mujoco>").unwrap();
    std::fs::write(ws.join("b.xml"), "<mujoco><worldbody/></mujoco>").unwrap();
    std::fs::write(ws.join("nested.xml"), r#"<mujoco><include file="a.xml"><include file="b.xml"/></include><worldbody/></mujoco>"#).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let why = load_mjcf(&c, &sim, "nested.xml").await.expect_err("a nested include is refused");
    assert!(why.contains("<include>") && why.contains("must be empty"), "{why}");
    let history = c.call("get_history", json!({"sim_id": sim})).await;
    let last = history["events"].as_array().unwrap().last().unwrap().clone();
    assert_eq!((last["tool"].as_str(), last["kind"].as_str()), (Some("load_mjcf"), Some("refused")), "{last}");
    // The server still serves.
    assert!(load_mjcf(&c, &sim, "a.xml").await.is_ok());
}

/// Rewrites simulation `id`'s first load_mjcf event so its model names `file` in an
/// `<asset><model>` (as a log written before files were resolved into blobs could), keeping
/// the log otherwise valid: the new text is stored as a blob under its hash.
fn plant_sub_model(data: &Path, id: &str, file: &str) -> u64 {
    let conn = rusqlite::Connection::open(data.join(format!("{id}.sqlite"))).unwrap();
    let (seq, command): (i64, String) = conn
        .query_row("SELECT seq, command FROM events WHERE tool = 'load_mjcf' AND kind = 'change' ORDER BY seq LIMIT 1", [], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap();
    let mut cmd: Value = serde_json::from_str(&command).unwrap();
    let old: Vec<u8> = conn.query_row("SELECT bytes FROM blobs WHERE hash = ?1", [cmd["mjcf"].as_str().unwrap()], |r| r.get(0)).unwrap();
    let text = String::from_utf8(old).unwrap().replacen("<worldbody>", &format!(r#"<asset><model name="m" file="{file}"/></asset><worldbody>"#), 1);
    let hash = blake3::hash(text.as_bytes()).to_hex().to_string();
    conn.execute("INSERT OR IGNORE INTO blobs (hash, bytes) VALUES (?1, ?2)", rusqlite::params![hash, text.as_bytes()]).unwrap();
    cmd["mjcf"] = json!(hash);
    conn.execute("UPDATE events SET command = ?1 WHERE seq = ?2", rusqlite::params![cmd.to_string(), seq]).unwrap();
    conn.execute("DELETE FROM snapshots WHERE seq >= ?1", [seq]).unwrap();
    seq as u64
}

#[tokio::test(flavor = "multi_thread")]
async fn a_log_whose_model_names_a_file_is_damaged_naming_it_and_the_file_is_never_opened() {
    let dir = tempfile::tempdir().unwrap();
    let outside = dir.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    // A FIFO: a fold that opened it would wait for ever (and the restart never listen).
    let pipe = outside.join("robot.xml");
    fifo(&pipe);
    let id = {
        let server = Server::start(dir.path(), &[]);
        std::fs::write(server.workspace.join("robot.xml"), ROBOT).unwrap();
        let c = server.client().await;
        let sim = c.new_sim(json!({})).await;
        c.call("load_mjcf", json!({"sim_id": sim, "file_path": "robot.xml"})).await;
        c.step(&sim, 5).await;
        server.terminate();
        sim
    };
    let data = dir.path().join("data");
    let seq = plant_sub_model(&data, &id, &pipe.display().to_string());
    let expected = format!("event {seq} needs file {}, which the log does not hold", pipe.display());
    // The CLI says so first, without opening the file.
    let out = tokio::time::timeout(
        Duration::from_secs(60),
        tokio::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(data.join(format!("{id}.sqlite"))).output(),
    )
    .await
    .expect("replay waits on the model's file")
    .unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success() && said.contains(&expected), "{said}");
    // A restart serves everything else and reports this simulation damaged, naming why.
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (_, damaged) = common::hard::listed(&c.call("list_simulations", json!({})).await);
    assert_eq!(damaged.len(), 1, "{damaged:?}");
    assert_eq!(damaged[0].0, id);
    assert!(damaged[0].1.contains(&expected), "{damaged:?}");
    let why = c.try_call("get_simulation_info", json!({"sim_id": id})).await.unwrap_err();
    assert!(why.contains(&expected), "{why}");
}

/// Every fixture model: (tool, path in the workspace).
fn fixture_models() -> Vec<(&'static str, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures");
    let mut v: Vec<(&str, String)> = ["two_link_arm.urdf", "iiwa14.urdf", "wheeled_base.urdf", "continuous_limits.urdf", "joint_limits.urdf", "mesh_bot/urdf/mesh_bot.urdf"]
        .into_iter()
        .map(|f| ("load_urdf", f.to_string()))
        .collect();
    let mut mjcf: Vec<PathBuf> = std::fs::read_dir(root.join("mjcf")).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|x| x == "xml")).collect();
    mjcf.sort();
    v.extend(mjcf.iter().map(|p| ("load_mjcf", format!("mjcf/{}", p.file_name().unwrap().to_string_lossy()))));
    v
}

#[tokio::test(flavor = "multi_thread")]
async fn every_model_and_every_recorded_log_folds_with_the_workspace_gone() {
    let dir = tempfile::tempdir().unwrap();
    let mut ids = Vec::new();
    {
        let server = Server::start(dir.path(), &[]);
        server.copy_fixtures();
        let c = server.client().await;
        for (tool, file) in fixture_models() {
            let sim = c.new_sim(json!({})).await;
            c.ground(&sim).await;
            c.call(tool, json!({"sim_id": sim, "file_path": file, "position": [0, 0, 1]})).await;
            c.step(&sim, 30).await;
            ids.push((sim, file));
        }
        server.terminate();
    }
    std::fs::remove_dir_all(dir.path().join("workspace")).unwrap();
    // Recovery folds every log; then each verifies and replays in a fresh process.
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (live, damaged) = common::hard::listed(&c.call("list_simulations", json!({})).await);
    assert!(damaged.is_empty(), "{damaged:?}");
    for (sim, file) in &ids {
        assert!(live.contains(sim), "{file}: not recovered");
        let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
        assert_eq!(v["ok"], json!(true), "{file}: {v}");
        common::assert_replays(&server.data, sim);
    }
    // The recorded sessions in replays/ name files of workspaces long gone.
    for p in common::recorded_logs() {
        physics_mcp::log::replay::replay(&p, None, |_, _| {}).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
}

/// What the file fuzzer found, kept as plain cases: nesting at the bound loads, steps,
/// verifies and forks (a fold once overflowed a smaller thread stack at 200 levels); one level
/// more, a 10,000-link chain and numbers the engine panics on are refused in a sentence naming
/// the parameter, changing nothing; the server never panics.
#[tokio::test(flavor = "multi_thread")]
async fn deep_huge_and_extreme_models_are_refused_and_models_at_the_bounds_work() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let ws = &server.workspace;
    let write = |name: &str, text: String| std::fs::write(ws.join(name), text).unwrap();
    let nested = |n: usize| format!("<mujoco><worldbody>{}<geom size=\"0.1\"/>{}</worldbody></mujoco>", "<body><joint type=\"hinge\"/>".repeat(n), "</body>".repeat(n));
    // <mujoco><worldbody> + n bodies: 62 bodies nest 64 levels.
    write("at_bound.xml", nested(62));
    write("over_bound.xml", nested(63));
    let chain: String = (0..600).map(|i| format!(r#"<link name="l{}"/><joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{}"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#, i + 1, i + 1)).collect();
    write("chain.urdf", format!(r#"<robot name="c"><link name="l0"/>{chain}</robot>"#));
    write("negative_cylinder.xml", r#"<mujoco><worldbody><body><geom type="cylinder" size="-1 0.5"/></body></worldbody></mujoco>"#.into());
    write("far_body.xml", r#"<mujoco><worldbody><body pos="0 0 1e400"><joint type="hinge" range="-1 1" limited="true"/><geom size="0.1"/></body></worldbody></mujoco>"#.into());
    write("far_joint.xml", FAR_JOINT.into());
    write("long_cylinder.urdf", r#"<robot name="r"><link name="a"/><link name="b"><collision><geometry><cylinder radius="0.1" length="1e26"/></geometry></collision></link><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#.into());
    write("overflowing_axis.urdf", r#"<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 -1e308 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#.into());
    write("overflowing_axis.xml", r#"<mujoco><worldbody><body><joint name="h" type="hinge" axis="1e200 1e200 0" range="-1 1" limited="true"/><geom size="0.1"/></body></worldbody></mujoco>"#.into());
    write("entities.xml", r#"<?xml version="1.0"?><!DOCTYPE mujoco [<!ENTITY a "<body><geom size='0.1'/></body>">]><mujoco><worldbody>&a;</worldbody></mujoco>"#.into());
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let before = common::hard::fingerprint(&c, &sim).await;
    let refused = [
        ("load_mjcf", "over_bound.xml", "nests elements deeper than 64"),
        ("load_urdf", "chain.urdf", "600 joints; a model may have at most 512"),
        ("load_mjcf", "negative_cylinder.xml", "size [-1.0, 0.5]"),
        ("load_mjcf", "far_body.xml", "has pos"),
        ("load_mjcf", "far_joint.xml", "joint hinge has pos [0.0, 1e308, 0.0]"),
        ("load_urdf", "long_cylinder.urdf", "cylinder length of 1000000"),
        ("load_mjcf", "entities.xml", "declarations (entities)"),
        // Finite parts whose squared length overflows: the axis normalised to zero and the
        // engine's joint solver panicked at the next step (file fuzzing found it).
        ("load_urdf", "overflowing_axis.urdf", "joint j has an axis with no finite, non-zero length"),
        ("load_mjcf", "overflowing_axis.xml", "joint h has an axis with no finite, non-zero length"),
    ];
    for (tool, file, says) in refused {
        let why = c.try_call(tool, json!({"sim_id": sim, "file_path": file})).await.expect_err(file);
        assert!(["file_path", "geom", "body", "link", "joint"].iter().any(|p| why.contains(p)), "{file}: {why}");
        assert!(why.contains(says), "{file}: {why}");
        assert!(!why.contains("Internal error"), "{file}: {why}");
    }
    let why = c.try_call("add_box", json!({"sim_id": sim, "dimensions": [1.8e19, 1, 1], "position": [0, 0, 1]})).await.expect_err("a huge box");
    assert!(why.contains("dimensions must be within 100000 m"), "{why}");
    common::hard::assert_unchanged(&c, &sim, &before, "a refused model").await;
    c.call("load_mjcf", json!({"sim_id": sim, "file_path": "at_bound.xml"})).await;
    c.call("step_simulation", json!({"sim_id": sim, "steps": 5})).await;
    let verified = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(verified["ok"], true, "{verified}");
    c.call("fork_simulation", json!({"sim_id": sim})).await;
    assert!(server.stderr.lock().unwrap().iter().all(|l| !l.contains("panicked")), "the server panicked");
}

/// A hinge anchored 1e308 m away (a limited one: rapier's joint-limit solve panicked on it at
/// every step).
const FAR_JOINT: &str = r#"<mujoco><worldbody><body pos="0 0 1"><joint name="hinge" type="hinge" pos="0 1e308 0" range="-1 1" limited="true"/><geom size="0.1"/></body></worldbody></mujoco>"#;

/// The joint-anchor bound holds at the edge (a call, a batch, a saved file's objects) but not
/// in the fold: a log that loaded such a model before the bound still folds to it.
#[test]
fn a_joint_anchor_beyond_the_bound_is_refused_at_the_edge_and_an_old_log_holding_one_folds() {
    let load = common::mjcf_command::load_mjcf("far_joint.xml", FAR_JOINT.as_bytes(), false);
    for why in [load.within_extent().unwrap_err(), load.clone().ready().unwrap_err()] {
        assert!(why.contains("joint hinge has pos [0.0, 1e308, 0.0], not finite numbers within 100000 m"), "{why}");
    }
    let mut world = common::empty_world("old");
    let limits = physics_mcp::limits::Limits::default();
    load.validate(&world, &limits).expect("the fold's check accepts what an old log recorded");
    let out = world.apply(&load, &mut |_| true);
    assert!(matches!(out, physics_mcp::outputs::Outcome::MjcfLoaded(_)), "{:?}", out.to_value());
}
