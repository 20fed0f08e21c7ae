//! Cluster mode (`serve --cluster`): the log of record of every simulation is a subject in a
//! replicated NATS JetStream stream, and the node that holds a simulation's lease serves it.
//! A node's SQLite files are a cache of those subjects that any node can rebuild, so a node's
//! death loses nothing acknowledged (docs/cluster.md).
//!
//! - `record`: what a subject holds (commits, takeovers);
//! - `replica`: the hook that sends every commit of a SQLite log to its subject, fenced;
//! - `lease`: who serves a simulation (a lease per node, expired unless renewed; an ownership
//!   record per simulation, changed only by a takeover);
//! - `transfer`: a whole log into a subject (a simulation joining, `import`) and back into a
//!   SQLite file (a takeover's cache, `export`);
//! - `retire`: what is left of a destroyed simulation, removed after its fenced marker.
//!
//! The rest of the server is synchronous; this module owns a small tokio runtime of its own
//! and blocks on it ([`Cluster::run`]), whatever thread calls.

pub mod calls;
pub mod lease;
pub mod portable;
pub mod record;
pub mod replica;
pub mod retire;
pub mod sweeps;
pub mod transfer;

use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use async_nats::jetstream::{self, kv, object_store, stream};

/// How a node joins a cluster (`serve --cluster …`).
#[derive(Clone, Debug)]
pub struct ClusterConfig {
    /// NATS server URLs, comma-separated (`nats://HOST:PORT,…`).
    pub urls: String,
    /// This node's name (in leases and takeover records; unique per live node).
    pub node: String,
    /// The prefix of every stream, bucket and subject the server keeps, so several
    /// deployments (or test runs) can share one NATS cluster.
    pub namespace: String,
    /// How many streams the simulations' subjects are spread over (one Raft leader each).
    pub streams: u32,
    /// Replicas of every stream, bucket and object (3 survives one server's loss).
    pub replicas: usize,
    /// How long a lease lasts unless renewed (the whole cluster must use one value).
    pub lease: Duration,
    /// Whether this process serves simulations (a node: it holds a lease) or only moves logs
    /// (`export`, `import`: no lease, no ownership).
    pub serves: bool,
}

impl ClusterConfig {
    /// The defaults (`--cluster-streams 4 --cluster-replicas 3 --lease-ms 5000`).
    pub fn new(urls: &str, node: &str) -> ClusterConfig {
        ClusterConfig {
            urls: urls.into(),
            node: node.into(),
            namespace: "pmcp".into(),
            streams: 4,
            replicas: 3,
            lease: Duration::from_millis(5000),
            serves: true,
        }
    }
}

/// Largest commit carried inside a message; a larger one goes to the object store and the
/// message names it (NATS's default max payload is 1 MiB).
pub const INLINE_COMMIT_MAX: usize = 256 * 1024;

/// How long an append keeps retrying while the cluster elects a leader or reconnects.
pub const APPEND_PATIENCE: Duration = Duration::from_secs(30);

