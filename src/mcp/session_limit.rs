//! `--max-sessions` and `--max-sessions-per-client`: bounds on live MCP sessions, so a client
//! that opens sessions in a loop (or 1,000 idle ones) can neither grow the server's memory
//! without end nor lock other clients out. Sessions live 8 hours idle; at a bound, the least
//! recently used *idle* session (no request in flight) is ended to admit the new one — its
//! client gets `404` on its next request and, as MCP clients do, starts a new session — and a
//! new `initialize` is answered `503` with one sentence only when every session in the way has
//! a request in flight. Every existing session and every stateless (2026-07-28) request goes on.
//!
//! Clients are told apart by their bearer token, else by their address
//! ([`tell_clients_apart`], an axum middleware that runs the request inside a task-local
//! naming its client; rmcp creates a session inside the POST's future, so the session manager
//! reads it there). A client at its own cap makes room among its own sessions; the table at
//! `--max-sessions` makes room among everyone's. On loopback with one shared token every
//! client is the same client, and the eviction is what protects new ones.
//!
//! The bounds are kept where sessions are made: [`BoundedSessions`] wraps rmcp's
//! [`LocalSessionManager`] and counts, evicts and creates under one lock, so requests that
//! arrive together cannot all see room and all get in. Nothing looks at a request before rmcp
//! has parsed it, so a request that creates no session — whatever its size — never meets the
//! bound. [`limit_sessions`] only rewrites rmcp's answer to a refused creation (a `500`) into
//! the `503` a client can act on.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};

