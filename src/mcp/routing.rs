//! Any node answers any call (cluster mode, docs/cluster.md "Routing"): a call naming a
//! simulation another live node owns is forwarded to that node over NATS and its answer passed
//! back — progress and log lines on the way, the client's cancellation the other way. A
//! simulation without a live owner is served here (taken over). Embedded, nothing changes.
//!
//! A forwarded call costs one NATS round trip, not a refold: the owner runs it exactly as if
//! its client had sent it there (`forwarded`). Retries are safe: every attempt of one call
//! carries one call id, which the owner runs at most once, and a node that lost the lease
//! runs nothing (its appends are fenced besides).

use std::sync::Arc;
use std::time::{Duration, Instant};

use async_nats::HeaderMap;
use futures_util::StreamExt;
use rmcp::handler::server::tool::ToolCallContext;
use rmcp::model::{CallToolRequestParams, CallToolResponse, CallToolResult, ContentBlock, ErrorData, ServerJsonRpcMessage, ServerNotification};
use rmcp::service::RequestContext;
use rmcp::{Peer, RoleServer};
use serde_json::Value;
use tokio_util::sync::CancellationToken;

use super::PhysicsServer;
use crate::cluster::calls::{self, Kind};
use crate::cluster::Cluster;

/// How long a call waits for an owner to take it before asking again (the owner may be
/// paused, or gone without NATS having noticed yet).
const ACCEPT_WITHIN: Duration = Duration::from_secs(2);
/// The pause between two attempts while an owner cannot be reached and its lease lives.
const RETRY_PAUSE: Duration = Duration::from_millis(100);

/// What became of a call sent to another node.
pub(super) enum Routed {
    /// Run here: this node owns the simulation, nobody does (it is taken over here), or this
    /// is not a cluster.
    Here,
    /// The owner's answer: a JSON-RPC result, or its error.
    Answered(Result<Value, ErrorData>),
    /// The owner took the call and then went silent: its outcome is unknown (the sentence).
    Lost(String),
}

/// A call on its way: what to send and to whom the notes go.
pub(super) struct Outgoing<'a> {
    /// The simulation the call is for.
    pub sim: &'a str,
    /// The JSON-RPC method and its params (with `_meta`, so a progress token travels).
    pub method: &'static str,
    pub params: Value,
    /// The caller's client, for progress and log notes (none: a resource read).
    pub peer: Option<Peer<RoleServer>>,
    /// The caller's cancellation.
    pub ct: CancellationToken,
}

impl PhysicsServer {
    /// Whether this server may send calls elsewhere: a cluster node's, serving its own clients
    /// (a call another node forwarded here runs here).
    pub(super) fn routes(&self) -> bool {
        self.reg.in_cluster() && !self.forwarded
    }

    /// Where a call for `out.sim` runs: here, or at its owner (its answer). The owner's notes
    /// reach the client in the order sent, all before the answer.
    pub(super) async fn route(&self, out: Outgoing<'_>) -> Routed {
        let Some(cluster) = self.reg.cluster().cloned().filter(|_| self.routes()) else { return Routed::Here };
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Vec<u8>>();
        let relay = out.peer.clone().map(|peer| {
            let log = self.log.clone();
            tokio::spawn(async move {
                while let Some(note) = rx.recv().await {
                    relay_note(&log, &note, &peer).await;
                }
            })
        });
        let routed = self.route_via(&cluster, out, &|note: &[u8]| {
            let _ = tx.send(note.to_vec());
        })
        .await;
        drop(tx);
        if let Some(relay) = relay {
            let _ = relay.await;
        }
        routed
    }

