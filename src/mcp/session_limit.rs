//! `--max-sessions`: a bound on live MCP sessions, so a client that opens sessions in a loop
//! (or 1,000 idle ones) cannot grow the server's memory without end. Sessions live 8 hours
//! idle; at the bound a new `initialize` is answered `503` with one sentence saying what to
//! do, while every existing session and every stateless (2026-07-28) request goes on.
//!
//! The bound is kept where sessions are made: [`BoundedSessions`] wraps rmcp's
//! [`LocalSessionManager`] and checks the live count and creates the session under one lock,
//! so requests that arrive together cannot all see room and all get in. Nothing looks at a
//! request before rmcp has parsed it, so a request that creates no session — whatever its
//! size — never meets the bound. [`limit_sessions`] only rewrites rmcp's answer to a refused
//! creation (a `500`) into the `503` a client can act on.

use std::sync::Arc;

use axum::body::{to_bytes, Body, HttpBody};
use axum::extract::Request;
use axum::http::StatusCode;
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

/// How the refusal sentence begins; [`limit_sessions`] finds it in rmcp's error reply.
const REFUSAL_START: &str = "Session limit reached: ";

/// rmcp's error replies are a line of text; a `500` with a longer (or streamed) body is not a
/// refused session and passes untouched.
const ERROR_BODY_LIMIT: u64 = 4096;

/// rmcp's in-memory sessions with at most `max` live at once.
///
/// Every method delegates to the inner [`LocalSessionManager`]; only creating a session
/// (`create_session`, and `restore_session`, which also adds one) first takes `gate` and
/// counts the inner manager's session table. The table, not a counter of our own, is the
/// count: rmcp removes a session from it when the client ends it (DELETE) and when it expires
/// idle, so the bound frees up exactly when a session is gone.
pub struct BoundedSessions {
    inner: LocalSessionManager,
    max: usize,
    /// Held from the count to the insert, so two creations cannot both take the last place.
    gate: tokio::sync::Mutex<()>,
}

impl BoundedSessions {
    /// `inner`'s sessions, at most `max` live at once.
    pub fn new(inner: LocalSessionManager, max: usize) -> Self {
        BoundedSessions { inner, max, gate: tokio::sync::Mutex::new(()) }
    }

    /// Live sessions now.
    pub async fn live(&self) -> usize {
        self.inner.sessions.read().await.len()
    }

    /// `Ok` with the gate held when there is room for one more session.
    async fn room(&self) -> Result<tokio::sync::MutexGuard<'_, ()>, SessionLimitError> {
        let gate = self.gate.lock().await;
        let live = self.live().await;
        if live >= self.max {
            return Err(SessionLimitError::Full { live, max: self.max });
        }
        Ok(gate)
    }
}

/// Why [`BoundedSessions`] failed: the bound, or rmcp's own session error.
#[derive(Debug, thiserror::Error)]
pub enum SessionLimitError {
    /// `max` sessions are live: the sentence a refused client is shown (as the `503` body).
    #[error("Session limit reached: {live} live MCP sessions (--max-sessions {max}); end idle sessions (DELETE /mcp) or restart the server with a higher --max-sessions")]
    Full {
        /// Sessions live when the new one was refused.
        live: usize,
        /// `--max-sessions`.
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
        let _gate = self.room().await?;
        Ok(self.inner.create_session().await?)
    }

    async fn initialize_session(&self, id: &SessionId, message: ClientJsonRpcMessage) -> Result<ServerJsonRpcMessage, Self::Error> {
        Ok(self.inner.initialize_session(id, message).await?)
    }

    async fn has_session(&self, id: &SessionId) -> Result<bool, Self::Error> {
        Ok(self.inner.has_session(id).await?)
    }

    async fn close_session(&self, id: &SessionId) -> Result<(), Self::Error> {
        Ok(self.inner.close_session(id).await?)
    }

    async fn create_stream(
        &self,
        id: &SessionId,
        message: ClientJsonRpcMessage,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        Ok(self.inner.create_stream(id, message).await?)
    }

    async fn accept_message(&self, id: &SessionId, message: ClientJsonRpcMessage) -> Result<(), Self::Error> {
        Ok(self.inner.accept_message(id, message).await?)
    }

    async fn create_standalone_stream(
        &self,
        id: &SessionId,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        Ok(self.inner.create_standalone_stream(id).await?)
    }

    async fn resume(
        &self,
        id: &SessionId,
        last_event_id: String,
    ) -> Result<impl Stream<Item = ServerSseMessage> + Send + Sync + 'static, Self::Error> {
        Ok(self.inner.resume(id, last_event_id).await?)
    }

    /// Only reached with an external session store (this server configures none); counted
    /// like a creation all the same, since it adds a live session.
    async fn restore_session(&self, id: SessionId) -> Result<RestoreOutcome<Self::Transport>, Self::Error> {
        let _gate = self.room().await?;
        Ok(self.inner.restore_session(id).await?)
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
        BoundedSessions::new(LocalSessionManager::default(), max)
    }

    #[test]
    fn the_refusal_is_the_sentence_a_client_is_shown() {
        let e = SessionLimitError::Full { live: 3, max: 3 };
        assert!(e.to_string().starts_with("Session limit reached: 3 live MCP sessions (--max-sessions 3); end idle sessions"));
        assert!(e.to_string().starts_with(REFUSAL_START));
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
