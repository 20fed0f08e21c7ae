//! What a client hears travels with routing. Three nodes: simulations created through node C
//! (so C owns them), a client on node A, a client on node B.
//! - A subscribes to `sim://S/info` (`resources/subscribe`); changes made through B (forwarded
//!   to C) and through C itself reach A as `notifications/resources/updated` for that URI, and
//!   `resources/read` of it through A is the owner's answer.
//! - B's long step_simulation on a simulation C owns reports progress to B's client.
//! - B cancels a long step on S: the cancellation reaches C, the step stops, and it is logged
//!   as the steps it took (the next call sees them, and the exported log replays).
//! - The web viewer through A shows S as C has it (the page and a frame, relayed to C).
#![allow(deprecated)] // rmcp marks resources/subscribe legacy; 2025-11-25 clients use it

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rmcp::model::{
    CallToolRequestParams, ClientRequest, ProgressNotificationParam, ReadResourceRequestParams, Request, ResourceContents,
    ResourceUpdatedNotificationParam, SubscribeRequestParams,
};
use rmcp::service::{NotificationContext, PeerRequestOptions, RunningService};
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::{ClientHandler, RoleClient, ServiceExt};
use serde_json::{json, Value};

use crate::common::until;
use crate::nats::NatsCluster;
use crate::nodes::{attempt, event_result, events, export_and_verify, shared_workspace, Node, Outcome};

/// Steps of the step whose progress is watched (as tests/protocol/step_progress.rs).
const PROGRESS_STEPS: u64 = 20_000;
/// Steps asked of the step that is cancelled: far more than it can take before the cancel.
const CANCELLED_STEPS: u64 = 1_000_000;
/// The cancelled call's client gives up (and sends notifications/cancelled) after this.
const CANCEL_AFTER: Duration = Duration::from_millis(400);
/// The call after the cancel must be answered within this: the step must have stopped
/// (1,000,000 steps of 300 boxes would take hours).
const AFTER_CANCEL_WITHIN: Duration = Duration::from_secs(60);

/// Progress notifications received: (progress, total).
type Progress = Vec<(f64, Option<f64>)>;

/// What a client heard: resource updates (URI) and progress.
#[derive(Clone, Default)]
struct Heard {
    updates: Arc<Mutex<Vec<String>>>,
    progress: Arc<Mutex<Progress>>,
}

impl ClientHandler for Heard {
    async fn on_resource_updated(&self, params: ResourceUpdatedNotificationParam, _cx: NotificationContext<RoleClient>) {
        self.updates.lock().unwrap().push(params.uri);
    }

    async fn on_progress(&self, p: ProgressNotificationParam, _cx: NotificationContext<RoleClient>) {
        self.progress.lock().unwrap().push((p.progress, p.total));
    }
}

impl Heard {
    fn updates_of(&self, uri: &str) -> usize {
        self.updates.lock().unwrap().iter().filter(|u| *u == uri).count()
    }
}

/// A session on `node` that records what it hears.
async fn listener(node: &Node) -> (Heard, RunningService<RoleClient, Heard>) {
    let heard = Heard::default();
    let service = heard.clone().serve(StreamableHttpClientTransport::from_uri(node.server().url.clone())).await.expect("initialize a listening session");
    (heard, service)
}


