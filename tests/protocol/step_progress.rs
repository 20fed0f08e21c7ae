//! Long `step_simulation` calls: MCP progress notifications reach the client, and a cancelled
//! call keeps (and logs) exactly the steps it took — a restart shows the same state.

use crate::common;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use common::{Client, Server};
use rmcp::model::{CallToolRequestParams, ClientRequest, ProgressNotificationParam, Request};
use rmcp::service::{NotificationContext, PeerRequestOptions};
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::{ClientHandler, RoleClient, ServiceExt};
use serde_json::json;

/// The (progress, total) pairs of the notifications received.
type Notified = Vec<(f64, Option<f64>)>;

#[derive(Clone, Default)]
struct ProgressLog(Arc<Mutex<Notified>>);

impl ClientHandler for ProgressLog {
    async fn on_progress(&self, p: ProgressNotificationParam, _: NotificationContext<RoleClient>) {
        self.0.lock().unwrap().push((p.progress, p.total));
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn long_steps_report_progress() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let log = ProgressLog::default();
    let client = log
        .clone()
        .serve(StreamableHttpClientTransport::from_uri(server.url.clone()))
        .await
        .unwrap();
    let args = |v: serde_json::Value| v.as_object().unwrap().clone();
    let r = client
        .call_tool(CallToolRequestParams::new("create_simulation").with_arguments(args(json!({}))))
        .await
        .unwrap();
    let sim = r.structured_content.unwrap()["simulation_id"].as_str().unwrap().to_string();
    client
        .call_tool(CallToolRequestParams::new("add_sphere").with_arguments(args(
            json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]}),
        )))
        .await
        .unwrap();
    let r = client
        .call_tool(CallToolRequestParams::new("step_simulation").with_arguments(args(
            json!({"sim_id": sim, "steps": 20000}),
        )))
        .await
        .unwrap();
    assert_eq!(r.structured_content.unwrap()["steps_taken"], 20000);
    tokio::time::sleep(Duration::from_millis(200)).await;
    let seen = log.0.lock().unwrap().clone();
    assert!(seen.len() >= 10, "only {} progress notifications", seen.len());
    // The server sends them in order from one task; rmcp's client may hand notifications to
    // the handler concurrently, so check the values as a set: distinct and increasing.
    let mut sorted: Vec<f64> = seen.iter().map(|(p, _)| *p).collect();
    sorted.sort_by(f64::total_cmp);
    assert!(sorted.windows(2).all(|w| w[0] < w[1]), "progress values must be distinct: {seen:?}");
    assert!(seen.iter().all(|(p, t)| *t == Some(20000.0) && *p <= 20000.0), "{seen:?}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_cancelled_step_keeps_and_logs_the_steps_it_took() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..300 {
        let (x, y, z) = ((i % 10) as f64 * 0.3, ((i / 10) % 10) as f64 * 0.3, 0.3 + (i / 100) as f64 * 0.3);
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [x, y, z]})).await;
    }
    let req = ClientRequest::CallToolRequest(Request::new(
        CallToolRequestParams::new("step_simulation")
            .with_arguments(json!({"sim_id": sim, "steps": 1_000_000}).as_object().unwrap().clone()),
    ));
    let mut opts = PeerRequestOptions::no_options();
    opts.timeout = Some(Duration::from_millis(400));
    let handle = c.service.send_cancellable_request(req, opts).await.unwrap();
    assert!(handle.await_response().await.is_err(), "the call should have been cancelled");
    // The next call waits for the cancelled one to stop, then sees the steps it took.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let steps = info["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < 1_000_000, "steps after cancel: {steps}");
    let hash = info["state_hash"].as_str().unwrap().to_string();
    // What the log recorded is exactly that: a restart folds to the same state.
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c: Client = server.client().await;
    let again = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(again["steps"].as_u64().unwrap(), steps);
    assert_eq!(again["state_hash"].as_str().unwrap(), hash);
}

/// Progress of run_sweep counts the steps of all variants; of batch, the steps of its calls.
#[tokio::test(flavor = "multi_thread")]
async fn sweeps_and_batches_report_progress() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let log = ProgressLog::default();
    let client = log.clone().serve(StreamableHttpClientTransport::from_uri(server.url.clone())).await.unwrap();
    let args = |v: serde_json::Value| v.as_object().unwrap().clone();
    let call = |tool: &str, v: serde_json::Value| CallToolRequestParams::new(tool.to_string()).with_arguments(args(v));
    let r = client.call_tool(call("create_simulation", json!({}))).await.unwrap();
    let sim = r.structured_content.unwrap()["simulation_id"].as_str().unwrap().to_string();
    client.call_tool(call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]}))).await.unwrap();
    for (tool, a, total) in [
        ("run_sweep", json!({"sim_id": sim, "variants": [[], [], [], []], "steps": 5000}), 20000.0),
        ("batch", json!({"sim_id": sim, "calls": [{"tool": "step_simulation", "arguments": {"steps": 8000}}, {"tool": "step_simulation", "arguments": {"steps": 8000}}]}), 16000.0),
    ] {
        log.0.lock().unwrap().clear();
        let r = client.call_tool(call(tool, a)).await.unwrap();
        assert_ne!(r.is_error, Some(true), "{tool}: {r:?}");
        tokio::time::sleep(Duration::from_millis(200)).await;
        let seen = log.0.lock().unwrap().clone();
        assert!(seen.len() >= 10, "{tool}: only {} progress notifications", seen.len());
        assert!(seen.iter().all(|(p, t)| *t == Some(total) && *p <= total), "{tool}: {seen:?}");
    }
}

/// A cancelled run_sweep deletes every variant and changes nothing; a cancelled batch is
/// refused as a whole (its steps are not kept, unlike a lone step_simulation's).
#[tokio::test(flavor = "multi_thread")]
async fn cancelled_sweeps_and_batches_leave_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..100 {
        let (x, y, z) = ((i % 10) as f64 * 0.3, ((i / 10) % 10) as f64 * 0.3, 0.3);
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [x, y, z]})).await;
    }
    let before = common::hard::fingerprint(&c, &sim).await;
    let data_files = || {
        let mut f: Vec<String> = std::fs::read_dir(&server.data).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        f.retain(|n| !n.ends_with("-wal") && !n.ends_with("-shm"));
        f.sort();
        f
    };
    let files_before = data_files();
    for (tool, a) in [
        ("run_sweep", json!({"sim_id": sim, "variants": [[], [], []], "steps": 1_000_000})),
        ("batch", json!({"sim_id": sim, "calls": [{"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [0, 0, 2]}}, {"tool": "step_simulation", "arguments": {"steps": 1_000_000}}]})),
    ] {
        let req = ClientRequest::CallToolRequest(Request::new(CallToolRequestParams::new(tool).with_arguments(a.as_object().unwrap().clone())));
        let mut opts = PeerRequestOptions::no_options();
        opts.timeout = Some(Duration::from_millis(600));
        let handle = c.service.send_cancellable_request(req, opts).await.unwrap();
        assert!(handle.await_response().await.is_err(), "{tool} should have been cancelled");
        // The sweep's variants run without the swept simulation's lock: wait until it is done.
        let mut waited = 0;
        while data_files() != files_before && waited < 600 {
            tokio::time::sleep(Duration::from_millis(100)).await;
            waited += 1;
        }
        assert_eq!(data_files(), files_before, "{tool} left files behind");
        common::hard::assert_unchanged(&c, &sim, &before, tool).await;
        assert_eq!(c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), 1);
    }
}
