//! physics-mcp in cluster mode as the tests drive it: nodes (the real binary, sharing one
//! workspace, each with its own data directory), calls whose outcome may be "lost" (the node
//! died or stopped mid-call), and the `export`/`import`/`replay` command lines.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use rmcp::model::CallToolRequestParams;
use serde_json::Value;

use crate::common::{Client, Server};
use crate::nats::NatsCluster;

/// The words of the refusal a node answers a forwarded call with when the simulation's owner
/// died (or stopped) while the call was with it: whether it was applied is unknown, as for a
/// lost call (the contract's wording; one place to change if it changes). Since routing, a call
/// on a simulation owned elsewhere is forwarded to its owner (or waits for the takeover when
/// the owner died), so no node refuses a call because another one owns the simulation.
pub const STOPPED_ANSWERING: &str = "stopped answering";

/// The refusal a node gave a call on a simulation another live node owned, before calls were
/// routed to the owner. Routing
/// forwards such calls instead, so a test seeing it fails.
pub const OWNED_ELSEWHERE: &str = "is owned by node";

/// The variable with which tests/common makes every server it starts a cluster node. These
/// tests choose per server (an embedded server beside a node, nodes with their own flags), so
/// they refuse to run with it set rather than start servers with `--cluster` twice.
const AMBIENT_CLUSTER: &str = "PHYSICS_TEST_CLUSTER";

/// Panics if `PHYSICS_TEST_CLUSTER` is set (see `AMBIENT_CLUSTER`).
pub fn assert_no_ambient_cluster() {
    if std::env::var(AMBIENT_CLUSTER).is_ok_and(|v| !v.is_empty()) {
        panic!("unset {AMBIENT_CLUSTER} for the cluster tests: they start their own NATS cluster and choose which servers join it");
    }
}

/// Whether a refusal says the owner the call was forwarded to stopped answering (the
/// outcome is unknown).
pub fn stopped_answering(refusal: &str) -> bool {
    refusal.contains(STOPPED_ANSWERING)
}

/// Whether a refusal is the "owned by another node" one (which routing must never answer).
pub fn owned_elsewhere(refusal: &str) -> bool {
    refusal.contains(OWNED_ELSEWHERE)
}

/// The workspace every node of a test shares (`root/workspace`, created): in cluster mode
/// user files live in one directory all nodes see.
pub fn shared_workspace(root: &Path) -> PathBuf {
    let workspace = root.join("workspace");
    std::fs::create_dir_all(&workspace).unwrap();
    workspace
}

/// One physics-mcp process in cluster mode. It keeps its directory (data cache, the
/// workspace link) across `kill9`/`restart`, as a machine that reboots does.
pub struct Node {
    pub name: String,
    dir: PathBuf,
    args: Vec<String>,
    /// Environment variables of the process (e.g. `RUST_LOG`).
    env: Vec<(String, String)>,
    server: Option<Server>,
    /// The stderr lines of this node's earlier processes (killed or stopped), so a failing
    /// run's evidence covers every incarnation, not only the last.
    earlier: Vec<std::sync::Arc<std::sync::Mutex<Vec<String>>>>,
}

impl Node {
    /// Starts node `name` under `root/name` (its own `data`, and `workspace` a symlink to the
    /// shared `workspace`: every node must read the same model files) on `cluster`, with
    /// `extra` flags (e.g. `--lease-ms`).
    pub fn start(root: &Path, name: &str, cluster: &NatsCluster, workspace: &Path, extra: &[&str]) -> Node {
        Node::start_with_env(root, name, cluster, workspace, extra, &[])
    }

    /// `start` with environment variables for the process (`RUST_LOG` to see what it logs).
    pub fn start_with_env(root: &Path, name: &str, cluster: &NatsCluster, workspace: &Path, extra: &[&str], env: &[(&str, &str)]) -> Node {
        let dir = root.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::os::unix::fs::symlink(workspace, dir.join("workspace")).expect("link the shared workspace");
        let mut args = vec!["--cluster".to_string(), cluster.urls(), "--node".to_string(), name.to_string()];
        args.extend(extra.iter().map(|s| s.to_string()));
        let env = env.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        let mut node = Node { name: name.to_string(), dir, args, env, server: None, earlier: Vec::new() };
        node.restart();
        node
    }