    /// `route` on a cluster node, handing the owner's notes to `notes`.
    async fn route_via(&self, cluster: &Arc<Cluster>, out: Outgoing<'_>, notes: &(dyn Fn(&[u8]) + Sync)) -> Routed {
        // An id that cannot name a simulation names none: the call here says so at once.
        if !crate::cluster::valid_id(out.sim) {
            return Routed::Here;
        }
        let cluster = cluster.clone();
        let call = uuid::Uuid::new_v4().to_string();
        let request = serde_json::json!({"jsonrpc": "2.0", "id": 1, "method": out.method, "params": out.params});
        let payload: bytes::Bytes = serde_json::to_vec(&request).unwrap_or_default().into();
        // A request too large for a message travels through the object store (stored once,
        // at the first attempt that goes to another node; deleted when the call is over).
        let mut stored = StoredRequest { cluster: cluster.clone(), name: None };
        let give_up = Instant::now() + cluster.config().lease + Duration::from_secs(5);
        let mut line: Option<Line> = None;
        // The owner last seen is tried first (no lease read); once it refuses, the lease.
        let mut hint = cluster.owner_hint(out.sim);
        loop {
            if self.reg.get_local(out.sim).is_some() && cluster.held_epoch(out.sim).is_some() {
                return Routed::Here;
            }
            let hinted = hint.is_some();
            let owner = match hint.take() {
                Some(owner) => owner,
                None => match cluster.lease_holder(out.sim).await {
                    Ok(Some(owner)) if owner != cluster.config().node => {
                        cluster.note_owner(out.sim, Some(&owner));
                        owner
                    }
                    // Nobody holds it (taken over here), this node does, or the cluster cannot
                    // say (the call here will say so).
                    _ => {
                        cluster.note_owner(out.sim, None);
                        return Routed::Here;
                    }
                },
            };
            // One inbox for every attempt of this call at one owner: a late answer to an
            // earlier attempt is still heard.
            if line.as_ref().is_none_or(|l| l.owner != owner) {
                match Line::open(&cluster, &owner, &call).await {
                    Ok(l) => line = Some(l),
                    Err(_) => return Routed::Here,
                }
            }
            if payload.len() > calls::REQUEST_INLINE_MAX && stored.name.is_none() {
                match cluster.store_request(&call, payload.clone()).await {
                    Ok(name) => stored.name = Some(name),
                    Err(why) => return Routed::Lost(format!("Simulation {}'s owner, node {owner}, was not sent the call ({why}); nothing was done", out.sim)),
                }
            }
            let l = line.as_mut().expect("opened above");
            let body = match &stored.name {
                Some(name) => Body::Stored(name),
                None => Body::Inline(payload.clone()),
            };
            match l.send(&cluster, (out.sim, body), &out.ct, notes).await {
                Attempt::Done(routed) => return routed,
                Attempt::Unserved => cluster.note_owner(out.sim, None),
            }
            // A stale hint costs one refusal; a live lease whose holder does not answer, a pause.
            if !hinted {
                if Instant::now() >= give_up {
                    // The owner's lease outlived the wait: the call here refuses, naming it.
                    return Routed::Here;
                }
                tokio::time::sleep(RETRY_PAUSE).await;
            }
        }
    }
}

impl PhysicsServer {
    /// A tool call for simulation `id` on a cluster node: forwarded to its owner, or run here.
    /// Run here and refused because a lease still shows (the instant a dead owner's lease
    /// lapses, the replicas expire it one by one), it is routed again until the wait ends —
    /// nothing was recorded of it. Refused, here or by the node it was forwarded to, because
    /// that node's lease ended while the call waited for the simulation (`sim::cluster::MOVED`:
    /// nothing was done either), it is routed again to the owner now, a few times.
    pub(super) async fn routed_call(&self, id: &str, request: CallToolRequestParams, cx: RequestContext<RoleServer>) -> Result<CallToolResponse, ErrorData> {
        let wait = self.reg.cluster().map_or(Duration::ZERO, |c| c.config().lease) + Duration::from_secs(5);
        let mut give_up = Instant::now() + wait;
        let mut moves = 0;
        loop {
            let out = Outgoing { sim: id, method: "tools/call", params: call_params(&request, &cx), peer: Some(cx.peer.clone()), ct: cx.ct.clone() };
            let answer = match self.route(out).await {
                Routed::Here => {
                    let answer = self.tool_router.call(ToolCallContext::new(self, request.clone(), cx.clone())).await?;
                    if refused_with(&answer, crate::sim::cluster::OWNED_BY) && Instant::now() < give_up {
                        tokio::time::sleep(RETRY_PAUSE).await;
                        continue;
                    }
                    answer
                }
                Routed::Answered(answer) => {
                    let result = serde_json::from_value::<CallToolResult>(answer?)
                        .map_err(|e| ErrorData::internal_error(format!("Internal error: the owner's answer could not be read: {e}"), None))?;
                    CallToolResponse::Complete(result)
                }
                Routed::Lost(why) => return Ok(CallToolResponse::Complete(CallToolResult::error(vec![ContentBlock::text(why)]))),
            };
            if refused_with(&answer, crate::sim::cluster::MOVED) && moves < MOVES && !cx.ct.is_cancelled() {
                moves += 1;
                give_up = Instant::now() + wait;
                tokio::time::sleep(RETRY_PAUSE).await;
                continue;
            }
            return Ok(answer);
        }
    }
}