/// One connection to a JetStream cluster and the buckets the server keeps there.
pub struct Cluster {
    rt: Option<tokio::runtime::Runtime>,
    js: jetstream::Context,
    /// `NS_nodes`: one lease per live node.
    nodes: kv::Store,
    /// `NS_owners`: one ownership record per owned simulation.
    owners: kv::Store,
    index: kv::Store,
    settings: kv::Store,
    objects: object_store::ObjectStore,
    config: ClusterConfig,
    /// This node's lease and the simulations it owns.
    held: Mutex<lease::Holdings>,
    /// Held while this node joins the cluster (`lease::join`): one join at a time.
    joining: Mutex<()>,
    /// Where calls for simulations other nodes own were last sent (`calls::owner_hint`).
    hints: Mutex<HashMap<String, String>>,
    /// One lock per simulation being taken over or destroyed here (`one_at_a_time`).
    takeovers: Mutex<HashMap<String, Arc<Mutex<()>>>>,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

/// Creates a bucket-like thing, or opens it when another node created it first, retried
/// `patiently`: a cluster that has just formed may not place replicas yet ("no suitable peers
/// for placement, peer offline" — seen in CI for the object store, the one bucket that was not
/// retried), and a bucket another node has just made may not answer yet.
async fn create_or_get<T, E1, E2, CF, GF>(create: impl Fn() -> CF, get: impl Fn() -> GF) -> Result<T, String>
where
    CF: Future<Output = Result<T, E1>>,
    GF: Future<Output = Result<T, E2>>,
    E1: std::fmt::Display,
    E2: std::fmt::Display,
{
    let (create, get) = (&create, &get);
    patiently(move || async move {
        match create().await {
            Ok(t) => Ok(t),
            Err(first) => get().await.map_err(|e| format!("{first}; then {e}")),
        }
    })
    .await
}

impl Cluster {
    /// Connects to the cluster and makes sure its streams and buckets exist.
    pub fn connect(config: ClusterConfig) -> anyhow::Result<Arc<Cluster>> {
        if !valid_id(&config.node) {
            anyhow::bail!("--node must be 1 to 64 letters, digits, '-' or '_', not {:?}", config.node);
        }
        if config.namespace.is_empty()
            || config.namespace.len() > 32
            || !config
                .namespace
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            anyhow::bail!(
                "--cluster-namespace must be 1 to 32 letters, digits, '_' or '-', not {:?}",
                config.namespace
            );
        }
        if config.streams == 0 || config.replicas == 0 || config.lease < Duration::from_millis(500) {
            anyhow::bail!("--cluster-streams and --cluster-replicas must be at least 1 and --lease-ms at least 500");
        }
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("cluster")
            .enable_all()
            .build()?;
        let mut cfg = config;
        let (js, nodes, owners, index, settings, objects, config) = rt.block_on(async move {
            let addrs: Vec<async_nats::ServerAddr> = cfg
                .urls
                .split(',')
                .map(|u| u.trim().parse())
                .collect::<Result<_, _>>()
                .map_err(|e| anyhow::anyhow!("--cluster {}: {e}", cfg.urls))?;
            let client = async_nats::ConnectOptions::new()
                .name(format!("physics-mcp {}", cfg.node))
                .retry_on_initial_connect()
                .connection_timeout(Duration::from_secs(5))
                .connect(addrs)
                .await
                .map_err(|e| anyhow::anyhow!("cannot connect to the cluster {}: {e}", cfg.urls))?;
            let mut js = jetstream::new(client);
            js.set_timeout(Duration::from_secs(5));
            let bucket = |name: &str, max_age: Duration, replicas: usize| kv::Config {
                bucket: name.into(),
                history: 1,
                max_age,
                num_replicas: replicas,
                ..Default::default()
            };
            let settings = open_bucket(
                &js,
                bucket(&format!("{}_settings", cfg.namespace), Duration::ZERO, cfg.replicas),
            )
            .await?;
            // Cluster-wide settings: the first node's values hold for every node (subjects are
            // spread by the stream count; leases expire by the bucket's age).
            cfg.streams = agreed(&settings, "streams", cfg.streams as u64).await? as u32;
            cfg.lease = Duration::from_millis(agreed(&settings, "lease_ms", cfg.lease.as_millis() as u64).await?);
            for k in 0..cfg.streams {
                let config = stream::Config {
                    name: stream_name(&cfg.namespace, k),
                    subjects: vec![format!("{}.log.{k}.>", cfg.namespace)],
                    num_replicas: cfg.replicas,
                    duplicate_window: Duration::from_secs(120),
                    allow_direct: true,
                    ..Default::default()
                };
                patiently(|| js.get_or_create_stream(config.clone()))
                    .await
                    .map_err(|e| anyhow::anyhow!("stream {}: {e}", stream_name(&cfg.namespace, k)))?;
            }
            let nodes = open_bucket(&js, bucket(&format!("{}_nodes", cfg.namespace), cfg.lease, cfg.replicas)).await?;
            let owners = open_bucket(&js, bucket(&format!("{}_owners", cfg.namespace), Duration::ZERO, cfg.replicas)).await?;
            let index = open_bucket(
                &js,
                bucket(&format!("{}_sims", cfg.namespace), Duration::ZERO, cfg.replicas),
            )
            .await?;
            let objects_name = format!("{}_objects", cfg.namespace);
            let objects = create_or_get(
                || {
                    js.create_object_store(object_store::Config {
                        bucket: objects_name.clone(),
                        num_replicas: cfg.replicas,
                        ..Default::default()
                    })
                },
                || js.get_object_store(&objects_name),
            )
            .await
            .map_err(|e| anyhow::anyhow!("object store {objects_name}: {e}"))?;
            anyhow::Ok((js, nodes, owners, index, settings, objects, cfg))
        })?;
        let serves = config.serves;
        let cluster = Arc::new(Cluster {
            rt: Some(rt),
            js,
            nodes,
            owners,
            index,
            settings,
            objects,
            config,
            held: Mutex::default(),
            joining: Mutex::default(),
            hints: Mutex::default(),
            takeovers: Mutex::default(),
        });
        if serves {
            cluster.join().map_err(|e| anyhow::anyhow!("this node could not join the cluster: {e}"))?;
            lease::start_renewing(&cluster);
        }
        Ok(cluster)
    }

