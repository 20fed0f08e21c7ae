//! One client cannot lock the others out or read their secret (docs/guarantees.md
//! "Isolation"): at the session bound the least recently used idle session makes room for a
//! new client (refused only when every session is busy), a client at its own cap makes room
//! among its own sessions, subscriptions are bounded and dropped with their session, and the
//! token can be given by file or environment instead of on the command line.

use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::Duration;

use crate::common;

use common::Server;
use serde_json::{json, Value};

const ACCEPT: &str = "application/json, text/event-stream";

/// The JSON-RPC messages of a reply body, whether plain JSON or SSE `data:` lines.
fn messages(text: &str) -> Vec<Value> {
    if text.trim_start().starts_with('{') {
        return serde_json::from_str(text).into_iter().collect();
    }
    text.lines().filter_map(|l| l.strip_prefix("data:")).filter_map(|d| serde_json::from_str(d.trim()).ok()).collect()
}

/// An HTTP client that sends `Authorization: Bearer <token>` when given one.
fn http_as(token: Option<&str>) -> reqwest::Client {
    let mut headers = reqwest::header::HeaderMap::new();
    if let Some(t) = token {
        headers.insert(reqwest::header::AUTHORIZATION, format!("Bearer {t}").parse().unwrap());
    }
    reqwest::Client::builder().default_headers(headers).build().unwrap()
}

/// `method` with `params` in session `sid`: the HTTP status and the JSON-RPC reply.
async fn request(http: &reqwest::Client, url: &str, sid: &str, method: &str, params: Value) -> (u16, Option<Value>) {
    let body = json!({"jsonrpc": "2.0", "id": 9, "method": method, "params": params});
    let r = http.post(url).header("Accept", ACCEPT).header("mcp-session-id", sid).json(&body).send().await.unwrap();
    let status = r.status().as_u16();
    let text = r.text().await.unwrap();
    (status, messages(&text).into_iter().find(|m| m["id"] == 9))
}

#[tokio::test(flavor = "multi_thread")]
async fn at_the_session_bound_new_clients_get_in_and_an_ended_idle_one_starts_over() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "20"]);
    let good = server.client().await;
    let sim = good.new_sim(json!({})).await;
    // One client opens 100 sessions and leaves them idle (the attack: everyone else locked out).
    let http = reqwest::Client::new();
    let mut opened = Vec::new();
    for i in 0..100 {
        let sid = common::raw_session(&http, &server.url, "2025-06-18").await.unwrap_or_else(|(s, why)| panic!("initialize {i}: {s} {why}"));
        opened.push(sid);
    }
    // The oldest idle ones were ended to make room: their next request is told 404.
    let (status, _) = request(&http, &server.url, &opened[0], "ping", json!({})).await;
    assert_eq!(status, 404);
    let (status, _) = request(&http, &server.url, opened.last().unwrap(), "ping", json!({})).await;
    assert_eq!(status, 200);
    // A new client gets in; the first, whose idle session was ended too, starts a new one and goes on.
    let newcomer = server.client().await;
    newcomer.call("list_simulations", json!({})).await;
    good.step(&sim, 5).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn when_every_session_is_busy_a_new_one_is_refused_in_one_sentence() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "2"]);
    let mut running = Vec::new();
    for _ in 0..2 {
        let c = Arc::new(server.client().await);
        let sim = c.new_sim(json!({})).await;
        c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]})).await;
        let busy = c.clone();
        running.push((c, tokio::spawn(async move { busy.try_call("step_simulation", json!({"sim_id": sim, "steps": 1_000_000})).await })));
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let (status, why) = common::raw_session(&reqwest::Client::new(), &server.url, "2025-06-18").await.expect_err("no session is idle");
    assert_eq!(status, 503, "{why}");
    assert!(why.starts_with("Session limit reached: 2 live MCP sessions (--max-sessions 2), each with a request in flight;"), "{why}");
    assert!(running.iter().all(|(_, step)| !step.is_finished()), "a step ended: the test proves nothing");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_client_at_its_cap_ends_its_own_sessions_not_others() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-sessions", "20", "--max-sessions-per-client", "10"]);
    // Two clients told apart by their bearer tokens (the server requires none).
    let (quiet, noisy) = (http_as(Some("quiet-one")), http_as(Some("noisy-one")));
    let mut kept = Vec::new();
    for _ in 0..5 {
        kept.push(common::raw_session(&quiet, &server.url, "2025-06-18").await.unwrap());
    }
    let mut opened = Vec::new();
    for _ in 0..30 {
        opened.push(common::raw_session(&noisy, &server.url, "2025-06-18").await.expect("its own idle sessions make room"));
    }
    for sid in &kept {
        assert_eq!(request(&quiet, &server.url, sid, "ping", json!({})).await.0, 200, "the quiet client's session was ended");
    }
    let alive = {
        let mut n = 0;
        for sid in &opened {
            n += usize::from(request(&noisy, &server.url, sid, "ping", json!({})).await.0 == 200);
        }
        n
    };
    assert_eq!(alive, 10, "the noisy client keeps its cap of sessions");
}

