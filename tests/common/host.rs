//! A stand-in MCP Apps host for the browser tests: a tiny HTTP server on a free loopback port
//! that serves `tests/browser/host.html` and its vendored `ext-apps-host.js`, and
//! reverse-proxies `/mcp` to a running physics server, so the host page and the MCP endpoint
//! share one origin (as a web chat client's page and its own backend would) and the page makes
//! no request to another origin.
//!
//! It runs on its own thread and tokio runtime: a test blocked on a browser process (even a
//! `#[tokio::test]` on a current-thread runtime) does not stall the proxy.

use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;

use axum::body::{Body, Bytes};
use axum::extract::State;
use axum::http::{header, HeaderMap, HeaderValue, Method, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;

/// Chromium flags a test of the host page needs besides `browser_viewer::headless`'s own:
/// - `--disable-features=IsolateSandboxedIframes`: the app's iframe (sandboxed, opaque origin)
///   otherwise runs in a renderer process of its own, whose tasks `--virtual-time-budget` does
///   not wait for: the DOM is dumped before the app has answered (seen: the handshake stopped
///   at a random step). Chromium keeps only the last `--disable-features`: merge, never repeat.
/// - `--use-angle=swiftshader --enable-unsafe-swiftshader`: WebGL on the CPU (SwiftShader) on a
///   machine without a GPU, explicitly (Chromium 156 here falls back to it even without them,
///   and with `--disable-gpu`; newer ones need the opt-in).
pub const CHROMIUM_FLAGS: [&str; 3] = ["--disable-features=IsolateSandboxedIframes", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"];

/// The running host: it stops when dropped.
pub struct Host {
    addr: SocketAddr,
    /// What the page POSTed to `/report` (the app's probes, relayed by host.html), oldest first.
    reports: Arc<std::sync::Mutex<Vec<String>>>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

struct Upstream {
    http: reqwest::Client,
    /// `http://127.0.0.1:PORT`: the physics server's own origin.
    origin: String,
}

/// Request headers not passed on: hop-by-hop ones, `Host` (reqwest sets the upstream's, which
/// the server's DNS-rebinding check expects), `Content-Length` (set from the body), and
/// `Accept-Encoding` (reqwest here decompresses nothing).
const DROPPED_REQUEST: [&str; 9] =
    ["host", "connection", "keep-alive", "proxy-connection", "te", "trailer", "transfer-encoding", "upgrade", "content-length"];
const DROPPED_RESPONSE: [&str; 7] = ["connection", "keep-alive", "proxy-connection", "te", "trailer", "transfer-encoding", "content-length"];

impl Host {
    /// Starts the host in front of the server at `server_base_url`: its origin
    /// (`http://127.0.0.1:PORT`) or its MCP endpoint (`…/mcp`, as `Server::url`).
    pub fn start(server_base_url: &str) -> Host {
        let base = server_base_url.trim_end_matches('/');
        let origin = base.strip_suffix("/mcp").unwrap_or(base).to_string();
        let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind the host");
        listener.set_nonblocking(true).unwrap();
        let addr = listener.local_addr().unwrap();
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let reports: Arc<std::sync::Mutex<Vec<String>>> = Arc::default();
        let sink = reports.clone();
        let held = reports.clone();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
            rt.block_on(async move {
                // No timeout: the GET /mcp event stream stays open as long as the page.
                let http = reqwest::Client::builder().redirect(reqwest::redirect::Policy::none()).build().unwrap();
                let app = Router::new()
                    .route("/host.html", get(|| file("host.html", "text/html; charset=utf-8")))
                    .route("/ext-apps-host.js", get(|| file("vendor/ext-apps-host.js", "text/javascript; charset=utf-8")))
                    // The page tells the test what the app reported, in wall-clock time: headless
                    // Chromium's virtual time does not wait for streamed MCP replies.
                    .route("/report", axum::routing::post(move |body: String| {
                        let sink = sink.clone();
                        async move { sink.lock().unwrap().push(body); "" }
                    }))
                    // `host.html?…&hold=1` loads this image, which answers once the app has
                    // reported a drawn frame (at most 30 s): the page's load event, which a
                    // plain `--screenshot` waits for, then comes after the app drew.
                    .route("/hold", get(move || {
                        let held = held.clone();
                        async move {
                            let from = held.lock().unwrap().len();
                            for _ in 0..300 {
                                if held.lock().unwrap()[from..].iter().any(|r| r.contains("\"mode\":\"app\"") && r.contains("\"rgb\":[")) {
                                    break;
                                }
                                tokio::time::sleep(std::time::Duration::from_millis(100)).await;
                            }
                            ([(header::CONTENT_TYPE, "image/gif")], &b"GIF89a\x01\x00\x01\x00\x00\x00\x00;"[..])
                        }
                    }))
                    .route("/mcp", axum::routing::any(proxy))
                    .route("/mcp/{*rest}", axum::routing::any(proxy))
                    .with_state(Arc::new(Upstream { http, origin }));
                let listener = tokio::net::TcpListener::from_std(listener).unwrap();
                tokio::select! {
                    r = axum::serve(listener, app) => r.expect("host server"),
                    _ = stopped => {}
                }
            });
            // Open event streams end with the runtime, without waiting for the browser.
            rt.shutdown_background();
        });
        Host { addr, reports, stop: Some(stop), thread: Some(thread) }
    }

    /// The reports the page has POSTed so far (JSON texts), oldest first.
    pub fn reports(&self) -> Vec<String> {
        self.reports.lock().unwrap().clone()
    }

    /// `http://127.0.0.1:PORT`, the host page's origin.
    pub fn origin(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// The host page calling `tool` with `args_json` (JSON text) and showing its UI.
    pub fn url(&self, tool: &str, args_json: &str) -> String {
        self.page(&[("tool", tool), ("args", args_json)])
    }

    /// `url`, sending `Authorization: Bearer <token>` to the server (`--token`).
    pub fn url_with_token(&self, tool: &str, args_json: &str, token: &str) -> String {
        self.page(&[("tool", tool), ("args", args_json), ("token", token)])
    }

    /// `url` whose load event waits for the app's first drawn frame (for a screenshot).
    pub fn url_held(&self, tool: &str, args_json: &str) -> String {
        self.page(&[("tool", tool), ("args", args_json), ("hold", "1")])
    }

    fn page(&self, query: &[(&str, &str)]) -> String {
        let query = form_urlencoded::Serializer::new(String::new()).extend_pairs(query).finish();
        format!("{}/host.html?{query}", self.origin())
    }
}

impl Drop for Host {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A file of `tests/browser/`, read at each request (no caching: edit and reload).
async fn file(name: &str, content_type: &'static str) -> Response {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/browser").join(name);
    match tokio::fs::read(&path).await {
        Ok(bytes) => ([(header::CONTENT_TYPE, content_type), (header::CACHE_CONTROL, "no-store")], bytes).into_response(),
        Err(e) => (StatusCode::NOT_FOUND, format!("{}: {e}\n", path.display())).into_response(),
    }
}

/// Passes a request under `/mcp` to the server and streams its answer back (an SSE reply or
/// the GET event stream chunk by chunk, as it comes). `Origin` is rewritten to the server's
/// own, as the page would send it were it served by the server.
async fn proxy(State(up): State<Arc<Upstream>>, method: Method, uri: Uri, headers: HeaderMap, body: Bytes) -> Response {
    let path = uri.path_and_query().map_or("/mcp", |p| p.as_str());
    let mut out = reqwest::header::HeaderMap::new();
    for (name, value) in &headers {
        if DROPPED_REQUEST.contains(&name.as_str()) || name == header::ACCEPT_ENCODING {
            continue;
        }
        if name == header::ORIGIN {
            out.insert(header::ORIGIN, HeaderValue::from_str(&up.origin).unwrap());
            continue;
        }
        out.append(name.clone(), value.clone());
    }
    let sent = up.http.request(method, format!("{}{path}", up.origin)).headers(out).body(body).send().await;
    let mut upstream = match sent {
        Ok(r) => r,
        Err(e) => return (StatusCode::BAD_GATEWAY, format!("host proxy: {e}\n")).into_response(),
    };
    let mut response = Response::builder().status(upstream.status());
    for (name, value) in upstream.headers() {
        if !DROPPED_RESPONSE.contains(&name.as_str()) {
            response = response.header(name.clone(), value.clone());
        }
    }
    // reqwest's `chunk()` as a stream (its `bytes_stream` needs a feature the tests lack).
    let (tx, rx) = futures::channel::mpsc::channel::<Result<Bytes, std::io::Error>>(16);
    tokio::spawn(async move {
        use futures::SinkExt;
        let mut tx = tx;
        loop {
            match upstream.chunk().await {
                Ok(Some(bytes)) => {
                    if tx.send(Ok(bytes)).await.is_err() {
                        return; // the browser went away
                    }
                }
                Ok(None) => return,
                Err(e) => {
                    let _ = tx.send(Err(std::io::Error::other(e))).await;
                    return;
                }
            }
        }
    });
    response.body(Body::from_stream(rx)).unwrap()
}
