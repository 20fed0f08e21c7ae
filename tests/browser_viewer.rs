//! The web viewer in a real browser: headless Chromium (Debian's `chromium` package) opens
//! `viewer_url` of a gui simulation, runs the page's script, and must show the simulation —
//! the status line names its steps and state hash, and the screenshot holds the red box the
//! server rendered. `#[ignore]`d for plain `cargo test` (no browser on a machine with only
//! Rust); `.ci/run` installs Chromium and runs these with `--ignored`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::Server;
use serde_json::json;

/// The Chromium binary, from `CHROMIUM` or the names Debian installs.
fn chromium() -> PathBuf {
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

/// Runs headless Chromium on `url` with `extra` flags, letting the page's timers run for
/// `budget_ms` of virtual time; returns stdout. The background-networking flags keep Chromium
/// from dialling Google's hosts, which a closed CI network refuses (and which then starves the
/// page's own loopback fetches); a fresh profile per run.
fn headless(url: &str, profile: &Path, budget_ms: u32, extra: &[&str]) -> String {
    let out = Command::new(chromium())
        .args(["--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=700,560"])
        .args(["--disable-dev-shm-usage", "--disable-quic", "--no-first-run", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync", "--no-proxy-server"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--virtual-time-budget={budget_ms}"))
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
