//! batch (docs/tools.md "Scale") over HTTP against the real server: a batch of 1,001 add_box
//! calls gives the state hash of the same 1,001 calls made one by one (and stays equal when
//! both step on); a batch with one bad call anywhere changes nothing; undo after a batch takes
//! back its last call only; reads inside a batch see the state the earlier calls left; a batch
//! holding a URDF survives a kill -9; every refusal names the call and changes nothing.

use crate::common;

use common::pile_calls;
use common::hard::{assert_unchanged, fingerprint};
use common::Server;
use serde_json::{json, Value};

/// The pile of the benches (deterministic, no randomness needed here): a static ground and
#[tokio::test(flavor = "multi_thread")]
async fn a_batch_equals_the_same_calls_one_by_one_and_undo_takes_back_its_last_call() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let calls = pile_calls();

    let one_by_one = c.new_sim(json!({})).await;
    for call in &calls {
        let mut a = call["arguments"].clone();
        a["sim_id"] = json!(one_by_one);
        c.call(call["tool"].as_str().unwrap(), a).await;
    }
    let batched = c.new_sim(json!({})).await;
    let out = c.call("batch", json!({"sim_id": batched, "calls": calls})).await;
    assert_eq!(out["results"].as_array().unwrap().len(), 1001);
    assert_eq!(out["results"][1000]["object_id"], json!(1000));
    assert_eq!(out["state_hash"].as_str().unwrap(), c.hash(&one_by_one).await, "batch vs one call per box");
    assert_eq!(out["head_seq"], json!(1002), "root + 1,001 change events");

    // Both continue identically (the batch's world is the world, not an approximation).
    c.step(&one_by_one, 60).await;
    c.step(&batched, 60).await;
    assert_eq!(c.hash(&batched).await, c.hash(&one_by_one).await);

    // Undo takes back one call (the step), then one add_box of the batch.
    c.call("undo", json!({"sim_id": batched})).await;
    let undone = c.call("undo", json!({"sim_id": batched})).await;
    let info = c.call("get_simulation_info", json!({"sim_id": batched})).await;
    assert_eq!(info["num_objects"].as_u64().or(info["objects"].as_array().map(|a| a.len() as u64)), Some(1000), "{undone} {info}");
    assert_eq!(info["head_seq"], json!(1001));

    // The log folds back: every recorded hash checked.
    let verified = c.call("verify_simulation", json!({"sim_id": batched})).await;
    assert_eq!(verified["ok"], json!(true), "{verified}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_bad_call_anywhere_refuses_the_whole_batch_and_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-steps", "100"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    c.ground(s).await;
    c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [0, 0, 1]})).await;
    let before = fingerprint(&c, s).await;

    let mut bad_at_500 = pile_calls();
    bad_at_500[500] = json!({"tool": "add_box", "arguments": {"dimensions": [0.1, -1, 0.1], "position": [0, 0, 1]}});
    let step = |n: u64| json!({"tool": "step_simulation", "arguments": {"steps": n}});
    let add = json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 2]}});
    let too_many: Vec<Value> = (0..10_001).map(|_| add.clone()).collect();
    let rows: Vec<(Value, Vec<&str>)> = vec![
        (json!(bad_at_500), vec!["calls[500]", "add_box", "dimensions"]),
        (json!([add, {"tool": "teleport", "arguments": {}}]), vec!["calls[1]", "teleport", "not a tool"]),
        (json!([add, {"tool": "fork_simulation"}]), vec!["calls[1]", "fork_simulation", "cannot be inside a batch"]),
        (json!([{"tool": "batch", "arguments": {"calls": []}}]), vec!["calls[0]", "batch", "cannot be inside"]),
        (json!([add, {"tool": "destroy_simulation"}]), vec!["calls[1]", "destroy_simulation"]),
        (json!([{"tool": "save_simulation", "arguments": {"file_path": "x.json"}}]), vec!["calls[0]", "save_simulation"]),
        (json!([{"tool": "load_simulation", "arguments": {"file_path": "x.json"}}]), vec!["calls[0]", "load_simulation"]),
        (json!([{"tool": "ray_test", "arguments": {"ray_from": [0, 0, 5], "ray_to": [0, 0, -5]}}]), vec!["calls[0]", "ray_test", "cannot be inside"]),
        (json!(too_many), vec!["calls", "10000", "10001"]),
        (json!([]), vec!["calls", "got 0"]),
        (json!([add, {"tool": "get_object_state", "arguments": {"object_id": 99}}]), vec!["calls[1]", "get_object_state", "99"]),
        (json!([add, {"tool": "remove_object", "arguments": {"object_id": 2}}, {"tool": "set_object_pose", "arguments": {"object_id": 2, "position": [0, 0, 3]}}]),
            vec!["calls[2]", "set_object_pose", "2"]),
        (json!([add, {"tool": "add_box", "arguments": {"sim_id": "another", "dimensions": [1, 1, 1]}}]), vec!["calls[1]", "sim_id", "another"]),
        (json!([step(60), add, step(60)]), vec!["steps", "120", "--max-steps"]),
        (json!([{"tool": "step_simulation", "arguments": {"steps": 10, "sample_every": 2}}]), vec!["calls[0]", "sample_every"]),
        (json!([add, {"tool": "add_box", "arguments": {"dimension": [1, 1, 1]}}]), vec!["calls[1]", "`dimension`"]),
    ];
    for (calls, words) in rows {
        let r = c.try_call("batch", json!({"sim_id": s, "calls": calls})).await;
        let why = r.expect_err("the batch must be refused");
        for w in words {
            assert!(why.contains(w), "{why:?} should mention {w:?}");
        }
        assert_unchanged(&c, s, &before, &why).await;
    }
    // The refused batches left no object behind and the simulation goes on as before.
    let info = c.call("get_simulation_info", json!({"sim_id": s})).await;
    assert_eq!(info["state_hash"].as_str().unwrap(), before.state_hash);
}

