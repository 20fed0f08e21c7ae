//! Calls between nodes (routing, docs/cluster.md "Routing"): the subjects a forwarded call and
//! its answer travel on, who holds a simulation's lease now, and the few message kinds an
//! answer is made of. What a call *does* is the MCP layer's (`mcp::routing`, `mcp::forwarded`);
//! this module only names and carries.
//!
//! - A call for simulation S goes to its owner's subject `{ns}.call.{node}` (one subscription per
//!   node, not per simulation: a node holding ten thousand simulations keeps one), with a reply
//!   inbox of the caller's.
//! - The owner answers on that inbox: `accepted` (it holds S and runs the call), or `not-owner`;
//!   then `beat`s while the call runs, `note`s (progress, log lines), and the answer in `part`s
//!   ending with `last` (an answer of up to the 1 MiB reply budget does not fit one message).
//! - A caller whose client cancels publishes to `{ns}.cancel.{node}.{call}`.
//! - Head moves and simulations coming or going are told to every node on `{ns}.news.*`, so
//!   subscribers on any node hear of changes made on any other.

use std::sync::Arc;
use std::time::Duration;

use async_nats::HeaderMap;
use bytes::Bytes;

use super::Cluster;

/// The header naming what a message of a call's answer is (`Kind`).
pub const KIND: &str = "Pmcp-Kind";
/// The header carrying a forwarded call's id (its cancel subject, the owner's de-duplication).
pub const CALL: &str = "Pmcp-Call";
/// The header naming the simulation a forwarded call is for.
pub const SIM: &str = "Pmcp-Sim";
/// The header naming the node a piece of news comes from.
pub const NODE: &str = "Pmcp-Node";
/// The header naming the object a forwarded call's request is in, when it is too large for
/// a message (the message's payload is then empty).
pub const STORED: &str = "Pmcp-Stored";

/// The largest request carried in a call's message; a larger one (a 10,000-call batch is
/// ≈ 2 MB) goes through the object store, as a large commit does, so a call of any size a
/// node takes from its own client it also takes forwarded.
pub const REQUEST_INLINE_MAX: usize = 512 * 1024;

/// The largest piece of an answer in one message (NATS's default payload limit is 1 MiB).
const PART: usize = 512 * 1024;

/// How long storing or reading a large request may take.
const REQUEST_WAIT: Duration = Duration::from_secs(60);

/// What a message on a call's reply inbox is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The owner holds the simulation and runs the call.
    Accepted,
    /// The node does not hold the simulation (its lease lapsed or moved): ask again.
    NotOwner,
    /// The call is still running.
    Beat,
    /// A notification for the caller's client (a JSON-RPC message).
    Note,
    /// A piece of the answer; more follow.
    Part,
    /// The answer's last piece (a JSON-RPC response or error).
    Last,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Accepted => "accepted",
            Kind::NotOwner => "not-owner",
            Kind::Beat => "beat",
            Kind::Note => "note",
            Kind::Part => "part",
            Kind::Last => "last",
        }
    }

    /// The kind a received message says it is.
    pub fn of(message: &async_nats::Message) -> Option<Kind> {
        let name = message.headers.as_ref()?.get(KIND)?.as_str();
        [Kind::Accepted, Kind::NotOwner, Kind::Beat, Kind::Note, Kind::Part, Kind::Last]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// A header value of a received message.
pub fn header<'a>(message: &'a async_nats::Message, name: &str) -> Option<&'a str> {
    Some(message.headers.as_ref()?.get(name)?.as_str())
}

impl Cluster {
    /// The connection (shared by the log, the leases and the calls).
    pub fn nats(&self) -> async_nats::Client {
        self.js.client()
    }

    /// Where calls for simulations `node` owns are sent.
    pub fn calls_subject(&self, node: &str) -> String {
        format!("{}.call.{node}", self.config.namespace)
    }

    /// Where the cancellation of a call forwarded to `node` is sent (`*` for `call`: every
    /// cancellation for that node, which it subscribes to once).
    pub fn cancel_subject(&self, node: &str, call: &str) -> String {
        format!("{}.cancel.{node}.{call}", self.config.namespace)
    }

    /// The node last seen holding `id`'s lease (a hint: a call sent there on it is refused
    /// with `not-owner` if the lease moved, and the lease is read again).
    pub fn owner_hint(&self, id: &str) -> Option<String> {
        self.hints.lock().unwrap_or_else(|p| p.into_inner()).get(id).cloned()
    }

