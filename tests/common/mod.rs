//! Test harness: the real `physics-mcp` binary on a free loopback port, driven by rmcp's
//! client over streamable HTTP — no mocks.
#![allow(dead_code)]

pub mod host;
pub mod pictures;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use rmcp::model::{CallToolRequestParams, CallToolResult};
use rmcp::service::RunningService;
use rmcp::transport::StreamableHttpClientTransport;
use rmcp::{RoleClient, ServiceExt};
use serde_json::{json, Value};

/// With `PHYSICS_TEST_CLUSTER=nats://…` set, every server a test starts is a node of that
/// JetStream cluster (its log of record there, its --data a cache): the suites that make
/// sense for both backends run against both (`.ci/run`, docs/cluster.md).
pub fn cluster_args(dir: &Path) -> Vec<String> {
    match std::env::var("PHYSICS_TEST_CLUSTER") {
        Ok(urls) if !urls.is_empty() => {
            // One namespace per test directory: a server restarted over the same directory
            // finds its simulations, and tests never see each other's.
            let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
            let namespace = format!("t{}", &blake3::hash(dir.to_string_lossy().as_bytes()).to_hex()[..16]);
            // The node's name too: a server restarted over the directory is the same node, and
            // takes its simulations back at once.
            ["--cluster", &urls, "--cluster-namespace", &namespace, "--node", &namespace, "--cluster-streams", "1", "--cluster-replicas", "1", "--lease-ms", "1000"]
                .map(String::from)
                .to_vec()
        }
        _ => Vec::new(),
    }
}

/// The physics-mcp binary the tests run: `PHYSICS_MCP_BIN` when set, else the one cargo built
/// for this test. The override is for a target directory shared by several worktrees, where
/// another worktree's build may replace `target/debug/physics-mcp` while a long suite runs: copy
/// the binary aside after building and point this at the copy.
pub fn bin() -> PathBuf {
    match std::env::var_os("PHYSICS_MCP_BIN") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => PathBuf::from(env!("CARGO_BIN_EXE_physics-mcp")),
    }
}

/// A running server process.
pub struct Server {
    child: Child,
    /// Every line the server wrote to stderr so far (also echoed as `[server] …`).
    pub stderr: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
    pub url: String,
    pub data: PathBuf,
    pub workspace: PathBuf,
}