    /// Starts the (stopped or killed) node again with the same directory and flags; returns
    /// when it prints its URL (a new port: `--bind 127.0.0.1:0`).
    pub fn restart(&mut self) {
        assert!(self.server.is_none(), "node {} is running", self.name);
        let args: Vec<&str> = self.args.iter().map(String::as_str).collect();
        let env: Vec<(&str, &str)> = self.env.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
        self.server = Some(Server::start_with_env(&self.dir, &args, &env));
    }

    /// kill -9 and reap.
    pub fn kill9(&mut self) {
        if let Some(s) = self.server.take() {
            self.earlier.push(s.stderr.clone());
            s.kill();
        }
    }

    /// SIGTERM, as an operator stops a node: it flushes its buffered read and refused events
    /// to the cluster before it exits (which must be clean).
    pub fn terminate(&mut self) {
        if let Some(s) = self.server.take() {
            self.earlier.push(s.stderr.clone());
            s.terminate();
        }
    }

    /// The running server (panics if the node is down).
    pub fn server(&self) -> &Server {
        self.server.as_ref().unwrap_or_else(|| panic!("node {} is down", self.name))
    }

    /// The process id, for signals sent from outside (SIGKILL from a timer, SIGSTOP/SIGCONT).
    pub fn pid(&self) -> u32 {
        self.server().pid()
    }

    /// The lines the running process has written to stderr so far (kept by the caller across
    /// a `kill9`: the handle outlives the process).
    pub fn stderr(&self) -> std::sync::Arc<std::sync::Mutex<Vec<String>>> {
        self.server().stderr.clone()
    }

    /// Every stderr line of every process this node has run, in order, each process's lines
    /// after a `--- restarted ---` line.
    pub fn all_stderr(&self) -> Vec<String> {
        let mut all = Vec::new();
        for lines in self.earlier.iter().chain(self.server.as_ref().map(|s| &s.stderr)) {
            if !all.is_empty() {
                all.push("--- restarted ---".to_string());
            }
            all.extend(lines.lock().unwrap_or_else(|p| p.into_inner()).iter().cloned());
        }
        all
    }

    /// A new MCP client on this node.
    pub async fn client(&self) -> Client {
        self.server().client().await
    }
}

/// Sends `signal` (e.g. "KILL", "STOP", "CONT") to process `pid`, as an operator's `kill` does.
pub fn signal(pid: u32, signal: &str) {
    let ok = Command::new("kill").args([&format!("-{signal}"), &pid.to_string()]).status().expect("run kill");
    assert!(ok.success(), "kill -{signal} {pid} failed");
}

/// What became of a call when the server may die under it: its result, its refusal, or no
/// answer at all (the connection broke or nothing came within the bound).
#[derive(Debug, Clone)]
pub enum Outcome {
    Ok(Value),
    Refused(String),
    Lost(String),
}

/// Calls `tool` without panicking on transport failures (common's `Client::raw` panics, which
/// is right for a server that must stay up but not for one the test kills): `Lost` after
/// `limit` or on a protocol error.
pub async fn attempt(c: &Client, tool: &str, args: Value, limit: Duration) -> Outcome {
    let Value::Object(args) = args else { panic!("arguments must be an object") };
    let call = c.service.call_tool(CallToolRequestParams::new(tool.to_string()).with_arguments(args));
    match tokio::time::timeout(limit, call).await {
        Err(_) => Outcome::Lost(format!("no reply within {limit:?}")),
        Ok(Err(e)) => Outcome::Lost(e.to_string()),
        Ok(Ok(r)) if r.is_error == Some(true) => {
            Outcome::Refused(r.content.iter().filter_map(|c| c.as_text().map(|t| t.text.clone())).collect::<Vec<_>>().join(" "))
        }
        Ok(Ok(r)) => Outcome::Ok(r.structured_content.unwrap_or(Value::Null)),
    }
}

