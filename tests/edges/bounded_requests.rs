//! One request's work with files is bounded and done before its simulation is locked: a batch
//! of 300 load_urdf of one 3 MB robot reads the file once (counted by the files layer's own
//! log line) and leaves the simulation readable meanwhile; a request whose files together
//! exceed the per-request budget is refused naming it.

use crate::common;

use common::Server;
use serde_json::{json, Value};

/// A two-link robot padded with a comment to `bytes`.
fn big_urdf(bytes: usize) -> String {
    let robot = r#"<robot name="r">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="arm"><inertial><mass value="0.5"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.05 0.05 0.3"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>"#;
    let pad = bytes.saturating_sub(robot.len() + 10);
    format!("<!-- {} -->\n{robot}", "x".repeat(pad))
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_of_300_loads_of_one_file_reads_it_once() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start_with_env(dir.path(), &[], &[("RUST_LOG", "warn,physics_mcp::files=debug")]);
    std::fs::write(server.workspace.join("big.urdf"), big_urdf(3 << 20)).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let calls: Vec<Value> = (0..300).map(|i| json!({"tool": "load_urdf", "arguments": {"file_path": "big.urdf", "position": [i as f64, 0, 0]}})).collect();
    let out = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    assert_eq!(out["results"].as_array().unwrap().len(), 300);
    let reads = server.stderr.lock().unwrap().iter().filter(|l| l.contains("read a user file") && l.contains("big.urdf")).count();
    assert_eq!(reads, 1, "the files layer read big.urdf {reads} times for one request");
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["objects"].as_array().unwrap().len(), 300);
    // A second request reads it again (nothing is kept between requests).
    c.call("load_urdf", json!({"sim_id": sim, "file_path": "big.urdf"})).await;
    let reads = server.stderr.lock().unwrap().iter().filter(|l| l.contains("read a user file") && l.contains("big.urdf")).count();
    assert_eq!(reads, 2);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_request_over_its_file_budget_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    // 40 distinct models of 7 MB: 280 MB of files in one request.
    let model = r#"<mujoco><worldbody><body name="b" pos="0 0 1"><joint type="hinge"/><geom size="0.1"/></body></worldbody></mujoco>"#;
    for i in 0..40 {
        std::fs::write(server.workspace.join(format!("r{i}.xml")), format!("<!-- {} -->{model}", "x".repeat(7 << 20))).unwrap();
    }
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let before = common::hard::fingerprint(&c, &sim).await;
    let calls: Vec<Value> = (0..40).map(|i| json!({"tool": "load_mjcf", "arguments": {"file_path": format!("r{i}.xml")}})).collect();
    let why = c.try_call("batch", json!({"sim_id": sim, "calls": calls})).await.unwrap_err();
    assert!(why.contains("one request may read") && why.contains("calls["), "{why}");
    common::hard::assert_unchanged(&c, &sim, &before, "an over-budget batch").await;
}
