//! Over HTTP: resource subscriptions (a second session hears the first
//! one step; updates are paced and the last change is always announced; unsubscribed hears
//! nothing) and MCP logging (after `logging/setLevel`, a refused call's reason arrives as
//! `notifications/message`).
#![allow(deprecated)] // rmcp marks resources/subscribe and logging legacy; 2025-11-25 clients use them

use crate::common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{until, Client, Server};
use rmcp::model::{
    LoggingLevel, LoggingMessageNotificationParam, ResourceUpdatedNotificationParam, SetLevelRequestParams,
    SubscribeRequestParams, UnsubscribeRequestParams,
};
use rmcp::service::{NotificationContext, RunningService};
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::{ClientHandler, RoleClient, ServiceExt};
use serde_json::json;

/// What a client heard: resource updates (URI and when) and log messages.
#[derive(Clone, Default)]
struct Heard {
    updates: Arc<Mutex<Vec<(String, Instant)>>>,
    logs: Arc<Mutex<Vec<LoggingMessageNotificationParam>>>,
}

impl ClientHandler for Heard {
    async fn on_resource_updated(&self, params: ResourceUpdatedNotificationParam, _cx: NotificationContext<RoleClient>) {
        self.updates.lock().unwrap().push((params.uri, Instant::now()));
    }

    async fn on_logging_message(&self, params: LoggingMessageNotificationParam, _cx: NotificationContext<RoleClient>) {
        self.logs.lock().unwrap().push(params);
    }
}

impl Heard {
    fn updates_of(&self, uri: &str) -> Vec<Instant> {
        self.updates.lock().unwrap().iter().filter(|(u, _)| u == uri).map(|(_, t)| *t).collect()
    }
}

/// A second session that records what it hears.
async fn listener(server: &Server) -> (Heard, RunningService<RoleClient, Heard>) {
    let heard = Heard::default();
    let service = heard
        .clone()
        .serve(StreamableHttpClientTransport::from_uri(server.url.clone()))
        .await
        .expect("initialize the listening session");
    (heard, service)
}


async fn subscribe(s: &RunningService<RoleClient, Heard>, uri: &str) {
    s.subscribe(SubscribeRequestParams::new(uri)).await.expect("resources/subscribe");
}

#[tokio::test]
async fn a_subscribed_session_hears_another_step_and_unsubscribed_hears_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let stepper: Client = server.client().await;
    let watched = stepper.new_sim(json!({})).await;
    let other = stepper.new_sim(json!({})).await;
    let (heard, watcher) = listener(&server).await;
    // A third session that never subscribes: it must hear no update at all.
    let (bystander, _bystander_service) = listener(&server).await;
    let info = format!("sim://{watched}/info");
    let other_info = format!("sim://{other}/info");
    subscribe(&watcher, &info).await;
    subscribe(&watcher, &other_info).await;

    stepper.step(&watched, 1).await;
    until("the first update", || heard.updates_of(&info).len() == 1).await;
    // An undo moves the head too.
    stepper.call("undo", json!({"sim_id": watched})).await;
    until("the update after undo", || heard.updates_of(&info).len() == 2).await;
    // A read does not move the head: no update for it.
    stepper.call("get_simulation_info", json!({"sim_id": watched})).await;

    watcher.unsubscribe(UnsubscribeRequestParams::new(&info)).await.expect("resources/unsubscribe");
    stepper.step(&watched, 1).await;
    // The other simulation's update is the marker that the step above has been announced
    // (to anyone who still listened) by now.
    stepper.step(&other, 1).await;
    until("the other simulation's update", || heard.updates_of(&other_info).len() == 1).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(heard.updates_of(&info).len(), 2, "an unsubscribed URI was still announced");
    assert!(bystander.updates.lock().unwrap().is_empty(), "a session that never subscribed heard updates");
}

#[tokio::test]
async fn a_burst_of_steps_is_paced_and_its_last_change_announced() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let stepper = server.client().await;
    let sim = stepper.new_sim(json!({})).await;
    stepper.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "mass": 1.0, "position": [0, 0, 1]})).await;
    let (heard, watcher) = listener(&server).await;
    let uri = format!("sim://{sim}/info");
    subscribe(&watcher, &uri).await;

    let start = Instant::now();
    let mut last_sent = start;
    for _ in 0..500 {
        last_sent = Instant::now();
        stepper.step(&sim, 1).await;
    }
    let elapsed = start.elapsed();
    until("an update after the last call", || heard.updates_of(&uri).last().is_some_and(|t| *t >= last_sent)).await;
    // Nothing more is pending once the trailing update arrived (let a stray one show up).
    tokio::time::sleep(Duration::from_millis(300)).await;
    let n = heard.updates_of(&uri).len();
    // At most one per 100 ms window of the burst, plus the leading and trailing ones
    // (21 for a 2 s burst).
    let bound = elapsed.as_millis() as usize / 100 + 2;
    eprintln!("500 steps in {elapsed:?}: {n} updates (bound {bound})");
    assert!(n >= 1 && n <= bound, "{n} updates for 500 steps in {elapsed:?} (at most {bound})");
}

