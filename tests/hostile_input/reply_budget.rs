//! The reply budget (docs/tools.md "Conventions"): a client the size of the Python
//! MCP SDK (it drops any SSE event over 1 MiB) calls every tool that can answer big, at its
//! limits — 16,384 rays, a 1024×1024 image with depth and segmentation, a 1000-event history
//! page, a long trajectory — over plain HTTP, measuring the raw bytes of each reply: each is
//! ≤ 1 MiB or a refusal saying what to change. With output_path the files hold exactly the full
//! data (the `.npy` arrays are read back and compared bit for bit with the inline ones), and
//! replay still re-checks every recorded read.

use crate::common;

use common::Server;
use serde_json::{json, Value};

/// The default budget, and the Python SDK's SSE event limit.
const MIB: usize = 1 << 20;

/// A raw MCP session over streamable HTTP, so a reply's bytes are measured as sent.
struct Raw {
    http: reqwest::Client,
    url: String,
    session: String,
    next_id: u64,
}

/// One tool reply: its raw HTTP body size, its largest SSE `data:` payload, and the result.
struct Reply {
    body_bytes: usize,
    event_bytes: usize,
    result: Value,
}

impl Reply {
    /// Ok(structuredContent) or Err(error text).
    fn outcome(&self) -> Result<&Value, String> {
        if self.result["isError"] == json!(true) {
            return Err(self.text());
        }
        Ok(&self.result["structuredContent"])
    }

    /// The text content, joined.
    fn text(&self) -> String {
        let items = self.result["content"].as_array().cloned().unwrap_or_default();
        items.iter().filter_map(|c| c["text"].as_str().map(str::to_owned)).collect::<Vec<_>>().join(" ")
    }
}

impl Raw {
    async fn connect(url: &str) -> Raw {
        let http = reqwest::Client::new();
        let session = common::raw_session(&http, url, "2025-11-25").await.expect("initialize");
        Raw { http, url: url.to_string(), session, next_id: 1 }
    }

    /// POSTs one message; returns the raw body.
    async fn post(&mut self, msg: Value) -> Vec<u8> {
        let response = self
            .http
            .post(&self.url)
            .header("Accept", "application/json, text/event-stream")
            .header("Content-Type", "application/json")
            .header("mcp-session-id", &self.session)
            .header("mcp-protocol-version", "2025-11-25")
            .body(msg.to_string())
            .send()
            .await
            .expect("POST");
        response.bytes().await.expect("body").to_vec()
    }

    /// Every tool's output schema, by name (tools/list).
    async fn output_schemas(&mut self) -> std::collections::BTreeMap<String, Value> {
        self.next_id += 1;
        let body = self.post(json!({"jsonrpc": "2.0", "id": self.next_id, "method": "tools/list"})).await;
        let text = String::from_utf8(body).unwrap();
        let data = text.lines().filter_map(|l| l.strip_prefix("data:")).map(str::trim).find(|d| d.contains("\"tools\"")).unwrap_or(text.trim());
        let listed: Value = serde_json::from_str(data).unwrap();
        listed["result"]["tools"].as_array().unwrap().iter().map(|t| (t["name"].as_str().unwrap().to_string(), t["outputSchema"].clone())).collect()
    }

    /// Calls `tool` and measures the reply.
    async fn call(&mut self, tool: &str, args: Value) -> Reply {
        self.next_id += 1;
        let msg = json!({"jsonrpc": "2.0", "id": self.next_id, "method": "tools/call", "params": {"name": tool, "arguments": args}});
        let body = self.post(msg).await;
        let text = String::from_utf8(body.clone()).expect("utf-8 body");
        // SSE: the reply is the `data:` event carrying our id; plain JSON: the body itself.
        let mut events: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("data:")).map(str::trim).filter(|d| !d.is_empty()).collect();
        if events.is_empty() {
            events.push(text.trim());
        }
        let event_bytes = events.iter().map(|e| e.len()).max().unwrap_or(0);
        let reply = events
            .iter()
            .filter_map(|e| serde_json::from_str::<Value>(e).ok())
            .find(|v| v["id"] == json!(self.next_id))
            .unwrap_or_else(|| panic!("{tool}: no reply in {} bytes", body.len()));
        assert!(reply.get("error").is_none(), "{tool}: JSON-RPC error {}", reply["error"]);
        Reply { body_bytes: body.len(), event_bytes, result: reply["result"].clone() }
    }
}

