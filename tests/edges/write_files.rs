//! A client's own files, over MCP/HTTP: write_file puts a file in the workspace (the one way a
//! client of a remote server can), list_files says what is there.
//!
//! - An agent-written URDF with a base64 STL mesh loads in the next call, steps, saves, and the
//!   saved file loads in another server (which never sees the mesh file) to the same state.
//! - Every refusal — outside the workspace, through a symbolic link (inside or out), into a
//!   FIFO or a folder, over `--max-write-bytes`, onto an existing file without `overwrite`, bad
//!   or doubled content — leaves the workspace exactly as it was (every entry's kind, size,
//!   contents and link target), the file outside untouched, and creates no folder.
//! - list_files walks in name order, lists a link as a link without entering it, leaves out
//!   the data directory, and bounds its answer.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use base64::Engine as _;
use common::Server;
use serde_json::{json, Value};

/// A binary STL of the tetrahedron (0,0,0), (s,0,0), (0,s,0), (0,0,s), faces outward.
fn tetrahedron_stl(s: f32) -> Vec<u8> {
    let v = [[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
    let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let mut out = b"physics-mcp test: agent-written tetrahedron".to_vec();
    out.resize(80, b' ');
    out.extend_from_slice(&(faces.len() as u32).to_le_bytes());
    for f in faces {
        out.extend_from_slice(&[0u8; 12]);
        for i in f {
            for x in v[i] {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    out
}

/// An agent's two-link URDF: a box base, and a child link colliding as the mesh at
/// `meshes/wedge.stl` beside it, on a revolute joint.
const AGENT_URDF: &str = r#"<?xml version="1.0"?>
<robot name="agent_arm">
  <link name="base"><inertial><mass value="2"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
  <link name="wedge"><inertial><origin xyz="0.05 0.05 0.05"/><mass value="0.5"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><geometry><mesh filename="meshes/wedge.stl"/></geometry></collision></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="wedge"/><origin xyz="0 0 0.15"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="2"/></joint>
</robot>
"#;

#[tokio::test(flavor = "multi_thread")]
async fn an_agent_written_urdf_with_a_base64_mesh_loads_saves_and_loads_in_another_server() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("a"), &[]);
    let c = server.client().await;
    let stl = tetrahedron_stl(0.3);
    let mesh = base64::engine::general_purpose::STANDARD.encode(&stl);
    let wrote = c.call("write_file", json!({"path": "agent/meshes/wedge.stl", "content_base64": mesh})).await;
    assert_eq!(wrote, json!({"path": "agent/meshes/wedge.stl", "bytes": stl.len()}));
    let wrote = c.call("write_file", json!({"path": "agent/arm.urdf", "content": AGENT_URDF})).await;
    assert_eq!(wrote["bytes"], AGENT_URDF.len());
    assert_eq!(std::fs::read(server.workspace.join("agent/meshes/wedge.stl")).unwrap(), stl, "the bytes as sent");

    let sim = c.new_sim(json!({})).await;
    c.call("load_urdf", json!({"sim_id": sim, "file_path": "plane.urdf"})).await;
    let arm = c.call("load_urdf", json!({"sim_id": sim, "file_path": "agent/arm.urdf", "position": [0, 0, 0.1], "use_fixed_base": true})).await;
    assert_eq!(arm["num_joints"], 1, "{arm}");
    let id = arm["object_id"].as_u64().unwrap();
    let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": 0})).await;
    assert_eq!((info["joint_name"].as_str(), info["joint_type"].as_str()), (Some("hinge"), Some("revolute")));
    // The mesh is the wedge's collider: a ray down onto it stops at its slanted face, 0.25 m
    // above the link frame at x = y = 0.025 (x + y + z = 0.3), not at the base box.
    let hit = c.call("ray_test", json!({"sim_id": sim, "ray_from": [0.025, 0.025, 2], "ray_to": [0.025, 0.025, 0]})).await;
    assert_eq!(hit["object_id"], id, "{hit}");
    let z = hit["hit_position"][2].as_f64().unwrap();
    assert!((z - (0.1 + 0.15 + 0.25)).abs() < 1e-4, "the mesh's face at z = 0.5: {hit}");
    c.step(&sim, 240).await;
    let hash = c.hash(&sim).await;
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "agent/run.json"})).await;

    // Another server gets the saved file the same way, and nothing else: no URDF, no mesh.
    let other = Server::start(&dir.path().join("b"), &[]);
    let b = other.client().await;
    let saved = std::fs::read_to_string(server.workspace.join("agent/run.json")).unwrap();
    b.call("write_file", json!({"path": "run.json", "content": saved})).await;
    let loaded = b.call("load_simulation", json!({"file_path": "run.json"})).await;
    let copy = loaded["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(b.hash(&copy).await, hash, "the same state, its mesh carried in the saved file");
    assert!(!other.workspace.join("agent").exists() && !other.workspace.join("meshes").exists());
    b.step(&copy, 240).await;
    c.step(&sim, 240).await;
    assert_eq!(b.hash(&copy).await, c.hash(&sim).await, "and the same future");
}

/// Every entry under `root` (not following links): kind, size, contents' hash or link target.
fn tree(root: &Path) -> BTreeMap<PathBuf, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let path = e.unwrap().path();
            let meta = path.symlink_metadata().unwrap();
            let what = if meta.file_type().is_symlink() {
                format!("link -> {}", std::fs::read_link(&path).unwrap().display())
            } else if meta.is_dir() {
                stack.push(path.clone());
                "dir".to_string()
            } else if meta.is_file() {
                format!("file {} {}", meta.len(), blake3::hash(&std::fs::read(&path).unwrap()).to_hex())
            } else {
                "other".to_string()
            };
            out.insert(path.strip_prefix(root).unwrap().to_path_buf(), what);
        }
    }
    out
}