/// How many times a call refused because its node's lease ended while it waited is sent again.
const MOVES: usize = 5;

/// Whether a call was refused with a sentence holding `words`.
fn refused_with(answer: &CallToolResponse, words: &str) -> bool {
    let CallToolResponse::Complete(r) = answer else { return false };
    r.is_error == Some(true) && r.content.iter().filter_map(|c| c.as_text()).any(|t| t.text.contains(words))
}

/// What a call's message carries: the request, or the name of the object holding it.
enum Body<'a> {
    Inline(bytes::Bytes),
    Stored(&'a str),
}

/// A request stored for a call (`Cluster::store_request`), deleted when the call is over.
struct StoredRequest {
    cluster: Arc<Cluster>,
    name: Option<String>,
}

impl Drop for StoredRequest {
    fn drop(&mut self) {
        if let Some(name) = self.name.take() {
            self.cluster.drop_request(name);
        }
    }
}

/// A tool call's params as forwarded: as the client sent them, with the request's `_meta`
/// (so a progress token reaches the owner's progress reports).
fn call_params(request: &CallToolRequestParams, cx: &RequestContext<RoleServer>) -> Value {
    let mut params = serde_json::to_value(request).unwrap_or_default();
    if let (Some(p), Ok(meta)) = (params.as_object_mut(), serde_json::to_value(&cx.meta)) {
        if meta.as_object().is_some_and(|m| !m.is_empty()) {
            p.insert("_meta".into(), meta);
        }
    }
    params
}

/// Sends a note from the owner on to a forwarded call's client: progress as it came, a log
/// line through the client's session level.
async fn relay_note(log: &super::logging::SessionLog, note: &[u8], peer: &Peer<RoleServer>) {
    let Ok(ServerJsonRpcMessage::Notification(n)) = serde_json::from_slice::<ServerJsonRpcMessage>(note) else { return };
    match n.notification {
        ServerNotification::ProgressNotification(p) => {
            let _ = peer.notify_progress(p.params).await;
        }
        #[allow(deprecated)]
        ServerNotification::LoggingMessageNotification(m) => log.send(peer, m.params.level, m.params.data),
        _ => {}
    }
}

/// What one attempt came to.
enum Attempt {
    Done(Routed),
    /// Nobody took the call (no such node, not the owner, no answer in time): ask again.
    Unserved,
}

/// The caller's end of a call to one owner: its inbox subscription.
struct Line {
    owner: String,
    call: String,
    inbox: String,
    replies: async_nats::Subscriber,
    client: async_nats::Client,
    /// Published to when the client cancels (also when this call is dropped unanswered).
    cancel: String,
}

impl Line {
    async fn open(cluster: &Arc<Cluster>, owner: &str, call: &str) -> Result<Line, String> {
        let client = cluster.nats();
        let inbox = client.new_inbox();
        let replies = client.subscribe(inbox.clone()).await.map_err(|e| e.to_string())?;
        Ok(Line { owner: owner.to_string(), call: call.to_string(), inbox, replies, client, cancel: cluster.cancel_subject(owner, call) })
    }