/// The protocol revision whose requests are stateless (no `initialize`, no session).
pub const STATELESS_REVISION: &str = "2026-07-28";

/// One stateless 2026-07-28 `tools/call` over plain HTTP to `url` (as a client behind a load
/// balancer sends it: no session, every request on its own; see tests/protocol/revisions.rs),
/// read like `attempt`: a JSON-RPC error, an HTTP error, a broken connection or no answer
/// within `limit` is `Lost`.
pub async fn attempt_stateless(http: &reqwest::Client, url: &str, id: u64, tool: &str, args: Value, limit: Duration) -> Outcome {
    let params = serde_json::json!({
        "name": tool,
        "arguments": args,
        "_meta": {
            "io.modelcontextprotocol/protocolVersion": STATELESS_REVISION,
            "io.modelcontextprotocol/clientCapabilities": {},
            "io.modelcontextprotocol/clientInfo": {"name": "cluster-test", "version": "0"},
        },
    });
    let body = serde_json::json!({"jsonrpc": "2.0", "id": id, "method": "tools/call", "params": params});
    let request = http
        .post(url)
        .header("Content-Type", "application/json")
        .header("Accept", "application/json, text/event-stream")
        .header("MCP-Protocol-Version", STATELESS_REVISION)
        .header("Mcp-Method", "tools/call")
        .header("Mcp-Name", tool)
        .body(body.to_string());
    let exchange = async {
        let response = request.send().await.map_err(|e| format!("POST {url}: {e}"))?;
        let status = response.status();
        if response.headers().get("mcp-session-id").is_some() {
            return Err(format!("a stateless request to {url} was given a session"));
        }
        let text = response.text().await.map_err(|e| format!("reading the reply of {url}: {e}"))?;
        if !status.is_success() {
            return Err(format!("HTTP {status} from {url}: {text}"));
        }
        let messages: Vec<Value> = if text.trim_start().starts_with('{') {
            serde_json::from_str(&text).into_iter().collect()
        } else {
            text.lines().filter_map(|l| l.strip_prefix("data:")).filter_map(|d| serde_json::from_str(d.trim()).ok()).collect()
        };
        messages.into_iter().find(|m| m["id"] == serde_json::json!(id)).ok_or_else(|| format!("no response with id {id} in {text}"))
    };
    let reply = match tokio::time::timeout(limit, exchange).await {
        Err(_) => return Outcome::Lost(format!("no reply within {limit:?}")),
        Ok(Err(e)) => return Outcome::Lost(e),
        Ok(Ok(reply)) => reply,
    };
    let result = &reply["result"];
    if result.is_null() {
        return Outcome::Lost(format!("JSON-RPC error: {}", reply["error"]));
    }
    if result["isError"] == Value::Bool(true) {
        let text = result["content"].as_array().into_iter().flatten().filter_map(|c| c["text"].as_str()).collect::<Vec<_>>().join(" ");
        return Outcome::Refused(text);
    }
    Outcome::Ok(result.get("structuredContent").cloned().unwrap_or(Value::Null))
}

/// Waits (up to 10 s) until process `pid`, sent SIGKILL, has exited (a zombie not yet reaped,
/// or gone): from then on its sockets are closed, so NATS and every peer see it dead.
pub fn wait_exited(pid: u32) {
    let started = std::time::Instant::now();
    loop {
        let state = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok().and_then(|s| {
            // The state follows the command name, which is in parentheses and may hold spaces.
            s.rsplit_once(')').and_then(|(_, rest)| rest.split_whitespace().next().map(str::to_string))
        });
        match state.as_deref() {
            None | Some("Z") | Some("X") => return,
            _ if started.elapsed() > Duration::from_secs(10) => panic!("process {pid} still runs 10 s after SIGKILL"),
            _ => std::thread::sleep(Duration::from_millis(1)),
        }
    }
}

/// Runs the physics-mcp binary with `args` and returns its output.
pub fn cli(args: &[&str]) -> Output {
    Command::new(crate::common::bin()).args(args).output().expect("run physics-mcp")
}