/// The state hash and head of a simulation (what a refusal must leave alone).
async fn mark(c: &mut Raw, sim: &str) -> (Value, Value) {
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let info = info.outcome().unwrap().clone();
    (info["state_hash"].clone(), info["head_seq"].clone())
}

/// Asserts a reply fits the budget, or is a refusal naming what to change.
fn fits_or_says(tool: &str, r: &Reply, budget: usize, words: &[&str]) {
    assert!(r.event_bytes <= budget && r.body_bytes <= budget + 256, "{tool}: reply of {} bytes (event {})", r.body_bytes, r.event_bytes);
    if let Err(why) = r.outcome() {
        assert!(why.contains("reply budget") || words.iter().any(|w| why.contains(w)), "{tool}: {why}");
        assert!(words.iter().any(|w| why.contains(w)), "{tool}: the refusal must say what to change: {why}");
    }
}

/// A 16×16 grid of boxes on a ground slab, so rays and pixels hit many objects.
async fn scene(c: &mut Raw) -> String {
    let r = c.call("create_simulation", json!({})).await;
    let sim = r.outcome().unwrap()["simulation_id"].as_str().unwrap().to_string();
    c.call("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.5], "position": [0, 0, -0.5], "mass": 0})).await;
    for i in 0..16 {
        for j in 0..16 {
            let p = [-3.0 + 0.4 * f64::from(i), -3.0 + 0.4 * f64::from(j), 0.1];
            let r = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": p})).await;
            r.outcome().unwrap();
        }
    }
    c.call("step_simulation", json!({"sim_id": sim, "steps": 5})).await.outcome().unwrap();
    sim
}

/// `n` vertical rays over the scene, from z = 3 down to z = -1.
fn rays(n: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let side = (n as f64).sqrt().ceil() as usize;
    let at = |k: usize| [-4.0 + 8.0 * (k % side) as f64 / side as f64, -4.0 + 8.0 * (k / side) as f64 / side as f64];
    let from = (0..n).map(|k| [at(k)[0], at(k)[1], 3.0]).collect();
    let to = (0..n).map(|k| [at(k)[0], at(k)[1], -1.0]).collect();
    (from, to)
}

/// The little-endian 4-byte words of a `.npy` written by the server, checked for its dtype
/// and shape.
fn npy_words(path: &str, descr: &str, shape: (usize, usize)) -> Vec<[u8; 4]> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let (d, s, data) = physics_mcp::files::npy::decode(&bytes).expect("a .npy v1.0 file");
    assert_eq!((d.as_str(), s), (descr, shape), "{path}");
    assert_eq!(data.len(), shape.0 * shape.1 * 4, "{path}: data length");
    data.chunks(4).map(|c| c.try_into().unwrap()).collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn every_big_reply_fits_one_mebibyte_or_says_what_to_change() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let mut c = Raw::connect(&server.url).await;
    let sim = scene(&mut c).await;
    let s = sim.as_str();

    // 16,384 rays inline: refused before the work (the per-ray bound is over budget), and
    // nothing changed.
    let before = mark(&mut c, s).await;
    let (from, to) = rays(16_384);
    let r = c.call("ray_test_batch", json!({"sim_id": s, "rays_from": from, "rays_to": to})).await;
    fits_or_says("ray_test_batch", &r, MIB, &["fewer rays"]);
    let why = r.outcome().expect_err("16,384 rays inline cannot fit 1 MiB");
    assert!(why.contains("fewer rays") && why.contains("output_path") && !why.contains('\n'), "{why}");
    assert_eq!(mark(&mut c, s).await, before, "a refusal changes nothing");

    // With output_path: a summary, and the file holds exactly what four inline batches say.
    let r = c.call("ray_test_batch", json!({"sim_id": s, "rays_from": from, "rays_to": to, "output_path": "out/rays.json"})).await;
    fits_or_says("ray_test_batch", &r, MIB, &[]);
    let summary = r.outcome().unwrap().clone();
    let schemas = c.output_schemas().await;
    let valid = |tool: &str, v: &Value| {
        let validator = jsonschema::validator_for(&schemas[tool]).unwrap();
        let errors: Vec<String> = validator.iter_errors(v).map(|e| e.to_string()).collect();
        assert!(errors.is_empty(), "{tool}: {errors:?} in {v}");
    };
    valid("ray_test_batch", &summary);
    assert_eq!(summary["rays"], 16_384);
    assert!(summary.get("results").is_none(), "{summary}");
    let file: Value = serde_json::from_slice(&std::fs::read(server.workspace.join(summary["output_path"].as_str().unwrap())).unwrap()).unwrap();
    let mut inline = Vec::new();
    for k in 0..4 {
        let part = json!({"sim_id": s, "rays_from": from[k * 4096..(k + 1) * 4096], "rays_to": to[k * 4096..(k + 1) * 4096]});
        let r = c.call("ray_test_batch", part).await;
        fits_or_says("ray_test_batch", &r, MIB, &[]);
        // Over 64 KB of structuredContent, the text is a short summary, not a second copy.
        assert!(r.text().len() < 1024 && r.text().contains("structuredContent"), "{}", r.text());
        inline.extend(r.outcome().unwrap()["results"].as_array().unwrap().clone());
    }
    assert_eq!(file["results"].as_array().unwrap(), &inline, "the file holds the full results");
    let hits = inline.iter().filter(|h| h["hit"] == json!(true)).count();
    assert_eq!(summary["hits"], hits);
    assert!(hits > 1000, "the scene is hit: {hits}");
    let again = c.call("ray_test_batch", json!({"sim_id": s, "rays_from": [[0, 0, 1]], "rays_to": [[0, 0, 0]], "output_path": "out/rays.json"})).await;
    assert!(again.outcome().unwrap_err().contains("already exists"));

    // A 1024×1024 camera image with depth and segmentation: refused before rendering inline;
    // to files, the arrays are exactly the image's.
    let big = json!({"sim_id": s, "width": 1024, "height": 1024, "include_depth": true, "include_segmentation": true});
    let r = c.call("get_camera_image", big.clone()).await;
    fits_or_says("get_camera_image", &r, MIB, &["smaller width and height"]);
    assert!(r.outcome().unwrap_err().contains("output_path"));
    let mut to_file = big.clone();
    to_file["output_path"] = json!("out/cam.png");
    let r = c.call("get_camera_image", to_file).await;
    fits_or_says("get_camera_image", &r, MIB, &[]);
    let cam = r.outcome().unwrap().clone();
    assert!(cam.get("depth").is_none() && cam.get("segmentation").is_none(), "{cam}");
    valid("get_camera_image", &cam);
    assert!(r.result["content"].as_array().unwrap().iter().all(|c| c["type"] != "image"), "no inline image with output_path");
    // Paths come back as the user names them: relative to the workspace.
    let at = |k: &str| server.workspace.join(cam[k].as_str().unwrap()).display().to_string();
    let png = std::fs::read(at("png_path")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let seg = npy_words(&at("segmentation_path"), "<i4", (1024, 1024));
    let depth = npy_words(&at("depth_path"), "<f4", (1024, 1024));
    let mut counts = std::collections::BTreeMap::<i32, u64>::new();
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (id, d) in seg.iter().zip(&depth) {
        let (id, d) = (i32::from_le_bytes(*id), f32::from_le_bytes(*d));
        if id >= 0 {
            *counts.entry(id).or_default() += 1;
            (lo, hi) = (lo.min(d), hi.max(d));
        }
    }
    let visible: std::collections::BTreeMap<i32, u64> = cam["visible_objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| (v["object_id"].as_i64().unwrap() as i32, v["pixels"].as_u64().unwrap()))
        .collect();
    assert_eq!(counts, visible, "segmentation.npy agrees with visible_objects");
    let range = &cam["depth_range"];
    let range = (range[0].as_f64().unwrap() as f32, range[1].as_f64().unwrap() as f32);
    assert_eq!(range, (lo, hi), "depth.npy agrees with depth_range");

    // Small enough to inline: the files hold bit for bit what the inline reply says.
    let small = json!({"sim_id": s, "width": 48, "height": 32, "include_depth": true, "include_segmentation": true});
    let inline = c.call("get_camera_image", small.clone()).await;
    let inline_png = inline.result["content"].as_array().unwrap().iter().find(|c| c["type"] == "image").unwrap()["data"].clone();
    let inline = inline.outcome().unwrap().clone();
    let mut to_file = small;
    to_file["output_path"] = json!("out/small.png");
    let files = c.call("get_camera_image", to_file).await.outcome().unwrap().clone();
    let depth = npy_words(&server.workspace.join(files["depth_path"].as_str().unwrap()).display().to_string(), "<f4", (32, 48));
    let want: Vec<[u8; 4]> = inline["depth"].as_array().unwrap().iter().map(|v| (v.as_f64().unwrap() as f32).to_le_bytes()).collect();
    assert_eq!(depth, want, "depth.npy holds the inline depth, bit for bit");
    let seg = npy_words(&server.workspace.join(files["segmentation_path"].as_str().unwrap()).display().to_string(), "<i4", (32, 48));
    let want: Vec<[u8; 4]> = inline["segmentation"].as_array().unwrap().iter().map(|v| (v.as_i64().unwrap() as i32).to_le_bytes()).collect();
    assert_eq!(seg, want, "seg.npy holds the inline segmentation");
    let png = std::fs::read(server.workspace.join(files["png_path"].as_str().unwrap())).unwrap();
    use base64::Engine;
    assert_eq!(base64::engine::general_purpose::STANDARD.encode(png), inline_png.as_str().unwrap(), "the .png is the inline image");
    assert!(files["depth_path"].as_str().unwrap().ends_with("out/small.depth.npy"));
    assert!(files["segmentation_path"].as_str().unwrap().ends_with("out/small.seg.npy"));

    // A 1024×1024 image alone, inline: a PNG of a simple scene fits (or is refused, saying so).
    let r = c.call("get_camera_image", json!({"sim_id": s, "width": 1024, "height": 1024})).await;
    fits_or_says("get_camera_image", &r, MIB, &["smaller width and height"]);

    // A long trajectory: inline it fits or is refused naming every/output_path.
    c.call("step_simulation", json!({"sim_id": s, "steps": 500})).await.outcome().unwrap();
    let r = c.call("get_trajectory", json!({"sim_id": s, "every": 1})).await;
    fits_or_says("get_trajectory", &r, MIB, &["output_path"]);
    let r = c.call("get_trajectory", json!({"sim_id": s, "every": 20, "object_ids": [1, 2, 3]})).await;
    fits_or_says("get_trajectory", &r, MIB, &["output_path"]);
    r.outcome().unwrap();

    // A 1000-event history page: ≤ 1 MiB, fewer events with `truncated` when they do not fit.
    // Batches of 1024 rays: ~35 KB of arguments each (under the 64 KB at which history shows
    // a blob reference), 40 of them over 1 MiB; then cheap reads up to over 1000 events.
    for _ in 0..40 {
        let (from, to) = rays(1024);
        c.call("ray_test_batch", json!({"sim_id": s, "rays_from": from, "rays_to": to})).await.outcome().unwrap();
    }
    for _ in 0..750 {
        c.call("get_num_joints", json!({"sim_id": s, "object_id": 1})).await.outcome().unwrap();
    }
    let mut truncated_pages = 0;
    let head = mark(&mut c, s).await;
    let mut since = 0;
    let mut seen = Vec::new();
    loop {
        let r = c.call("get_history", json!({"sim_id": s, "since_seq": since, "limit": 1000})).await;
        fits_or_says("get_history", &r, MIB, &[]);
        let page = r.outcome().unwrap().clone();
        let events = page["events"].as_array().unwrap();
        valid("get_history", &page);
        assert!(!events.is_empty());
        seen.extend(events.iter().map(|e| e["seq"].as_u64().unwrap()));
        since = *seen.last().unwrap();
        let truncated = page.get("truncated") == Some(&json!(true));
        truncated_pages += usize::from(truncated);
        if !truncated && events.len() < 1000 {
            break;
        }
        assert!(truncated || events.len() == 1000);
    }
    assert!(seen.windows(2).all(|w| w[1] == w[0] + 1), "pages follow each other without gaps");
    assert!(seen.len() > 1000, "{} events", seen.len());
    assert!(truncated_pages > 0, "40 batches of 35 KB arguments cannot fit one page");
    assert_eq!(mark(&mut c, s).await.0, head.0);

    // Replay re-checks every recorded read (output_path ones included) against its hash.
    let log = server.data.join(format!("{sim}.sqlite"));
    server.terminate();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(&log).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[tokio::test(flavor = "multi_thread")]
async fn a_small_budget_refuses_after_the_work_and_truncates_history() {
    let dir = tempfile::tempdir().unwrap();
    let budget = 20_000;
    let server = Server::start(dir.path(), &["--max-reply-bytes", "20000"]);
    let mut c = Raw::connect(&server.url).await;
    let sim = scene(&mut c).await;
    let s = sim.as_str();
    // 256 boxes resting on the ground: their contacts are computed, then refused as over budget.
    let before = mark_small(&mut c, s).await;
    let r = c.call("get_all_collisions", json!({"sim_id": s})).await;
    fits_or_says("get_all_collisions", &r, budget, &["get_collisions_for_pair"]);
    let why = r.outcome().expect_err("hundreds of contacts cannot fit 20,000 bytes");
    assert!(why.contains("over the reply budget of 20000 bytes"), "{why}");
    // Logged as refused (not as answered with a reply that never went out).
    let tail = c.call("get_history", json!({"sim_id": s, "limit": 1})).await;
    let last = tail.outcome().unwrap()["last_seq"].as_u64().unwrap();
    let page = c.call("get_history", json!({"sim_id": s, "since_seq": last - 1, "limit": 1})).await;
    let event = page.outcome().unwrap()["events"][0].clone();
    assert_eq!((event["tool"].as_str(), event["kind"].as_str()), (Some("get_all_collisions"), Some("refused")), "{event}");
    // A ray batch whose bound is over budget is refused before casting.
    let (from, to) = rays(100);
    let r = c.call("ray_test_batch", json!({"sim_id": s, "rays_from": from, "rays_to": to})).await;
    assert!(r.outcome().unwrap_err().contains("fewer rays"));
    // A sampled step whose samples could not fit is refused before stepping.
    // (4 samples of 256 objects: under the fixed 500 KB trajectory bound, over this budget.)
    let r = c.call("step_simulation", json!({"sim_id": s, "steps": 10, "sample_every": 5})).await;
    fits_or_says("step_simulation", &r, budget, &["sample_every"]);
    let why = r.outcome().expect_err("4 samples of 256 objects cannot fit 20,000 bytes");
    assert!(why.contains("--max-reply-bytes"), "{why}");
    let r = c.call("get_history", json!({"sim_id": s, "limit": 1000})).await;
    fits_or_says("get_history", &r, budget, &[]);
    let page = r.outcome().unwrap();
    assert_eq!(page["truncated"], true);
    assert!(!page["events"].as_array().unwrap().is_empty());
    assert_eq!(mark_small(&mut c, s).await, before, "nothing changed");
}

/// `mark` for a budget too small for get_simulation_info's object list: reads the head and
/// hash from a one-event history page instead.
async fn mark_small(c: &mut Raw, sim: &str) -> (Value, Value) {
    let r = c.call("get_history", json!({"sim_id": sim, "limit": 1})).await;
    let page = r.outcome().unwrap().clone();
    let head = page["head_seq"].clone();
    let h = c.call("get_history", json!({"sim_id": sim, "since_seq": head.as_u64().unwrap() - 1, "limit": 1})).await;
    (h.outcome().unwrap()["events"][0]["state_hash"].clone(), head)
}