#[tokio::test]
async fn after_set_level_a_refused_call_is_logged_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let (heard, session) = listener(&server).await;
    let refuse = || {
        session.call_tool(
            rmcp::model::CallToolRequestParams::new("step_simulation")
                .with_arguments(json!({"sim_id": "no-such-sim", "steps": 1}).as_object().unwrap().clone()),
        )
    };
    // Before a level is set, nothing is logged.
    assert_eq!(refuse().await.unwrap().is_error, Some(true));
    session.set_level(SetLevelRequestParams::new(LoggingLevel::Info)).await.expect("logging/setLevel");
    let r = refuse().await.unwrap();
    assert_eq!(r.is_error, Some(true));
    until("the log message", || !heard.logs.lock().unwrap().is_empty()).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let logs = heard.logs.lock().unwrap().clone();
    assert_eq!(logs.len(), 1, "one message, for the call after setLevel only: {logs:?}");
    assert_eq!(logs[0].level, LoggingLevel::Info);
    assert_eq!(logs[0].data["tool"], "step_simulation");
    assert!(logs[0].data["refused"].as_str().unwrap().contains("no-such-sim"), "{:?}", logs[0].data);

    // At warning, a refusal (info) is not sent.
    session.set_level(SetLevelRequestParams::new(LoggingLevel::Warning)).await.expect("logging/setLevel");
    refuse().await.unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(heard.logs.lock().unwrap().len(), 1, "an info message went to a session at warning");
}

#[tokio::test]
async fn a_simulation_skipped_as_damaged_at_start_is_a_warning_after_set_level() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("data")).unwrap();
    std::fs::write(dir.path().join("data/broken.sqlite"), b"this is not a database").unwrap();
    let server = Server::start(dir.path(), &[]);
    let (heard, session) = listener(&server).await;
    session.set_level(SetLevelRequestParams::new(LoggingLevel::Warning)).await.expect("logging/setLevel");
    until("the damaged-simulation warning", || !heard.logs.lock().unwrap().is_empty()).await;
    let logs = heard.logs.lock().unwrap().clone();
    assert_eq!(logs[0].level, LoggingLevel::Warning);
    assert_eq!(logs[0].data["simulation_id"], "broken", "{:?}", logs[0].data);
}

/// A snapshot write slower than the stall threshold is a `warning` to the calling session
/// (the threshold is 0 here, so every snapshot is one; by default it is 1 s), told once.
#[tokio::test]
async fn a_snapshot_stall_is_a_warning_after_set_level() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start_with_env(dir.path(), &[], &[("PHYSICS_MCP_STALL_MS", "0")]);
    let (heard, session) = listener(&server).await;
    session.set_level(SetLevelRequestParams::new(LoggingLevel::Warning)).await.expect("logging/setLevel");
    let call = |tool: &str, args: serde_json::Value| {
        session.call_tool(rmcp::model::CallToolRequestParams::new(tool.to_string()).with_arguments(args.as_object().unwrap().clone()))
    };
    let created = call("create_simulation", json!({})).await.unwrap();
    let sim = created.structured_content.unwrap()["simulation_id"].as_str().unwrap().to_string();
    // 64 changes since the last snapshot make the next commit carry one.
    for k in 0..70 {
        let r = call("add_sphere", json!({"sim_id": sim, "radius": 0.05, "position": [k as f64 * 0.2, 0, 1]})).await.unwrap();
        assert_ne!(r.is_error, Some(true));
    }
    until("the stall warning", || !heard.logs.lock().unwrap().is_empty()).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let logs = heard.logs.lock().unwrap().clone();
    assert_eq!(logs.len(), 1, "one snapshot, one warning: {logs:?}");
    assert_eq!(logs[0].level, LoggingLevel::Warning);
    assert!(logs[0].data["stall"].as_str().unwrap().starts_with("the snapshot at seq "), "{:?}", logs[0].data);
}
