//! A change's cost at any world size (`cargo bench --bench change_cost`): what one change that touches one body
//! costs in a world of 100 objects and in one of 9,900 — add_box, set_object_pose,
//! apply_force — over MCP/HTTP (the release server, one kept-alive rmcp client), as the mean
//! per call over whole snapshot intervals, so each call's share of the snapshots is in it.
//!
//! - The scene: boxes on a grid in a world without gravity (no contacts: the cost measured is
//!   the change's, not a collision's), built with `batch`, which leaves a snapshot at its end.
//! - set_object_pose and apply_force: 2,560 calls on bodies chosen by a fixed pseudo-random
//!   sequence; at 9,900 objects that is one snapshot interval (a quarter of the objects, 2,475
//!   changes: `sim::snapshot_every_changes`), at 100 forty of them (64 changes).
//! - add_box: whole snapshot intervals of calls from the size on, each on a fresh scene (40 of
//!   64 calls at 100, 2 of 2,475 at 9,900: about as many calls at both sizes).
//! - Rounds alternate the sizes; REPORT lines give the median over rounds, the ratio, and the
//!   disk the 9,900-object log uses (file bytes; snapshots on its chain and their bytes).

// A benchmark reads the clock and its files; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use physics_mcp::sim::snapshot_every_changes;
use serde_json::{json, Value};

/// Rounds per size (medians are reported).
const ROUNDS: usize = 3;
/// Calls per round for set_object_pose and apply_force.
const CALLS: usize = 2_560;
/// The two world sizes compared.
const SIZES: [usize; 2] = [100, 9_900];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A 0.1 m box at grid cell `i` (0.5 m apart, 40 × 40 × n), as add_box arguments.
fn box_args(i: usize) -> Value {
    let (x, y, z) = ((i % 40) as f64 * 0.5, ((i / 40) % 40) as f64 * 0.5, (i / 1600) as f64 * 0.5 + 1.0);
    json!({"dimensions": [0.1, 0.1, 0.1], "position": [x, y, z], "mass": 1.0})
}

/// A deterministic pseudo-random object id in 0..n (xorshift; the same sequence every run).
fn ids(n: usize) -> impl FnMut() -> usize {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s % n as u64) as usize
    }
}

/// A new simulation of `n` boxes (ids 0..n), built in batches.
async fn scene(client: &common::Client, n: usize) -> String {
    let sim = client.new_sim(json!({"gravity": [0.0, 0.0, 0.0]})).await;
    for chunk in (0..n).collect::<Vec<_>>().chunks(5_000) {
        let calls: Vec<Value> = chunk.iter().map(|i| json!({"tool": "add_box", "arguments": box_args(*i)})).collect();
        client.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    }
    sim
}

/// Mean ms per call of `tool` in a world of `n` objects: 2,560 calls on one fresh scene, or
/// for add_box whole snapshot intervals of calls, each on a fresh scene.
async fn mean_ms(client: &common::Client, tool: &str, n: usize) -> f64 {
    if tool != "add_box" {
        return window_ms(client, tool, n, CALLS).await;
    }
    let interval = snapshot_every_changes(n) as usize;
    let windows = CALLS.div_ceil(interval).max(1);
    let mut total = 0.0;
    for _ in 0..windows {
        total += window_ms(client, tool, n, interval).await;
    }
    total / windows as f64
}

/// Mean ms per call of `calls` calls of `tool` on a fresh scene of `n` objects.
async fn window_ms(client: &common::Client, tool: &str, n: usize, calls: usize) -> f64 {
    let sim = scene(client, n).await;
    let mut next = ids(n);
    let t = Instant::now();
    for k in 0..calls {
        let args = match tool {
            "add_box" => box_args(n + k),
            "set_object_pose" => json!({"object_id": next(), "position": [0.0, 0.0, 50.0 + k as f64 * 1e-3]}),
            _ => json!({"object_id": next(), "force": [0.0, 0.0, 1.0]}),
        };
        let mut args = args;
        args["sim_id"] = json!(sim);
        client.call(tool, args).await;
    }
    let ms = t.elapsed().as_secs_f64() * 1e3 / calls as f64;
    client.call("destroy_simulation", json!({"sim_id": sim})).await;
    ms
}

/// The disk a log of `n` objects built call by call uses: (file bytes, snapshots on the chain,
/// their bytes). Built with one add_box call per object, as a client without `batch` would.
async fn disk(client: &common::Client, data: &std::path::Path, n: usize) -> (u64, i64, i64) {
    let sim = client.new_sim(json!({"gravity": [0.0, 0.0, 0.0]})).await;
    for i in 0..n {
        let mut args = box_args(i);
        args["sim_id"] = json!(sim);
        client.call("add_box", args).await;
    }
    let path = data.join(format!("{sim}.sqlite"));
    let conn = rusqlite::Connection::open_with_flags(&path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY).unwrap();
    let (count, bytes): (i64, i64) =
        conn.query_row("SELECT COUNT(*), COALESCE(SUM(LENGTH(bytes)), 0) FROM snapshots", [], |r| Ok((r.get(0)?, r.get(1)?))).unwrap();
    let files: u64 = std::fs::read_dir(data)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(&sim))
        .map(|e| e.metadata().map(|m| m.len()).unwrap_or(0))
        .sum();
    (files, count, bytes)
}

fn main() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let server = common::Server::start(dir.path(), &["--max-objects", "20000"]);
    let client = rt.block_on(server.client());
    for tool in ["add_box", "set_object_pose", "apply_force"] {
        let mut by_size: Vec<Vec<f64>> = vec![Vec::new(); SIZES.len()];
        for _ in 0..ROUNDS {
            for (i, &n) in SIZES.iter().enumerate() {
                by_size[i].push(rt.block_on(mean_ms(&client, tool, n)));
            }
        }
        let (small, big) = (median(by_size[0].clone()), median(by_size[1].clone()));
        println!(
            "REPORT {tool} mean per call incl. snapshots: {:.3} ms at {} objects, {:.3} ms at {} objects, ratio {:.2} (medians of {ROUNDS} rounds; target <= 1.2)",
            small, SIZES[0], big, SIZES[1], big / small
        );
    }
    let (files, snaps, snap_bytes) = rt.block_on(disk(&client, &server.data, SIZES[1]));
    println!(
        "REPORT disk of a {}-object scene built with one add_box per object: {:.1} MB in its log files; {snaps} snapshots on the chain, {:.1} MB",
        SIZES[1],
        files as f64 / 1e6,
        snap_bytes as f64 / 1e6
    );
}
