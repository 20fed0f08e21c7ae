//! The noisy neighbour (docs/guarantees.md "Isolation"): a well-behaved client steps and reads
//! its own small simulation while an adversarial client, on the same server, runs every attack
//! on isolation one after another — scaled to CI. It passes when every call of the good
//! client is answered within [`GOOD_WITHIN`], the server's peak memory stays within
//! [`RSS_BOUND_MIB`] of what it held before the attacks, and each attack is refused quickly or
//! does no harm.
//!
//! Ignored in the plain `cargo test` (it measures a whole server's latency and memory, so it
//! runs alone): `.ci/run` runs it with `cargo test --test edges -- --ignored noisy_neighbour`.
//! Seeded: `PHYSICS_SEED=N` repeats the adversary's choices (which attack order, which ids).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common;

use common::{Client, Server};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use serde_json::{json, Value};

/// The longest any call of the good client may take while the attacks run.
const GOOD_WITHIN: Duration = Duration::from_secs(2);
/// The most the server's resident memory may grow above its level before the attacks.
const RSS_BOUND_MIB: u64 = 200;
/// The longest a refusal of an adversary's call may take (accepted calls may wait for work).
const REFUSED_WITHIN: Duration = Duration::from_secs(5);

fn rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status.lines().find(|l| l.starts_with("VmRSS:")).and_then(|l| l.split_whitespace().nth(1)).and_then(|n| n.parse().ok()).unwrap_or(0)
}

fn boxes(n: usize, mass: f64) -> Vec<Value> {
    (0..n)
        .map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [(i % 50) as f64 * 0.3, (i / 50) as f64 * 0.3, 0.1], "mass": mass}}))
        .collect()
}

/// What the adversary saw of one attack: its name, how long its slowest request took, and
/// how many of its requests were refused.
struct Seen {
    attack: &'static str,
    /// The slowest request of all: accepted ones may wait for real work (a queued call for the
    /// step it waits behind).
    slowest: Duration,
    /// The slowest refusal: a refusal is prompt whatever the server is busy with.
    slowest_refusal: Duration,
    refused: usize,
    requests: usize,
}

