//! A 2026-07-28 client is served statelessly over plain HTTP — a
//! `tools/call` without `initialize` and `server/discover` — with no MCP client library in
//! between, so what is tested is the wire itself.

use crate::common;

use common::Server;
use serde_json::{json, Value};

const REVISION: &str = "2026-07-28";

/// One stateless JSON-RPC request: the per-request `_meta` that 2026-07-28 requires, the
/// matching `MCP-Protocol-Version` header, no session id. Returns the JSON-RPC response
/// (from a JSON body or from the SSE event that carries it).
async fn post(url: &str, id: u64, method: &str, mut params: Value) -> Value {
    params["_meta"] = json!({
        "io.modelcontextprotocol/protocolVersion": REVISION,
        "io.modelcontextprotocol/clientCapabilities": {},
        "io.modelcontextprotocol/clientInfo": {"name": "plain-http-test", "version": "0"},
    });
    let body = json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params});
    let mut request = reqwest::Client::new().post(url);
    // 2026-07-28 routes by headers too: `Mcp-Name` carries the tool's (or prompt's) name.
    if let Some(name) = params["name"].as_str() {
        request = request.header("Mcp-Name", name);
    }
    let response = request
        .header("Content-Type", "application/json")
        .header("Accept", "application/json, text/event-stream")
        .header("MCP-Protocol-Version", REVISION)
        .header("Mcp-Method", method)
        .body(body.to_string())
        .send()
        .await
        .expect("POST /mcp");
    let status = response.status();
    assert!(response.headers().get("mcp-session-id").is_none(), "a stateless request was given a session");
    let text = response.text().await.unwrap();
    assert!(status.is_success(), "{method}: HTTP {status}: {text}");
    let messages: Vec<Value> = if text.trim_start().starts_with('{') {
        vec![serde_json::from_str(&text).unwrap()]
    } else {
        text.lines()
            .filter_map(|l| l.strip_prefix("data:"))
            .filter_map(|d| serde_json::from_str(d.trim()).ok())
            .collect()
    };
    messages
        .into_iter()
        .find(|m| m["id"] == json!(id))
        .unwrap_or_else(|| panic!("{method}: no response with id {id} in {text}"))
}

#[tokio::test]
async fn a_2026_07_28_client_calls_tools_without_initialize_and_discovers_the_server() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);

    let discovered = post(&server.url, 1, "server/discover", json!({})).await;
    let result = &discovered["result"];
    assert!(
        result["supportedVersions"].as_array().is_some_and(|v| v.contains(&json!(REVISION))),
        "server/discover: {discovered}"
    );
    assert!(result.to_string().contains("physics-mcp"), "server/discover names no server: {discovered}");
    let caps = &result["capabilities"];
    assert_eq!(caps["resources"]["subscribe"], true, "{discovered}");
    assert!(caps["logging"].is_object(), "{discovered}");

    let created = post(&server.url, 2, "tools/call", json!({"name": "create_simulation", "arguments": {}})).await;
    let sim = created["result"]["structuredContent"]["simulation_id"]
        .as_str()
        .unwrap_or_else(|| panic!("create_simulation: {created}"))
        .to_string();
    // A second, independent request sees the first one's simulation: state lives in the
    // server, not in a session.
    let stepped = post(&server.url, 3, "tools/call", json!({"name": "step_simulation", "arguments": {"sim_id": sim, "steps": 2}})).await;
    assert_ne!(stepped["result"]["isError"], true, "{stepped}");
    let info = post(&server.url, 4, "tools/call", json!({"name": "get_simulation_info", "arguments": {"sim_id": sim}})).await;
    assert!(info["result"]["structuredContent"]["current_time"].as_f64().is_some_and(|t| t > 0.0), "{info}");
}