    /// Sends the call once and follows its answer.
    async fn send(&mut self, cluster: &Cluster, (sim, body): (&str, Body<'_>), ct: &CancellationToken, notes: &(dyn Fn(&[u8]) + Sync)) -> Attempt {
        let mut headers = HeaderMap::new();
        headers.insert(calls::CALL, self.call.as_str());
        headers.insert(calls::SIM, sim);
        let payload = match body {
            Body::Inline(payload) => payload,
            Body::Stored(name) => {
                headers.insert(calls::STORED, name);
                bytes::Bytes::new()
            }
        };
        let sent = self
            .client
            .publish_with_reply_and_headers(cluster.calls_subject(&self.owner), self.inbox.clone(), headers, payload)
            .await;
        if sent.is_err() {
            return Attempt::Unserved;
        }
        let mut guard = CancelOnDrop { client: self.client.clone(), subject: self.cancel.clone(), armed: false };
        let mut accepted = false;
        let mut cancelled = false;
        let mut answer = Vec::new();
        loop {
            let wait = if accepted { cluster.silence_limit() } else { ACCEPT_WITHIN };
            let next = tokio::select! {
                m = tokio::time::timeout(wait, self.replies.next()) => m,
                _ = ct.cancelled(), if !cancelled => {
                    cancelled = true;
                    guard.fire().await;
                    continue;
                }
            };
            let message = match next {
                Ok(Some(m)) => m,
                Ok(None) | Err(_) if !accepted => return Attempt::Unserved,
                Ok(None) | Err(_) => {
                    guard.armed = false;
                    return Attempt::Done(Routed::Lost(format!(
                        "Simulation {sim}'s owner, node {}, stopped answering during this call; whether it was recorded is unknown (get_history tells once the simulation is served again)",
                        self.owner
                    )));
                }
            };
            if message.status == Some(async_nats::StatusCode::NO_RESPONDERS) {
                return Attempt::Unserved;
            }
            match Kind::of(&message) {
                Some(Kind::Accepted) => {
                    accepted = true;
                    guard.armed = true;
                }
                Some(Kind::NotOwner) => return Attempt::Unserved,
                Some(Kind::Beat) if cancelled => guard.fire().await,
                Some(Kind::Beat) | None => {}
                Some(Kind::Note) => notes(&message.payload),
                Some(Kind::Part) => answer.extend_from_slice(&message.payload),
                Some(Kind::Last) => {
                    guard.armed = false;
                    answer.extend_from_slice(&message.payload);
                    return Attempt::Done(Routed::Answered(response_of(&answer)));
                }
            }
        }
    }
}

/// The result (or error) of a JSON-RPC response.
fn response_of(bytes: &[u8]) -> Result<Value, ErrorData> {
    let broken = || ErrorData::internal_error("Internal error: the owner's answer could not be read", None);
    match serde_json::from_slice::<ServerJsonRpcMessage>(bytes).map_err(|_| broken())? {
        ServerJsonRpcMessage::Response(r) => serde_json::to_value(&r.result).map_err(|_| broken()),
        ServerJsonRpcMessage::Error(e) => Err(e.error),
        _ => Err(broken()),
    }
}

/// Tells the owner to stop a call when the client cancels — or when this side stops waiting
/// for an accepted call (the caller's request was dropped).
struct CancelOnDrop {
    client: async_nats::Client,
    subject: String,
    armed: bool,
}

impl CancelOnDrop {
    async fn fire(&self) {
        let _ = self.client.publish(self.subject.clone(), bytes::Bytes::new()).await;
    }
}

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        if self.armed {
            let (client, subject) = (self.client.clone(), self.subject.clone());
            if let Ok(rt) = tokio::runtime::Handle::try_current() {
                rt.spawn(async move {
                    let _ = client.publish(subject, bytes::Bytes::new()).await;
                });
            }
        }
    }
}