#[tokio::test(flavor = "multi_thread")]
async fn write_file_refusals_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-write-bytes", "1000"]);
    let c = server.client().await;
    let ws = server.workspace.clone();
    let outside = dir.path().join("outside.urdf");
    std::fs::write(&outside, "outside, never written").unwrap();
    std::fs::write(ws.join("taken.urdf"), "<robot name=\"taken\"/>").unwrap();
    std::fs::create_dir(ws.join("folder")).unwrap();
    std::os::unix::fs::symlink(ws.join("taken.urdf"), ws.join("link_in.urdf")).unwrap();
    std::os::unix::fs::symlink(&outside, ws.join("link_out.urdf")).unwrap();
    let fifo = ws.join("pipe.urdf");
    assert!(Command::new("mkfifo").arg(&fifo).status().expect("mkfifo").success());
    let before = tree(&ws);
    let data_before = tree(&server.data);

    let small = "x".repeat(10);
    let b64 = |n: usize| base64::engine::general_purpose::STANDARD.encode(vec![7u8; n]);
    let rows = [
        (json!({"path": "../outside.urdf", "content": small}), "Access denied"),
        (json!({"path": outside.display().to_string(), "content": small}), "Access denied"),
        (json!({"path": "../data/x.json", "content": small}), "Access denied"),
        (json!({"path": "link_out.urdf", "content": small, "overwrite": true}), "Access denied"),
        (json!({"path": "link_in.urdf", "content": small}), "symbolic link"),
        (json!({"path": "link_in.urdf", "content": small, "overwrite": true}), "symbolic link"),
        (json!({"path": "pipe.urdf", "content": small, "overwrite": true}), "not a regular file"),
        (json!({"path": "folder", "content": small, "overwrite": true}), "a folder"),
        (json!({"path": "taken.urdf", "content": small}), "already exists"),
        (json!({"path": "new/deep/big.urdf", "content": "y".repeat(1001)}), "at most 1000"),
        (json!({"path": "new/deep/big.stl", "content_base64": b64(1001)}), "at most 1000"),
        (json!({"path": "new/deep/bad.stl", "content_base64": "not base64!"}), "content_base64"),
        (json!({"path": "new/deep/both.urdf", "content": small, "content_base64": b64(3)}), "not both"),
        (json!({"path": "new/deep/none.urdf"}), "content or content_base64"),
        (json!({"path": "", "content": small}), "path"),
        (json!({"path": "new/deep/x.urdf", "content": 5}), "content"),
        (json!({"path": "new/x.urdf", "text": small}), "Unknown parameter"),
    ];
    for (args, needle) in rows {
        let why = c.try_call("write_file", args.clone()).await.expect_err(&format!("write_file {args} must be refused"));
        assert!(why.contains(needle), "write_file {args}: {why}");
        assert_eq!(tree(&ws), before, "write_file {args} changed the workspace");
    }
    assert_eq!(std::fs::read_to_string(&outside).unwrap(), "outside, never written");
    assert_eq!(tree(&server.data), data_before, "nothing in --data");
    assert!(!ws.join("new").exists(), "no folder was made for a refused file");

    // Within the limit, a new file; an existing one only with overwrite (atomically: the
    // link to it still points at it and now reads the new content).
    assert_eq!(c.call("write_file", json!({"path": "new/ok.stl", "content_base64": b64(1000)})).await["bytes"], 1000);
    c.call("write_file", json!({"path": "taken.urdf", "content": "<robot name=\"new\"/>", "overwrite": true})).await;
    assert_eq!(std::fs::read_to_string(ws.join("link_in.urdf")).unwrap(), "<robot name=\"new\"/>");
    assert!(ws.join("link_in.urdf").symlink_metadata().unwrap().file_type().is_symlink());
}

