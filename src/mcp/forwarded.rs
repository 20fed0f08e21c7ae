//! The owner's end of routing (cluster mode, docs/cluster.md "Routing"): calls other nodes
//! forward to this node's subject run here through the same MCP handler a local client's do —
//! one request served on an in-process transport — so a forwarded call is checked, logged,
//! measured and answered exactly like a local one. Its notifications (progress, log lines) and
//! its answer go back to the caller's inbox; heartbeats say it still runs; a cancellation from
//! the caller cancels it. And news from other nodes (a head moved, the list changed) reaches
//! this node's subscribers.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use futures_util::StreamExt;
use rmcp::model::{ClientJsonRpcMessage, ErrorData, JsonRpcError, NumberOrString, ServerJsonRpcMessage};
use rmcp::transport::OneshotTransport;
use rmcp::RoleServer;
use tokio_util::sync::CancellationToken;

use super::{PhysicsServer, Sessions};
use crate::cluster::calls::{self, answer, answer_whole, header, Kind};
use crate::cluster::Cluster;

/// How long a call id is remembered (a caller retries an unanswered call well within this).
const REMEMBER: Duration = Duration::from_secs(600);

/// Starts serving the calls forwarded to this node and hearing the other nodes' news, on the
/// current runtime, for as long as the process runs. `server` is a session of this process's
/// server (its registry, sessions and viewer).
pub fn start(server: PhysicsServer, cluster: Arc<Cluster>) {
    let server = server.for_forwarded_calls();
    let sessions = server.sessions.clone();
    let running = Running::default();
    let (c, r) = (cluster.clone(), running.clone());
    tokio::spawn(async move {
        let me = c.config().node.clone();
        let Some(mut calls) = subscribe(&c, c.calls_subject(&me)).await else { return };
        // Every cancellation for this node on one subscription (`Running::cancel`).
        let Some(mut cancels) = subscribe(&c, c.cancel_subject(&me, "*")).await else { return };
        loop {
            tokio::select! {
                Some(message) = calls.next() => {
                    let (server, cluster, running) = (server.clone(), c.clone(), r.clone());
                    tokio::spawn(async move { serve_one(server, cluster, message, running).await });
                }
                Some(cancel) = cancels.next() => r.cancel(cancel.subject.rsplit('.').next().unwrap_or_default()),
                else => return,
            }
        }
    });
    tokio::spawn(async move {
        let Some(mut news) = subscribe(&cluster, cluster.news_subject("*")).await else { return };
        while let Some(message) = news.next().await {
            hear(&sessions, &cluster, &message);
        }
    });
}

/// Subscribes, retrying while the connection is being made.
async fn subscribe(cluster: &Cluster, subject: String) -> Option<async_nats::Subscriber> {
    let client = cluster.nats();
    match crate::cluster::patiently(|| client.subscribe(subject.clone())).await {
        Ok(s) => Some(s),
        Err(e) => {
            tracing::error!("cannot subscribe to {subject}: {e}; this node will not serve forwarded calls or hear other nodes' news");
            None
        }
    }
}

/// Another node's news, told to this node's subscribers (this node's own news they heard
/// when it happened).
fn hear(sessions: &Sessions, cluster: &Cluster, message: &async_nats::Message) {
    if header(message, calls::NODE) == Some(cluster.config().node.as_str()) {
        return;
    }
    match message.subject.rsplit('.').next() {
        Some("moved") => sessions.subscriptions().head_moved(&String::from_utf8_lossy(&message.payload)),
        Some("listed") => sessions.notify_list_changed(),
        _ => {}
    }
}

/// The forwarded calls this node has taken: each id (remembered for `REMEMBER`, so a retry
/// is not run again) with its cancellation.
#[derive(Clone, Default)]
struct Running(Arc<Mutex<Taken>>);

#[derive(Default)]
struct Taken {
    calls: HashMap<String, CancellationToken>,
    /// The ids in the order taken, to forget them `REMEMBER` later without a scan.
    order: std::collections::VecDeque<(Instant, String)>,
}

