//! An output never replaces a file: outputs (animations, trajectories, ray and camera files)
//! are created new — an existing path is refused, and of concurrent writers to one new path
//! exactly one wins; save_simulation and generate_revolute_joint replace only their own files
//! unless `overwrite: true`; the command line replaces only with `--force`; files written get
//! the usual permissions (the umask), not 0600.

use crate::common;

use std::os::unix::fs::PermissionsExt;
use std::process::Command;

use common::Server;
use serde_json::json;

fn mode(path: &std::path::Path) -> u32 {
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

/// The permissions a file made by this process (and the server it starts) gets: 0666 less
/// the umask.
fn usual() -> u32 {
    let dir = tempfile::tempdir().unwrap();
    let probe = dir.path().join("probe");
    std::fs::write(&probe, b"").unwrap();
    mode(&probe)
}

#[tokio::test(flavor = "multi_thread")]
async fn concurrent_outputs_to_one_path_leave_exactly_one_and_never_replace_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..4 {
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [i as f64 * 0.3, 0, 1]})).await;
    }
    c.step(&sim, 120).await;
    // Eight clients at once, one path each kind: exactly one of each is written.
    for (tool, path, extra) in [
        ("render_animation", "clip.gif", json!({"width": 64, "height": 48, "every": 4})),
        ("get_trajectory", "poses.csv", json!({})),
        ("ray_test_batch", "rays.json", json!({"rays_from": [[0, 0, 5]], "rays_to": [[0, 0, -5]]})),
        ("get_camera_image", "shot.png", json!({"width": 32, "height": 24})),
    ] {
        let mut args = extra.as_object().unwrap().clone();
        args.insert("sim_id".into(), json!(sim));
        args.insert("output_path".into(), json!(path));
        let clients: Vec<common::Client> = futures_clients(&server, 8).await;
        let calls = clients.iter().map(|c| c.try_call(tool, serde_json::Value::Object(args.clone())));
        let results = futures::future::join_all(calls).await;
        let won = results.iter().filter(|r| r.is_ok()).count();
        assert_eq!(won, 1, "{tool}: {} writers succeeded: {results:?}", won);
        for r in results.iter().filter_map(|r| r.as_ref().err()) {
            assert!(r.contains("already exists"), "{tool}: {r}");
        }
        let written = std::fs::read(server.workspace.join(path)).unwrap();
        assert!(!written.is_empty());
        assert_eq!(mode(&server.workspace.join(path)), usual(), "{tool}: an output gets the usual permissions");
    }
    // A file of the user's at an output path is never replaced.
    std::fs::write(server.workspace.join("mine.gif"), b"my own file").unwrap();
    let why = c.try_call("render_animation", json!({"sim_id": sim, "output_path": "mine.gif", "width": 32, "height": 24})).await.unwrap_err();
    assert!(why.contains("already exists"), "{why}");
    assert_eq!(std::fs::read(server.workspace.join("mine.gif")).unwrap(), b"my own file");
}

async fn futures_clients(server: &Server, n: usize) -> Vec<common::Client> {
    let mut v = Vec::new();
    for _ in 0..n {
        v.push(server.client().await);
    }
    v
}

#[tokio::test(flavor = "multi_thread")]
async fn saves_and_generated_urdfs_replace_only_their_own_files() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let ws = &server.workspace;
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    // A user's URDF where a save or a generated URDF would go.
    std::fs::write(ws.join("robot.urdf"), "<robot name=\"mine\"/>").unwrap();
    std::fs::set_permissions(ws.join("robot.urdf"), std::fs::Permissions::from_mode(0o640)).unwrap();
    let why = c.try_call("save_simulation", json!({"sim_id": sim, "file_path": "robot.urdf"})).await.unwrap_err();
    assert!(why.contains("not a physics-mcp save") && why.contains("overwrite"), "{why}");
    let gen = json!({"parent_shape": "box", "child_shape": "box", "parent_dimensions": [0.1, 0.1, 0.1], "child_dimensions": [0.1, 0.1, 0.1], "output_path": "robot.urdf"});
    let why = c.try_call("generate_revolute_joint", gen.clone()).await.unwrap_err();
    assert!(why.contains("not a URDF written by generate_revolute_joint") && why.contains("overwrite"), "{why}");
    assert_eq!(std::fs::read_to_string(ws.join("robot.urdf")).unwrap(), "<robot name=\"mine\"/>");
    assert_eq!(mode(&ws.join("robot.urdf")), 0o640, "a refused write leaves the user's file as it was");
    // Their own files are replaced; anything else with overwrite: true.
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "run.json"})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    let saved = c.call("save_simulation", json!({"sim_id": sim, "file_path": "run.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "run.json"})).await;
    assert_eq!(loaded["state_hash"], saved["state_hash"]);
    c.call("generate_revolute_joint", json!({"parent_shape": "box", "child_shape": "sphere", "parent_dimensions": [0.1, 0.1, 0.1], "child_dimensions": [0.1], "output_path": "gen.urdf"})).await;
    c.call("generate_revolute_joint", json!({"parent_shape": "box", "child_shape": "box", "parent_dimensions": [0.1, 0.1, 0.1], "child_dimensions": [0.2, 0.1, 0.1], "output_path": "gen.urdf"})).await;
    assert!(std::fs::read_to_string(ws.join("gen.urdf")).unwrap().contains("<box size=\"0.4 0.2 0.2\"/>"));
    let mut forced = gen.clone();
    forced["overwrite"] = json!(true);
    c.call("generate_revolute_joint", forced).await;
    assert!(std::fs::read_to_string(ws.join("robot.urdf")).unwrap().contains("generate_revolute_joint"));
    for f in ["run.json", "gen.urdf", "robot.urdf"] {
        assert_eq!(mode(&ws.join(f)), usual(), "{f}: the usual permissions (the umask's)");
    }
}

#[test]
fn the_command_line_replaces_an_output_only_with_force() {
    let dir = tempfile::tempdir().unwrap();
    let log = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("replays/drop_and_stack.sqlite");
    let out = dir.path().join("report.html");
    std::fs::write(&out, "mine").unwrap();
    let run = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_physics-mcp")).args(args).output().unwrap();
    let (l, o) = (log.to_str().unwrap(), out.to_str().unwrap());
    let refused = run(&["report", l, "-o", o]);
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--force"), "{}", String::from_utf8_lossy(&refused.stderr));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "mine");
    let csv = dir.path().join("t.csv");
    std::fs::write(&csv, "mine").unwrap();
    assert!(!run(&["replay", l, "--trajectory", csv.to_str().unwrap()]).status.success());
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), "mine");
    let gif = dir.path().join("a.gif");
    std::fs::write(&gif, "mine").unwrap();
    assert!(!run(&["replay", l, "--render", gif.to_str().unwrap(), "--size", "32x24"]).status.success());
    assert_eq!(std::fs::read_to_string(&gif).unwrap(), "mine");
    assert!(run(&["report", l, "-o", o, "--force"]).status.success());
    assert!(std::fs::read_to_string(&out).unwrap().starts_with("<!"));
}