impl Server {
    /// Copies `tests/fixtures` (URDFs and their meshes) into the server's workspace.
    #[allow(dead_code)]
    pub fn copy_fixtures(&self) {
        fn copy(from: &Path, to: &Path) {
            std::fs::create_dir_all(to).unwrap();
            for e in std::fs::read_dir(from).unwrap() {
                let e = e.unwrap();
                let target = to.join(e.file_name());
                if e.file_type().unwrap().is_dir() {
                    copy(&e.path(), &target);
                } else {
                    std::fs::copy(e.path(), target).unwrap();
                }
            }
        }
        copy(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures"), &self.workspace);
    }

    /// `http://127.0.0.1:PORT`: the server's origin (`url` is its MCP endpoint, `…/mcp`).
    pub fn base_url(&self) -> &str {
        self.url.strip_suffix("/mcp").unwrap_or(&self.url)
    }

    /// Starts `physics-mcp serve` on 127.0.0.1:0 over `dir/data` and `dir/workspace`.
    pub fn start(dir: &Path, extra: &[&str]) -> Server {
        Self::start_with_env(dir, extra, &[])
    }

    /// `start` with extra environment variables for the server (e.g. `RUST_LOG`).
    pub fn start_with_env(dir: &Path, extra: &[&str], env: &[(&str, &str)]) -> Server {
        let data = dir.join("data");
        let workspace = dir.join("workspace");
        let mut child = Command::new(bin())
            .args(["serve", "--bind", "127.0.0.1:0", "--data"])
            .arg(&data)
            .arg("--workspace")
            .arg(&workspace)
            .args(extra)
            .args(cluster_args(dir))
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start physics-mcp");
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = mpsc::channel();
        let lines = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let kept = lines.clone();
        std::thread::spawn(move || {
            let mut sent = false;
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Ok(mut v) = kept.lock() {
                    v.push(line.clone());
                }
                if !sent {
                    if let Some(rest) = line.strip_prefix("physics-mcp listening on ") {
                        let _ = tx.send(Ok(rest.to_string()));
                        sent = true;
                        continue;
                    }
                }
                if !line.contains("physics_mcp::timing") {
                    eprintln!("[server] {line}");
                }
                if !sent && line.starts_with("physics-mcp:") && !line.starts_with("physics-mcp: warning:") {
                    let _ = tx.send(Err(line));
                    sent = true;
                }
            }
        });
        let url = match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(Ok(url)) => url,
            Ok(Err(e)) => panic!("server refused to start: {e}"),
            Err(_) => panic!("server did not start"),
        };
        Server { child, stderr: lines, url, data, workspace }
    }

    /// Starts a server expected to refuse to start; returns its stderr.
    pub fn start_failure(args: &[&str]) -> (bool, String) {
        let out = Command::new(bin())
            .args(args)
            .stdin(Stdio::null())
            .output()
            .expect("run physics-mcp");
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    }

    /// SIGTERM, as an operator stops the server: it commits buffered events before it exits.
    #[allow(dead_code)]
    pub fn terminate(mut self) {
        let pid = self.child.id().to_string();
        let sent = Command::new("kill").args(["-TERM", &pid]).status().expect("run kill");
        assert!(sent.success(), "kill -TERM {pid} failed");
        let status = self.child.wait().unwrap();
        assert!(status.success(), "the server exited with {status} after SIGTERM");
    }

    /// SIGTERM, then waits at most `limit` for the exit (killing the process past it):
    /// returns how long the exit took, panicking if it did not come or was not clean.
    pub fn terminate_within(mut self, limit: Duration) -> Duration {
        let pid = self.child.id().to_string();
        let sent = Command::new("kill").args(["-TERM", &pid]).status().expect("run kill");
        assert!(sent.success(), "kill -TERM {pid} failed");
        let started = std::time::Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                assert!(status.success(), "the server exited with {status} after SIGTERM");
                return started.elapsed();
            }
            if started.elapsed() > limit {
                let _ = self.child.kill();
                panic!("the server was still running {limit:?} after SIGTERM");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// kill -9.
    pub fn kill(mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// The server's process id (to change its limits from outside, as an operator would).
    #[allow(dead_code)]
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// A connected MCP client.
    pub async fn client(&self) -> Client {
        Client::connect(&self.url).await
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// An MCP client session over streamable HTTP.
pub struct Client {
    pub service: RunningService<RoleClient, ()>,
}

impl Client {
    /// Connects and initializes.
    pub async fn connect(url: &str) -> Client {
        let transport = StreamableHttpClientTransport::from_uri(url.to_string());
        let service = ().serve(transport).await.expect("initialize MCP session");
        Client { service }
    }

    /// Calls a tool and returns the raw result.
    pub async fn raw(&self, tool: &str, args: Value) -> CallToolResult {
        let args = match args {
            Value::Object(m) => m,
            other => panic!("arguments must be an object, got {other}"),
        };
        // A reply the client cannot read makes rmcp's client resume the stream forever; a
        // bound turns that hang into a failure naming the call.
        let call = self.service.call_tool(CallToolRequestParams::new(tool.to_string()).with_arguments(args));
        tokio::time::timeout(Duration::from_secs(600), call)
            .await
            .unwrap_or_else(|_| panic!("{tool}: no reply within 600 s"))
            .unwrap_or_else(|e| panic!("{tool} failed at the protocol level: {e}"))
    }

    /// Calls a tool: Ok(structuredContent) or Err(error text).
    pub async fn try_call(&self, tool: &str, args: Value) -> Result<Value, String> {
        let r = self.raw(tool, args).await;
        if r.is_error == Some(true) {
            let text = r
                .content
                .iter()
                .filter_map(|c| c.as_text().map(|t| t.text.clone()))
                .collect::<Vec<_>>()
                .join(" ");
            Err(text)
        } else {
            Ok(r.structured_content.expect("structuredContent"))
        }
    }

    /// Calls a tool that must succeed.
    pub async fn call(&self, tool: &str, args: Value) -> Value {
        match self.try_call(tool, args.clone()).await {
            Ok(v) => v,
            Err(e) => panic!("{tool} {args} was refused: {e}"),
        }
    }

    /// Creates a simulation (extra arguments merged in) and returns its id.
    pub async fn new_sim(&self, args: Value) -> String {
        self.call("create_simulation", args).await["simulation_id"]
            .as_str()
            .expect("simulation_id")
            .to_string()
    }

    /// Adds a static ground slab whose top is at z = 0 and returns its id.
    pub async fn ground(&self, sim: &str) -> u64 {
        self.call(
            "add_box",
            json!({"sim_id": sim, "dimensions": [50, 50, 0.5], "position": [0, 0, -0.5], "mass": 0}),
        )
        .await["object_id"]
            .as_u64()
            .expect("object_id")
    }

    /// Steps `n` times.
    pub async fn step(&self, sim: &str, n: u64) -> Value {
        self.call("step_simulation", json!({"sim_id": sim, "steps": n})).await
    }

    /// The object's state.
    pub async fn state(&self, sim: &str, id: u64) -> Value {
        self.call("get_object_state", json!({"sim_id": sim, "object_id": id})).await
    }

    /// The simulation's state hash.
    pub async fn hash(&self, sim: &str) -> String {
        self.call("get_simulation_info", json!({"sim_id": sim})).await["state_hash"]
            .as_str()
            .expect("state_hash")
            .to_string()
    }
}

/// Every recorded session log in `replays/`, in name order.
pub fn recorded_logs() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("replays");
    let mut logs: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "sqlite"))
        .collect();
    logs.sort();
    logs
}

