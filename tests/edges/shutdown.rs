//! A shutdown always ends: SIGTERM (and, for `stdio`, the end of its input) ends the server
//! within 10 s whatever is running — a million-step call on the 1,000-box pile, a kept
//! 64-variant sweep, a fork of a large world — with every buffered read flushed and a running
//! step cancelled the way a client cancels it (logged as the steps it took), and a restart
//! then finds every simulation whole.

use crate::common;

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};
use std::time::Duration;

use common::{pile_calls, Client, Server};
use serde_json::{json, Value};

/// The bound docs/guarantees.md promises.
const WITHIN: Duration = Duration::from_secs(10);

/// A simulation holding the 1,000-box pile.
async fn pile(c: &Client) -> String {
    let sim = c.new_sim(json!({})).await;
    c.call("batch", json!({"sim_id": sim, "calls": pile_calls()})).await;
    sim
}

/// Starts `tool` on a client of its own without waiting for it (the server goes away under it).
fn start_call(url: &str, tool: &'static str, args: Value) -> tokio::task::JoinHandle<()> {
    let url = url.to_string();
    tokio::spawn(async move {
        let c = Client::connect(&url).await;
        let _ = c.service.call_tool(rmcp::model::CallToolRequestParams::new(tool).with_arguments(args.as_object().unwrap().clone())).await;
    })
}

/// After a restart, every simulation verifies and nothing is damaged.
async fn all_whole(c: &Client) -> Vec<String> {
    let (ids, damaged) = common::hard::listed(&c.call("list_simulations", json!({})).await);
    assert!(damaged.is_empty(), "{damaged:?}");
    for id in &ids {
        let v = c.call("verify_simulation", json!({"sim_id": id})).await;
        assert_eq!(v["ok"], json!(true), "{id}: {v}");
    }
    ids
}

#[tokio::test(flavor = "multi_thread")]
async fn sigterm_during_a_long_step_cancels_it_flushes_reads_and_exits() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = pile(&c).await;
    // Reads on a simulation nothing else touches: only the shutdown's flush commits them.
    let idle = c.new_sim(json!({})).await;
    c.ground(&idle).await;
    for _ in 1..=10 {
        c.state(&idle, 0).await;
    }
    let step = start_call(&server.url, "step_simulation", json!({"sim_id": sim, "steps": 1_000_000}));
    tokio::time::sleep(Duration::from_secs(2)).await;
    let took = tokio::task::spawn_blocking(move || server.terminate_within(WITHIN)).await.unwrap();
    eprintln!("exited {took:?} after SIGTERM");
    step.abort();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    all_whole(&c).await;
    let h = c.call("get_history", json!({"sim_id": idle, "limit": 1000})).await;
    let events = h["events"].as_array().unwrap();
    let reads = events.iter().filter(|e| e["tool"] == "get_object_state" && e["kind"] == "read").count();
    assert_eq!(reads, 10, "buffered reads were flushed at shutdown");
    let steps = c.call("get_simulation_info", json!({"sim_id": sim})).await["steps"].as_u64().unwrap();
    assert!(steps > 0 && steps < 1_000_000, "the step was cancelled and logged as the {steps} steps it took");
}

#[tokio::test(flavor = "multi_thread")]
async fn sigterm_during_a_kept_sweep_or_a_fork_exits_and_keeps_nothing_half_made() {
    for what in ["sweep", "fork"] {
        let dir = tempfile::tempdir().unwrap();
        let server = Server::start(dir.path(), &["--max-sims", "200"]);
        let c = server.client().await;
        let sim = pile(&c).await;
        c.step(&sim, 5).await;
        let call = if what == "sweep" {
            let variants: Vec<Value> = (0..64).map(|i| json!([{"tool": "set_object_velocity", "arguments": {"object_id": 1, "linear_velocity": [i as f64 * 0.01, 0, 0]}}])).collect();
            start_call(&server.url, "run_sweep", json!({"sim_id": sim, "variants": variants, "steps": 50, "keep": true}))
        } else {
            start_call(&server.url, "fork_simulation", json!({"sim_id": sim}))
        };
        tokio::time::sleep(Duration::from_millis(if what == "sweep" { 1500 } else { 50 })).await;
        let took = tokio::task::spawn_blocking(move || server.terminate_within(WITHIN)).await.unwrap();
        eprintln!("{what}: exited {took:?} after SIGTERM");
        call.abort();
        let server = Server::start(dir.path(), &["--max-sims", "200"]);
        let c = server.client().await;
        let ids = all_whole(&c).await;
        assert!(ids.contains(&sim));
        // Kept variants are all there or none is: the sweep was stopped before keeping any.
        assert!(ids.len() == 1 || ids.len() == 65 || what == "fork", "{what}: {} simulations after the restart", ids.len());
    }
}

/// One JSON-RPC exchange over a stdio server: sends `msg`, returns the response with its id.
fn rpc(stdin: &mut impl Write, stdout: &mut impl BufRead, msg: Value) -> Value {
    writeln!(stdin, "{msg}").unwrap();
    stdin.flush().unwrap();
    let id = msg["id"].clone();
    loop {
        let mut line = String::new();
        assert!(stdout.read_line(&mut line).unwrap() > 0, "the server closed stdout");
        let v: Value = serde_json::from_str(&line).unwrap();
        if v["id"] == id {
            return v;
        }
    }
}

#[test]
fn stdio_ends_within_the_bound_when_its_input_ends_during_a_long_step() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_physics-mcp"))
        .arg("stdio")
        .arg("--data")
        .arg(dir.path().join("data"))
        .arg("--workspace")
        .arg(dir.path().join("ws"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let init = json!({"jsonrpc": "2.0", "id": 1, "method": "initialize", "params": {"protocolVersion": "2025-11-25", "capabilities": {}, "clientInfo": {"name": "t", "version": "1"}}});
    rpc(&mut stdin, &mut stdout, init);
    writeln!(stdin, "{}", json!({"jsonrpc": "2.0", "method": "notifications/initialized"})).unwrap();
    let call = |id: u64, name: &str, args: Value| json!({"jsonrpc": "2.0", "id": id, "method": "tools/call", "params": {"name": name, "arguments": args}});
    let created = rpc(&mut stdin, &mut stdout, call(2, "create_simulation", json!({})));
    let sim = created["result"]["structuredContent"]["simulation_id"].as_str().unwrap().to_string();
    rpc(&mut stdin, &mut stdout, call(3, "batch", json!({"sim_id": sim, "calls": pile_calls()})));
    writeln!(stdin, "{}", call(4, "step_simulation", json!({"sim_id": sim, "steps": 1_000_000}))).unwrap();
    stdin.flush().unwrap();
    std::thread::sleep(Duration::from_secs(2));
    drop(stdin);
    let started = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            assert!(status.success(), "stdio exited with {status}");
            break;
        }
        if started.elapsed() > WITHIN {
            let _ = child.kill();
            panic!("stdio was still running {WITHIN:?} after its input ended");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    eprintln!("stdio exited {:?} after its input ended", started.elapsed());
    // The step was logged as the steps it took.
    let log = dir.path().join("data").join(format!("{sim}.sqlite"));
    let events = physics_mcp::log::replay::events(&log).unwrap();
    let step = events.iter().rev().find(|e| e.tool == "step_simulation").expect("the step was logged");
    let taken = serde_json::from_str::<Value>(step.result.as_deref().unwrap()).unwrap()["steps_taken"].as_u64().unwrap();
    assert!(taken > 0 && taken < 1_000_000, "{taken}");
    physics_mcp::log::replay::replay(&log, None, |_, _| {}).unwrap();
}
