//! The viewer as an MCP App inside a host (tests/browser/host.html, the official ext-apps
//! AppBridge): the host calls a linked tool, loads `ui://physics-mcp/viewer` into a sandboxed
//! iframe, and the app — reading only through the host's bridge — draws the simulation: the
//! red box's colour is read back where the app projects it, and no request goes beyond
//! loopback. Run in wall-clock time (`run_until`): headless Chromium's virtual time does not
//! wait for an MCP host's streamed replies. `#[ignore]`d like the other browser tests.

use std::path::Path;
use std::time::Duration;

use serde_json::{json, Value};

use crate::browser_3d::{object, pixel, reddish};
use crate::browser_viewer::{headless, run_until};
use crate::common::host::{self, Host};
use crate::common::Server;

const WINDOW: &str = "--window-size=900,650";

/// Whether a report from the app shows `steps` steps with object `id` drawn red.
fn drawn(report: &Value, steps: u64, id: u64) -> bool {
    report["steps"] == steps
        && report["objects"].as_array().is_some_and(|o| {
            o.iter().any(|o| o["id"] == id && o["rgb"].as_array().is_some_and(|c| reddish(&c.iter().map(|v| v.as_u64().unwrap_or(0) as u8).collect::<Vec<u8>>())))
        })
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
async fn browser_app_in_host_draws_the_simulation() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let red = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.3], "position": [0, 0, 1], "color": [1, 0, 0, 1]})).await;
    let red = red["object_id"].as_u64().unwrap();
    c.step(&sim, 120).await;
    let hash = c.hash(&sim).await;

    let host = Host::start(server.base_url());
    let url = host.url("get_trajectory", &json!({"sim_id": sim, "object_ids": [red], "every": 60}).to_string());
    // host::CHROMIUM_FLAGS but its --disable-features, which QUIET_BROWSER's list already holds
    // (Chromium keeps only the last one given).
    let mut flags: Vec<&str> = host::CHROMIUM_FLAGS.iter().copied().filter(|f| !f.starts_with("--disable-features")).collect();
    flags.push(WINDOW);
    let reports = || host.reports().iter().filter_map(|r| serde_json::from_str::<Value>(r).ok()).collect::<Vec<Value>>();
    let (ok, outside) = run_until(&url, &dir.path().join("profile"), &flags, Duration::from_secs(90), || reports().iter().any(|r| drawn(r, 120, red)));
    assert!(ok, "the app never reported the red box drawn after 120 steps; its reports: {:?}", reports());
    assert!(outside.is_empty(), "requests beyond loopback: {outside:?}");
    let seen = reports().into_iter().find(|r| drawn(r, 120, red)).unwrap();
    assert_eq!(seen["mode"], "app", "{seen}");
    assert_eq!(seen["sim"], sim.as_str(), "the app shows the simulation of the call: {seen}");

    // The host's screenshot (load waits for the app's first drawn frame): the iframe fills
    // the window, so the app's pixel is the window's.
    let at = object(&seen, red).clone();
    let shot = dir.path().join("app.png");
    let mut flags = host::CHROMIUM_FLAGS.to_vec();
    let shot_flag = format!("--screenshot={}", shot.display());
    flags.extend([WINDOW, shot_flag.as_str(), "--timeout=40000"]);
    headless(&host.url_held("get_trajectory", &json!({"sim_id": sim, "object_ids": [red], "every": 60}).to_string()), &dir.path().join("profile-shot"), 0, &flags);
    let rgb = pixel(&shot, at["x"].as_u64().unwrap(), at["y"].as_u64().unwrap());
    assert!(reddish(&rgb), "the host's screenshot has {rgb:?} where the app projects the red box ({at})");
    if std::env::var_os("UPDATE_SCREENSHOTS").is_some() {
        std::fs::copy(&shot, Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/app-in-host.png")).unwrap();
    }
    assert_eq!(c.hash(&sim).await, hash, "looking changed nothing");
}
