//! Concurrent clients and a SIGTERM at any moment lose nothing that was acknowledged and leave
//! nothing half made. Several clients, each its own MCP session, issue a seeded mix of
//! create_simulation, fork_simulation, run_sweep (kept and not), batch (adds and steps),
//! step_simulation (short and long), undo/redo, reads (get_object_state,
//! get_simulation_info, get_history, list_simulations), save_simulation/load_simulation and
//! destroy_simulation on each other's simulations; at a seeded moment the server gets SIGTERM
//! and must exit within 10 s. Every reply before that is a result or a one-sentence refusal
//! (no panic, no "Internal error"). After a restart: nothing is listed damaged, no partial file
//! is left, every file in the data directory is a listed simulation's, every simulation
//! verifies and its log replays; every acknowledged state-changing call is in its log — the
//! simulation exists unless its destroy was acknowledged, and its log holds the acknowledged
//! head with the acknowledged state hash (create, fork, load, kept sweep variants, batch,
//! step, undo, redo, and the head a get_simulation_info reported); an acknowledged destroy
//! left no file; and every acknowledged read was flushed into its log.
//!
//! The seed decides the calls and the moment of the signal (the interleaving itself is up to
//! the scheduler): `PHYSICS_SEED=N` replays a run's choices. Rounds (each a fresh server and
//! its own seed derived from the main one): `PHYSICS_INTERLEAVE_ROUNDS` (default 4).

use crate::common;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::hard::{listed, rng, seed};
use common::{Client, Server};
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rmcp::model::CallToolRequestParams;
use serde_json::{json, Value};

/// Clients running at once.
const CLIENTS: usize = 4;
/// A call before the signal that takes longer than this is a hang.
const WATCHDOG: Duration = Duration::from_secs(60);
const LIMITS: &[&str] = &["--max-sims", "300"];

/// An acknowledged state-changing call: the simulation it made or changed, and the head and
/// state hash its reply (or a later get_simulation_info) reported.
#[derive(Debug, Clone)]
struct Ack {
    sim: String,
    head: Option<u64>,
    hash: Option<String>,
    what: String,
}

/// What the clients saw acknowledged.
#[derive(Default)]
struct Record {
    acks: Vec<Ack>,
    /// Simulations whose destroy_simulation was acknowledged.
    destroyed: BTreeSet<String>,
    /// Simulations whose destroy_simulation was sent and not answered (the signal came
    /// first): they may be gone or not.
    destroying: BTreeSet<String>,
    /// Acknowledged calls logged as reads, per simulation.
    reads: BTreeMap<String, usize>,
    /// Simulations the clients pick from.
    known: Vec<String>,
    /// The base simulations (never destroyed).
    base: Vec<String>,
    /// Refusals before the signal, normalised, with counts.
    refusals: BTreeMap<String, usize>,
    calls: usize,
    accepted: usize,
}

type Shared = Arc<Mutex<Record>>;

/// A refusal with ids and numbers blanked, to count refusals by kind.
fn kind_of(text: &str) -> String {
    let mut out = String::new();
    let mut last_hash = false;
    for w in text.split_whitespace() {
        let hex = w.trim_matches(|c: char| !c.is_ascii_alphanumeric()).chars().filter(|c| c.is_ascii_hexdigit() || *c == '-').count();
        let blank = w.len() >= 8 && hex * 10 >= w.len() * 8 || w.chars().any(|c| c.is_ascii_digit());
        if blank {
            if !last_hash {
                out.push_str("# ");
            }
            last_hash = true;
        } else {
            out.push_str(w);
            out.push(' ');
            last_hash = false;
        }
    }
    out.trim_end().chars().take(160).collect()
}

/// A refusal is one sentence: no panic text, no backtrace, no "Internal error".
fn one_sentence(text: &str, what: &str) {
    assert!(!text.trim().is_empty() && !text.contains('\n'), "{what}: not one sentence: {text:?}");
    for bad in ["panicked", "Internal error", "backtrace", "stack overflow", ".rs:"] {
        assert!(!text.contains(bad), "{what}: the refusal says {bad:?}: {text}");
    }
}

/// A batch of adds and steps (sim_id left out, as batch allows).
fn batch_calls(rng: &mut ChaCha8Rng) -> Value {
    let calls: Vec<Value> = (0..rng.gen_range(1..12))
        .map(|_| match rng.gen_range(0..10) {
            0..=4 => json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0), rng.gen_range(0.2..2.0)]}}),
            5 => json!({"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [rng.gen_range(-2.0..2.0), 0, 1]}}),
            6 => json!({"tool": "set_object_velocity", "arguments": {"object_id": 0, "linear_velocity": [0, 0, 0]}}),
            _ => json!({"tool": "step_simulation", "arguments": {"steps": rng.gen_range(1..20)}}),
        })
        .collect();
    json!(calls)
}