use axum::body::{to_bytes, Body, HttpBody};
use axum::extract::{ConnectInfo, Request};
use axum::http::{header, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use futures_core::Stream;
use rmcp::model::{ClientJsonRpcMessage, ServerJsonRpcMessage};
use rmcp::transport::streamable_http_server::session::local::{LocalSessionManager, LocalSessionManagerError};
use rmcp::transport::streamable_http_server::session::{
    EventStore, RestoreOutcome, ServerSseMessage, SessionId, SessionManager,
};

/// The default bound (docs/tools.md: `--max-sessions 1000`).
pub const DEFAULT_MAX_SESSIONS: usize = 1000;

/// The default bound per client (docs/tools.md: `--max-sessions-per-client 100`).
pub const DEFAULT_MAX_SESSIONS_PER_CLIENT: usize = 100;

tokio::task_local! {
    /// The client of the request being served (`tell_clients_apart`).
    static CLIENT: Arc<str>;
}

/// Who sent a request: its bearer token's digest (never the token itself), else its address.
fn client_of(req: &Request) -> Arc<str> {
    let bearer = req.headers().get(header::AUTHORIZATION).and_then(|v| v.to_str().ok()).and_then(|v| v.strip_prefix("Bearer "));
    if let Some(token) = bearer {
        return Arc::from(format!("token {}", &blake3::hash(token.as_bytes()).to_hex()[..16]));
    }
    match req.extensions().get::<ConnectInfo<SocketAddr>>() {
        Some(ConnectInfo(addr)) => Arc::from(format!("address {}", addr.ip())),
        None => Arc::from("unknown"),
    }
}

/// Runs the request inside a task-local naming its client (bearer token, else address), which
/// [`BoundedSessions`] reads when rmcp creates a session for it.
pub async fn tell_clients_apart(req: Request, next: Next) -> Response {
    let client = client_of(&req);
    CLIENT.scope(client, next.run(req)).await
}

/// The client of the request being served, if it was told apart.
fn current_client() -> Arc<str> {
    CLIENT.try_with(Arc::clone).unwrap_or_else(|_| Arc::from("unknown"))
}

/// What a live session did lately.
struct Activity {
    /// Its client (`tell_clients_apart`).
    client: Arc<str>,
    /// When it was last used (a tick of `BoundedSessions::clock`, not wall time).
    used: u64,
    /// Requests in flight (its `initialize` counts until it is answered).
    in_flight: usize,
}

/// The activity of every live session, shared with the request streams that report back.
#[derive(Clone, Default)]
struct Activities {
    table: Arc<Mutex<HashMap<SessionId, Activity>>>,
    clock: Arc<AtomicU64>,
}

impl Activities {
    fn table(&self) -> std::sync::MutexGuard<'_, HashMap<SessionId, Activity>> {
        self.table.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Session `id` was used now; `delta` requests more (or fewer) are in flight.
    fn used(&self, id: &SessionId, delta: isize) {
        let tick = self.clock.fetch_add(1, Ordering::Relaxed);
        if let Some(a) = self.table().get_mut(id) {
            a.used = tick;
            a.in_flight = a.in_flight.saturating_add_signed(delta);
        }
    }

    /// The least recently used idle session, of `client` only when given.
    fn idlest(&self, client: Option<&str>) -> Option<SessionId> {
        self.table()
            .iter()
            .filter(|(_, a)| a.in_flight == 0 && client.is_none_or(|c| *a.client == *c))
            .min_by_key(|(_, a)| a.used)
            .map(|(id, _)| id.clone())
    }

    /// Live sessions of `client`.
    fn of(&self, client: &str) -> usize {
        self.table().values().filter(|a| *a.client == *client).count()
    }
}

/// A request's answer stream that reports, when it ends (answered, or dropped because the
/// client went away), that its session has one request fewer in flight.
struct InFlight<S> {
    inner: Pin<Box<S>>,
    session: SessionId,
    activities: Activities,
}

impl<S: Stream> Stream for InFlight<S> {
    type Item = S::Item;
    fn poll_next(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<S::Item>> {
        self.inner.as_mut().poll_next(cx)
    }
}

impl<S> Drop for InFlight<S> {
    fn drop(&mut self) {
        self.activities.used(&self.session, -1);
    }
}

/// How the refusal sentence begins; [`limit_sessions`] finds it in rmcp's error reply.
const REFUSAL_START: &str = "Session limit reached: ";

/// rmcp's error replies are a line of text; a `500` with a longer (or streamed) body is not a
/// refused session and passes untouched.
const ERROR_BODY_LIMIT: u64 = 4096;

/// rmcp's in-memory sessions with at most `max` live at once and `per_client` of one client.
///
/// Every method delegates to the inner [`LocalSessionManager`]; creating a session
/// (`create_session`, and `restore_session`, which also adds one) first takes `gate`, counts,
/// and ends the least recently used idle session in the way. The inner table, not a counter of
/// our own, is the total: rmcp removes a session from it when the client ends it (DELETE) and
/// when it expires idle, so the bound frees up exactly when a session is gone. Requests are
/// followed as they come and go (`create_stream` and the stream it returns) to know which
/// sessions are idle and which was used least recently.
pub struct BoundedSessions {
    inner: LocalSessionManager,
    max: usize,
    per_client: usize,
    /// Held from the count to the insert, so two creations cannot both take the last place.
    gate: tokio::sync::Mutex<()>,
    activities: Activities,
}

impl BoundedSessions {
    /// `inner`'s sessions, at most `max` live at once and `per_client` of one client.
    pub fn new(inner: LocalSessionManager, max: usize, per_client: usize) -> Self {
        BoundedSessions { inner, max, per_client, gate: tokio::sync::Mutex::new(()), activities: Activities::default() }
    }

    /// Live sessions now.
    pub async fn live(&self) -> usize {
        self.inner.sessions.read().await.len()
    }

    /// `Ok` with the gate held once there is room for one more session of `client`: when the
    /// client is at its cap, its least recently used idle session is ended; when the table is
    /// full, everyone's. Refused only when every session in the way has a request in flight.
    async fn room(&self, client: &str) -> Result<tokio::sync::MutexGuard<'_, ()>, SessionLimitError> {
        let gate = self.gate.lock().await;
        if self.activities.of(client) >= self.per_client {
            let Some(idle) = self.activities.idlest(Some(client)) else {
                return Err(SessionLimitError::ClientFull { max: self.per_client });
            };
            self.evict(&idle).await;
        }
        let live = self.live().await;
        if live >= self.max {
            let Some(idle) = self.activities.idlest(None) else {
                return Err(SessionLimitError::Full { live, max: self.max });
            };
            self.evict(&idle).await;
        }
        Ok(gate)
    }

    /// Ends idle session `id` to make room (its client re-initializes on the `404` it gets next).
    async fn evict(&self, id: &SessionId) {
        tracing::info!(session = %id, "ending the least recently used idle session to admit a new one");
        let _ = self.close_session(id).await;
    }

    /// A session just made for `client`, busy until its `initialize` is answered.
    fn made(&self, id: &SessionId, client: Arc<str>) {
        let used = self.activities.clock.fetch_add(1, Ordering::Relaxed);
        self.activities.table().insert(id.clone(), Activity { client, used, in_flight: 1 });
    }
}

/// Why [`BoundedSessions`] failed: the bound, or rmcp's own session error.
#[derive(Debug, thiserror::Error)]
pub enum SessionLimitError {
    /// `max` sessions are live, each with a request in flight: the sentence a refused client
    /// is shown (as the `503` body).
    #[error("Session limit reached: {live} live MCP sessions (--max-sessions {max}), each with a request in flight; retry once one is answered, or restart the server with a higher --max-sessions")]
    Full {
        /// Sessions live when the new one was refused.
        live: usize,
        /// `--max-sessions`.
        max: usize,
    },
    /// This client has `max` sessions, each with a request in flight.
    #[error("Session limit reached: this client (by its token, else its address) has {max} live MCP sessions (--max-sessions-per-client {max}), each with a request in flight; end one (DELETE /mcp) or retry once one is answered")]
    ClientFull {
        /// `--max-sessions-per-client`.
        max: usize,
    },
    /// rmcp's session manager failed (shown as rmcp shows it).
    #[error(transparent)]
    Session(#[from] LocalSessionManagerError),
}

impl SessionManager for BoundedSessions {
    type Error = SessionLimitError;
    type Transport = <LocalSessionManager as SessionManager>::Transport;

    async fn create_session(&self) -> Result<(SessionId, Self::Transport), Self::Error> {
        let client = current_client();
        let _gate = self.room(&client).await?;
        let (id, transport) = self.inner.create_session().await?;
        self.made(&id, client);
        Ok((id, transport))
    }

    async fn initialize_session(&self, id: &SessionId, message: ClientJsonRpcMessage) -> Result<ServerJsonRpcMessage, Self::Error> {
        let answered = self.inner.initialize_session(id, message).await;
        self.activities.used(id, -1);
        Ok(answered?)
    }

    async fn has_session(&self, id: &SessionId) -> Result<bool, Self::Error> {
        Ok(self.inner.has_session(id).await?)
    }

    async fn close_session(&self, id: &SessionId) -> Result<(), Self::Error> {
        self.activities.table().remove(id);
        Ok(self.inner.close_session(id).await?)
    }

    /// A request: in flight until its answer stream ends or is dropped.
    async fn create_stream(
        &self,
        id: &SessionId,
        message: ClientJsonRpcMessage,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        self.activities.used(id, 1);
        let stream = match self.inner.create_stream(id, message).await {
            Ok(s) => s,
            Err(e) => {
                self.activities.used(id, -1);
                return Err(e.into());
            }
        };
        Ok(InFlight { inner: Box::pin(stream), session: id.clone(), activities: self.activities.clone() })
    }

    async fn accept_message(&self, id: &SessionId, message: ClientJsonRpcMessage) -> Result<(), Self::Error> {
        self.activities.used(id, 0);
        Ok(self.inner.accept_message(id, message).await?)
    }

    async fn create_standalone_stream(
        &self,
        id: &SessionId,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        self.activities.used(id, 0);
        Ok(self.inner.create_standalone_stream(id).await?)
    }

    async fn resume(
        &self,
        id: &SessionId,
        last_event_id: String,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        self.activities.used(id, 0);
        Ok(self.inner.resume(id, last_event_id).await?)
    }

    /// Only reached with an external session store (this server configures none); counted
    /// like a creation all the same, since it adds a live session.
    async fn restore_session(&self, id: SessionId) -> Result<RestoreOutcome<Self::Transport>, Self::Error> {
        let client = current_client();
        let _gate = self.room(&client).await?;
        let restored = self.inner.restore_session(id.clone()).await?;
        self.made(&id, client);
        self.activities.used(&id, -1);
        Ok(restored)
    }

    fn event_store(&self) -> Option<Arc<dyn EventStore>> {
        self.inner.event_store()
    }
}

/// Turns rmcp's answer to a creation [`BoundedSessions`] refused — `500 Encounter an error
/// when create session: Session limit reached: …` — into `503 Service Unavailable` with the
/// sentence alone, which tells a client to wait or end a session rather than that the server
/// broke. It never reads a request; every other response passes untouched.
pub async fn limit_sessions(req: Request, next: Next) -> Response {
    let response = next.run(req).await;
    if response.status() != StatusCode::INTERNAL_SERVER_ERROR
        || response.body().size_hint().exact().is_none_or(|n| n > ERROR_BODY_LIMIT)
    {
        return response;
    }
    let (parts, body) = response.into_parts();
    let Ok(bytes) = to_bytes(body, ERROR_BODY_LIMIT as usize).await else {
        return Response::from_parts(parts, Body::empty());
    };
    match std::str::from_utf8(&bytes).ok().and_then(|text| text.find(REFUSAL_START).map(|at| &text[at..])) {
        Some(why) => (StatusCode::SERVICE_UNAVAILABLE, why.to_string()).into_response(),
        None => Response::from_parts(parts, Body::from(bytes)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounded(max: usize) -> BoundedSessions {
        BoundedSessions::new(LocalSessionManager::default(), max, usize::MAX)
    }

    #[test]
    fn the_refusal_is_the_sentence_a_client_is_shown() {
        let e = SessionLimitError::Full { live: 3, max: 3 };
        assert!(e.to_string().starts_with("Session limit reached: 3 live MCP sessions (--max-sessions 3), each with a request in flight;"));
        assert!(e.to_string().starts_with(REFUSAL_START));
        assert!(SessionLimitError::ClientFull { max: 2 }.to_string().starts_with(REFUSAL_START));
    }

    /// Makes session `id` idle, as when its `initialize` has been answered.
    fn initialized(sessions: &BoundedSessions, id: &SessionId) {
        sessions.activities.used(id, -1);
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn at_the_bound_the_least_recently_used_idle_session_makes_room() {
        let sessions = bounded(2);
        let (a, _ta) = sessions.create_session().await.unwrap();
        let (b, _tb) = sessions.create_session().await.unwrap();
        // Both busy initializing: nothing can be ended.
        assert!(matches!(sessions.create_session().await, Err(SessionLimitError::Full { live: 2, max: 2 })));
        initialized(&sessions, &a);
        initialized(&sessions, &b);
        // a is used again (a request came and went): b is now the least recently used.
        sessions.activities.used(&a, 1);
        sessions.activities.used(&a, -1);
        let (c, _tc) = sessions.create_session().await.expect("b is ended to admit c");
        assert!(sessions.has_session(&a).await.unwrap() && sessions.has_session(&c).await.unwrap());
        assert!(!sessions.has_session(&b).await.unwrap());
        // a has a request in flight and c is still initializing: nothing idle, refused.
        sessions.activities.used(&a, 1);
        assert!(matches!(sessions.create_session().await, Err(SessionLimitError::Full { live: 2, max: 2 })));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_client_at_its_cap_makes_room_among_its_own_sessions() {
        let sessions = BoundedSessions::new(LocalSessionManager::default(), 10, 2);
        let as_client = |c: &'static str| CLIENT.scope(Arc::from(c), sessions.create_session());
        let (other, _t0) = as_client("address 10.0.0.2").await.unwrap();
        initialized(&sessions, &other);
        let (first, _t1) = as_client("address 10.0.0.1").await.unwrap();
        let (second, _t2) = as_client("address 10.0.0.1").await.unwrap();
        assert!(matches!(as_client("address 10.0.0.1").await, Err(SessionLimitError::ClientFull { max: 2 })));
        initialized(&sessions, &first);
        initialized(&sessions, &second);
        let (_third, _t3) = as_client("address 10.0.0.1").await.expect("its own idle session makes room");
        // Its own least recently used went; the other client's older idle session stayed.
        assert!(!sessions.has_session(&first).await.unwrap());
        assert!(sessions.has_session(&second).await.unwrap() && sessions.has_session(&other).await.unwrap());
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn concurrent_creations_stop_at_the_bound_and_an_ended_session_makes_room() {
        let sessions = Arc::new(bounded(2));
        let mut tries = tokio::task::JoinSet::new();
        for _ in 0..10 {
            let sessions = sessions.clone();
            tries.spawn(async move { sessions.create_session().await });
        }
        let (mut made, mut refused, mut transports) = (Vec::new(), 0, Vec::new());
        while let Some(outcome) = tries.join_next().await {
            match outcome.unwrap() {
                Ok((id, transport)) => {
                    made.push(id);
                    transports.push(transport);
                }
                Err(SessionLimitError::Full { live: 2, max: 2 }) => refused += 1,
                Err(e) => panic!("{e}"),
            }
        }
        assert_eq!((made.len(), refused), (2, 8));
        assert_eq!(sessions.live().await, 2);
        sessions.close_session(&made[0]).await.unwrap();
        assert_eq!(sessions.live().await, 1);
        let _third = sessions.create_session().await.expect("room after a session ended");
        assert!(matches!(sessions.create_session().await, Err(SessionLimitError::Full { live: 2, max: 2 })));
    }
}
