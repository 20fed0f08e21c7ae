//! Serving the MCP server: streamable HTTP at `/mcp` (axum) and stdio.
//!
//! HTTP binds loopback by default, validates `Host` and `Origin` against DNS rebinding (only
//! loopback unless `--allow-origin` adds more) and, with a token (`--token-file`,
//! `PHYSICS_MCP_TOKEN` or `--token`), requires `Authorization: Bearer <token>` on every
//! request; serving another address without one prints a warning.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{header, Method, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use rmcp::transport::streamable_http_server::session::local::LocalSessionManager;
use rmcp::transport::streamable_http_server::{StreamableHttpServerConfig, StreamableHttpService};
use rmcp::ServiceExt;
use subtle::ConstantTimeEq;
use tokio_util::sync::CancellationToken;

use super::session_limit::{limit_sessions, tell_clients_apart, BoundedSessions};
use super::{PhysicsServer, Sessions};
use crate::sim::Registry;

/// HTTP serving options (from the CLI).
#[derive(Clone, Debug)]
pub struct HttpOptions {
    /// Address to bind (port 0 picks a free one; the chosen address is printed on stderr).
    pub bind: SocketAddr,
    /// Bearer token required on every request, if set.
    pub token: Option<String>,
    /// Extra browser origins allowed besides loopback ones.
    pub allow_origin: Vec<String>,
    /// Live MCP sessions at most (`--max-sessions`); past it a new one ends the least
    /// recently used idle one, and is refused only when none is idle.
    pub max_sessions: usize,
    /// Live MCP sessions of one client (bearer token, else address) at most
    /// (`--max-sessions-per-client`), with the same rule among its own.
    pub max_sessions_per_client: usize,
}

async fn require_token(State(token): State<Option<Arc<str>>>, req: Request, next: Next) -> Response {
    if let Some(token) = token {
        let bearer = req
            .headers()
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "));
        // A browser opening the viewer cannot send a header: the viewer also takes `?token=`.
        let query = req
            .uri()
            .path()
            .starts_with("/viewer/")
            .then(|| query_token(req.uri().query().unwrap_or("")))
            .flatten();
        let ok = bearer
            .into_iter()
            .chain(query.as_deref())
            // Constant time, so a wrong guess does not tell how many bytes were right.
            .any(|given| bool::from(given.as_bytes().ct_eq(token.as_bytes())));
        if !ok {
            return (StatusCode::UNAUTHORIZED, "missing or wrong bearer token (--token)\n")
                .into_response();
        }
    }
    next.run(req).await
}

/// The `token` query parameter, percent-decoded.
fn query_token(query: &str) -> Option<String> {
    form_urlencoded::parse(query.as_bytes()).find(|(k, _)| k == "token").map(|(_, v)| v.into_owned())
}

/// The viewer's DNS-rebinding guard (rmcp checks `/mcp` itself): a page from another site that
/// resolves its name to this machine arrives with its own `Host`, which is refused here.
async fn require_known_host(State(hosts): State<Arc<Vec<String>>>, req: Request, next: Next) -> Response {
    let host = req.headers().get(header::HOST).and_then(|v| v.to_str().ok()).unwrap_or("");
    let name = match host.strip_prefix('[') {
        Some(v6) => v6.split(']').next().unwrap_or(""),
        None => host.rsplit_once(':').map_or(host, |(name, _)| name),
    };
    if !hosts.iter().any(|h| h == name) {
        return (StatusCode::FORBIDDEN, "the viewer answers only to this server's own host names\n").into_response();
    }
    next.run(req).await
}

/// Answers a successful `DELETE /mcp` (the client ending its session) with 204 No Content
/// instead of rmcp's 202 Accepted: the Python `mcp` SDK expects 200 or 204 there and logs
/// `Session termination failed: 202` at every session end otherwise. Errors pass unchanged.
async fn session_end_no_content(req: Request, next: Next) -> Response {
    let delete = req.method() == Method::DELETE;
    let mut response = next.run(req).await;
    if delete && response.status() == StatusCode::ACCEPTED {
        *response.status_mut() = StatusCode::NO_CONTENT;
    }
    response
}