    /// Runs `f` on the cluster's runtime and waits for it: the bridge from the server's
    /// synchronous code (a call's thread, start-up, the CLI).
    pub fn run<T: Send + 'static>(&self, f: impl Future<Output = T> + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        self.rt
            .as_ref()
            .expect("runtime lives as long as the cluster")
            .spawn(async move {
                let _ = tx.send(f.await);
            });
        rx.recv().expect("a cluster task never drops its answer")
    }

    /// `run` with a deadline: every wait on the cluster ends, with an error naming it, after
    /// `limit` (a read of a subject that was purged meanwhile, a server that never answers).
    pub fn run_for<T: Send + 'static>(&self, limit: Duration, f: impl Future<Output = T> + Send + 'static) -> Result<T, String> {
        self.run(async move { tokio::time::timeout(limit, f).await.map_err(|_| format!("the cluster did not answer within {limit:?}")) })
    }

    /// Holds `id`'s lock for takeovers and destruction: two calls never rebuild one simulation
    /// at once, and a destroy never races a takeover of the same id — while calls for other
    /// simulations go on (no lock is node-wide).
    pub fn one_at_a_time(&self, id: &str) -> SimLock {
        let lock = {
            let mut all = self.takeovers.lock().unwrap_or_else(|p| p.into_inner());
            all.retain(|_, l| Arc::strong_count(l) > 1);
            all.entry(id.to_string()).or_default().clone()
        };
        SimLock(lock)
    }

    /// This node's configuration.
    pub fn config(&self) -> &ClusterConfig {
        &self.config
    }

    /// The stream and subject a simulation's log lives on (spread by a hash of its id).
    pub fn subject(&self, id: &str) -> (String, String) {
        let k = blake3::hash(id.as_bytes()).as_bytes()[0] as u32 % self.config.streams;
        (
            stream_name(&self.config.namespace, k),
            format!("{}.log.{k}.{id}", self.config.namespace),
        )
    }

    /// The saved-file MAC key every node uses: the first node's, shared through the cluster
    /// so a file saved on one node loads (fast) on any other.
    pub fn shared_mac_key(&self, local: [u8; 32]) -> anyhow::Result<[u8; 32]> {
        let settings = self.settings.clone();
        let hex = blake3::Hash::from_bytes(local).to_hex().to_string();
        let stored = self.run(async move {
            match settings.create("mac_key", hex.clone().into()).await {
                Ok(_) => Ok(hex),
                Err(_) => kv_get(&settings, "mac_key")
                    .await?
                    .map(|b| String::from_utf8_lossy(&b).into_owned())
                    .ok_or_else(|| "the cluster's mac_key vanished".to_string()),
            }
        });
        let stored = stored.map_err(|e| anyhow::anyhow!("the cluster's saved-file key: {e}"))?;
        let hash =
            blake3::Hash::from_hex(stored.trim()).map_err(|e| anyhow::anyhow!("the cluster's saved-file key: {e}"))?;
        Ok(*hash.as_bytes())
    }
}

