//! The web viewer in a real browser: headless Chromium (Debian's `chromium` package) opens
//! `viewer_url` of a gui simulation, runs the page's script, and must show the simulation —
//! the status line names its steps and state hash, and the screenshot holds the red box the
//! server rendered. The session report (a file, offline) and the viewer scrubbed
//! to a past seq load without a console message or a request to another origin, and their
//! screenshots are what README shows (`UPDATE_SCREENSHOTS=1` copies them into docs/). `#[ignore]`d for plain `cargo test` (no browser on a machine with only
//! Rust); `.ci/run` installs Chromium and runs these with `--ignored`.

use crate::common;

use std::io::Read;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex};

use common::Server;
use serde_json::json;

/// The Chromium binary, from `CHROMIUM` or the names Debian installs.
pub(crate) fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return PathBuf::from(p);
    }
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if let Ok(out) = Command::new("which").arg(name).output() {
            if out.status.success() {
                return PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
            }
        }
    }
    panic!("no chromium on PATH: apt-get install chromium (or set CHROMIUM)");
}

/// WebGL without a GPU: SwiftShader, opted into as Chromium asks (else it warns on the console).
pub(crate) const WEBGL: [&str; 1] = ["--enable-unsafe-swiftshader"];

/// Runs headless Chromium on `url` with `extra` flags, letting the page's timers run for
/// `budget_ms` of virtual time; returns stdout. The background-networking flags keep Chromium
/// from dialling Google's hosts, which a closed CI network refuses (and which then starves the
/// page's own loopback fetches); a fresh profile per run.
pub(crate) fn headless(url: &str, profile: &Path, budget_ms: u32, extra: &[&str]) -> String {
    let out = Command::new(chromium())
        .args(["--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=700,560"])
        .args(WEBGL)
        .args(["--disable-dev-shm-usage", "--disable-quic", "--no-first-run", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync", "--no-proxy-server"])
        .arg(format!("--user-data-dir={}", profile.display()))
        // 0: no virtual time (the page's load event decides when it is done).
        .args((budget_ms > 0).then(|| format!("--virtual-time-budget={budget_ms}")))
        .arg("--run-all-compositor-stages-before-draw")
        .args(extra)
        .arg(url)
        .output()
        .expect("run chromium");
    assert!(out.status.success(), "chromium failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
async fn the_viewer_page_shows_the_simulation_in_a_real_browser() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let created = c.call("create_simulation", json!({"gui": true})).await;
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    let url = created["viewer_url"].as_str().expect("viewer_url for a gui simulation").to_string();
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.4, 0.4, 0.4], "position": [0, 0, 0.4], "color": [1, 0, 0, 1]})).await;
    c.step(&sim, 120).await;
    let hash = c.hash(&sim).await;

    // The DOM after the page's script ran: its status line shows this simulation's state. A
    // loaded machine may need more virtual time for the first frame; try a longer budget before
    // failing, and show what the status line said.
    let mut status = String::new();
    for (attempt, budget) in [4_000, 15_000, 40_000].into_iter().enumerate() {
        let dom = headless(&url, &dir.path().join(format!("profile-dom-{attempt}")), budget, &["--dump-dom"]);
        status = status_line(&dom);
        if status.contains("120 steps") {
            break;
        }
        eprintln!("attempt {attempt} ({budget} ms): status line {status:?}");
    }
    assert!(status.contains("120 steps"), "status line: {status:?}");
    assert!(status.contains(&hash[..12]), "the page shows the state hash {}: {status:?}", &hash[..12]);

    // The screenshot: the frame drawn on the page's canvas holds the red box.
    let shot = dir.path().join("viewer.png");
    headless(&url, &dir.path().join("profile-shot"), 15_000, &[&format!("--screenshot={}", shot.display())]);
    let mut reader = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&shot).unwrap())).read_info().unwrap();
    let mut px = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut px).unwrap();
    let channels = info.color_type.samples();
    let red = px.chunks(channels).filter(|p| p[0] > 120 && p[1] < 70 && p[2] < 70).count();
    assert!(red > 500, "{red} red pixels in a {}x{} screenshot", info.width, info.height);
    // Looking changed nothing.
    assert_eq!(c.hash(&sim).await, hash);
}

/// The text of the page's `<span id="status">` in a dumped DOM.
fn status_line(dom: &str) -> String {
    let Some(start) = dom.find("<span id=\"status\">") else { return format!("no status span in {} bytes of DOM", dom.len()) };
    let rest = &dom[start + "<span id=\"status\">".len()..];
    rest[..rest.find("</span>").unwrap_or(rest.len())].to_string()
}

