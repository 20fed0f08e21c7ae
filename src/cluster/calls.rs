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

/// The largest piece of an answer in one message (NATS's default payload limit is 1 MiB).
const PART: usize = 512 * 1024;

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
        self.owners.lock().unwrap_or_else(|p| p.into_inner()).get(id).cloned()
    }

    /// Remembers (or, with none, forgets) the node holding `id`'s lease.
    pub fn note_owner(&self, id: &str, owner: Option<&str>) {
        let mut owners = self.owners.lock().unwrap_or_else(|p| p.into_inner());
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

    /// Who holds `id`'s lease now (none: nobody, and the caller may take it). Runs on the
    /// cluster's runtime; awaitable from any.
    pub async fn lease_holder(self: &Arc<Self>, id: &str) -> Result<Option<String>, String> {
        let leases = self.leases.clone();
        let key = id.to_string();
        self.spawn(async move { super::kv_get(&leases, &key).await })
            .await?
            .map(|v| v.map(|b| String::from_utf8_lossy(&b).into_owned()))
    }

    /// Runs `f` on the cluster's runtime and awaits it from any runtime (the async twin of
    /// `run`).
    pub async fn spawn<T: Send + 'static>(&self, f: impl std::future::Future<Output = T> + Send + 'static) -> Result<T, String> {
        let rt = self.rt.as_ref().ok_or("the cluster connection is closed")?;
        rt.spawn(f).await.map_err(|e| format!("a cluster task failed: {e}"))
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
