//! A cancelled step_simulation was logged as the steps requested, so
//! verify_simulation and `replay` diverged at it, and without a snapshot at that event a
//! restart called the simulation corrupt. It now logs the steps it took: cancelled at several
//! points (with and without a snapshot at the step), the simulation verifies, the CLI replays
//! its log, a kill -9 restart serves the same state and a fork at that seq equals it.

use crate::common;

use std::time::Duration;

use common::{Client, Server};
use rmcp::model::{CallToolRequestParams, ClientRequest, Request};
use rmcp::service::PeerRequestOptions;
use serde_json::json;

/// Asks for `steps` and cancels after `after`; returns the steps taken.
async fn cancelled_step(c: &Client, sim: &str, steps: u64, after: Duration) -> u64 {
    let before = c.call("get_simulation_info", json!({"sim_id": sim})).await["steps"].as_u64().unwrap();
    let req = ClientRequest::CallToolRequest(Request::new(
        CallToolRequestParams::new("step_simulation")
            .with_arguments(json!({"sim_id": sim, "steps": steps}).as_object().unwrap().clone()),
    ));
    let mut opts = PeerRequestOptions::no_options();
    opts.timeout = Some(after);
    let handle = c.service.send_cancellable_request(req, opts).await.unwrap();
    assert!(handle.await_response().await.is_err(), "the call should have been cancelled");
    let now = c.call("get_simulation_info", json!({"sim_id": sim})).await["steps"].as_u64().unwrap();
    now - before
}

/// `physics-mcp replay LOG`: (success, stdout and stderr).
pub(crate) fn replay_cli(log: &std::path::Path) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(log).output().unwrap();
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

#[tokio::test(flavor = "multi_thread")]
async fn a_cancelled_step_logs_the_steps_it_took() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    server.copy_fixtures();
    // Few objects (robots: slow steps, one object each) and requests under the snapshot
    // threshold (3 × 30,000 body-steps < 100,000), then a large one: a snapshot is due after
    // the work actually done, so none sits at these cancelled events and a restart refolds them.
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for (file, x) in [("iiwa14.urdf", 0), ("wheeled_base.urdf", 2)] {
        c.call("load_urdf", json!({"sim_id": sim, "file_path": file, "position": [x, 0, 0.3]})).await;
    }
    let mut cancels = Vec::new();
    for (steps, ms) in [(30_000, 20), (30_000, 60), (1_000_000, 250)] {
        let took = cancelled_step(&c, &sim, steps, Duration::from_millis(ms)).await;
        eprintln!("cancelled after {ms} ms: took {took} of {steps}");
        assert!(took > 0 && took < steps, "cancelled after {ms} ms: took {took} of {steps}");
        let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
        cancels.push((info["head_seq"].as_u64().unwrap(), info["state_hash"].as_str().unwrap().to_string(), took));
        c.step(&sim, 5).await;
    }
    let history = c.call("get_history", json!({"sim_id": sim, "limit": 1000, "detail": "full"})).await;
    for (seq, hash, took) in &cancels {
        let e = history["events"].as_array().unwrap().iter().find(|e| e["seq"] == *seq).unwrap();
        assert_eq!(e["state_hash"], json!(hash));
        assert_eq!(e["summary"]["steps_taken"], json!(took), "{e}");
    }
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    let head = c.hash(&sim).await;
    // kill -9, then the CLI replays the log as left on disk and a restart serves the same state.
    drop(c);
    server.kill();
    let (ok, out) = replay_cli(&dir.path().join("data").join(format!("{sim}.sqlite")));
    assert!(ok, "{out}");
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, head);
    for (seq, hash, _) in &cancels {
        let f = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": seq})).await;
        assert_eq!(&f["state_hash"], hash);
    }
}
