//! The viewer as an MCP App (SEP-1865): the server announces `io.modelcontextprotocol/ui`, a
//! client that announces it too sees the viewer linked from the tools a person looks at, the
//! `ui://` resource is one self-contained HTML page of `text/html;profile=mcp-app` under the
//! reply limit, and what the app reads (`sim://{id}/viewer/…`) is a look: not logged, nothing
//! changes. A client that does not announce the extension sees the tools as they always were.

use crate::common;

use common::Server;
use rmcp::model::{ClientCapabilities, ClientConfig, ReadResourceRequestParams, ResourceContents};
use rmcp::ServiceExt;
use serde_json::{json, Value};

const APP: &str = "ui://physics-mcp/viewer";
const LINKED: [&str; 4] = ["create_simulation", "step_simulation", "render_animation", "get_trajectory"];

/// A client that shows MCP Apps, as a host announces it.
async fn app_client(url: &str) -> rmcp::service::RunningService<rmcp::RoleClient, ClientConfig> {
    let mut ext = std::collections::BTreeMap::new();
    ext.insert("io.modelcontextprotocol/ui".to_string(), serde_json::from_value(json!({"mimeTypes": ["text/html;profile=mcp-app"]})).unwrap());
    let mut info = ClientConfig::default();
    info.capabilities = ClientCapabilities::builder().enable_extensions_with(ext).build();
    let transport = rmcp::transport::StreamableHttpClientTransport::from_uri(url.to_string());
    info.serve(transport).await.expect("initialize an app-showing client")
}

async fn read_text(c: &rmcp::Peer<rmcp::RoleClient>, uri: &str) -> (String, Option<String>) {
    let read = c.read_resource(ReadResourceRequestParams::new(uri)).await.unwrap_or_else(|e| panic!("read {uri}: {e}"));
    match &read.contents[0] {
        ResourceContents::TextResourceContents { text, mime_type, .. } => (text.clone(), mime_type.clone()),
        other => panic!("{uri}: not text: {other:?}"),
    }
}

fn linked(tools: &[rmcp::model::Tool]) -> Vec<String> {
    let mut out: Vec<String> = tools
        .iter()
        .filter(|t| t.meta.as_ref().and_then(|m| m.0.get("ui")).and_then(|ui| ui.get("resourceUri")) == Some(&json!(APP)))
        .map(|t| t.name.to_string())
        .collect();
    out.sort();
    out
}

#[tokio::test(flavor = "multi_thread")]
async fn hosts_that_show_apps_get_the_viewer_linked_and_others_see_no_change() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let plain = server.client().await;
    let app = app_client(&server.url).await;

    let announced = app.peer_info().expect("server info").capabilities.extensions.clone().unwrap_or_default();
    assert_eq!(announced.get("io.modelcontextprotocol/ui").map(|v| Value::Object(v.clone())), Some(json!({"mimeTypes": ["text/html;profile=mcp-app"]})));

    let mut want: Vec<String> = LINKED.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(linked(&app.list_all_tools().await.unwrap()), want);
    let plain_tools = plain.service.list_all_tools().await.unwrap();
    assert!(plain_tools.iter().all(|t| t.meta.is_none()), "a client without the extension sees no _meta");

    // The app: one page, no outside reference, under the 1 MiB reply limit.
    let (html, mime) = read_text(app.peer(), APP).await;
    assert_eq!(mime.as_deref(), Some("text/html;profile=mcp-app"));
    assert!(html.starts_with("<!doctype html>") && html.contains("var THREE="), "three.js is inlined");
    let reply = serde_json::to_string(&html).unwrap().len();
    assert!(reply < 1024 * 1024, "the app's reply is {reply} bytes");
    let listed = app.list_all_resources().await.unwrap();
    assert!(listed.iter().any(|r| r.uri == APP && r.mime_type.as_deref() == Some("text/html;profile=mcp-app")));

    // What the app reads through the host is a look: the log and the world stay as they were.
    let sim = plain.new_sim(json!({"gui": true})).await;
    plain.ground(&sim).await;
    plain.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]})).await;
    plain.step(&sim, 30).await;
    let hash = plain.hash(&sim).await;
    let (history, _) = read_text(plain.service.peer(), &format!("sim://{sim}/history")).await;
    let (poses, mime) = read_text(app.peer(), &format!("sim://{sim}/viewer/poses")).await;
    assert_eq!(mime.as_deref(), Some("application/json"));
    let poses: Value = serde_json::from_str(&poses).unwrap();
    assert_eq!(poses["steps"], 30);
    assert_eq!(poses["scene"]["parts"].as_array().unwrap().len(), 2, "{poses}");
    let (timeline, _) = read_text(app.peer(), &format!("sim://{sim}/viewer/timeline")).await;
    let timeline: Value = serde_json::from_str(&timeline).unwrap();
    let first = timeline["events"][0]["seq"].as_u64().unwrap();
    let (clip, _) = read_text(app.peer(), &format!("sim://{sim}/viewer/clip?from_seq={first}&every=10")).await;
    let clip: Value = serde_json::from_str(&clip).unwrap();
    assert_eq!(clip["complete"], true);
    assert_eq!(clip["frames"].as_array().unwrap().last().unwrap()["steps"], 30, "{clip}");
    let bad = app.read_resource(ReadResourceRequestParams::new(format!("sim://{sim}/viewer/clip?from_seq=x"))).await;
    assert!(bad.unwrap_err().to_string().contains("from_seq"), "a bad query names its parameter");
    assert_eq!(read_text(plain.service.peer(), &format!("sim://{sim}/history")).await.0, history, "nothing logged");
    assert_eq!(plain.hash(&sim).await, hash, "nothing changed");
}
