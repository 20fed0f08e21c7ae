//! MCP resources and prompts over HTTP against the real server: every simulation's
//! `sim://{id}/info`, `/history` and `/image`, list-changed notifications to every session when
//! simulations come and go, and the workflow prompts — one of them followed to check its
//! numbers are physics.

use crate::common;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use base64::Engine;
use common::{Client, Server};
use rmcp::model::{GetPromptRequestParams, ReadResourceRequestParams, ResourceContents};
use rmcp::service::{NotificationContext, RunningService};
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::{ClientHandler, RoleClient, ServiceExt};
use serde_json::{json, Value};

/// Counts `notifications/resources/list_changed`.
#[derive(Clone, Default)]
struct ListChanges(Arc<AtomicUsize>);

impl ClientHandler for ListChanges {
    async fn on_resource_list_changed(&self, _: NotificationContext<RoleClient>) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

async fn watcher(server: &Server) -> (RunningService<RoleClient, ListChanges>, Arc<AtomicUsize>) {
    let changes = ListChanges::default();
    let count = changes.0.clone();
    let transport = StreamableHttpClientTransport::from_uri(server.url.clone());
    (changes.serve(transport).await.expect("initialize"), count)
}

/// Waits (up to 10 s) until the counter reaches `n`.
async fn until(count: &AtomicUsize, n: usize) {
    for _ in 0..200 {
        if count.load(Ordering::SeqCst) >= n {
            return;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    panic!("{} list-changed notifications, expected {n}", count.load(Ordering::SeqCst));
}

async fn read(c: &Client, uri: &str) -> Result<ResourceContents, String> {
    c.service
        .read_resource(ReadResourceRequestParams::new(uri))
        .await
        .map(|r| r.contents.into_iter().next().expect("one content"))
        .map_err(|e| e.to_string())
}

fn text(c: &ResourceContents) -> (&str, &str) {
    match c {
        ResourceContents::TextResourceContents { text, mime_type, .. } => (text.as_str(), mime_type.as_deref().unwrap_or("")),
        other => panic!("expected text, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn every_simulation_is_readable_as_info_history_and_image() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let (w, changes) = watcher(&server).await;
    let c = server.client().await;

    let sim = c.new_sim(json!({})).await;
    until(&changes, 1).await;
    let ground = c.ground(&sim).await;
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [0, 0, 1], "color": [1, 0, 0, 1]})).await;
    c.step(&sim, 240).await;
    let hash = c.hash(&sim).await;

    // The other session lists the new simulation's three resources, and the templates.
    let listed = w.list_all_resources().await.unwrap();
    for (part, mime) in [("info", "application/json"), ("history", "application/x-ndjson"), ("image", "image/png")] {
        let uri = format!("sim://{sim}/{part}");
        let r = listed.iter().find(|r| r.uri == uri).unwrap_or_else(|| panic!("{uri} not listed: {listed:?}"));
        assert_eq!(r.mime_type.as_deref(), Some(mime));
    }
    let templates = w.list_all_resource_templates().await.unwrap();
    assert_eq!(templates.len(), 3);

    // info is get_simulation_info's answer.
    let info = read(&c, &format!("sim://{sim}/info")).await.unwrap();
    let (body, mime) = text(&info);
    assert_eq!(mime, "application/json");
    let info: Value = serde_json::from_str(body).unwrap();
    assert_eq!(info["state_hash"], hash.as_str());
    assert_eq!(info["objects"].as_array().unwrap().len(), 2);
    assert_eq!(info["objects"][0]["object_id"], ground);

    // history: one JSON event per line, the last state-changing one with today's hash; reading
    // resources adds no events.
    let history = read(&c, &format!("sim://{sim}/history")).await.unwrap();
    let lines: Vec<Value> = text(&history).0.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let tools: Vec<&str> = lines.iter().map(|e| e["tool"].as_str().unwrap()).collect();
    assert_eq!(&tools[..4], ["create_simulation", "add_box", "add_sphere", "step_simulation"], "{tools:?}");
    let last_change = lines.iter().rev().find(|e| e["mutates"] == true).unwrap();
    // Events as get_history gives them by default: the state hash by its first 12 hex.
    assert_eq!(last_change["state_hash"], &hash[..12]);
    let again = read(&c, &format!("sim://{sim}/history")).await.unwrap();
    assert_eq!(text(&again).0.lines().count(), lines.len(), "reading a resource was logged");

    // image: a PNG from the viewer camera; the red ball is in it.
    let image = read(&c, &format!("sim://{sim}/image")).await.unwrap();
    let ResourceContents::BlobResourceContents { blob, mime_type, .. } = image else { panic!("expected a blob") };
    assert_eq!(mime_type.as_deref(), Some("image/png"));
    let png = base64::engine::general_purpose::STANDARD.decode(blob).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(png));
    let mut reader = decoder.read_info().unwrap();
    let mut px = vec![0; reader.output_buffer_size().unwrap()];
    let frame = reader.next_frame(&mut px).unwrap();
    assert_eq!((frame.width, frame.height), (320, 240));
    let red = px.chunks(3).filter(|p| p[0] > 150 && p[1] < 80 && p[2] < 80).count();
    assert!(red > 50, "the red ball covers {red} pixels of the viewer image");
    assert_eq!(c.hash(&sim).await, hash, "reading resources changed the world");

    // Unknown simulations and URIs are clear errors.
    let err = read(&c, "sim://no-such-sim/info").await.unwrap_err();
    assert!(err.contains("no-such-sim"), "{err}");
    let err = read(&c, &format!("sim://{sim}/video")).await.unwrap_err();
    assert!(err.contains("info, history or image"), "{err}");

    // Fork, load and destroy notify as well; a destroyed simulation leaves the list.
    let fork = c.call("fork_simulation", json!({"sim_id": sim})).await["simulation_id"].as_str().unwrap().to_string();
    until(&changes, 2).await;
    c.call("destroy_simulation", json!({"sim_id": fork})).await;
    until(&changes, 3).await;
    let listed = w.list_all_resources().await.unwrap();
    assert!(listed.iter().all(|r| !r.uri.contains(&fork)), "{listed:?}");
    assert!(listed.iter().any(|r| r.uri.contains(&sim)));
}

#[tokio::test(flavor = "multi_thread")]
async fn prompts_are_listed_and_the_drop_test_numbers_hold() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let prompts = c.service.list_all_prompts().await.unwrap();
    let names: Vec<&str> = prompts.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["drop-test", "robot-arm-reach", "replay-a-session"]);

    let args = json!({"shape": "capsule", "height": "3"});
    let got = c
        .service
        .get_prompt(GetPromptRequestParams::new("drop-test").with_arguments(args.as_object().unwrap().clone()))
        .await
        .unwrap();
    let body = serde_json::to_string(&got.messages).unwrap();
    assert!(body.contains("Add a capsule") && body.contains("[0, 0, 3]"), "{body}");
    let err = c.service.get_prompt(GetPromptRequestParams::new("juggle")).await.unwrap_err().to_string();
    assert!(err.contains("drop-test"), "{err}");

    // Follow the drop test as written: box (half-extents 0.2) rests at 0.2, capsule at 0.4.
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [20, 20, 0.5], "position": [0, 0, -0.5], "mass": 0})).await;
    let bx = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 2], "mass": 1})).await;
    let cap = c.call("add_capsule", json!({"sim_id": sim, "radius": 0.2, "height": 0.4, "position": [3, 0, 2], "mass": 1})).await;
    c.step(&sim, 720).await;
    for (obj, want) in [(bx, 0.2), (cap, 0.4)] {
        let id = obj["object_id"].as_u64().unwrap();
        let z = c.state(&sim, id).await["position"][2].as_f64().unwrap();
        assert!((z - want).abs() < 0.01, "object {id} rests at {z}, the prompt says {want}");
    }
}

