//! `physics-mcp call URL TOOL '{json}'` (every README command works from a clone of
//! this repository alone): a real server, the real binary as the client; results print as
//! JSON, refusals print their sentence and exit 1, a token is sent when given.

use crate::common;

use std::process::Command;

use common::Server;
use serde_json::Value;

fn call(url: &str, tool: &str, args: &str, extra: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_physics-mcp"))
        .args(["call", url, tool, args])
        .args(extra)
        .output()
        .expect("run physics-mcp call");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn a_call_from_the_shell_prints_the_result_and_refusals_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let (code, out, err) = call(&server.url, "create_simulation", "{}", &[]);
    assert_eq!(code, 0, "{out} {err}");
    let created: Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("not JSON ({e}): {out}"));
    let sim = created["simulation_id"].as_str().expect("simulation_id");

    let (code, out, _) = call(&server.url, "add_box", &format!(r#"{{"sim_id": "{sim}", "position": [0, 0, 1], "dimensions": [0.1, 0.1, 0.1]}}"#), &[]);
    assert_eq!(code, 0, "{out}");
    assert_eq!(serde_json::from_str::<Value>(&out).unwrap()["object_id"], 0);

    let (code, out, _) = call(&server.url, "step_simulation", &format!(r#"{{"sim_id": "{sim}", "step": 240}}"#), &[]);
    assert_eq!(code, 1, "a misspelled parameter is refused: {out}");
    assert!(out.contains("steps"), "the closest known name is offered: {out}");

    let (code, _, err) = call(&server.url, "create_simulation", "[1, 2]", &[]);
    assert_eq!(code, 1);
    assert!(err.contains("JSON object"), "{err}");
}

#[test]
fn a_token_is_sent_when_given() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--token", "s3cret"]);
    let (code, _, _) = call(&server.url, "list_simulations", "{}", &[]);
    assert_ne!(code, 0, "without the token the server refuses");
    let (code, out, err) = call(&server.url, "list_simulations", "{}", &["--token", "s3cret"]);
    assert_eq!(code, 0, "{out} {err}");
    assert!(out.contains("simulations"), "{out}");
}