/// SIGINT or SIGTERM, listened for from this call on, not from the first poll: serving calls
/// it before announcing its address, so a signal sent the moment a client sees the address
/// ends the server cleanly instead of killing it by the signal's default action (seen: the
/// cluster ledger test's SIGTERM right after a restart).
fn signalled() -> impl std::future::Future<Output = ()> {
    #[cfg(unix)]
    let handlers = {
        use tokio::signal::unix::{signal, SignalKind};
        (signal(SignalKind::terminate()).ok(), signal(SignalKind::interrupt()).ok())
    };
    async move {
        #[cfg(unix)]
        if let (Some(mut term), Some(mut int)) = handlers {
            tokio::select! {
                _ = term.recv() => {},
                _ = int.recv() => {},
            }
            return;
        }
        let _ = tokio::signal::ctrl_c().await;
    }
}

/// After a signal: running work is told to stop (`shutdown::begin`) and the sessions are
/// cancelled.
async fn shutdown_signal(signal: impl std::future::Future<Output = ()>, ct: CancellationToken) {
    signal.await;
    crate::shutdown::begin();
    ct.cancel();
}

/// The end of every serving mode: buffered events flushed, within `shutdown::DEADLINE` of
/// the moment shutdown began (`Registry::flush_all_until` says what a busy simulation keeps).
async fn finish(reg: Arc<Registry>) {
    crate::shutdown::begin();
    let deadline = crate::shutdown::began() + crate::shutdown::DEADLINE - std::time::Duration::from_millis(500);
    let busy = tokio::task::spawn_blocking(move || {
        let busy = reg.flush_all_until(deadline);
        // Cluster mode: the flushed simulations can be taken over at once, not a lease later.
        reg.leave_cluster();
        busy
    })
    .await
    .unwrap_or(0);
    if busy > 0 {
        tracing::warn!("{busy} simulation(s) were still busy at shutdown; their calls commit their own events");
    }
}

/// SSE priming events (an empty event with an id and a `retry:` field at the start of every
/// stream) are off: they exist so a client can resume a cut stream from an event store, which
/// this server does not keep (sessions live in memory), and they cost every reply an event.
/// README "Connecting a client" has the measurement; `PHYSICS_MCP_SSE_RETRY_MS=<ms>` turns
/// them on (for repeating that measurement and for clients that insist).
fn sse_retry() -> Option<std::time::Duration> {
    std::env::var("PHYSICS_MCP_SSE_RETRY_MS")
        .ok()
        .and_then(|ms| ms.trim().parse::<u64>().ok())
        .map(std::time::Duration::from_millis)
}

/// MCP sessions (in memory), at most `max` live: priming events as `sse_retry` says, and an
/// idle session lives for `SESSION_IDLE` instead of rmcp's 5 minutes — an agent often thinks
/// longer than that between calls, and an expired session makes its client start over.
fn session_manager(max: usize, per_client: usize) -> Arc<BoundedSessions> {
    let mut manager = LocalSessionManager::default();
    manager.session_config.sse_retry = sse_retry();
    manager.session_config.keep_alive = Some(SESSION_IDLE);
    Arc::new(BoundedSessions::new(manager, max, per_client.max(1)))
}

/// The HTTP request-body cap: rmcp's 4 MiB, or more when `--max-write-bytes` needs it — a
/// write_file of that many bytes, sent as base64 (4 bytes for every 3), with 64 KiB for the
/// request around it — so the flag, not the transport, says how large a file may be.
fn request_body_cap(max_write_bytes: usize) -> usize {
    const RMCP_DEFAULT: usize = 4 << 20;
    RMCP_DEFAULT.max(max_write_bytes.div_ceil(3).saturating_mul(4).saturating_add(64 << 10))
}

/// How long an idle MCP session is kept.
const SESSION_IDLE: std::time::Duration = std::time::Duration::from_secs(8 * 3600);

