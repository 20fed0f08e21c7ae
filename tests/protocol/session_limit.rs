//! `--max-sessions` bounds the sessions live at once, however their `initialize` requests
//! interleave, and never refuses a request that creates no session (a stateless 2026-07-28
//! request of any size goes through at the bound, and ends no session).

use crate::common;

use std::sync::Arc;
use std::time::Duration;

use common::Server;
use serde_json::{json, Value};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

const ACCEPT: &str = "application/json, text/event-stream";
const STATELESS: &str = "2026-07-28";

fn host_port(url: &str) -> String {
    url.trim_start_matches("http://").trim_end_matches("/mcp").to_string()
}

/// The JSON-RPC messages of a reply body, whether plain JSON or SSE `data:` lines.
fn messages(text: &str) -> Vec<Value> {
    if text.trim_start().starts_with('{') {
        return serde_json::from_str(text).into_iter().collect();
    }
    text.lines()
        .filter_map(|l| l.strip_prefix("data:"))
        .filter_map(|d| serde_json::from_str(d.trim()).ok())
        .collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn a_large_stateless_request_at_the_bound_is_served() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "1"]);
    let http = reqwest::Client::new();
    let sid = common::raw_session(&http, &server.url, "2025-06-18").await.expect("within the bound");

    // A stateless tools/call whose body is well over 64 KiB (a large, unused `_meta` field):
    // it creates no session, so the bound has nothing to say about it.
    let padding = "x".repeat(100 * 1024);
    let call = json!({"jsonrpc": "2.0", "id": 7, "method": "tools/call", "params": {
        "name": "list_simulations",
        "arguments": {},
        "_meta": {
            "io.modelcontextprotocol/protocolVersion": STATELESS,
            "io.modelcontextprotocol/clientCapabilities": {},
            "io.modelcontextprotocol/clientInfo": {"name": "session-limit-test", "version": "0"},
            "example.com/padding": padding,
        }}});
    let body = call.to_string();
    assert!(body.len() > 64 * 1024);
    let r = http
        .post(&server.url)
        .header("Content-Type", "application/json")
        .header("Accept", ACCEPT)
        .header("MCP-Protocol-Version", STATELESS)
        .header("Mcp-Method", "tools/call")
        .header("Mcp-Name", "list_simulations")
        .body(body)
        .send()
        .await
        .unwrap();
    let status = r.status().as_u16();
    assert!(r.headers().get("mcp-session-id").is_none(), "a stateless request was given a session");
    let text = r.text().await.unwrap();
    assert_eq!(status, 200, "a stateless request at the session bound was refused: {text}");
    let reply = messages(&text)
        .into_iter()
        .find(|m| m["id"] == 7)
        .unwrap_or_else(|| panic!("no JSON-RPC reply with id 7 in {text}"));
    assert!(reply.get("result").is_some() || reply.get("error").is_some(), "{reply}");
    // Nor did it end the session at the bound to make room.
    let ping = json!({"jsonrpc": "2.0", "id": 8, "method": "ping"});
    let r = http.post(&server.url).header("Accept", ACCEPT).header("mcp-session-id", &sid).json(&ping).send().await.unwrap();
    assert_eq!(r.status().as_u16(), 200, "the session at the bound was ended by a stateless request");
}

/// One `initialize` over its own connection, its body dribbled out in small pieces: the
/// headers first, then (after everyone's headers are in, `headers_sent`) the body a few bytes
/// at a time. Returns the status and, when given one, the session id, and the body.
async fn slow_initialize(addr: String, headers_sent: Arc<tokio::sync::Barrier>) -> (u16, Option<String>, String) {
    let init = json!({"jsonrpc": "2.0", "id": 0, "method": "initialize", "params": {
        "protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "slow", "version": "0"}}});
    let body = init.to_string().into_bytes();
    let mut s = TcpStream::connect(&addr).await.unwrap();
    s.set_nodelay(true).unwrap();
    let head = format!(
        "POST /mcp HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nAccept: {ACCEPT}\r\nConnection: close\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    s.write_all(head.as_bytes()).await.unwrap();
    s.write_all(&body[..1]).await.unwrap();
    headers_sent.wait().await;
    // Let the server take in every request's headers before any body is complete.
    tokio::time::sleep(Duration::from_millis(300)).await;
    for piece in body[1..].chunks(16) {
        s.write_all(piece).await.unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut reply = Vec::new();
    s.read_to_end(&mut reply).await.unwrap();
    let reply = String::from_utf8_lossy(&reply).into_owned();
    let (head, body) = reply.split_once("\r\n\r\n").unwrap_or((&reply, ""));
    let status = head.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let sid = head.lines().find_map(|l| {
        let (name, value) = l.split_once(':')?;
        name.eq_ignore_ascii_case("mcp-session-id").then(|| value.trim().to_string())
    });
    (status, sid, body.to_string())
}

#[tokio::test(flavor = "multi_thread")]
async fn slow_concurrent_initializes_never_make_more_than_the_bound() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "2"]);
    let addr = host_port(&server.url);
    let headers_sent = Arc::new(tokio::sync::Barrier::new(10));
    let tasks: Vec<_> = (0..10).map(|_| tokio::spawn(slow_initialize(addr.clone(), headers_sent.clone()))).collect();
    let mut sessions = Vec::new();
    for t in tasks {
        let (status, sid, body) = t.await.unwrap();
        match (status, sid) {
            (200, Some(sid)) => sessions.push(sid),
            // Refused only while every session in the way was still being initialized.
            (503, None) => assert!(body.starts_with("Session limit reached: 2 live MCP sessions (--max-sessions 2), each with a request in flight"), "{body}"),
            (status, sid) => panic!("an initialize was answered {status} (session {sid:?}): {body}"),
        }
    }
    assert!(sessions.len() >= 2, "fewer sessions than the bound: {sessions:?}");
    // However they interleaved, at most two are live: the others were ended to make room.
    let http = reqwest::Client::new();
    let mut live = 0;
    for sid in &sessions {
        let ping = json!({"jsonrpc": "2.0", "id": 1, "method": "ping"});
        let r = http.post(&server.url).header("Accept", ACCEPT).header("mcp-session-id", sid).json(&ping).send().await.unwrap();
        live += usize::from(r.status().as_u16() == 200);
    }
    assert_eq!(live, 2, "live sessions past --max-sessions 2");
}
