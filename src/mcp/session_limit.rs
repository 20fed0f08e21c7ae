//! `--max-sessions`: a bound on live MCP sessions, so a client that opens sessions in a loop
//! (or 1,000 idle ones) cannot grow the server's memory without end. Sessions live 8 hours
//! idle; at the bound a new `initialize` is answered `503` with one sentence saying what to
//! do, while every existing session and every stateless (2026-07-28) request goes on.

use std::sync::Arc;

use axum::body::{to_bytes, Body};
use axum::extract::{Request, State};
use axum::http::{Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use rmcp::transport::streamable_http_server::session::local::LocalSessionManager;

/// The default bound (SPEC: `--max-sessions 1000`).
pub const DEFAULT_MAX_SESSIONS: usize = 1000;

/// Largest request body read to see whether it is an `initialize` (bigger ones are not).
const PEEK_LIMIT: usize = 64 * 1024;

/// What the middleware needs: the live sessions and the bound.
#[derive(Clone)]
pub struct SessionLimit {
    /// rmcp's session table (its `sessions` map is public).
    pub manager: Arc<LocalSessionManager>,
    /// `--max-sessions`.
    pub max: usize,
}

/// Refuses an `initialize` (a POST without `Mcp-Session-Id` whose method is initialize) when
/// `max` sessions are live; passes everything else through untouched.
pub async fn limit_sessions(State(limit): State<SessionLimit>, req: Request, next: Next) -> Response {
    if req.method() != Method::POST || req.headers().contains_key("mcp-session-id") {
        return next.run(req).await;
    }
    let live = limit.manager.sessions.read().await.len();
    if live < limit.max {
        return next.run(req).await;
    }
    let (parts, body) = req.into_parts();
    let Ok(bytes) = to_bytes(body, PEEK_LIMIT).await else {
        return (StatusCode::PAYLOAD_TOO_LARGE, "The request body is too large for a session's first message").into_response();
    };
    if is_initialize(&bytes) {
        let why = format!(
            "Session limit reached: {live} live MCP sessions (--max-sessions {}); end idle sessions (DELETE /mcp) or restart the server with a higher --max-sessions",
            limit.max
        );
        return (StatusCode::SERVICE_UNAVAILABLE, why).into_response();
    }
    next.run(Request::from_parts(parts, Body::from(bytes))).await
}

/// Whether a JSON-RPC body (a message or a batch) is an `initialize` request.
fn is_initialize(body: &[u8]) -> bool {
    match serde_json::from_slice::<serde_json::Value>(body) {
        Ok(serde_json::Value::Array(msgs)) => msgs.iter().any(|m| m["method"] == "initialize"),
        Ok(m) => m["method"] == "initialize",
        Err(_) => false,
    }
}

#[cfg(test)]
mod tests {
    use super::is_initialize;

    #[test]
    fn only_initialize_is_counted_as_a_new_session() {
        assert!(is_initialize(br#"{"jsonrpc":"2.0","id":1,"method":"initialize","params":{}}"#));
        assert!(is_initialize(br#"[{"jsonrpc":"2.0","id":1,"method":"initialize"}]"#));
        assert!(!is_initialize(br#"{"jsonrpc":"2.0","id":1,"method":"tools/call","params":{}}"#));
        assert!(!is_initialize(b"not json"));
    }
}