/// Runs `requests` calls of one attack side by side; each is a future giving "refused?".
async fn attack<F>(name: &'static str, requests: Vec<F>) -> Seen
where
    F: std::future::Future<Output = bool> + Send + 'static,
{
    let n = requests.len();
    let tasks: Vec<_> = requests
        .into_iter()
        .map(|f| {
            tokio::spawn(async move {
                let start = Instant::now();
                let refused = f.await;
                (start.elapsed(), refused)
            })
        })
        .collect();
    let mut seen = Seen { attack: name, slowest: Duration::ZERO, slowest_refusal: Duration::ZERO, refused: 0, requests: n };
    for t in tasks {
        let (took, refused) = t.await.expect("an attack task");
        seen.slowest = seen.slowest.max(took);
        if refused {
            seen.slowest_refusal = seen.slowest_refusal.max(took);
        }
        seen.refused += usize::from(refused);
    }
    seen
}

fn refused(r: Result<Value, String>) -> bool {
    r.is_err()
}

/// Starts a long step on `sim` (seconds) and returns once it holds the simulation: the
/// attacks on a busy simulation run meanwhile and await the returned task at their end.
async fn keep_busy(c: &Arc<Client>, sim: &str) -> tokio::task::JoinHandle<Result<Value, String>> {
    let (c, sim) = (c.clone(), sim.to_string());
    let stepping = tokio::spawn(async move { c.try_call("step_simulation", json!({"sim_id": sim, "steps": 40_000})).await });
    tokio::time::sleep(Duration::from_millis(300)).await;
    stepping
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
#[ignore = "the noisy-neighbour run: .ci/run runs it alone"]
async fn noisy_neighbour() {
    let seed: u64 = std::env::var("PHYSICS_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or_else(rand::random);
    println!("seed={seed}");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let (url, pid) = (server.url.clone(), server.pid());
    let http = reqwest::Client::new();

    // The adversary's worlds, made before the measurement starts.
    let bad = Arc::new(server.client().await);
    let big = bad.new_sim(json!({})).await;
    bad.call("batch", json!({"sim_id": big, "calls": boxes(1_000, 1.0)})).await;
    let five_hundred = bad.new_sim(json!({})).await;
    bad.call("batch", json!({"sim_id": five_hundred, "calls": boxes(500, 0.0)})).await;
    let statics = bad.new_sim(json!({})).await;
    bad.call("batch", json!({"sim_id": statics, "calls": boxes(2_000, 0.0)})).await;
    let busy = bad.new_sim(json!({})).await;
    bad.call("batch", json!({"sim_id": busy, "calls": boxes(200, 1.0)})).await;
    let long = bad.new_sim(json!({"gui": true})).await;
    bad.call("batch", json!({"sim_id": long, "calls": boxes(50, 1.0)})).await;
    let steps: Vec<Value> = (0..2_000).map(|_| json!({"tool": "step_simulation", "arguments": {"steps": 1}})).collect();
    bad.call("batch", json!({"sim_id": long, "calls": steps})).await;

    // The good client: its own small simulation, stepped and read in a loop.
    let good = server.client().await;
    let mine = good.new_sim(json!({"gui": true})).await;
    good.ground(&mine).await;
    good.call("add_box", json!({"sim_id": mine, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    let start_rss = rss_kib(pid);
    let done = Arc::new(AtomicBool::new(false));
    let peak = Arc::new(AtomicU64::new(start_rss));
    let sampler = {
        let (done, peak) = (done.clone(), peak.clone());
        tokio::spawn(async move {
            while !done.load(Ordering::Relaxed) {
                peak.fetch_max(rss_kib(pid), Ordering::Relaxed);
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
    };
    let good_latencies = Arc::new(Mutex::new(Vec::<(String, Duration)>::new()));
    let good_loop = {
        let (done, lat, mine, url, http) = (done.clone(), good_latencies.clone(), mine.clone(), url.clone(), http.clone());
        tokio::spawn(async move {
            let viewer = url.replace("/mcp", &format!("/viewer/{mine}/poses"));
            let mut i = 0u64;
            while !done.load(Ordering::Relaxed) {
                i += 1;
                let timed = |what: String, start: Instant| lat.lock().unwrap().push((what, start.elapsed()));
                let t = Instant::now();
                good.step(&mine, 10).await;
                timed("step_simulation".into(), t);
                let t = Instant::now();
                good.state(&mine, 1).await;
                timed("get_object_state".into(), t);
                if i.is_multiple_of(5) {
                    let t = Instant::now();
                    good.call("list_simulations", json!({})).await;
                    timed("list_simulations".into(), t);
                    let t = Instant::now();
                    let r = http.get(&viewer).send().await.expect("the good client's viewer");
                    assert!(r.status().is_success(), "the good client's viewer answered {}", r.status());
                    timed("viewer poses".into(), t);
                }
                if i.is_multiple_of(20) {
                    let t = Instant::now();
                    let s = good.new_sim(json!({})).await;
                    good.call("destroy_simulation", json!({"sim_id": s})).await;
                    timed("create+destroy".into(), t);
                }
            }
            good
        })
    };

    // The attacks, in a seeded order.
    type Attack = Box<dyn FnOnce() -> std::pin::Pin<Box<dyn std::future::Future<Output = Seen> + Send>> + Send>;
    let mut attacks: Vec<Attack> = Vec::new();
    {
        let bad = bad.clone();
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let calls = (0..8).map(|_| {
                    let bad = bad.clone();
                    async move {
                        let mut args = serde_json::Map::new();
                        args.insert("x".repeat(4_000_000), json!(1));
                        refused(bad.try_call("generate_revolute_joint", Value::Object(args)).await)
                    }
                });
                attack("4 MB unknown parameter names", calls.collect()).await
            })
        }));
    }
    {
        let (bad, busy) = (bad.clone(), busy.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let stepping = keep_busy(&bad, &busy).await;
                let calls = (0..600).map(|_| {
                    let (bad, busy) = (bad.clone(), busy.clone());
                    async move { refused(bad.try_call("get_history", json!({"sim_id": busy})).await) }
                });
                let seen = attack("600 calls parked on a busy simulation", calls.collect()).await;
                let _ = stepping.await;
                seen
            })
        }));
    }
    {
        let (bad, busy, http, url) = (bad.clone(), busy.clone(), http.clone(), url.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let stepping = keep_busy(&bad, &busy).await;
                // A past moment of a busy simulation: a few are answered when it is free, the
                // rest told "ask again" (202) at once, none holding a thread meanwhile.
                let calls = (0..60).map(|_| {
                    let (http, ask) = (http.clone(), url.replace("/mcp", &format!("/viewer/{busy}/poses?seq=1")));
                    async move { http.get(&ask).send().await.map_or(true, |r| r.status().as_u16() != 200) }
                });
                let seen = attack("60 viewer asks of a busy simulation", calls.collect()).await;
                let _ = stepping.await;
                seen
            })
        }));
    }
    {
        let (bad, sim) = (bad.clone(), five_hundred.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let calls = [200usize, 1_000].into_iter().map(|n| {
                    let (bad, sim) = (bad.clone(), sim.clone());
                    async move {
                        let reads: Vec<Value> = (0..n).map(|_| json!({"tool": "get_simulation_info", "arguments": {}})).collect();
                        refused(bad.try_call("batch", json!({"sim_id": sim, "calls": reads})).await)
                    }
                });
                attack("batches of 200 and 1,000 reads of 500 objects", calls.collect()).await
            })
        }));
    }
    {
        let (bad, sim) = (bad.clone(), statics.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let steps: Vec<Value> = (0..400).map(|_| json!({"tool": "step_simulation", "arguments": {"steps": 51}})).collect();
                let call = async move { refused(bad.try_call("batch", json!({"sim_id": sim, "calls": steps})).await) };
                attack("a batch of 400 step calls on 2,000 boxes", vec![call]).await
            })
        }));
    }
    {
        let (bad, sim) = (bad.clone(), big.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let variants: Vec<Value> = (0..128).map(|_| json!([])).collect();
                let call = async move { refused(bad.try_call("run_sweep", json!({"sim_id": sim, "variants": variants, "steps": 1})).await) };
                attack("a sweep of 128 variants of 1,000 objects", vec![call]).await
            })
        }));
    }
    {
        let url = url.clone();
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let client = Client::connect(&url).await;
                let calls = (0..20).map(|i| {
                    let peer = client.service.peer().clone();
                    async move {
                        let uri = format!("sim://{}{i}/info", "u".repeat(3_000_000));
                        #[allow(deprecated)]
                        let r = peer.subscribe(rmcp::model::SubscribeRequestParams::new(uri)).await;
                        r.is_err()
                    }
                });
                let seen = attack("20 subscriptions of 3 MB URIs", calls.collect()).await;
                drop(client);
                seen
            })
        }));
    }
    {
        let (http, url, sim) = (http.clone(), url.clone(), long.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let calls = (0..4).map(|k| {
                    let (http, url, sim) = (http.clone(), url.clone(), sim.clone());
                    async move {
                        let ask = url.replace("/mcp", &format!("/viewer/{sim}/object?id={}", 99_999 + k));
                        // The browser gives up after half a second.
                        match tokio::time::timeout(Duration::from_millis(500), http.get(&ask).send()).await {
                            Ok(Ok(r)) => !r.status().is_success(),
                            _ => true,
                        }
                    }
                });
                attack("viewer asks for objects that never existed", calls.collect()).await
            })
        }));
    }
    {
        let (bad, sim, http, url) = (bad.clone(), long.clone(), http.clone(), url.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let call = async move {
                    for _ in 0..20 {
                        let fork = bad.call("fork_simulation", json!({"sim_id": sim})).await["simulation_id"].as_str().unwrap().to_string();
                        let _ = http.get(url.replace("/mcp", &format!("/viewer/{fork}/timeline"))).send().await;
                        bad.call("destroy_simulation", json!({"sim_id": fork})).await;
                    }
                    false
                };
                attack("20 rounds of fork, timeline, destroy", vec![call]).await
            })
        }));
    }
    {
        let (bad, sim) = (bad.clone(), long.clone());
        attacks.push(Box::new(move || {
            Box::pin(async move {
                let call = async move { refused(bad.try_call("render_animation", json!({"sim_id": sim, "to_seq": 99_999, "output_path": "a/b/c.gif"})).await) };
                attack("a refused animation with an output folder", vec![call]).await
            })
        }));
    }
    attacks.shuffle(&mut rng);
    // Last: the sessions it opens push out idle ones, the adversary's own among them. The
    // adversary is another client (its own bearer token; this server has none, so any passes):
    // on one loopback address with no token every client is one (docs/tools.md
    // `--max-sessions-per-client`), and one client's flood may end its own idle sessions.
    {
        let mut auth = reqwest::header::HeaderMap::new();
        auth.insert(reqwest::header::AUTHORIZATION, "Bearer the-adversary".parse().unwrap());
        let http = reqwest::Client::builder().default_headers(auth).build().unwrap();
        let url = url.clone();
        attacks.push(Box::new(move || {
            Box::pin(async move {
                // 64 connections at a time: a thousand at once overflow the kernel's accept
                // queue, which resets connections before the server sees them.
                let gate = Arc::new(tokio::sync::Semaphore::new(64));
                let calls = (0..1_000).map(|_| {
                    let (http, url, gate) = (http.clone(), url.clone(), gate.clone());
                    async move {
                        let _one = gate.acquire_owned().await.unwrap();
                        // Only the initialize is judged: the adversary's own older sessions
                        // (idle, so first to go) may be ended before their `initialized`.
                        let init = json!({"jsonrpc": "2.0", "id": 0, "method": "initialize", "params": {
                            "protocolVersion": "2025-11-25", "capabilities": {}, "clientInfo": {"name": "flood", "version": "0"}}});
                        let sent = http.post(&url).header("Accept", "application/json, text/event-stream").json(&init).send().await;
                        sent.map_or(true, |r| r.status().as_u16() != 200)
                    }
                });
                attack("1,000 sessions opened and left idle", calls.collect()).await
            })
        }));
    }
    let mut seen = Vec::new();
    for a in attacks {
        let s = a().await;
        println!(
            "{:<50} {:>5} requests, {:>5} refused (slowest refusal {:?}), slowest {:?}",
            s.attack, s.requests, s.refused, s.slowest_refusal, s.slowest
        );
        seen.push(s);
    }
    done.store(true, Ordering::Relaxed);
    let _good = good_loop.await.expect("the good client's loop");
    sampler.await.unwrap();
    let grew_mib = (peak.load(Ordering::Relaxed).saturating_sub(start_rss)) / 1024;
    let latencies = good_latencies.lock().unwrap().clone();
    let worst = latencies.iter().max_by_key(|(_, d)| *d).cloned().expect("the good client made calls");
    println!("good client: {} calls, slowest {:?} ({}); server memory grew by {grew_mib} MiB at its peak", latencies.len(), worst.1, worst.0);
    assert!(!server.workspace.join("a").exists(), "a refused call made a folder");
    for s in &seen {
        assert!(s.slowest_refusal <= REFUSED_WITHIN, "{}: a refusal took {:?}", s.attack, s.slowest_refusal);
    }
    assert!(worst.1 <= GOOD_WITHIN, "the good client waited {:?} for {} (seed={seed})", worst.1, worst.0);
    assert!(grew_mib <= RSS_BOUND_MIB, "the server's memory grew by {grew_mib} MiB (seed={seed})");
}
