//! Slow and broken clients: a client that sends half a request and stalls, clients
//! that never read their (large) replies, 1,000 idle sessions, a 100 MB body — the server keeps
//! serving a well-behaved client throughout, and its peak memory is reported. At
//! `--max-sessions` a new session ends the least recently used idle one.

use crate::common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use common::Server;
use serde_json::{json, Value};

const ACCEPT: &str = "application/json, text/event-stream";

fn host_port(url: &str) -> String {
    url.trim_start_matches("http://").trim_end_matches("/mcp").to_string()
}

/// Opens a raw MCP session (initialize + initialized) and returns its id.
async fn raw_session(http: &reqwest::Client, url: &str) -> Result<String, (u16, String)> {
    common::raw_session(http, url, "2025-06-18").await
}

/// The server's peak resident memory (VmHWM), in MiB.
fn peak_rss_mib(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let kb: f64 = status.lines().find_map(|l| l.strip_prefix("VmHWM:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok()).unwrap_or(0.0);
    kb / 1024.0
}

#[tokio::test(flavor = "multi_thread")]
async fn at_the_bound_the_least_recently_used_idle_session_makes_room() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "3"]);
    let http = reqwest::Client::new();
    let mut sids = Vec::new();
    for _ in 0..3 {
        sids.push(raw_session(&http, &server.url).await.expect("within the bound"));
    }
    // The first is used again: the second is now the least recently used.
    let list = json!({"jsonrpc": "2.0", "id": 2, "method": "tools/list"});
    let used = |sid: String| {
        let http = http.clone();
        let url = server.url.clone();
        let list = list.clone();
        async move { http.post(&url).header("Accept", ACCEPT).header("mcp-session-id", sid).json(&list).send().await.unwrap().status().as_u16() }
    };
    assert_eq!(used(sids[0].clone()).await, 200);
    raw_session(&http, &server.url).await.expect("an idle session makes room");
    assert_eq!(used(sids[1].clone()).await, 404, "the least recently used idle session was ended");
    assert_eq!(used(sids[0].clone()).await, 200);
    assert_eq!(used(sids[2].clone()).await, 200);
}

#[tokio::test(flavor = "multi_thread")]
async fn broken_and_idle_clients_do_not_stop_the_server_serving_others() {
    let dir = tempfile::tempdir().unwrap();
    // Room for the 1,000 idle sessions besides the eleven working ones.
    let server = Server::start(dir.path(), &["--max-sessions", "1100"]);
    let addr = host_port(&server.url);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for k in 0..50 {
        c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [k as f64 * 0.1 - 2.5, 0, 1], "color": [k as f64 / 50.0, 0.5, 0.2]})).await;
    }
    let base_rss = peak_rss_mib(server.pid());

    // Half a request, then silence (the connection stays open).
    let mut half = TcpStream::connect(&addr).unwrap();
    write!(half, "POST /mcp HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nAccept: {ACCEPT}\r\nContent-Length: 1000\r\n\r\n{{\"jsonrpc\":").unwrap();
    c.step(&sim, 10).await;

    // Ten clients ask for 1024x1024 images (the largest replies the budget lets through) and
    // never read them.
    let http = reqwest::Client::new();
    let mut unread = Vec::new();
    for _ in 0..10 {
        let sid = raw_session(&http, &server.url).await.unwrap();
        let call = json!({"jsonrpc": "2.0", "id": 7, "method": "tools/call", "params": {"name": "get_camera_image",
            "arguments": {"sim_id": sim, "width": 1024, "height": 1024}}});
        let body = serde_json::to_vec(&call).unwrap();
        let mut s = TcpStream::connect(&addr).unwrap();
        write!(s, "POST /mcp HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nAccept: {ACCEPT}\r\nmcp-session-id: {sid}\r\nContent-Length: {}\r\n\r\n", body.len()).unwrap();
        s.write_all(&body).unwrap();
        unread.push(s);
    }
    c.step(&sim, 10).await;
    c.call("get_object_state", json!({"sim_id": sim, "object_id": 3})).await;

    // 1,000 idle sessions.
    for _ in 0..1000 {
        raw_session(&http, &server.url).await.expect("within --max-sessions");
    }
    c.step(&sim, 10).await;

    // A 100 MB body: refused, and the server is still there.
    let mut big = TcpStream::connect(&addr).unwrap();
    big.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    write!(big, "POST /mcp HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nAccept: {ACCEPT}\r\nContent-Length: {}\r\n\r\n", 100 << 20).unwrap();
    let chunk = vec![b' '; 1 << 20];
    let mut sent = 0usize;
    for _ in 0..100 {
        if big.write_all(&chunk).is_err() {
            break; // the server stopped reading and closed: refused early
        }
        sent += chunk.len();
    }
    let mut answer = String::new();
    let _ = big.read_to_string(&mut answer);
    let status_line = answer.lines().next().unwrap_or("(closed without an answer)").to_string();
    assert!(!status_line.contains(" 200 "), "a 100 MB body is not served: {status_line}");

    c.step(&sim, 10).await;
    let info: Value = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["steps"], 40, "every step of the well-behaved client was served: {info}");
    let peak = peak_rss_mib(server.pid());
    eprintln!(
        "broken clients: peak RSS {peak:.0} MiB (before: {base_rss:.0} MiB); 100 MB body: {status_line} after {} MB sent",
        sent >> 20
    );
    assert!(peak < 512.0, "memory stays bounded: peak RSS {peak:.0} MiB");
    drop((half, unread));
}