/// An in-process registry's configuration in `dir` (data/ and ws/ under it), default limits.
pub fn config(dir: &Path) -> physics_mcp::sim::Config {
    physics_mcp::sim::Config {
        data_dir: dir.join("data"),
        workspace: dir.join("ws"),
        limits: physics_mcp::limits::Limits::default(),
        sync: physics_mcp::log::sqlite::SyncMode::Normal,
    }
}

/// Opens a raw MCP session over HTTP — `initialize` at `protocol`, then
/// `notifications/initialized` — for tests that need the wire itself (headers, sessions,
/// exact bytes). Returns the session id, or the status and body of a refused `initialize`.
pub async fn raw_session(http: &reqwest::Client, url: &str, protocol: &str) -> Result<String, (u16, String)> {
    const ACCEPT: &str = "application/json, text/event-stream";
    let init = json!({"jsonrpc": "2.0", "id": 0, "method": "initialize", "params": {
        "protocolVersion": protocol, "capabilities": {}, "clientInfo": {"name": "raw", "version": "0"}}});
    let r = http.post(url).header("Accept", ACCEPT).json(&init).send().await.expect("POST initialize");
    let status = r.status().as_u16();
    let sid = r.headers().get("mcp-session-id").map(|v| v.to_str().unwrap().to_string());
    let body = r.text().await.expect("initialize reply");
    let Some(sid) = sid.filter(|_| status == 200) else { return Err((status, body)) };
    let note = json!({"jsonrpc": "2.0", "method": "notifications/initialized"});
    let r = http.post(url).header("Accept", ACCEPT).header("mcp-session-id", &sid).json(&note).send().await.unwrap();
    assert!(r.status().is_success(), "initialized: {}", r.status());
    Ok(sid)
}

/// Waits (at most 20 s, generous for a loaded CI machine) until `done` holds; panics naming
/// `what` otherwise. For what a server does in the background (notifications, news).
pub async fn until(what: &str, mut done: impl FnMut() -> bool) {
    let start = std::time::Instant::now();
    while !done() {
        assert!(start.elapsed() < Duration::from_secs(20), "timed out waiting for {what}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

pub fn v3(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("array");
    [a[0].as_f64().unwrap(), a[1].as_f64().unwrap(), a[2].as_f64().unwrap()]
}

/// Relative error |a - b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// Loads `tests/fixtures/<name>` into an in-process world as load_urdf would (no meshes: the
/// fixtures used in process have none) and returns the robot's object id.
pub fn load_fixture(
    w: &mut physics_mcp::world::World,
    name: &str,
    position: [f32; 3],
    fixed_base: bool,
) -> u32 {
    let text = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures").join(name)).unwrap();
    let cmd = physics_mcp::command::Command::LoadUrdf {
        file_path: name.into(),
        urdf: physics_mcp::command::Blob::new(text),
        meshes: Default::default(),
        position,
        orientation: [0.0, 0.0, 0.0, 1.0],
        fixed_base,
        continuous_limits_from_file: true,
        revolute_prismatic_limits_from_file: true,
        inertials_as_pybullet: true,
        parsed: Default::default(),
    };
    w.apply(&cmd, &mut |_| true).to_value()["object_id"].as_u64().unwrap() as u32
}

/// 1,000 boxes on a 10×10×10 grid over a static floor, as batch calls (`{tool, arguments}`).
pub fn pile_calls() -> Vec<Value> {
    let mut calls = vec![json!({"tool": "add_box", "arguments": {"dimensions": [20, 20, 0.5], "position": [0, 0, -0.5], "mass": 0}})];
    for i in 0..10 {
        for j in 0..10 {
            for k in 0..10 {
                let p = [i as f64 * 0.25 - 1.125, j as f64 * 0.25 - 1.125, 0.5 + k as f64 * 0.25];
                calls.push(json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": p, "orientation": [0, 0, 0.0998, 0.995]}}));
            }
        }
    }
    calls
}

/// An empty in-process world with PyBullet's gravity.
pub fn empty_world(id: &str) -> physics_mcp::world::World {
    let root = physics_mcp::command::Command::CreateSimulation { simulation_id: id.into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) };
    physics_mcp::world::World::create(&root).unwrap().0
}
/// Hardening helpers: seeds, fingerprints, list_simulations parts.
pub mod hard;
pub mod gymnasium;
pub mod mjcf_command;

/// `physics-mcp replay` of simulation `id`'s log in `data`, every recorded hash checked:
/// panics with its output unless it replays.
pub fn assert_replays(data: &Path, id: &str) {
    let path = data.join(format!("{id}.sqlite"));
    let out = Command::new(bin()).arg("replay").arg(&path).output().unwrap();
    assert!(
        out.status.success(),
        "replay of {id} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