    /// Remembers (or, with none, forgets) the node holding `id`'s lease.
    pub fn note_owner(&self, id: &str, owner: Option<&str>) {
        let mut owners = self.hints.lock().unwrap_or_else(|p| p.into_inner());
        match owner {
            Some(node) => {
                // A bound, not a cache policy: a node routing to many simulations forgets
                // hints wholesale and reads the leases again.
                if owners.len() >= 100_000 {
                    owners.clear();
                }
                owners.insert(id.to_string(), node.to_string());
            }
            None => {
                owners.remove(id);
            }
        }
    }

    /// Where news of one kind (`moved`, `listed`) reaches every node.
    pub fn news_subject(&self, what: &str) -> String {
        format!("{}.news.{what}", self.config.namespace)
    }

    /// How often a running forwarded call says it still runs.
    pub fn beat_every(&self) -> Duration {
        (self.config.lease / 4).max(Duration::from_millis(250))
    }

    /// After how long without a word a forwarded call's owner is taken for gone: a lease (by
    /// then a dead owner's lease has lapsed, too) and a margin.
    pub fn silence_limit(&self) -> Duration {
        self.config.lease + Duration::from_secs(2)
    }

    /// Runs `f` on the cluster's runtime and awaits it from any runtime (the async twin of
    /// `run`).
    pub async fn spawn<T: Send + 'static>(&self, f: impl std::future::Future<Output = T> + Send + 'static) -> Result<T, String> {
        let rt = self.rt.as_ref().ok_or("the cluster connection is closed")?;
        rt.spawn(f).await.map_err(|e| format!("a cluster task failed: {e}"))
    }

    /// Stores forwarded call `call`'s request (too large for a message) in the object store;
    /// returns the object's name, which the call's message carries instead.
    pub async fn store_request(self: &Arc<Self>, call: &str, bytes: Bytes) -> Result<String, String> {
        let (store, name) = (self.objects.clone(), format!("call/{call}"));
        let stored = name.clone();
        self.spawn(async move {
            let put = super::patiently(|| {
                let mut reader = bytes.as_ref();
                let (store, name) = (&store, &name);
                async move { store.put(name.as_str(), &mut reader).await.map(|_| ()) }
            });
            tokio::time::timeout(REQUEST_WAIT, put).await.map_err(|_| format!("storing {name}: no answer within {REQUEST_WAIT:?}"))?.map_err(|e| format!("storing {name}: {e}"))
        })
        .await??;
        Ok(stored)
    }

    /// A forwarded call's request that was stored (`store_request`).
    pub async fn fetch_request(self: &Arc<Self>, name: &str) -> Result<Vec<u8>, String> {
        let (store, name) = (self.objects.clone(), name.to_string());
        self.spawn(async move {
            use tokio::io::AsyncReadExt;
            let read = super::patiently(|| async {
                let mut object = store.get(&name).await.map_err(|e| format!("reading {name}: {e}"))?;
                let mut bytes = Vec::new();
                object.read_to_end(&mut bytes).await.map_err(|e| format!("reading {name}: {e}"))?;
                Ok::<_, String>(bytes)
            });
            tokio::time::timeout(REQUEST_WAIT, read).await.map_err(|_| format!("reading {name}: no answer within {REQUEST_WAIT:?}"))?
        })
        .await?
    }

    /// Deletes a stored request once its call is answered (or given up).
    pub fn drop_request(self: &Arc<Self>, name: String) {
        let store = self.objects.clone();
        if let Some(rt) = &self.rt {
            rt.spawn(async move {
                let _ = tokio::time::timeout(REQUEST_WAIT, store.delete(&name)).await;
            });
        }
    }

    /// Tells every node a piece of news (`what`, about `payload`), naming this node.
    pub async fn tell(&self, what: &str, payload: String) {
        let mut headers = HeaderMap::new();
        headers.insert(NODE, self.config.node.as_str());
        let subject = self.news_subject(what);
        if let Err(e) = self.nats().publish_with_headers(subject, headers, payload.into()).await {
            tracing::debug!("news not sent: {e}");
        }
    }
}

/// Sends one message of a call's answer.
pub async fn answer(client: &async_nats::Client, inbox: &str, kind: Kind, payload: Bytes) -> Result<(), String> {
    let mut headers = HeaderMap::new();
    headers.insert(KIND, kind.name());
    client
        .publish_with_headers(inbox.to_string(), headers, payload)
        .await
        .map_err(|e| e.to_string())
}

/// Sends a call's answer: parts of at most `PART` bytes, the last marked `Last`.
pub async fn answer_whole(client: &async_nats::Client, inbox: &str, bytes: Vec<u8>) -> Result<(), String> {
    let bytes = Bytes::from(bytes);
    let mut start = 0;
    while bytes.len() - start > PART {
        answer(client, inbox, Kind::Part, bytes.slice(start..start + PART)).await?;
        start += PART;
    }
    answer(client, inbox, Kind::Last, bytes.slice(start..)).await
}