#[tokio::test(flavor = "multi_thread")]
async fn subscriptions_are_bounded_and_end_with_their_session() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start_with_env(dir.path(), &[], &[("RUST_LOG", "physics_mcp=info")]);
    let http = reqwest::Client::new();
    let sid = common::raw_session(&http, &server.url, "2025-06-18").await.unwrap();
    // A 3 MB URI is refused, naming the parameter.
    let huge = format!("sim://{}/info", "x".repeat(3 << 20));
    let (_, reply) = request(&http, &server.url, &sid, "resources/subscribe", json!({"uri": huge})).await;
    let reply = reply.expect("a JSON-RPC reply");
    let why = reply["error"]["message"].as_str().unwrap_or_else(|| panic!("accepted: {reply}"));
    assert!(why.starts_with(&format!("uri is {} bytes; a subscribed URI may have at most 512", huge.len())), "{why}");
    // 64 subscriptions, then no more.
    for i in 0..64 {
        let (_, reply) = request(&http, &server.url, &sid, "resources/subscribe", json!({"uri": format!("sim://s{i}/info")})).await;
        assert!(reply.as_ref().is_some_and(|r| r.get("result").is_some()), "subscription {i}: {reply:?}");
    }
    let (_, reply) = request(&http, &server.url, &sid, "resources/subscribe", json!({"uri": "sim://one-more/info"})).await;
    let why = reply.unwrap()["error"]["message"].as_str().unwrap().to_string();
    assert!(why.contains("already holds 64 subscriptions"), "{why}");
    // Ending the session drops them.
    let r = http.delete(&server.url).header("mcp-session-id", &sid).send().await.unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    let stderr = server.stderr.clone();
    common::until("the session's subscriptions to be dropped", || {
        stderr.lock().unwrap().iter().any(|l| l.contains("subscriptions dropped") && l.contains("uris=64"))
    })
    .await;
}

/// `physics-mcp serve` on loopback with `args` and `env`, and the base of its MCP URL.
fn serve(dir: &std::path::Path, args: &[&str], env: &[(&str, &str)]) -> Server {
    Server::start_with_env(dir, args, env)
}

#[tokio::test(flavor = "multi_thread")]
async fn the_token_comes_from_a_file_or_the_environment_not_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let secret = "s3cret-from-a-file";
    let file = dir.path().join("token");
    std::fs::write(&file, format!("{secret}\n")).unwrap();
    let server = serve(dir.path(), &["--token-file", file.to_str().unwrap()], &[]);
    let cmdline = std::fs::read(format!("/proc/{}/cmdline", server.pid())).unwrap();
    assert!(!String::from_utf8_lossy(&cmdline).contains(secret), "the token is on the command line");
    let r = reqwest::Client::new().post(&server.url).header("Accept", ACCEPT).json(&json!({})).send().await.unwrap();
    assert_eq!(r.status().as_u16(), 401);
    assert!(common::raw_session(&http_as(Some(secret)), &server.url, "2025-06-18").await.is_ok());
    // `call` takes it from a file and from the environment.
    let call = |extra: &[&str], env: &[(&str, &str)]| {
        Command::new(common::bin())
            .args(["call", &server.url, "list_simulations"])
            .args(extra)
            .envs(env.iter().copied())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .unwrap()
    };
    assert!(call(&["--token-file", file.to_str().unwrap()], &[]).status.success());
    assert!(call(&[], &[("PHYSICS_MCP_TOKEN", secret)]).status.success());
    let refused = call(&[], &[]);
    assert!(!refused.status.success(), "a call without the token was served");
    drop(server);
    // `serve` takes it from the environment.
    let dir = tempfile::tempdir().unwrap();
    let server = serve(dir.path(), &[], &[("PHYSICS_MCP_TOKEN", "from-the-environment")]);
    assert!(common::raw_session(&reqwest::Client::new(), &server.url, "2025-06-18").await.is_err());
    assert!(common::raw_session(&http_as(Some("from-the-environment")), &server.url, "2025-06-18").await.is_ok());
    // An empty token file is refused at start, saying so.
    let empty = dir.path().join("empty");
    std::fs::write(&empty, "\n").unwrap();
    let data = dir.path().join("data2");
    let (started, stderr) = Server::start_failure(&["serve", "--bind", "127.0.0.1:0", "--data", data.to_str().unwrap(), "--token-file", empty.to_str().unwrap()]);
    assert!(!started && stderr.contains("gives an empty token"), "{stderr}");
}

#[test]
fn serving_beyond_loopback_without_a_token_warns() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(common::bin())
        .args(["serve", "--bind", "0.0.0.0:0", "--data"])
        .arg(dir.path().join("data"))
        .arg("--workspace")
        .arg(dir.path().join("ws"))
        .env_remove("PHYSICS_MCP_TOKEN")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let mut lines = std::io::BufRead::lines(std::io::BufReader::new(stderr));
    let mut warned = false;
    for line in lines.by_ref().map_while(Result::ok) {
        warned |= line.starts_with("physics-mcp: warning: serving on 0.0.0.0:") && line.contains("without a token");
        if line.contains("listening on") {
            break;
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    assert!(warned, "no warning for serving on 0.0.0.0 without a token");
}
