//! Does one client's work stall another's? `cargo bench --bench concurrency` drives the real
//! release binary over HTTP: one client's get_object_state loop on its own simulation, timed
//! alone and then while a second client creates (and destroys) simulations in a loop — the
//! registry's table lock must not be held across a create's I/O. Prints p50/p99 of both and
//! their ratio (`REPORT` lines), measured in the same run, and a control: the reads beside a
//! client as busy that takes no registry lock (on 2 cores, sharing them costs the reader too).

// A benchmark reads the clock; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../tests/common/mod.rs"]
mod common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use serde_json::json;

/// Round trips timed per run (after 200 to warm up).
const CALLS: usize = 3000;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

/// get_object_state round trips on `sim`, sorted, in ms.
async fn loop_reads(c: &common::Client, sim: &str) -> Vec<f64> {
    let q = json!({"sim_id": sim, "object_id": 0});
    let mut lat = Vec::with_capacity(CALLS);
    for i in 0..CALLS + 200 {
        let t = Instant::now();
        c.call("get_object_state", q.clone()).await;
        if i >= 200 {
            lat.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    lat.sort_by(f64::total_cmp);
    lat
}

fn main() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let server = common::Server::start(dir.path(), &["--max-sims", "1000"]);
    rt.block_on(async {
        let reader = server.client().await;
        let sim = reader.new_sim(json!({})).await;
        reader.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
        let alone = loop_reads(&reader, &sim).await;
        let stop = Arc::new(AtomicBool::new(false));
        let creator = {
            let (url, stop) = (server.url.clone(), stop.clone());
            tokio::spawn(async move {
                let c = common::Client::connect(&url).await;
                let mut created = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    let id = c.new_sim(json!({})).await;
                    c.call("destroy_simulation", json!({"sim_id": id})).await;
                    created += 1;
                }
                created
            })
        };
        let beside = loop_reads(&reader, &sim).await;
        stop.store(true, Ordering::Relaxed);
        let created = creator.await.unwrap();
        // The control: a second client as busy, on another simulation, touching no registry
        // lock. What it costs the reader is the machine's cores being shared, not a lock.
        let stop = Arc::new(AtomicBool::new(false));
        let other = {
            let (url, stop) = (server.url.clone(), stop.clone());
            tokio::spawn(async move {
                let c = common::Client::connect(&url).await;
                let sim = c.new_sim(json!({})).await;
                let mut calls = 0u64;
                while !stop.load(Ordering::Relaxed) {
                    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
                    c.call("undo", json!({"sim_id": sim})).await;
                    calls += 2;
                }
                calls
            })
        };
        let control = loop_reads(&reader, &sim).await;
        stop.store(true, Ordering::Relaxed);
        let other_calls = other.await.unwrap();
        let (p50a, p99a, p50b, p99b) = (percentile(&alone, 0.5), percentile(&alone, 0.99), percentile(&beside, 0.5), percentile(&beside, 0.99));
        println!("REPORT get_object_state alone (n={CALLS}): p50 {p50a:.3} ms, p99 {p99a:.3} ms");
        println!("REPORT get_object_state beside a create_simulation loop ({created} creates): p50 {p50b:.3} ms, p99 {p99b:.3} ms");
        println!("REPORT p99 ratio beside creates / alone: {:.2}x (target < 2x)", p99b / p99a);
        let (p50c, p99c) = (percentile(&control, 0.5), percentile(&control, 0.99));
        println!("REPORT control: beside another client's add_box/undo loop ({other_calls} calls, no registry lock): p50 {p50c:.3} ms, p99 {p99c:.3} ms, {:.2}x alone", p99c / p99a);
    });
}
