//! write_file in a cluster: every node serves one shared workspace (docs/cluster.md "User
//! files"), so a file an agent writes through one node is listed and loaded through another —
//! also by a simulation that node does not own (the load is decided, the file read, where the
//! call lands, then carried to the owner). Once loaded, the file's bytes are in the log: the
//! simulation's owner dies, the file is deleted, and the node that takes the simulation over
//! still has the robot, its exported log replaying to the same hash.

use serde_json::json;

use crate::nats::NatsCluster;
use crate::nodes::{attempt, export_and_verify, shared_workspace, Node, Outcome};

/// A one-joint URDF an agent might write.
const PENDULUM: &str = r#"<robot name="pendulum">
  <link name="pivot"><inertial><mass value="0"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <link name="bob"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><origin xyz="0 0 -0.5"/><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="swing" type="continuous"><parent link="pivot"/><child link="bob"/><axis xyz="0 1 0"/></joint>
</robot>
"#;

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_file_written_through_one_node_loads_through_another() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let mut a = Node::start(root.path(), "a", &nats, &workspace, &["--lease-ms", "1000"]);
    let b = Node::start(root.path(), "b", &nats, &workspace, &["--lease-ms", "1000"]);
    let (ca, cb) = (a.client().await, b.client().await);

    // Written through b, seen through a.
    cb.call("write_file", json!({"path": "agent/pendulum.urdf", "content": PENDULUM})).await;
    let listed = ca.call("list_files", json!({"path": "agent"})).await;
    assert_eq!(listed["entries"], json!([{"path": "agent/pendulum.urdf", "bytes": PENDULUM.len(), "kind": "file"}]));
    // A second write of the path through a is refused as on one server: the file exists.
    let why = ca.try_call("write_file", json!({"path": "agent/pendulum.urdf", "content": "x"})).await.unwrap_err();
    assert!(why.contains("already exists"), "{why}");

    // a owns the simulation; the load is sent to b, which reads the shared file and forwards.
    let sim = ca.new_sim(json!({})).await;
    let loaded = cb.call("load_urdf", json!({"sim_id": sim, "file_path": "agent/pendulum.urdf", "position": [0, 0, 1]})).await;
    assert_eq!(loaded["num_joints"], 1, "{loaded}");
    ca.call("reset_joint_state", json!({"sim_id": sim, "object_id": 0, "joint_index": 0, "target_value": 0.5})).await;
    ca.step(&sim, 120).await;
    let hash = ca.hash(&sim).await;

    // The file goes, then its owner: the node taking the simulation over needs neither.
    std::fs::remove_file(workspace.join("agent/pendulum.urdf")).unwrap();
    a.kill9();
    match attempt(&cb, "get_joint_state", json!({"sim_id": sim, "object_id": 0, "joint_index": 0}), std::time::Duration::from_secs(60)).await {
        Outcome::Ok(state) => assert!(state["joint_position"].as_f64().unwrap() != 0.5, "it swung: {state}"),
        other => panic!("after its owner died, b answered {other:?}"),
    }
    assert_eq!(cb.hash(&sim).await, hash, "taken over whole, from the log alone");
    let out = tempfile::tempdir().unwrap();
    let (_, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "shared_files");
    assert_eq!(summary["final_hash"], json!(hash));
}