/// Hosts Chromium itself calls on its own (network time, component updates, sign-in) even
/// with background networking off; requests to them are not the page's.
/// Chromium's own background traffic off, as far as flags go (Chromium 148 otherwise opens five
/// connections to www.google.com at start, which the stand-in proxy would count).
const QUIET_BROWSER: [&str; 8] = [
    "--disable-features=IsolateSandboxedIframes,NetworkTimeServiceQuerying,OptimizationHints,OptimizationHintsFetching,OptimizationGuideModelDownloading,MediaRouter,Translate,AutofillServerCommunication,InterestFeedContentSuggestions,CertificateTransparencyComponentUpdater,SafeBrowsing,NetworkPrediction,PreconnectToSearch,SearchPrefetchServicePrefetching,LoadingPredictorUseLocalPredictions,LoadingPredictorPrefetch",
    "--no-pings",
    "--dns-prefetch-disable",
    "--disable-domain-reliability",
    "--disable-client-side-phishing-detection",
    "--disable-default-apps",
    "--disable-extensions",
    "--no-default-browser-check",
];

/// Hosts Chromium itself contacts at start whatever the page (Chromium 148 still preconnects
/// once to www.google.com with every background feature above off); our pages reference none.
const CHROMIUM_OWN_HOSTS: [&str; 5] = ["clients2.google.com", "update.googleapis.com", "accounts.google.com", "redirector.gvt1.com", "www.google.com"];

/// What a page did in a real browser: its console messages and the requests it made to other
/// origins (seen by a stand-in proxy every non-loopback request is sent to).
pub(crate) struct Watched {
    pub(crate) console: Vec<String>,
    pub(crate) outside: Vec<String>,
}