impl Running {
    fn taken(&self) -> std::sync::MutexGuard<'_, Taken> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Takes call `id` unless it was taken before; its cancellation token.
    fn take(&self, id: &str) -> Option<CancellationToken> {
        let mut taken = self.taken();
        while taken.order.front().is_some_and(|(at, _)| at.elapsed() >= REMEMBER) {
            if let Some((_, old)) = taken.order.pop_front() {
                taken.calls.remove(&old);
            }
        }
        if taken.calls.contains_key(id) {
            return None;
        }
        let ct = CancellationToken::new();
        taken.calls.insert(id.to_string(), ct.clone());
        taken.order.push_back((Instant::now(), id.to_string()));
        Some(ct)
    }

    /// Forgets call `id` (it was not run: it may be sent again).
    fn drop_call(&self, id: &str) {
        self.taken().calls.remove(id);
    }

    /// The caller's client cancelled call `id`.
    fn cancel(&self, id: &str) {
        if let Some(ct) = self.taken().calls.get(id) {
            ct.cancel();
        }
    }
}

/// Runs one forwarded call (at most once per call id) and answers it.
async fn serve_one(server: PhysicsServer, cluster: Arc<Cluster>, message: async_nats::Message, running: Running) {
    let Some(inbox) = message.reply.as_ref().map(|r| r.to_string()) else { return };
    let (Some(call), Some(sim)) = (header(&message, calls::CALL), header(&message, calls::SIM)) else { return };
    // A retry of a call already taken: its answer goes to the same inbox.
    let Some(ct) = running.take(call) else { return };
    let client = cluster.nats();
    // The lease, re-proved by compare-and-set (a blocking round trip) only if it lapsed here.
    let owns = cluster.held_epoch(sim).is_some() || {
        let (c, id) = (cluster.clone(), sim.to_string());
        tokio::task::spawn_blocking(move || c.owns(&id)).await.unwrap_or(false)
    };
    if !owns {
        running.drop_call(call);
        let _ = answer(&client, &inbox, Kind::NotOwner, bytes::Bytes::new()).await;
        return;
    }
    if answer(&client, &inbox, Kind::Accepted, bytes::Bytes::new()).await.is_err() {
        return;
    }
    let payload = match header(&message, calls::STORED) {
        Some(name) => match cluster.fetch_request(name).await {
            Ok(bytes) => bytes::Bytes::from(bytes),
            Err(e) => {
                let reply = error_reply(ErrorData::internal_error(format!("a forwarded call's request could not be read: {e}"), None));
                let _ = answer_whole(&client, &inbox, serde_json::to_vec(&reply).unwrap_or_default()).await;
                return;
            }
        },
        None => message.payload.clone(),
    };
    let request: ClientJsonRpcMessage = match serde_json::from_slice(&payload) {
        Ok(r) => r,
        Err(e) => {
            let reply = error_reply(ErrorData::invalid_request(format!("a forwarded call could not be read: {e}"), None));
            let _ = answer_whole(&client, &inbox, serde_json::to_vec(&reply).unwrap_or_default()).await;
            return;
        }
    };
    let (transport, mut out) = OneshotTransport::<RoleServer>::new(request);
    let service = rmcp::service::serve_directly_with_ct(server, transport, None, ct.clone());
    tokio::spawn(async move {
        let _ = service.waiting().await;
    });
    let mut beat = tokio::time::interval(cluster.beat_every());
    beat.tick().await;
    let last = loop {
        tokio::select! {
            m = out.recv() => match m {
                Some(m @ (ServerJsonRpcMessage::Response(_) | ServerJsonRpcMessage::Error(_))) => {
                    break Some(m)
                }
                Some(note) => {
                    let _ = answer(&client, &inbox, Kind::Note, serde_json::to_vec(&note).unwrap_or_default().into()).await;
                }
                None => break None,
            },
            _ = beat.tick() => {
                let _ = answer(&client, &inbox, Kind::Beat, bytes::Bytes::new()).await;
            }
        }
    };
    // Cancelled: the caller's client expects no answer, but the caller waits for one.
    let reply = last.unwrap_or_else(|| error_reply(ErrorData::internal_error("the call was cancelled", None)));
    if let Err(e) = answer_whole(&client, &inbox, serde_json::to_vec(&reply).unwrap_or_default()).await {
        tracing::warn!("the answer to a forwarded call for simulation {sim} was not sent: {e}");
    }
}

/// A JSON-RPC error answer.
fn error_reply(error: ErrorData) -> ServerJsonRpcMessage {
    ServerJsonRpcMessage::Error(JsonRpcError { jsonrpc: Default::default(), id: Some(NumberOrString::Number(1)), error })
}
