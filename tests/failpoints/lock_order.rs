//! The registry's table lock guards map operations only, never I/O: with a create held inside
//! its commit (a fail point that sleeps there; fail points are in every debug build), another
//! client's calls on other simulations — get_object_state, list_simulations, a fork — still
//! complete. Run by `.ci/run`: `cargo test --test failpoints -- --ignored`.

use crate::common;

use std::time::Duration;

use common::Server;
use serde_json::json;

#[tokio::test(flavor = "multi_thread")]
#[ignore = "holds a create for a minute: .ci/run runs it (cargo test --test failpoints -- --ignored)"]
async fn a_create_held_in_its_commit_does_not_stall_other_simulations() {
    let dir = tempfile::tempdir().unwrap();
    // The first create passes; the second sleeps for a minute between its commit and its publish.
    let server = Server::start_with_env(dir.path(), &[], &[("FAILPOINTS", "create_before_publish=1*off->1*sleep(60000)")]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    let url = server.url.clone();
    let held = tokio::spawn(async move { common::Client::connect(&url).await.try_call("create_simulation", json!({})).await });
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert!(!held.is_finished(), "the second create should be held at its fail point");
    // A minute of sleep on one side, a 20 s watchdog on the other: a stall is a failure.
    let watchdog = Duration::from_secs(20);
    let state = tokio::time::timeout(watchdog, c.try_call("get_object_state", json!({"sim_id": sim, "object_id": 0}))).await;
    assert!(state.expect("get_object_state waited for another simulation's create").is_ok());
    let listed = tokio::time::timeout(watchdog, c.try_call("list_simulations", json!({}))).await;
    assert!(listed.expect("list_simulations waited for a create").is_ok());
    let forked = tokio::time::timeout(watchdog, c.try_call("fork_simulation", json!({"sim_id": sim}))).await;
    assert!(forked.expect("fork_simulation waited for a create").is_ok());
    held.abort();
}