#[tokio::test(flavor = "multi_thread")]
async fn reads_inside_a_batch_see_the_earlier_calls_and_a_robot_batch_survives_kill_9() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let out = c
        .call(
            "batch",
            json!({"sim_id": s, "calls": [
                {"tool": "add_box", "arguments": {"dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0}},
                {"tool": "load_urdf", "arguments": {"file_path": "two_link_arm.urdf", "position": [0, 0, 1], "use_fixed_base": true}},
                {"tool": "get_simulation_info"},
                {"tool": "set_joint_motor_control", "arguments": {"object_id": 1, "joint_index": 0, "control_mode": "POSITION_CONTROL", "target_position": 0.5}},
                {"tool": "step_simulation", "arguments": {"steps": 120}},
                {"tool": "get_joint_state", "arguments": {"object_id": 1, "joint_index": 0}},
                {"tool": "get_link_state", "arguments": {"object_id": 1, "link_index": 0}},
                {"tool": "get_object_state", "arguments": {"object_id": 0}},
            ]}),
        )
        .await;
    let r = out["results"].as_array().unwrap();
    assert_eq!(r.len(), 8);
    assert_eq!(r[2]["head_seq"], json!(3), "the read sees the two changes before it: {}", r[2]);
    assert!(r[5]["joint_position"].as_f64().unwrap() > 0.05, "the motor moved the joint: {}", r[5]);
    // Each read in the batch answers what the same read made alone would.
    let alone = c.call("get_joint_state", json!({"sim_id": s, "object_id": 1, "joint_index": 0})).await;
    assert_eq!(r[5], alone);
    let hash = out["state_hash"].as_str().unwrap().to_string();
    assert_eq!(c.hash(s).await, hash);

    // Acknowledged, so committed: a kill -9 loses none of it (the URDF is in the log too).
    std::fs::remove_file(server.workspace.join("two_link_arm.urdf")).unwrap();
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(s).await, hash);
    let verified = c.call("verify_simulation", json!({"sim_id": s})).await;
    assert_eq!(verified["ok"], json!(true), "{verified}");
    c.step(s, 10).await;
    // The replay CLI re-runs the batch's events, results of its reads included.
    server.terminate();
    common::assert_replays(&dir.path().join("data"), s);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_of_reads_only_changes_nothing_and_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    c.ground(s).await;
    let before = fingerprint(&c, s).await;
    let out = c.call("batch", json!({"sim_id": s, "calls": [{"tool": "get_object_state", "arguments": {"object_id": 0}}, {"tool": "get_simulation_info"}]})).await;
    assert_eq!(out["head_seq"].as_u64(), Some(before.head_seq));
    assert_eq!(out["state_hash"].as_str(), Some(before.state_hash.as_str()));
    assert_unchanged(&c, s, &before, "a batch of reads").await;
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(s).await, before.state_hash);
}
