//! The WebGL viewer in a real browser (headless Chromium, WebGL by SwiftShader): it draws the
//! framed scene (a known object's colour where the page projects it, read back by the page and
//! seen in the screenshot), scrubbing to an earlier seq moves that object to where the
//! simulation said it was then, a click opens the inspector on it, play at 1× shows simulated
//! time at the pace of (virtual) wall time within one frame, with no console message and no
//! request beyond loopback. `#[ignore]`d for plain `cargo test`; `.ci/run` runs it.

use crate::common;

use std::path::Path;

use common::Server;
use serde_json::{json, Value};

use super::browser_viewer::{headless, watched};

/// Window size of every run here; the view is the window less the timeline bar.
const WINDOW: &str = "--window-size=900,650";

/// The page's `#probe` (what it drew where) from a dumped DOM.
pub(crate) fn probe(dom: &str, id: &str) -> Value {
    let open = format!("<pre id=\"{id}\">");
    let Some(start) = dom.find(&open) else { panic!("no #{id} in {} bytes of DOM", dom.len()) };
    let rest = &dom[start + open.len()..];
    let text = rest[..rest.find("</pre>").unwrap_or(rest.len())].replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("#{id} is not JSON ({e}): {text:?}"))
}

/// The probed object `id` (its projected pixel, world position and the colour read back).
pub(crate) fn object(probe: &Value, id: u64) -> &Value {
    probe["objects"].as_array().unwrap().iter().find(|o| o["id"] == id).unwrap_or_else(|| panic!("object {id} not drawn: {probe}"))
}

/// Whether an RGB colour is clearly red (a lit or shaded red face).
pub(crate) fn reddish(rgb: &[u8]) -> bool {
    rgb[0] > 90 && u32::from(rgb[0]) > 2 * u32::from(rgb[1]) + 20 && u32::from(rgb[0]) > 2 * u32::from(rgb[2]) + 20
}

/// The RGB of pixel (x, y) of a PNG screenshot.
pub(crate) fn pixel(png_path: &Path, x: u64, y: u64) -> [u8; 3] {
    let mut reader = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png_path).unwrap())).read_info().unwrap();
    let mut px = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut px).unwrap();
    let c = info.color_type.samples();
    let i = (y as usize * info.width as usize + x as usize) * c;
    [px[i], px[i + 1], px[i + 2]]
}

/// Loads `url` until the probe says `ready`, with longer virtual-time budgets on a loaded machine.
fn probed(url: &str, dir: &Path, name: &str, ready: impl Fn(&Value) -> bool) -> Value {
    let mut last = Value::Null;
    for (attempt, budget) in [5_000, 15_000, 40_000].into_iter().enumerate() {
        let dom = headless(url, &dir.join(format!("profile-{name}-{attempt}")), budget, &[WINDOW, "--dump-dom"]);
        last = probe(&dom, "probe");
        if ready(&last) {
            return last;
        }
    }
    panic!("{name}: the page never got there: {last}");
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs Chromium; run by .ci/run with --ignored"]
async fn browser_the_3d_viewer_draws_scrubs_inspects_and_plays() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let created = c.call("create_simulation", json!({"gui": true})).await;
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    let url = created["viewer_url"].as_str().unwrap().to_string();
    c.ground(&sim).await;
    let boxed = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.3], "position": [0, 0, 2.5], "color": [1, 0, 0, 1]})).await;
    let red = boxed["object_id"].as_u64().unwrap();
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [0.8, 0.3, 0.2], "color": [0.2, 0.4, 1, 1]})).await;
    let first = c.call("step_simulation", json!({"sim_id": sim, "steps": 48})).await;
    let past_seq = first["head_seq"].as_u64().unwrap();
    let then = c.state(&sim, red).await;
    c.step(&sim, 552).await; // 2.5 s in all
    let hash = c.hash(&sim).await;

    // Live: the framed scene shows the red box where the page projects it.
    let now = probed(&format!("{url}?probe=1"), dir.path(), "live", |p| p["steps"] == 600 && p["webgl"] == true);
    let at = object(&now, red);
    let rgb: Vec<u8> = serde_json::from_value(at["rgb"].clone()).unwrap();
    assert!(reddish(&rgb), "the page read back {rgb:?} at the red box's projection: {now}");
    let shot = dir.path().join("live.png");
    let w = watched(&url, &dir.path().join("profile-shot"), 8_000, &[WINDOW, &format!("--screenshot={}", shot.display())]);
    assert!(w.console.is_empty(), "console: {:?}", w.console);
    assert!(w.outside.is_empty(), "requests beyond loopback: {:?}", w.outside);
    let seen = pixel(&shot, at["x"].as_u64().unwrap(), at["y"].as_u64().unwrap());
    assert!(reddish(&seen), "the screenshot has {seen:?} at the red box's projection");

    // Scrubbed back: the box is where get_object_state said it was after the first step call.
    let back = probed(&format!("{url}?probe=1&seq={past_seq}"), dir.path(), "past", |p| p["seq"] == past_seq);
    let was = object(&back, red);
    for k in 0..3 {
        let (drawn, said) = (was["at"][k].as_f64().unwrap(), then["position"][k].as_f64().unwrap());
        assert!((drawn - said).abs() < 1e-3, "axis {k}: drawn at {drawn}, get_object_state said {said}");
    }
    assert!(then["position"][2].as_f64().unwrap() > at["at"][2].as_f64().unwrap() + 1.0, "the box fell since: {then} vs {at}");

    // A click on the box opens the inspector on it.
    let clicked = probed(&format!("{url}?probe=1&click=first"), dir.path(), "click", |p| p["inspector"] == "loaded");
    assert_eq!(clicked["inspected"], red, "{clicked}");

    // Play at 1× from the start: simulated time keeps pace with virtual time within one frame.
    let first_seq = 1;
    let played = probed(&format!("{url}?probe=1&seq={first_seq}&play=1"), dir.path(), "play", |p| p["play"]["sim_s"].as_f64().unwrap_or(0.0) >= 2.0);
    let (sim_s, clock_s) = (played["play"]["sim_s"].as_f64().unwrap(), played["play"]["clock_s"].as_f64().unwrap());
    let frame = played["play"]["frame_dt"].as_f64().unwrap() / 240.0;
    assert!((clock_s - sim_s).abs() <= frame + 1e-6, "{sim_s} s simulated shown at {clock_s} s of play (one frame: {frame} s)");

    assert_eq!(c.hash(&sim).await, hash, "looking changed nothing");
}
