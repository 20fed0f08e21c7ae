//! The web viewer on any node (cluster mode, docs/cluster.md "Routing"): a viewer request for
//! a simulation another live node owns is relayed to that node over NATS and its answer — the
//! page, a frame (live during a long step: the owner publishes them), the timeline — passed
//! back, so a browser may open the viewer through any node. Frames come from the owner; this
//! node neither takes the simulation over nor re-simulates it.

use std::sync::Arc;
use std::time::Duration;

use async_nats::HeaderMap;
use axum::extract::{Request, State};
use axum::http::{header, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::Router;
use futures_util::StreamExt;
use tower::ServiceExt;

use crate::cluster::calls::header as nats_header;
use crate::cluster::Cluster;
use crate::sim::Registry;

/// The header carrying a relayed request's path and query, and its answer's status.
const PATH: &str = "Pmcp-Path";
const STATUS: &str = "Pmcp-Status";
/// How long a relayed viewer request waits for the owner.
const WAIT: Duration = Duration::from_secs(10);
/// The largest answer relayed (one NATS message; a frame is tens of kilobytes).
const MAX_BODY: usize = 900 * 1024;

/// `viewer` with requests for simulations owned by other nodes relayed to them; the plain
/// `viewer` also answers the requests other nodes relay here. Embedded: `viewer` as it is.
pub fn relayed(viewer: Router, reg: &Arc<Registry>) -> Router {
    let Some(cluster) = reg.cluster().cloned() else { return viewer };
    serve(viewer.clone(), cluster.clone());
    viewer.layer(middleware::from_fn_with_state((reg.clone(), cluster), relay))
}

/// The simulation a viewer path names (`/viewer/{id}[/…]`).
fn sim_of(path: &str) -> Option<&str> {
    path.strip_prefix("/viewer/")?.split('/').next().filter(|s| !s.is_empty())
}

async fn relay(State((reg, cluster)): State<(Arc<Registry>, Arc<Cluster>)>, req: Request, next: Next) -> Response {
    let Some(id) = sim_of(req.uri().path()).map(str::to_string) else { return next.run(req).await };
    if reg.get_local(&id).is_some() && cluster.held_epoch(&id).is_some() {
        return next.run(req).await;
    }
    let owner = match cluster.lease_holder(&id).await {
        Ok(Some(owner)) if owner != cluster.config().node => owner,
        _ => return next.run(req).await,
    };
    let path = req.uri().path_and_query().map_or_else(|| req.uri().path().to_string(), |p| p.to_string());
    let mut headers = HeaderMap::new();
    headers.insert(PATH, path.as_str());
    let subject = format!("{}.view.{owner}", cluster.config().namespace);
    let client = cluster.nats();
    let asked = client.request_with_headers(subject, headers, bytes::Bytes::new());
    match tokio::time::timeout(WAIT, asked).await {
        Ok(Ok(answer)) => {
            let status = nats_header(&answer, STATUS).and_then(|s| s.parse().ok()).unwrap_or(StatusCode::BAD_GATEWAY);
            let kind = nats_header(&answer, "Content-Type").unwrap_or("text/plain").to_string();
            (status, [(header::CONTENT_TYPE, kind), (header::CACHE_CONTROL, "no-store".into())], answer.payload).into_response()
        }
        _ => (StatusCode::SERVICE_UNAVAILABLE, format!("the node that owns simulation {id}, {owner}, did not answer; try again")).into_response(),
    }
}

/// Answers the viewer requests other nodes relay here with this node's own viewer.
fn serve(viewer: Router, cluster: Arc<Cluster>) {
    tokio::spawn(async move {
        let subject = format!("{}.view.{}", cluster.config().namespace, cluster.config().node);
        let client = cluster.nats();
        let Ok(mut asked) = crate::cluster::patiently(|| client.subscribe(subject.clone())).await else {
            tracing::error!("cannot subscribe to {subject}: other nodes cannot show this node's simulations in the viewer");
            return;
        };
        while let Some(message) = asked.next().await {
            let (viewer, client) = (viewer.clone(), client.clone());
            tokio::spawn(async move {
                let (Some(reply), Some(path)) = (message.reply.clone(), nats_header(&message, PATH)) else { return };
                let Ok(req) = Request::get(path).body(axum::body::Body::empty()) else { return };
                let Ok(response) = viewer.oneshot(req).await;
                let status = response.status();
                let kind = response.headers().get(header::CONTENT_TYPE).and_then(|v| v.to_str().ok()).unwrap_or("text/plain").to_string();
                let (status, kind, body) = match axum::body::to_bytes(response.into_body(), MAX_BODY).await {
                    Ok(body) => (status, kind, body),
                    Err(_) => (StatusCode::BAD_GATEWAY, "text/plain".into(), bytes::Bytes::from_static(b"the answer is too large to relay between nodes")),
                };
                let mut headers = HeaderMap::new();
                headers.insert(STATUS, status.as_str());
                headers.insert("Content-Type", kind.as_str());
                let _ = client.publish_with_headers(reply, headers, body).await;
            });
        }
    });
}