/// A sweep's variants: adds, pushes and steps.
fn variants(rng: &mut ChaCha8Rng) -> Value {
    let v: Vec<Value> = (0..rng.gen_range(1..5))
        .map(|i| {
            json!([
                {"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [i as f64 * 0.3, 0, 1]}},
                {"tool": "apply_force", "arguments": {"object_id": 0, "force": [rng.gen_range(-5.0..5.0), 0, 0]}}
            ])
        })
        .collect();
    json!(v)
}

fn hash(v: &Value) -> Option<String> {
    v["state_hash"].as_str().map(str::to_string)
}

/// One client: seeded calls until the signal (or `calls` calls). Records what was
/// acknowledged; a call that gets no answer after the signal is not acknowledged.
async fn client(url: String, shared: Shared, seed: u64, calls: usize, stopping: Arc<AtomicBool>, me: usize) {
    let c = Client::connect(&url).await;
    let mut rng = rng(seed);
    let mut mine: Vec<String> = Vec::new();
    for i in 0..calls {
        if stopping.load(Ordering::SeqCst) {
            return;
        }
        let (sim, base) = {
            let r = lock(&shared);
            (r.known.choose(&mut rng).cloned().unwrap_or_default(), r.base.clone())
        };
        let save = format!("save{}.json", rng.gen_range(0..4));
        let (tool, args): (&str, Value) = match rng.gen_range(0..100) {
            0..=4 => ("create_simulation", json!({})),
            5..=10 => {
                if rng.gen_bool(0.2) {
                    ("fork_simulation", json!({"sim_id": sim, "at_seq": rng.gen_range(1..6)}))
                } else {
                    ("fork_simulation", json!({"sim_id": sim}))
                }
            }
            11..=15 => {
                let mut a = json!({"sim_id": sim, "variants": variants(&mut rng), "steps": rng.gen_range(1..40), "keep": rng.gen_bool(0.5)});
                if rng.gen_bool(0.3) {
                    a["observe"] = json!({"every": rng.gen_range(1..10), "include_velocities": true});
                }
                ("run_sweep", a)
            }
            16..=27 => ("batch", json!({"sim_id": sim, "calls": batch_calls(&mut rng)})),
            28..=39 => {
                // Now and then a long one (not on the large simulation, whose forks every
                // replay would then re-simulate).
                let long = rng.gen_bool(0.05) && base.first() != Some(&sim);
                let steps = if long { rng.gen_range(1_000..4_000) } else { rng.gen_range(1..60) };
                ("step_simulation", json!({"sim_id": sim, "steps": steps}))
            }
            40..=44 => ("undo", json!({"sim_id": sim})),
            45..=47 => ("redo", json!({"sim_id": sim})),
            48..=57 => ("get_object_state", json!({"sim_id": sim, "object_id": rng.gen_range(0..4)})),
            58..=67 => ("get_simulation_info", json!({"sim_id": sim})),
            68..=72 => ("get_history", json!({"sim_id": sim, "since_seq": rng.gen_range(0..20), "limit": rng.gen_range(1..50)})),
            73..=77 => ("list_simulations", json!({})),
            78..=82 => ("save_simulation", json!({"sim_id": sim, "file_path": save})),
            83..=87 => ("load_simulation", json!({"file_path": save})),
            _ => {
                // Mostly a simulation this client made; sometimes any but the base ones.
                let target = if rng.gen_bool(0.7) { mine.choose(&mut rng).cloned() } else { Some(sim.clone()) };
                match target.filter(|t| !base.contains(t)) {
                    Some(t) => ("destroy_simulation", json!({"sim_id": t})),
                    None => ("get_simulation_info", json!({"sim_id": sim})),
                }
            }
        };
        let what = format!("client {me} call {i}: {tool} {}", args.to_string().chars().take(200).collect::<String>());
        if tool == "destroy_simulation" {
            lock(&shared).destroying.insert(args["sim_id"].as_str().unwrap().to_string());
        }
        let call = c.service.call_tool(CallToolRequestParams::new(tool).with_arguments(args.as_object().unwrap().clone()));
        let reply = call_within(call).await;
        // Answered, the destroy's outcome is known; unanswered, it stays in `destroying`.
        if tool == "destroy_simulation" && matches!(reply, Ok(Ok(_))) {
            lock(&shared).destroying.remove(args["sim_id"].as_str().unwrap());
        }
        let reply = match reply {
            Ok(Ok(r)) => r,
            Ok(Err(e)) => {
                assert!(stopping.load(Ordering::SeqCst), "{what}: the request failed before the signal: {e}");
                return;
            }
            Err(_) => {
                assert!(stopping.load(Ordering::SeqCst), "{what}: no answer within {WATCHDOG:?} before the signal");
                return;
            }
        };
        let follow_up = {
            let mut follow_up = false;
            let mut r = lock(&shared);
            r.calls += 1;
            if reply.is_error == Some(true) {
                let text = reply.content.iter().filter_map(|c| c.as_text().map(|t| t.text.clone())).collect::<Vec<_>>().join(" ");
                one_sentence(&text, &what);
                if !stopping.load(Ordering::SeqCst) {
                    // Refusals of the calls themselves (not found, nothing to undo, the
                    // limit) are expected; the server's own trouble is not.
                    for trouble in ["could not be recorded", "disk I/O", "damaged", "corrupt", "could not write", "could not read", "database"] {
                        assert!(!text.contains(trouble), "{what}: refused for the server's own trouble: {text}");
                    }
                    *r.refusals.entry(format!("{tool}: {}", kind_of(&text))).or_default() += 1;
                }
                continue;
            }
            r.accepted += 1;
            let v = reply.structured_content.unwrap_or(Value::Null);
            let mut ack = |sim: &str, head: Option<u64>, hash: Option<String>| {
                r.acks.push(Ack { sim: sim.to_string(), head, hash, what: what.clone() });
            };
            match tool {
                "create_simulation" | "fork_simulation" | "load_simulation" => {
                    let id = v["simulation_id"].as_str().unwrap_or_else(|| panic!("{what}: no simulation_id in {v}")).to_string();
                    ack(&id, None, hash(&v));
                    r.known.push(id.clone());
                    mine.push(id);
                }
                "run_sweep" => {
                    *r.reads.entry(sim.clone()).or_default() += 1;
                    for variant in v["variants"].as_array().into_iter().flatten() {
                        if let Some(id) = variant["simulation_id"].as_str() {
                            r.acks.push(Ack { sim: id.to_string(), head: None, hash: hash(variant), what: what.clone() });
                            r.known.push(id.to_string());
                            mine.push(id.to_string());
                        }
                    }
                }
                "batch" | "undo" | "redo" => ack(&sim, v["head_seq"].as_u64(), hash(&v)),
                // A step's reply carries no head or hash: a get_simulation_info after it does.
                "step_simulation" => {
                    ack(&sim, v["head_seq"].as_u64(), hash(&v));
                    follow_up = true;
                }
                "get_simulation_info" => {
                    // What a read reports was committed: it must be in the log.
                    ack(&sim, v["head_seq"].as_u64(), hash(&v));
                    *r.reads.entry(sim.clone()).or_default() += 1;
                }
                "get_object_state" | "get_history" | "save_simulation" => *r.reads.entry(sim.clone()).or_default() += 1,
                "list_simulations" => {
                    let (ids, damaged) = listed(&v);
                    assert!(damaged.is_empty(), "{what}: damaged while running: {damaged:?}");
                    for id in ids {
                        if !r.known.contains(&id) && !r.destroyed.contains(&id) {
                            r.known.push(id);
                        }
                    }
                }
                "destroy_simulation" => {
                    let target = args["sim_id"].as_str().unwrap().to_string();
                    r.known.retain(|k| *k != target);
                    mine.retain(|k| *k != target);
                    r.destroyed.insert(target);
                }
                _ => {}
            }
            follow_up
        };
        if follow_up && rng.gen_bool(0.5) {
            let args = json!({"sim_id": sim}).as_object().unwrap().clone();
            let call = c.service.call_tool(CallToolRequestParams::new("get_simulation_info").with_arguments(args));
            match tokio::time::timeout(WATCHDOG, call).await {
                Ok(Ok(info)) if info.is_error != Some(true) => {
                    let v = info.structured_content.unwrap_or(Value::Null);
                    let mut r = lock(&shared);
                    r.acks.push(Ack { sim: sim.clone(), head: v["head_seq"].as_u64(), hash: hash(&v), what: format!("get_simulation_info after {what}") });
                    *r.reads.entry(sim.clone()).or_default() += 1;
                }
                Ok(Ok(_)) => {}
                _ => {
                    assert!(stopping.load(Ordering::SeqCst), "{what}: the get_simulation_info after it got no answer before the signal");
                    return;
                }
            }
        }
    }
}

/// A call under the watchdog.
async fn call_within<T>(call: impl std::future::Future<Output = T>) -> Result<T, tokio::time::error::Elapsed> {
    tokio::time::timeout(WATCHDOG, call).await
}

/// The record, even after a client panicked holding it (its panic is the failure to see).
fn lock(shared: &Shared) -> std::sync::MutexGuard<'_, Record> {
    shared.lock().unwrap_or_else(|e| e.into_inner())
}