/// Panics with the command's output unless it exited 0.
fn assert_success(what: &str, out: &Output) {
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `physics-mcp export URLS SIM OUT`, which must succeed; returns `OUT`.
pub fn export(urls: &str, sim: &str, out: &Path) -> PathBuf {
    let o = cli(&["export", urls, sim, out.to_str().unwrap()]);
    assert_success(&format!("export {sim}"), &o);
    assert!(out.is_file(), "export {sim} wrote no {}", out.display());
    out.to_path_buf()
}

/// `physics-mcp import URLS FILE [--as ID]`; the caller judges the exit status.
pub fn import(urls: &str, file: &Path, as_id: Option<&str>) -> Output {
    let mut args = vec!["import", urls, file.to_str().unwrap()];
    if let Some(id) = as_id {
        args.extend(["--as", id]);
    }
    cli(&args)
}

/// `physics-mcp import …` that must succeed.
pub fn import_ok(urls: &str, file: &Path, as_id: Option<&str>) {
    assert_success(&format!("import {}", file.display()), &import(urls, file, as_id));
}

/// `physics-mcp replay FILE --json`, every recorded hash checked: panics with the divergence
/// unless it exits 0 saying ok. Returns the summary (events, final_hash, …).
pub fn assert_replays(file: &Path) -> Value {
    let o = cli(&["replay", file.to_str().unwrap(), "--json"]);
    assert_success(&format!("replay {}", file.display()), &o);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let v: Value = serde_json::from_str(stdout.trim()).unwrap_or_else(|e| panic!("replay --json printed {stdout:?}: {e}"));
    assert_eq!(v["ok"], Value::Bool(true), "replay of {}: {v}", file.display());
    v["summary"].clone()
}

/// Exports `sim` into `dir/<label>.sqlite` and checks that it replays; returns the file and
/// the replay summary.
pub fn export_and_verify(urls: &str, sim: &str, dir: &Path, label: &str) -> (PathBuf, Value) {
    let file = export(urls, sim, &dir.join(format!("{label}.sqlite")));
    let summary = assert_replays(&file);
    (file, summary)
}

/// A log's events (any SQLite log: exported, embedded or recorded).
pub fn events(file: &Path) -> Vec<physics_mcp::log::sqlite::Event> {
    physics_mcp::log::replay::events(file).unwrap_or_else(|e| panic!("read {}: {e}", file.display()))
}

/// The simulation id a SQLite log belongs to (its `meta` table), to import it knowing the id.
pub fn log_sim_id(file: &Path) -> String {
    let c = rusqlite::Connection::open_with_flags(file, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY).unwrap();
    c.query_row("SELECT value FROM meta WHERE key = 'simulation_id'", [], |r| r.get(0))
        .unwrap_or_else(|e| panic!("{}: no simulation_id in meta: {e}", file.display()))
}

/// The ids list_simulations names.
pub async fn listed_ids(c: &Client) -> Vec<String> {
    crate::common::hard::listed(&c.call("list_simulations", serde_json::json!({})).await).0
}

/// The arguments of an event, parsed (Null when they are not JSON, e.g. a blob reference).
pub fn event_args(e: &physics_mcp::log::sqlite::Event) -> Value {
    serde_json::from_str(&e.arguments).unwrap_or(Value::Null)
}

/// The recorded result of an event, parsed (Null when absent or not JSON).
pub fn event_result(e: &physics_mcp::log::sqlite::Event) -> Value {
    e.result.as_deref().and_then(|r| serde_json::from_str(r).ok()).unwrap_or(Value::Null)
}

/// p-th percentile (nearest rank) of durations, in milliseconds.
pub fn percentile_ms(sorted: &[Duration], p: f64) -> f64 {
    assert!(!sorted.is_empty());
    let rank = ((p / 100.0) * sorted.len() as f64).ceil().max(1.0) as usize;
    sorted[rank.min(sorted.len()) - 1].as_secs_f64() * 1e3
}