/// sim://{id}/history is held to the reply budget like a tool reply: under a small
/// --max-reply-bytes it carries the newest events that fit, the last one included.
#[tokio::test(flavor = "multi_thread")]
async fn the_history_resource_keeps_the_newest_events_that_fit_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-reply-bytes", "20000"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    for k in 0..200 {
        c.call("add_sphere", json!({"sim_id": sim, "radius": 0.05, "position": [k as f64 * 0.1, 0, 1]})).await;
    }
    // (get_simulation_info of 200 objects is itself over this budget.)
    let last = c.call("get_history", json!({"sim_id": sim, "limit": 1})).await["last_seq"].as_u64().unwrap() + 1;
    let contents = read(&c, &format!("sim://{sim}/history")).await.expect("readable");
    let (body, _) = text(&contents);
    let reply = serde_json::to_string(body).unwrap();
    assert!(reply.len() <= 20_000, "the text as carried is {} bytes", reply.len());
    let seqs: Vec<u64> = body.lines().map(|l| serde_json::from_str::<Value>(l).unwrap()["seq"].as_u64().unwrap()).collect();
    assert!(seqs.len() > 10 && seqs.len() < 200, "{} events kept", seqs.len());
    assert_eq!(seqs.last().copied(), Some(last), "the newest event (that get_history read) is kept");
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "a contiguous tail");
}