#[tokio::test(flavor = "multi_thread")]
async fn list_files_walks_the_workspace_in_name_order_without_following_links() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let ws = server.workspace.clone();
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("secret.txt"), "outside").unwrap();
    c.call("write_file", json!({"path": "b/two.urdf", "content": "22"})).await;
    c.call("write_file", json!({"path": "a.urdf", "content": "1"})).await;
    std::os::unix::fs::symlink(&elsewhere, ws.join("c_link")).unwrap();
    assert!(Command::new("mkfifo").arg(ws.join("d_pipe")).status().unwrap().success());

    let all = c.call("list_files", json!({})).await;
    let entries: Vec<(String, u64, String)> = all["entries"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["path"].as_str().unwrap().to_string(), e["bytes"].as_u64().unwrap(), e["kind"].as_str().unwrap().to_string()))
        .collect();
    let want = [("a.urdf", 1, "file"), ("b/", 0, "dir"), ("b/two.urdf", 2, "file"), ("c_link", 0, "symlink"), ("d_pipe", 0, "other")];
    assert_eq!(entries, want.map(|(p, b, k)| (p.to_string(), b, k.to_string())).to_vec(), "{all}");
    assert!(all.get("truncated").is_none(), "{all}");
    let sub = c.call("list_files", json!({"path": "b"})).await;
    assert_eq!(sub["entries"], json!([{"path": "b/two.urdf", "bytes": 2, "kind": "file"}]));
    let one = c.call("list_files", json!({"path": "a.urdf"})).await;
    assert_eq!(one["entries"], json!([{"path": "a.urdf", "bytes": 1, "kind": "file"}]));
    for (args, needle) in [
        (json!({"path": "nowhere"}), "does not exist"),
        (json!({"path": ".."}), "Access denied"),
        (json!({"path": "c_link"}), "Access denied"),
        (json!({"path": 3}), "path"),
    ] {
        let why = c.try_call("list_files", args.clone()).await.expect_err(&format!("list_files {args}"));
        assert!(why.contains(needle), "list_files {args}: {why}");
    }
    // A bounded answer: 256 entries, the rest counted.
    for i in 0..300 {
        std::fs::write(ws.join("b").join(format!("f{i:03}")), "").unwrap();
    }
    let many: Value = c.call("list_files", json!({})).await;
    assert_eq!(many["entries"].as_array().unwrap().len(), 256);
    assert_eq!((many["truncated"].as_bool(), many["total"].as_u64()), (Some(true), Some(305)), "{}", many["total"]);
}