/// One round: a fresh server, base simulations, clients, SIGTERM at a seeded moment, a
/// restart and every check.
async fn round(seed: u64, round: usize) {
    let mut rng = rng(seed);
    let what = |s: &str| format!("round {round} (round seed {seed}): {s}");
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), LIMITS);
    let shared: Shared = Arc::default();
    {
        let c = server.client().await;
        let mut base = Vec::new();
        for i in 0..3 {
            let sim = c.new_sim(json!({})).await;
            c.ground(&sim).await;
            // One larger simulation, so steps on it take a while.
            let boxes = if i == 0 { 80 } else { 4 };
            let calls: Vec<Value> = (0..boxes)
                .map(|k| json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [f64::from(k % 12) * 0.25 - 1.5, f64::from(k / 12) * 0.25 - 1.5, 0.3 + f64::from(k % 3) * 0.3]}}))
                .collect();
            let b = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
            let ack = Ack { sim: sim.clone(), head: b["head_seq"].as_u64(), hash: b["state_hash"].as_str().map(str::to_string), what: "setup".into() };
            lock(&shared).acks.push(ack);
            base.push(sim);
        }
        let mut r = lock(&shared);
        r.known = base.clone();
        r.base = base;
    }
    // Clients, then the signal at a seeded moment.
    let stopping = Arc::new(AtomicBool::new(false));
    let clients: Vec<_> = (0..CLIENTS)
        .map(|i| tokio::spawn(client(server.url.clone(), shared.clone(), rng.gen(), 100_000, stopping.clone(), i)))
        .collect();
    let kill_after = Duration::from_millis(rng.gen_range(300..6_000));
    tokio::time::sleep(kill_after).await;
    for c in &clients {
        assert!(!c.is_finished(), "{}", what("a client ended before the signal (see its panic above)"));
    }
    stopping.store(true, Ordering::SeqCst);
    let (data, stderr) = (server.data.clone(), server.stderr.clone());
    let took = tokio::task::spawn_blocking(move || server.terminate_within(Duration::from_secs(10))).await.unwrap();
    // A reply the server sent before it exited is in the client's hands within moments; a
    // call still waiting then will never be answered (rmcp's client may keep retrying its
    // stream), so it is not acknowledged and its client is stopped.
    tokio::time::sleep(Duration::from_secs(2)).await;
    for c in clients {
        if c.is_finished() {
            if let Err(e) = c.await {
                std::panic::resume_unwind(e.into_panic());
            }
        } else {
            c.abort();
        }
    }
    let mut partial_at_exit: Vec<String> = std::fs::read_dir(&data)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| physics_mcp::log::sqlite::is_partial(n))
        .collect();
    partial_at_exit.sort();
    // Fork and load build their log under `<id>.partial`; a background checkpoint of it that
    // outlived the Log once left `<id>.partial-wal`/`-shm` beside the published log (seen in
    // nearly every round before `Drop for Log` waited for it).
    assert!(partial_at_exit.is_empty(), "{}", what(&format!("partial files left by a clean exit: {partial_at_exit:?}")));
    let panics: Vec<String> = stderr.lock().unwrap().iter().filter(|l| l.contains("panicked")).cloned().collect();
    assert!(panics.is_empty(), "{}", what(&format!("the server panicked: {panics:?}")));
    let record = std::mem::take(&mut *lock(&shared));
    eprintln!(
        "round {round}: SIGTERM after {kill_after:?}, exit took {took:?}; {} calls answered ({} accepted), {} acknowledged changes, {} destroys ({} unanswered); partial files at exit: {:?}",
        record.calls,
        record.accepted,
        record.acks.len(),
        record.destroyed.len(),
        record.destroying.len(),
        partial_at_exit
    );

    // The restart.
    let server = Server::start(dir.path(), LIMITS);
    let c = server.client().await;
    let (live, damaged) = listed(&c.call("list_simulations", json!({})).await);
    assert!(damaged.is_empty(), "{}", what(&format!("damaged after the restart: {damaged:?}")));
    let mut names: Vec<String> = std::fs::read_dir(&server.data).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    for n in &names {
        assert!(!physics_mcp::log::sqlite::is_partial(n), "{}", what(&format!("partial file left after the restart: {n}")));
        if let Some(id) = n.split('.').next().filter(|_| n.contains(".sqlite")) {
            assert!(live.iter().any(|l| l == id), "{}", what(&format!("{n} is in the data directory but {id} is not listed")));
        }
    }
    for id in &record.destroyed {
        assert!(!live.contains(id), "{}", what(&format!("{id} is listed after its destroy was acknowledged")));
        assert!(!server.data.join(format!("{id}.sqlite")).exists(), "{}", what(&format!("{id}'s log is left after its destroy was acknowledged")));
    }
    let mut logs: BTreeMap<String, Vec<physics_mcp::log::Event>> = BTreeMap::new();
    for ack in record.acks.iter().filter(|a| !record.destroyed.contains(&a.sim)) {
        let shown = format!("{} acknowledged by {} (head {:?}, hash {:?})", ack.sim, ack.what, ack.head, ack.hash);
        if record.destroying.contains(&ack.sim) && !live.contains(&ack.sim) {
            continue; // its destroy was sent and not answered: it may have happened
        }
        assert!(live.contains(&ack.sim), "{}", what(&format!("{shown}: the simulation is gone")));
        let events = logs.entry(ack.sim.clone()).or_insert_with(|| {
            physics_mcp::log::replay::events(&server.data.join(format!("{}.sqlite", ack.sim))).unwrap_or_else(|e| panic!("{shown}: the log cannot be read: {e}"))
        });
        let changes = |e: &&physics_mcp::log::Event| matches!(e.kind.as_str(), "root" | "change" | "move");
        match (ack.head, &ack.hash) {
            (Some(head), hash) => {
                let e = events.iter().find(|e| e.seq == head).unwrap_or_else(|| panic!("{}", what(&format!("{shown}: no event {head} in the log"))));
                assert!(changes(&e), "{}", what(&format!("{shown}: event {head} is a {}", e.kind.as_str())));
                if let Some(hash) = hash {
                    assert_eq!(&e.state_hash, hash, "{}", what(&format!("{shown}: event {head} has another state hash")));
                }
            }
            (None, Some(hash)) => {
                assert!(events.iter().filter(changes).any(|e| &e.state_hash == hash), "{}", what(&format!("{shown}: no event with that state hash")));
            }
            (None, None) => {}
        }
    }
    for (sim, acked) in record.reads.iter().filter(|(s, _)| !record.destroyed.contains(*s)) {
        if !live.contains(sim) {
            continue; // never made known as live: a read of a simulation destroyed unacknowledged
        }
        let events = logs.entry(sim.clone()).or_insert_with(|| physics_mcp::log::replay::events(&server.data.join(format!("{sim}.sqlite"))).unwrap());
        let logged = events.iter().filter(|e| e.kind.as_str() == "read" && !e.inherited).count();
        assert!(logged >= *acked, "{}", what(&format!("{sim}: {acked} reads were answered but {logged} are in the log")));
    }
    let started = Instant::now();
    for id in &live {
        let v = c.call("verify_simulation", json!({"sim_id": id})).await;
        assert_eq!(v["ok"], json!(true), "{}", what(&format!("{id} does not verify: {v}")));
        common::assert_replays(&server.data, id);
    }
    let mut kinds: Vec<_> = record.refusals.iter().collect();
    kinds.sort_by(|a, b| b.1.cmp(a.1));
    eprintln!(
        "round {round}: {} simulations verified and replayed in {:.1} s; refusals by kind: {:?}",
        live.len(),
        started.elapsed().as_secs_f64(),
        kinds.iter().take(12).collect::<Vec<_>>()
    );
    tokio::task::spawn_blocking(move || server.terminate_within(Duration::from_secs(10))).await.unwrap();
}

#[tokio::test(flavor = "multi_thread")]
async fn acknowledged_calls_survive_any_interleaving_and_a_sigterm_anywhere() {
    let seed = seed();
    let rounds: usize = std::env::var("PHYSICS_INTERLEAVE_ROUNDS").ok().and_then(|s| s.parse().ok()).unwrap_or(4);
    let mut rng = rng(seed);
    let started = Instant::now();
    for r in 0..rounds {
        round(rng.gen(), r).await;
    }
    eprintln!("{rounds} rounds in {:.1} s (seed={seed})", started.elapsed().as_secs_f64());
}