/// A tool call through `s` that must be answered: its structured content.
async fn call(s: &RunningService<RoleClient, Heard>, tool: &str, args: Value) -> Value {
    let r = s
        .call_tool(CallToolRequestParams::new(tool.to_string()).with_arguments(args.as_object().unwrap().clone()))
        .await
        .unwrap_or_else(|e| panic!("{tool}: {e}"));
    assert_ne!(r.is_error, Some(true), "{tool} {args} was refused: {r:?}");
    r.structured_content.expect("structuredContent")
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn updates_progress_and_cancellation_travel_between_nodes() {
    let nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let nodes: Vec<Node> = ["a", "b", "c"].iter().map(|n| Node::start(root.path(), n, &nats, &workspace, &[])).collect();
    let (a, b, c) = (&nodes[0], &nodes[1], &nodes[2]);

    // S, owned by C: a ground and 300 boxes (slow steps, for the cancel below).
    let cc = c.client().await;
    let sim = cc.new_sim(json!({})).await;
    cc.ground(&sim).await;
    let boxes: Vec<Value> = (0..300)
        .map(|i| {
            let p = [(i % 10) as f64 * 0.3, ((i / 10) % 10) as f64 * 0.3, 0.3 + (i / 100) as f64 * 0.3];
            json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": p}})
        })
        .collect();
    cc.call("batch", json!({"sim_id": sim, "calls": boxes})).await;

    // A subscribes; B steps (forwarded to C); A hears it. Then C changes it; A hears that too.
    let (heard_a, on_a) = listener(a).await;
    let uri = format!("sim://{sim}/info");
    on_a.subscribe(SubscribeRequestParams::new(&uri)).await.expect("resources/subscribe on A");
    let (heard_b, on_b) = listener(b).await;
    call(&on_b, "step_simulation", json!({"sim_id": sim, "steps": 1})).await;
    until("A's update for a step made through B", || heard_a.updates_of(&uri) >= 1).await;
    let heard = heard_a.updates_of(&uri);
    cc.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 2]})).await;
    until("A's update for a change made through C", || heard_a.updates_of(&uri) > heard).await;
    assert!(heard_b.updates.lock().unwrap().is_empty(), "B subscribed to nothing but heard {:?}", heard_b.updates.lock().unwrap());

    // resources/read through A is the owner's get_simulation_info.
    let read = on_a.read_resource(ReadResourceRequestParams::new(&uri)).await.expect("resources/read through A");
    let Some(ResourceContents::TextResourceContents { text, .. }) = read.contents.into_iter().next() else { panic!("sim://…/info is not text") };
    let read: Value = serde_json::from_str(&text).expect("sim://…/info is JSON");
    let info = cc.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!((&read["state_hash"], &read["head_seq"]), (&info["state_hash"], &info["head_seq"]), "resources/read through A vs the owner");

    // The viewer through A shows C's simulation: the page and a frame of the owner's state.
    let port: u16 = a.server().url.rsplit(':').next().and_then(|p| p.trim_end_matches("/mcp").parse().ok()).expect("A's port");
    let (status, _) = crate::nats::http_get(port, &format!("/viewer/{sim}")).expect("the viewer page through A");
    assert_eq!(status, 200, "the viewer page of C's simulation through A");
    let (status, frame) = crate::nats::http_get(port, &format!("/viewer/{sim}/frame")).expect("a frame through A");
    assert_eq!(status, 200, "a frame of C's simulation through A: {frame}");
    let frame: Value = serde_json::from_str(&frame).expect("a frame is JSON");
    assert_eq!(frame["state_hash"], info["state_hash"], "the frame through A is the owner's state");
    // The WebGL page's poses, and the MCP App's read of them, come from the owner too.
    let (status, poses) = crate::nats::http_get(port, &format!("/viewer/{sim}/poses")).expect("poses through A");
    assert_eq!(status, 200, "poses of C's simulation through A: {poses}");
    let poses: Value = serde_json::from_str(&poses).expect("poses are JSON");
    assert_eq!(poses["state_hash"], info["state_hash"], "the poses through A are the owner's state");
    let read = on_a.read_resource(ReadResourceRequestParams::new(format!("sim://{sim}/viewer/poses"))).await.expect("the app's read through A");
    let Some(ResourceContents::TextResourceContents { text, .. }) = read.contents.into_iter().next() else { panic!("viewer poses are not text") };
    let read: Value = serde_json::from_str(&text).expect("viewer poses are JSON");
    assert_eq!(read["state_hash"], info["state_hash"], "the app's read through A is the owner's state");

    // Progress of a forwarded long step reaches B's client.
    let light = cc.new_sim(json!({})).await;
    cc.call("add_sphere", json!({"sim_id": light, "radius": 0.1, "position": [0, 0, 1]})).await;
    let stepped = call(&on_b, "step_simulation", json!({"sim_id": light, "steps": PROGRESS_STEPS})).await;
    assert_eq!(stepped["steps_taken"], json!(PROGRESS_STEPS));
    tokio::time::sleep(Duration::from_millis(200)).await;
    let seen = heard_b.progress.lock().unwrap().clone();
    assert!(seen.len() >= 10, "only {} progress notifications of a forwarded step reached B's client: {seen:?}", seen.len());
    let mut values: Vec<f64> = seen.iter().map(|(p, _)| *p).collect();
    values.sort_by(f64::total_cmp);
    assert!(values.windows(2).all(|w| w[0] < w[1]), "progress values must be distinct: {seen:?}");
    assert!(seen.iter().all(|(p, t)| *t == Some(PROGRESS_STEPS as f64) && *p <= PROGRESS_STEPS as f64), "{seen:?}");

    // B cancels a long forwarded step on S: C stops it, and keeps and logs the steps it took.
    let before = info["steps"].as_u64().expect("steps");
    let req = ClientRequest::CallToolRequest(Request::new(
        CallToolRequestParams::new("step_simulation").with_arguments(json!({"sim_id": sim, "steps": CANCELLED_STEPS}).as_object().unwrap().clone()),
    ));
    let mut opts = PeerRequestOptions::no_options();
    opts.timeout = Some(CANCEL_AFTER);
    let handle = on_b.send_cancellable_request(req, opts).await.expect("send the long step");
    assert!(handle.await_response().await.is_err(), "the step should have been cancelled");
    let cancelled_at = Instant::now();
    // The next call (through B, so forwarded too) waits for the cancelled step to stop.
    let bc = b.client().await;
    let after = match attempt(&bc, "get_simulation_info", json!({"sim_id": sim}), AFTER_CANCEL_WITHIN).await {
        Outcome::Ok(v) => v,
        other => panic!("after cancelling a forwarded step, get_simulation_info got {other:?} (did the cancellation reach the owner?)"),
    };
    let took = after["steps"].as_u64().expect("steps") - before;
    eprintln!("the cancelled forwarded step took {took} of {CANCELLED_STEPS} steps; the next call was answered {:?} after the cancel", cancelled_at.elapsed());
    assert!(took > 0 && took < CANCELLED_STEPS, "steps taken by the cancelled step: {took}");
    assert_eq!(cc.call("get_simulation_info", json!({"sim_id": sim})).await["state_hash"], after["state_hash"], "B and the owner disagree");

    // The log holds the cancelled step as the steps it took, and replays.
    let out = tempfile::tempdir().unwrap();
    let (file, summary) = export_and_verify(&nats.urls(), &sim, out.path(), "notifications");
    assert_eq!(summary["final_hash"], after["state_hash"], "the exported log's final state");
    let log = events(&file);
    let last_step = log.iter().rev().find(|e| e.ok && e.tool == "step_simulation").expect("a step in the log");
    assert_eq!(event_result(last_step)["steps_taken"], json!(took), "the cancelled step's logged result: {:?}", last_step.summary);
}