/// Headless Chromium on `url` in wall-clock time — no virtual time, which does not wait for
/// streamed replies (an MCP host's calls) — until `done` holds (checked every 100 ms) or
/// `limit` passes; then it is stopped. Requests beyond loopback go to a recording stand-in
/// proxy, as in `watched`. Returns whether `done` held, and the requests it saw.
pub(crate) fn run_until(url: &str, profile: &Path, extra: &[&str], limit: std::time::Duration, done: impl Fn() -> bool) -> (bool, Vec<String>) {
    let (port, seen) = stand_in_proxy();
    let mut child = Command::new(chromium())
        .args(["--headless=new", "--no-sandbox", "--hide-scrollbars"])
        .args(WEBGL)
        .args(["--disable-dev-shm-usage", "--disable-quic", "--no-first-run", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync"])
        .args(QUIET_BROWSER)
        .arg(format!("--proxy-server=127.0.0.1:{port}"))
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("run chromium");
    let start = std::time::Instant::now();
    let mut ok = false;
    while start.elapsed() < limit {
        if done() {
            ok = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let _ = child.kill();
    let _ = child.wait();
    let outside = seen.lock().unwrap().iter().filter(|l| !CHROMIUM_OWN_HOSTS.iter().any(|h| l.contains(h))).cloned().collect();
    (ok, outside)
}

/// A stand-in proxy on loopback that answers nothing and records each request's first line.
fn stand_in_proxy() -> (u16, Arc<Mutex<Vec<String>>>) {
    let proxy = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = proxy.local_addr().unwrap().port();
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    std::thread::spawn(move || {
        for conn in proxy.incoming().flatten() {
            let mut conn = conn;
            let _ = conn.set_read_timeout(Some(std::time::Duration::from_millis(500)));
            let mut buf = [0u8; 512];
            let n = conn.read(&mut buf).unwrap_or(0);
            let line = String::from_utf8_lossy(&buf[..n]).lines().next().unwrap_or("").to_string();
            log.lock().unwrap().push(line);
        }
    });
    (port, seen)
}

/// Loads `url` in headless Chromium with every non-loopback request sent to a local
/// stand-in proxy (which answers nothing and records the request line), console messages on
/// stderr, and `extra` flags.
pub(crate) fn watched(url: &str, profile: &Path, budget_ms: u32, extra: &[&str]) -> Watched {
    let (port, seen) = stand_in_proxy();
    let out = Command::new(chromium())
        .args(["--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"])
        .args(WEBGL)
        .args(["--disable-dev-shm-usage", "--disable-quic", "--no-first-run", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync", "--enable-logging=stderr", "--v=0"])
        .args(QUIET_BROWSER)
        .arg(format!("--proxy-server=127.0.0.1:{port}"))
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--virtual-time-budget={budget_ms}"))
        .arg("--run-all-compositor-stages-before-draw")
        .args(extra)
        .arg(url)
        .output()
        .expect("run chromium");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "chromium failed: {stderr}");
    // SwiftShader's own performance notes on the compositor reading the WebGL canvas back
    // ("GL Driver Message … GPU stall due to ReadPixels") are the browser's, not the page's.
    let console = stderr.lines().filter(|l| l.contains(":CONSOLE") && !l.contains("GL Driver Message")).map(str::to_string).collect();
    let outside = seen
        .lock()
        .unwrap()
        .iter()
        .filter(|l| !CHROMIUM_OWN_HOSTS.iter().any(|h| l.contains(h)))
        .cloned()
        .collect();
    Watched { console, outside }
}

/// Checks a screenshot decodes and has some non-white picture; copies it to docs/ when
/// `UPDATE_SCREENSHOTS` is set.
fn keep_screenshot(shot: &Path, name: &str) {
    let mut reader = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(shot).unwrap())).read_info().unwrap();
    let mut px = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut px).unwrap();
    let inked = px.chunks(info.color_type.samples()).filter(|p| p[0] < 200 || p[1] < 200 || p[2] < 200).count();
    assert!(inked > 2000, "{name}: {inked} inked pixels");
    if std::env::var_os("UPDATE_SCREENSHOTS").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs");
        std::fs::create_dir_all(&docs).unwrap();
        std::fs::copy(shot, docs.join(name)).unwrap();
    }
}

#[test]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
fn browser_the_report_page_is_offline_and_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("drop_and_stack.sqlite");
    std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("replays/drop_and_stack.sqlite"), &log).unwrap();
    let page = dir.path().join("report.html");
    let out = Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("report").arg(&log).arg("-o").arg(&page).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let url = format!("file://{}", page.display());
    let shot = dir.path().join("report.png");
    let w = watched(&url, &dir.path().join("profile-report"), 3_000, &["--window-size=1000,1000", &format!("--screenshot={}", shot.display())]);
    assert!(w.console.is_empty(), "console: {:?}", w.console);
    assert!(w.outside.is_empty(), "requests to other origins: {:?}", w.outside);
    keep_screenshot(&shot, "report.png");
    // The DOM as the browser built it: the timeline's rows are there.
    let dom = headless(&url, &dir.path().join("profile-report-dom"), 2_000, &["--dump-dom"]);
    assert!(dom.matches("<tr class=\"event").count() >= 5, "timeline rows in the DOM");
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
async fn browser_the_viewer_scrubbed_to_a_past_seq_shows_it() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let created = c.call("create_simulation", json!({"gui": true})).await;
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    let url = created["viewer_url"].as_str().unwrap().to_string();
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.4, 0.4, 0.4], "position": [0, 0, 1.2], "color": [1, 0, 0, 1]})).await;
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [0.6, 0.2, 2], "color": [0.2, 0.4, 1, 1]})).await;
    c.step(&sim, 60).await;
    let past = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let (past_seq, past_hash) = (past["head_seq"].as_u64().unwrap(), past["state_hash"].as_str().unwrap().to_string());
    c.step(&sim, 120).await;
    let now = c.hash(&sim).await;

    let scrubbed = format!("{url}?seq={past_seq}");
    let mut status = String::new();
    for (attempt, budget) in [5_000, 15_000, 40_000].into_iter().enumerate() {
        let dom = headless(&scrubbed, &dir.path().join(format!("profile-dom-{attempt}")), budget, &["--dump-dom"]);
        status = status_line(&dom);
        if status.contains(&past_hash[..12]) {
            break;
        }
    }
    assert!(status.contains(&format!("seq {past_seq}")), "status line: {status:?}");
    assert!(status.contains("60 steps") && status.contains(&past_hash[..12]), "the past state: {status:?}");
    let shot = dir.path().join("viewer.png");
    let w = watched(&scrubbed, &dir.path().join("profile-shot"), 15_000, &["--window-size=700,820", &format!("--screenshot={}", shot.display())]);
    assert!(w.console.is_empty(), "console: {:?}", w.console);
    assert!(w.outside.is_empty(), "requests to other origins: {:?}", w.outside);
    keep_screenshot(&shot, "viewer.png");
    assert_eq!(c.hash(&sim).await, now, "looking back changed nothing");
}