/// Creates a key-value bucket, or opens it when another node created it first.
pub(crate) async fn open_bucket(js: &jetstream::Context, config: kv::Config) -> anyhow::Result<kv::Store> {
    let name = config.bucket.clone();
    create_or_get(|| js.create_key_value(config.clone()), || js.get_key_value(name.clone()))
        .await
        .map_err(|e| anyhow::anyhow!("bucket {name}: {e}"))
}

/// The cluster's value of setting `key`: this node's `mine` if it is the first to say, else
/// the stored one.
async fn agreed(settings: &kv::Store, key: &str, mine: u64) -> anyhow::Result<u64> {
    let started = std::time::Instant::now();
    loop {
        if settings.create(key, mine.to_string().into()).await.is_ok() {
            return Ok(mine);
        }
        if let Some(b) = kv_get(settings, key)
            .await
            .map_err(|e| anyhow::anyhow!("setting {key}: {e}"))?
        {
            return String::from_utf8_lossy(&b)
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("the cluster's setting {key} is unreadable"));
        }
        // Neither created nor there: the bucket is not ready yet.
        if started.elapsed() > Duration::from_secs(10) {
            anyhow::bail!("the cluster's setting {key} could be neither written nor read");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// A simulation's lock for takeovers and destruction (`Cluster::one_at_a_time`): lock it with
/// `hold`.
pub struct SimLock(Arc<Mutex<()>>);

impl SimLock {
    /// Waits for the simulation's lock.
    pub fn hold(&self) -> std::sync::MutexGuard<'_, ()> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// Whether `id` can name a simulation (or a node) in a cluster: 1 to 64 letters, digits, '-' or
/// '_' — a file name, a NATS subject token and a key. Anything else names nothing, and is
/// answered "not found" before the cluster is asked (a bad key is not an error that passes).
pub fn valid_id(id: &str) -> bool {
    !id.is_empty() && id.len() <= 64 && id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// A failed cluster request: one that may pass (retried) or not (returned at once).
#[derive(Debug)]
pub(crate) struct Failure {
    permanent: bool,
    why: String,
}

impl Failure {
    /// A failure worth retrying (no responders, a timeout, an election).
    pub(crate) fn passing(e: impl std::fmt::Display) -> Failure {
        Failure { permanent: false, why: e.to_string() }
    }
    /// A failure that asking again cannot change (an invalid key).
    pub(crate) fn permanent(e: impl std::fmt::Display) -> Failure {
        Failure { permanent: true, why: e.to_string() }
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.why)
    }
}

/// `patiently`, except that a permanent failure is returned at once.
pub(crate) async fn patiently_unless<T, F, Fut>(mut attempt: F) -> Result<T, Failure>
where
    F: FnMut() -> Fut,
    Fut: Future<Output = Result<T, Failure>>,
{
    let started = std::time::Instant::now();
    loop {
        match attempt().await {
            Ok(t) => return Ok(t),
            Err(e) if e.permanent || started.elapsed() >= PATIENCE => return Err(e),
            Err(e) => {
                tracing::debug!("retrying a cluster request: {e}");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// How long a request that may fail for a passing reason (a bucket or stream just created, a
/// leader being elected: "no responders", timeouts) is retried.
pub const PATIENCE: Duration = Duration::from_secs(20);

/// Runs `attempt` until it succeeds or [`PATIENCE`] has passed (then its last error).
pub(crate) async fn patiently<T, E, F, Fut>(mut attempt: F) -> Result<T, E>
where
    F: FnMut() -> Fut,
    Fut: Future<Output = Result<T, E>>,
    E: std::fmt::Display,
{
    let started = std::time::Instant::now();
    loop {
        match attempt().await {
            Ok(t) => return Ok(t),
            Err(e) if started.elapsed() >= PATIENCE => return Err(e),
            Err(e) => {
                tracing::debug!("retrying a cluster request: {e}");
                tokio::time::sleep(Duration::from_millis(100)).await;
            }
        }
    }
}

/// A key's value, retried for a few seconds while the bucket's replicas cannot answer yet
/// (a bucket just created, a server just lost: direct gets see "no responders").
pub(crate) async fn kv_get(store: &kv::Store, key: &str) -> Result<Option<bytes::Bytes>, String> {
    patiently_unless(|| async {
        store.get(key).await.map_err(|e| match e.kind() {
            kv::EntryErrorKind::InvalidKey => Failure::permanent(e),
            _ => Failure::passing(e),
        })
    })
    .await
    .map_err(|e| e.to_string())
}

/// The name of stream `k` of a namespace.
fn stream_name(namespace: &str, k: u32) -> String {
    format!("{namespace}_log_{k}")
}

/// What the cluster-wide index says of a simulation (list_simulations without asking owners).
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug, Default)]
pub struct IndexEntry {
    /// The simulation's label.
    #[serde(default)]
    pub name: Option<String>,
    /// Objects when its owner last wrote the entry.
    #[serde(default)]
    pub objects: usize,
    /// Simulated time when its owner last wrote the entry.
    #[serde(default)]
    pub simulation_time: f64,
}

/// How long one index or listing request may take before the call it serves says so.
const INDEX_WAIT: Duration = Duration::from_secs(30);

impl Cluster {
    /// Writes a simulation's index entry (on joining, takeover, and after changes).
    pub fn index_put(&self, id: &str, entry: &IndexEntry) -> Result<(), String> {
        let index = self.index.clone();
        let (id, bytes) = (id.to_string(), serde_json::to_vec(entry).unwrap_or_default());
        self.run_for(INDEX_WAIT, async move {
            patiently(|| index.put(&id, bytes.clone().into()))
                .await
                .map(|_| ())
                .map_err(|e| e.to_string())
        })?
    }

    /// Like `index_put`, without waiting (after a change: the entry is a convenience, the log
    /// is the record). The write starts once `after` (the simulation's previous one) is done, so
    /// a simulation's index writes land in order, and whoever removes the entry can wait for the
    /// last one first (`remove`): none lands after a destroy.
    pub fn index_touch(&self, id: &str, entry: &IndexEntry, after: Option<tokio::task::JoinHandle<()>>) -> Option<tokio::task::JoinHandle<()>> {
        let index = self.index.clone();
        let (id, bytes) = (id.to_string(), serde_json::to_vec(entry).unwrap_or_default());
        let rt = self.rt.as_ref()?;
        Some(rt.spawn(async move {
            if let Some(previous) = after {
                let _ = previous.await;
            }
            let _ = tokio::time::timeout(INDEX_WAIT, index.put(id, bytes.into())).await;
        }))
    }

    /// A simulation's index entry, if the cluster has it (read from the bucket's leader: a
    /// replica that lags could call a simulation just made "not found").
    pub fn index_get(&self, id: &str) -> Result<Option<IndexEntry>, String> {
        if !valid_id(id) {
            return Ok(None);
        }
        let index = self.index.clone();
        let id = id.to_string();
        self.run_for(INDEX_WAIT, async move {
            let got = lease::leader_entry(&index, &id).await?;
            Ok(got.map(|(b, _)| serde_json::from_slice(&b).unwrap_or_default()))
        })?
    }

    /// Every simulation in the cluster with its index entry, by id.
    pub fn index_all(&self) -> Result<Vec<(String, IndexEntry)>, String> {
        use futures_util::StreamExt;
        let index = self.index.clone();
        self.run_for(INDEX_WAIT, async move {
            let ids = patiently(|| async {
                let mut keys = index.keys().await.map_err(|e| e.to_string())?.boxed();
                let mut ids = Vec::new();
                while let Some(k) = keys.next().await {
                    ids.push(k.map_err(|e| e.to_string())?);
                }
                Ok::<_, String>(ids)
            })
            .await?;
            let mut out = Vec::new();
            for id in ids {
                if let Some(b) = kv_get(&index, &id).await? {
                    out.push((id, serde_json::from_slice(&b).unwrap_or_default()));
                }
            }
            out.sort_by(|a, b| a.0.cmp(&b.0));
            Ok(out)
        })?
    }
}