/// Serves MCP over streamable HTTP until SIGINT/SIGTERM, then commits buffered events.
pub async fn serve_http(reg: Arc<Registry>, opts: HttpOptions) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(opts.bind).await?;
    let local = listener.local_addr()?;
    if opts.token.is_none() && !local.ip().is_loopback() {
        warn_without_token(local);
    }
    // A reply is several small writes (headers, SSE events, the final chunk): without
    // TCP_NODELAY, Nagle's algorithm can hold them back for a delayed ACK (~40 ms per call,
    // seen with Python's http.client).
    let listener = axum::serve::ListenerExt::tap_io(listener, |tcp: &mut tokio::net::TcpStream| {
        let _ = tcp.set_nodelay(true);
    });
    let mut hosts: Vec<String> = vec!["localhost".into(), "127.0.0.1".into(), "::1".into()];
    if !local.ip().is_loopback() {
        hosts.push(local.ip().to_string());
    }
    let mut origins: Vec<String> = vec![
        "http://localhost:*".into(),
        "http://127.0.0.1:*".into(),
        "http://[::1]:*".into(),
    ];
    origins.extend(opts.allow_origin.iter().cloned());
    let hosts_for_viewer = hosts.clone();
    let ct = CancellationToken::new();
    // SSE priming events: off unless asked for (see `sse_retry`).
    let config = StreamableHttpServerConfig::default()
        .with_max_request_body_bytes(request_body_cap(reg.limits().max_write_bytes))
        .with_sse_retry(sse_retry())
        .with_allowed_hosts(hosts)
        .with_allowed_origins(origins)
        .with_cancellation_token(ct.child_token());
    let server_reg = reg.clone();
    let sessions = Sessions::of(&reg);
    let viewer_base: Arc<str> = Arc::from(format!("http://{local}"));
    let manager = session_manager(opts.max_sessions, opts.max_sessions_per_client);
    if let Some(cluster) = reg.cluster() {
        let template = PhysicsServer::new(reg.clone(), sessions.clone()).with_viewer(viewer_base.clone());
        super::forwarded::start(template, cluster.clone());
    }
    let service = StreamableHttpService::new(
        move || Ok(PhysicsServer::new(server_reg.clone(), sessions.clone()).with_viewer(viewer_base.clone())),
        manager,
        config,
    );
    let token: Option<Arc<str>> = opts.token.as_deref().map(Arc::from);
    let viewer = super::viewer_relay::relayed(crate::seeing::viewer::router(reg.clone()), &reg)
        .route_layer(middleware::from_fn_with_state(Arc::new(hosts_for_viewer), require_known_host));
    let mcp = axum::Router::new()
        .nest_service("/mcp", service)
        .layer(middleware::from_fn(session_end_no_content))
        .layer(middleware::from_fn(limit_sessions))
        .layer(middleware::from_fn(tell_clients_apart));
    let app = mcp
        .merge(viewer)
        .layer(middleware::from_fn_with_state(token, require_token));
    let signal = signalled();
    announce_address(local);
    // Graceful: no new connection, open ones finish their replies — for at most
    // `shutdown::GRACE` after the signal (a client may hold a stream open for ever), then the
    // flush.
    // Each request knows its peer's address (`tell_clients_apart`).
    let app = app.into_make_service_with_connect_info::<SocketAddr>();
    let serving = axum::serve(listener, app).with_graceful_shutdown(shutdown_signal(signal, ct.clone()));
    tokio::select! {
        served = serving => served?,
        _ = async {
            ct.cancelled().await;
            tokio::time::sleep_until((crate::shutdown::began() + crate::shutdown::GRACE).into()).await;
        } => {
            tracing::warn!("connections were still open {:?} after the signal; closing them", crate::shutdown::GRACE);
        }
    }
    finish(reg).await;
    Ok(())
}

/// Serves MCP over stdin/stdout (logs go to stderr) until stdin closes.
pub async fn serve_stdio(reg: Arc<Registry>) -> anyhow::Result<()> {
    let sessions = Sessions::of(&reg);
    if let Some(cluster) = reg.cluster() {
        super::forwarded::start(PhysicsServer::new(reg.clone(), sessions.clone()), cluster.clone());
    }
    let service = PhysicsServer::new(reg.clone(), sessions)
        .serve(rmcp::transport::stdio())
        .await?;
    // Input ended (the client went away) or a signal: either way, stop and flush.
    let cancel = service.cancellation_token();
    tokio::select! {
        waited = service.waiting() => {
            waited?;
        }
        _ = signalled() => {
            crate::shutdown::begin();
            cancel.cancel();
        }
    };
    finish(reg).await;
    Ok(())
}

/// Serving beyond loopback with no token lets anyone who reaches the address drive every
/// simulation: said once, on stderr, before the address line.
fn warn_without_token(local: SocketAddr) {
    use std::io::Write;
    let line = format!(
        "physics-mcp: warning: serving on {local}, which is not a loopback address, without a token: anyone who can reach it can call every tool; give one with --token-file PATH or PHYSICS_MCP_TOKEN\n"
    );
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

/// Prints the line clients wait for — `physics-mcp listening on http://HOST:PORT/mcp` — in
/// one write. `eprintln!` writes unbuffered stderr piece by piece, so a script polling the log
/// could read `…listening on http://` before the address arrived and connect to nowhere.
fn announce_address(local: std::net::SocketAddr) {
    use std::io::Write;
    let line = format!("physics-mcp listening on http://{local}/mcp\n");
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}
