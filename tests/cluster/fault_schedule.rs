//! A seeded fault schedule over three nodes and three NATS servers, judged by its history
//! (Jepsen-style, bounded). Clients call every kind of tool — changes, reads,
//! batches over 1 MiB, kept sweeps, forks, destroys, exports — through random nodes as
//! stateless requests (a round-robin balancer's traffic), while the schedule pauses
//! (SIGSTOP/SIGCONT) and kills nodes and NATS servers and starts them again (at most one NATS
//! server down or paused at a time, so three-way replication keeps its majority; at most one
//! node). Every call's invocation and completion is recorded; afterwards the history must say:
//!
//! - every acknowledged change is in its simulation's exported log exactly once, at the head
//!   its reply named, with the result it replied, and in the order the calls were made;
//!   a refused one is not there, one of unknown fate at most once; every exported log replays;
//! - no read returns a state older than a change acknowledged before the read was sent, and
//!   no read finds a simulation whose destroy was acknowledged before it;
//! - every id a reply names exists, or was destroyed by a destroy that was not refused;
//! - no call waits past its deadline, and no export hangs.
//!
//! Real processes cannot be replayed from a seed alone, so a failing run keeps its schedule
//! and its history as files (the path is printed); `PHYSICS_FAULT_SCHEDULE=that/schedule.json`
//! runs that schedule again. `PHYSICS_FAULT_SECONDS` sets how long faults are injected
//! (default 100: `.ci/run`'s share; longer runs on demand), `PHYSICS_SEED` the seed, and
//! `PHYSICS_FAULT_KEEP` where failing runs are kept (default `target/fault-schedule`).
//! Judged by histories, never by timings: a slow machine makes a run slower, not red.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rand::Rng;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use crate::common::hard::{rng, seed};
use crate::nats::NatsCluster;
use crate::nodes::{attempt_stateless, event_args, event_result, events, shared_workspace, signal, Node, Outcome};

/// Seconds of faults by default (`PHYSICS_FAULT_SECONDS` overrides).
const DEFAULT_SECONDS: u64 = 100;
/// A call not answered within this has hung (generous: a takeover of a big log after a kill
/// on two loaded cores takes seconds, not this).
const CALL_DEADLINE: Duration = Duration::from_secs(60);
/// Concurrent clients.
const CLIENTS: usize = 4;
/// The nodes' lease.
const LEASE_MS: &str = "1500";
/// Nodes and NATS servers.
const NODES: usize = 3;
/// Calls in the one batch over 1 MiB a run makes.
const BIG_BATCH: usize = 6000;

/// One fault of the schedule.
#[derive(Serialize, Deserialize, Clone, Debug)]
enum Fault {
    /// SIGSTOP node `node`, SIGCONT after `ms`.
    PauseNode { node: usize, ms: u64 },
    /// kill -9 node `node`, start it again after `ms`.
    KillNode { node: usize, ms: u64 },
    /// SIGSTOP NATS server `server`, SIGCONT after `ms`.
    PauseNats { server: usize, ms: u64 },
    /// kill -9 NATS server `server`, start it again after `ms`.
    KillNats { server: usize, ms: u64 },
}

/// A fault and when it begins, from the start of the run.
#[derive(Serialize, Deserialize, Clone, Debug)]
struct Step {
    at_ms: u64,
    fault: Fault,
}

/// A run's faults: what a failing run keeps, and what `PHYSICS_FAULT_SCHEDULE` replays.
#[derive(Serialize, Deserialize, Clone, Debug)]
struct Schedule {
    seed: u64,
    seconds: u64,
    steps: Vec<Step>,
}

impl Schedule {
    /// Faults every 2–6 s, each over before the next begins (one node and one NATS server at
    /// most are affected at a time, and never both at once).
    fn generate(seed: u64, seconds: u64) -> Schedule {
        let mut r = rng(seed ^ 0x5eed_fa17);
        let mut steps = Vec::new();
        let mut at = 3000u64;
        while at < seconds * 1000 {
            let fault = match r.gen_range(0..10) {
                0..=3 => Fault::PauseNode { node: r.gen_range(0..NODES), ms: r.gen_range(500..4000) },
                4..=5 => Fault::KillNode { node: r.gen_range(0..NODES), ms: r.gen_range(500..3000) },
                6..=7 => Fault::PauseNats { server: r.gen_range(0..3), ms: r.gen_range(500..3000) },
                _ => Fault::KillNats { server: r.gen_range(0..3), ms: r.gen_range(1000..5000) },
            };
            let length = match &fault {
                Fault::PauseNode { ms, .. } | Fault::KillNode { ms, .. } | Fault::PauseNats { ms, .. } | Fault::KillNats { ms, .. } => *ms,
            };
            steps.push(Step { at_ms: at, fault });
            at += length + r.gen_range(2000..6000);
        }
        Schedule { seed, seconds, steps }
    }
}

/// What became of a call.
#[derive(Serialize, Deserialize, Clone, Debug)]
#[serde(rename_all = "snake_case")]
enum Fate {
    /// Answered: its structured result.
    Ok(Value),
    /// Refused, and the sentence says nothing was done.
    Refused(String),
    /// Unknown: no answer (a killed node), or a refusal saying it is unknown.
    Unknown(String),
}

/// One call of the history.
#[derive(Serialize, Deserialize, Clone, Debug)]
struct Op {
    client: usize,
    node: usize,
    tool: String,
    /// The simulation it is for (the one it made, for a create).
    sim: Option<String>,
    /// add_box's tag (its x), the one thing that tells two add_box calls apart in a log.
    tag: Option<f64>,
    /// Milliseconds from the start of the run.
    invoked: u64,
    completed: u64,
    fate: Fate,
}

/// The run's shared state: the nodes' URLs (None while down), the simulations the clients
/// know, the history.
struct World {
    started: Instant,
    urls: Mutex<Vec<Option<String>>>,
    sims: Mutex<Vec<String>>,
    history: Mutex<Vec<Op>>,
    tags: AtomicU64,
    big_batch_done: AtomicBool,
    stop: AtomicBool,
    out: PathBuf,
    cluster_urls: String,
}

impl World {
    fn now(&self) -> u64 {
        self.started.elapsed().as_millis() as u64
    }
}

/// How an answer reads: a refusal saying the outcome is unknown is not a refusal.
fn fate_of(outcome: Outcome) -> Fate {
    match outcome {
        Outcome::Ok(v) => Fate::Ok(v),
        Outcome::Refused(e) if e.contains("whether") || e.contains("stopped answering") || e.contains("unknown") => Fate::Unknown(e),
        Outcome::Refused(e) => Fate::Refused(e),
        Outcome::Lost(e) => Fate::Unknown(e),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn a_seeded_fault_schedule_keeps_every_promise() {
    let schedule = match std::env::var("PHYSICS_FAULT_SCHEDULE") {
        Ok(path) => serde_json::from_str(&std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))).unwrap_or_else(|e| panic!("{path}: {e}")),
        Err(_) => {
            let seconds = std::env::var("PHYSICS_FAULT_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(DEFAULT_SECONDS);
            Schedule::generate(seed(), seconds)
        }
    };
    eprintln!("fault schedule: seed {}, {} s, {} faults", schedule.seed, schedule.seconds, schedule.steps.len());
    let mut nats = NatsCluster::start();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let flags = ["--lease-ms", LEASE_MS, "--max-sims", "400"];
    // Takeovers and lease losses are logged (info), so a failing run's kept logs show who
    // served each simulation when.
    let logging = [("RUST_LOG", "warn,physics_mcp::sim::cluster=info,physics_mcp::cluster=info")];
    let mut nodes: Vec<Node> = ["a", "b", "c"].iter().map(|n| Node::start_with_env(root.path(), n, &nats, &workspace, &flags, &logging)).collect();
    let world = Arc::new(World {
        started: Instant::now(),
        urls: Mutex::new(nodes.iter().map(|n| Some(n.server().url.clone())).collect()),
        sims: Mutex::default(),
        history: Mutex::default(),
        tags: AtomicU64::new(0),
        big_batch_done: AtomicBool::new(false),
        stop: AtomicBool::new(false),
        out: root.path().join("exports"),
        cluster_urls: nats.urls(),
    });
    std::fs::create_dir_all(&world.out).unwrap();
    let clients: Vec<_> = (0..CLIENTS).map(|k| tokio::spawn(client(world.clone(), k, schedule.seed.wrapping_add(k as u64)))).collect();

    // The schedule, on this task: faults in order, each healed before the next.
    for step in &schedule.steps {
        let wait = Duration::from_millis(step.at_ms).saturating_sub(world.started.elapsed());
        tokio::time::sleep(wait).await;
        eprintln!("[{:>6} ms] {:?}", world.now(), step.fault);
        tokio::task::block_in_place(|| inject(&step.fault, &mut nodes, &mut nats, &world));
    }
    let end = Duration::from_secs(schedule.seconds).saturating_sub(world.started.elapsed());
    tokio::time::sleep(end).await;
    world.stop.store(true, Ordering::SeqCst);
    for c in clients {
        c.await.unwrap();
    }
    let history = world.history.lock().unwrap().clone();
    eprintln!("{} calls made; checking the history", history.len());
    let verdict = tokio::task::block_in_place(|| judge(&world, &history));
    if let Err(broken) = verdict {
        let keep = keep_run(&schedule, &history, &broken, &nodes);
        panic!("the history breaks {} promise(s); schedule and history kept in {}:\n{}", broken.len(), keep.display(), broken.join("\n"));
    }
}

/// Injects one fault and heals it: the nodes' URLs say which are up meanwhile.
fn inject(fault: &Fault, nodes: &mut [Node], nats: &mut NatsCluster, world: &World) {
    let sleep = |ms: u64| std::thread::sleep(Duration::from_millis(ms));
    match *fault {
        Fault::PauseNode { node, ms } => {
            signal(nodes[node].pid(), "STOP");
            sleep(ms);
            signal(nodes[node].pid(), "CONT");
        }
        Fault::KillNode { node, ms } => {
            world.urls.lock().unwrap()[node] = None;
            nodes[node].kill9();
            sleep(ms);
            nodes[node].restart();
            world.urls.lock().unwrap()[node] = Some(nodes[node].server().url.clone());
        }
        Fault::PauseNats { server, ms } => {
            signal(nats.pid(server), "STOP");
            sleep(ms);
            signal(nats.pid(server), "CONT");
        }
        Fault::KillNats { server, ms } => {
            nats.kill9(server);
            sleep(ms);
            nats.restart(server);
        }
    }
}

/// One client: calls until the run stops, each through a random live node.
async fn client(world: Arc<World>, k: usize, seed: u64) {
    let mut r = rng(seed);
    let http = reqwest::Client::new();
    let mut id = 0u64;
    while !world.stop.load(Ordering::SeqCst) {
        id += 1;
        let live: Vec<(usize, String)> = world.urls.lock().unwrap().iter().enumerate().filter_map(|(i, u)| u.clone().map(|u| (i, u))).collect();
        let Some((node, url)) = live.get(r.gen_range(0..live.len().max(1))).cloned() else {
            tokio::time::sleep(Duration::from_millis(100)).await;
            continue;
        };
        let sim = {
            let sims = world.sims.lock().unwrap();
            (!sims.is_empty()).then(|| sims[r.gen_range(0..sims.len())].clone())
        };
        let roll = r.gen_range(0..100);
        let (tool, args, tag): (&str, Value, Option<f64>) = match (roll, &sim) {
            (_, None) | (0..=1, _) => ("create_simulation", json!({}), None),
            (2..=40, Some(s)) => {
                let tag = 1000.0 + world.tags.fetch_add(1, Ordering::SeqCst) as f64;
                ("add_box", json!({"sim_id": s, "dimensions": [0.05, 0.05, 0.05], "position": [tag, 0.0, 0.5], "mass": 0}), Some(tag))
            }
            (41..=50, Some(s)) => ("step_simulation", json!({"sim_id": s, "steps": 3}), None),
            (51..=75, Some(s)) => ("get_simulation_info", json!({"sim_id": s}), None),
            (76..=77, Some(s)) => ("fork_simulation", json!({"sim_id": s}), None),
            (78..=81, Some(s)) => ("destroy_simulation", json!({"sim_id": s}), None),
            (82..=83, Some(s)) => {
                let variants: Vec<Value> = (0..2).map(|i| json!([{"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [i as f64, 5.0, 1.0]}}])).collect();
                ("run_sweep", json!({"sim_id": s, "variants": variants, "steps": 5, "keep": true}), None)
            }
            (84..=87, Some(s)) => {
                export_op(&world, k, node, s).await;
                continue;
            }
            (_, Some(s)) if !world.big_batch_done.swap(true, Ordering::SeqCst) => {
                let calls: Vec<Value> = (0..BIG_BATCH).map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.02, 0.02, 0.02], "position": [-((i % 100) as f64) * 0.1, (i / 100) as f64 * 0.1, 3.0], "mass": 0}})).collect();
                ("batch", json!({"sim_id": s, "calls": calls}), None)
            }
            (_, Some(s)) => ("get_simulation_info", json!({"sim_id": s}), None),
        };
        let invoked = world.now();
        let outcome = attempt_stateless(&http, &url, id, tool, args, CALL_DEADLINE).await;
        let completed = world.now();
        let fate = fate_of(outcome);
        if let Fate::Ok(v) = &fate {
            let mut sims = world.sims.lock().unwrap();
            match tool {
                "create_simulation" | "fork_simulation" => sims.extend(v["simulation_id"].as_str().map(str::to_string)),
                "run_sweep" => sims.extend(v["variants"].as_array().into_iter().flatten().filter_map(|x| x["simulation_id"].as_str().map(str::to_string))),
                "destroy_simulation" => sims.retain(|x| Some(x) != sim.as_ref()),
                _ => {}
            }
        }
        let sim = match (tool, &fate) {
            ("create_simulation", Fate::Ok(v)) => v["simulation_id"].as_str().map(str::to_string),
            _ => sim,
        };
        world.history.lock().unwrap().push(Op { client: k, node, tool: tool.to_string(), sim, tag, invoked, completed, fate });
    }
}

/// An export of `sim` (the `physics-mcp export` command) during the run: it must end within
/// the deadline; a log it writes must replay.
async fn export_op(world: &World, k: usize, node: usize, sim: &str) {
    let file = world.out.join(format!("{sim}-{}.sqlite", world.now()));
    let invoked = world.now();
    let mut child = Command::new(crate::common::bin())
        .args(["export", &world.cluster_urls, sim, file.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run export");
    let fate = loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut said = String::new();
            if let Some(mut e) = child.stderr.take() {
                use std::io::Read;
                let _ = e.read_to_string(&mut said);
            }
            break if status.success() {
                match crate::nodes::cli(&["replay", file.to_str().unwrap(), "--json"]) {
                    o if o.status.success() => Fate::Ok(json!({"exported": file})),
                    o => Fate::Refused(format!("EXPORTED LOG DOES NOT REPLAY: {}", String::from_utf8_lossy(&o.stdout))),
                }
            } else {
                Fate::Refused(said.trim().to_string())
            };
        }
        if world.now() - invoked > CALL_DEADLINE.as_millis() as u64 {
            let _ = child.kill();
            break Fate::Unknown(format!("no reply within {CALL_DEADLINE:?}: export hung"));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    let _ = std::fs::remove_file(&file);
    world.history.lock().unwrap().push(Op { client: k, node, tool: "export".into(), sim: Some(sim.to_string()), tag: None, invoked, completed: world.now(), fate });
}

/// The history's verdict: every broken promise, one line each.
fn judge(world: &World, history: &[Op]) -> Result<(), Vec<String>> {
    let mut broken = Vec::new();
    for op in history {
        match &op.fate {
            Fate::Unknown(e) if e.contains("no reply within") => broken.push(format!("{} on {:?} waited past its deadline ({e})", op.tool, op.sim)),
            Fate::Refused(e) if e.contains("EXPORTED LOG DOES NOT REPLAY") => broken.push(format!("export of {:?}: {e}", op.sim)),
            Fate::Refused(e) if e.contains("Internal error") => broken.push(format!("{} on {:?}: {e}", op.tool, op.sim)),
            _ => {}
        }
    }
    // Every simulation any reply named, with the calls made on it.
    let mut named: BTreeMap<String, u64> = BTreeMap::new();
    for op in history {
        if let Fate::Ok(v) = &op.fate {
            let ids: Vec<String> = match op.tool.as_str() {
                "create_simulation" | "fork_simulation" => v["simulation_id"].as_str().map(str::to_string).into_iter().collect(),
                "run_sweep" => v["variants"].as_array().into_iter().flatten().filter_map(|x| x["simulation_id"].as_str().map(str::to_string)).collect(),
                _ => Vec::new(),
            };
            for id in ids {
                named.entry(id).or_insert(op.completed);
            }
        }
    }
    // Each simulation on its own (three at a time: each costs an export and a replay).
    let named_list: Vec<(&String, &u64)> = named.iter().collect();
    let found = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for chunk in named_list.chunks(named_list.len().div_ceil(3).max(1)) {
            let found = &found;
            scope.spawn(move || {
                for (sim, named_at) in chunk {
                    let mut mine = Vec::new();
                    check_sim(world, history, sim, **named_at, &mut mine);
                    found.lock().unwrap().extend(mine);
                }
            });
        }
    });
    broken.extend(found.into_inner().unwrap());
    if broken.is_empty() {
        let acked = history.iter().filter(|o| matches!(o.fate, Fate::Ok(_))).count();
        let unknown = history.iter().filter(|o| matches!(o.fate, Fate::Unknown(_))).count();
        let tools: BTreeSet<&str> = history.iter().filter(|o| matches!(o.fate, Fate::Ok(_))).map(|o| o.tool.as_str()).collect();
        eprintln!("history holds: {acked} acknowledged, {unknown} of unknown fate, {} simulations named; tools answered: {tools:?}", named.len());
        Ok(())
    } else {
        Err(broken)
    }
}

/// The promises about one simulation `sim` (named by a reply at `named_at` ms).
fn check_sim(world: &World, history: &[Op], sim: &str, named_at: u64, broken: &mut Vec<String>) {
    let on = |sim: &str| history.iter().filter(move |o| o.sim.as_deref() == Some(sim)).collect::<Vec<_>>().into_iter();
    let destroys: Vec<&Op> = on(sim).filter(|o| o.tool == "destroy_simulation" && !matches!(o.fate, Fate::Refused(_))).collect();
    let acked_destroy = destroys.iter().filter(|o| matches!(o.fate, Fate::Ok(_))).map(|o| o.completed).min();
    // Reads after an acknowledged destroy find nothing.
    if let Some(gone_at) = acked_destroy {
        for read in on(sim).filter(|o| o.tool == "get_simulation_info" && o.invoked > gone_at) {
            if matches!(read.fate, Fate::Ok(_)) {
                broken.push(format!("a read of {sim} sent at {} ms found it, destroyed (acknowledged) at {gone_at} ms", read.invoked));
            }
        }
    }
    // No read older than a change acknowledged before it was sent.
    let changes: Vec<(u64, u64, &Op)> = on(sim)
        .filter(|o| matches!(o.tool.as_str(), "add_box" | "step_simulation" | "batch"))
        .filter_map(|o| match &o.fate {
            Fate::Ok(v) => v["head_seq"].as_u64().map(|h| (o.completed, h, o)),
            _ => None,
        })
        .collect();
    for read in on(sim).filter(|o| o.tool == "get_simulation_info") {
        let Fate::Ok(v) = &read.fate else { continue };
        let head = v["head_seq"].as_u64().unwrap_or(0);
        if let Some((done, h, ch)) = changes.iter().filter(|(done, _, _)| *done < read.invoked).max_by_key(|(_, h, _)| *h) {
            if head < *h {
                broken.push(format!("a read of {sim} sent at {} ms answered head {head}, but {} reached head {h} at {done} ms", read.invoked, ch.tool));
            }
        }
    }
    // Its log, whole.
    let file = world.out.join(format!("{sim}-final.sqlite"));
    let o = crate::nodes::cli(&["export", &world.cluster_urls, sim, file.to_str().unwrap()]);
    if !o.status.success() {
        let said = String::from_utf8_lossy(&o.stderr).into_owned();
        if destroys.is_empty() {
            broken.push(format!("{sim}, named at {named_at} ms and never destroyed, has no log: {}", said.trim()));
        }
        return;
    }
    if acked_destroy.is_some() {
        broken.push(format!("{sim}'s destroy was acknowledged, yet the cluster still has its log"));
    }
    let replayed = crate::nodes::cli(&["replay", file.to_str().unwrap(), "--json"]);
    if !replayed.status.success() {
        broken.push(format!("{sim}'s exported log does not replay: {}", String::from_utf8_lossy(&replayed.stdout)));
        return;
    }
    let log = events(&file);
    check_log(sim, &log, on(sim).collect(), broken);
}

/// One simulation's log against its calls: acknowledged changes once each, at the head and
/// with the result replied, in call order; refused ones absent; unknown ones at most once.
fn check_log(sim: &str, log: &[physics_mcp::log::sqlite::Event], ops: Vec<&Op>, broken: &mut Vec<String>) {
    use physics_mcp::log::sqlite::Kind;
    let own = |e: &&physics_mcp::log::sqlite::Event| e.ok && !e.inherited && e.kind == Kind::Change;
    let tagged = |tag: f64| -> Vec<&physics_mcp::log::sqlite::Event> { log.iter().filter(own).filter(|e| e.tool == "add_box" && event_args(e)["position"][0].as_f64() == Some(tag)).collect() };
    let mut acked: Vec<(u64, u64, u64)> = Vec::new();
    for op in ops {
        match (&op.fate, op.tool.as_str()) {
            (Fate::Ok(v), "add_box" | "step_simulation" | "batch") => {
                let Some(head) = v["head_seq"].as_u64() else {
                    broken.push(format!("{sim}: {} acknowledged with no head_seq: {v}", op.tool));
                    continue;
                };
                let at = log.iter().find(|e| e.seq == head);
                match at {
                    Some(e) if own(&e) => {
                        if op.tool == "add_box" && event_result(e) != *v {
                            broken.push(format!("{sim}: {} acknowledged at head {head} replied {v}, its log records {}", op.tool, event_result(e)));
                        }
                    }
                    _ => broken.push(format!("{sim}: {} acknowledged at head {head} is not that event of its log", op.tool)),
                }
                if let Some(tag) = op.tag {
                    let found = tagged(tag);
                    if found.len() != 1 {
                        broken.push(format!("{sim}: add_box x = {tag}, acknowledged, is in its log {} times", found.len()));
                    }
                }
                acked.push((op.invoked, op.completed, head));
            }
            (Fate::Refused(e), "add_box") => {
                if let Some(tag) = op.tag.filter(|t| !tagged(*t).is_empty()) {
                    broken.push(format!("{sim}: add_box x = {tag} was refused ({e}), yet is in its log"));
                }
            }
            (Fate::Unknown(_), "add_box") => {
                if let Some(tag) = op.tag.filter(|t| tagged(*t).len() > 1) {
                    broken.push(format!("{sim}: add_box x = {tag}, of unknown fate, is in its log {} times", tagged(tag).len()));
                }
            }
            _ => {}
        }
    }
    // Real-time order: a change acknowledged before another was sent comes first in the log.
    for a in &acked {
        for b in &acked {
            if a.1 < b.0 && a.2 >= b.2 {
                broken.push(format!("{sim}: a change acknowledged at {} ms (head {}) is not before one sent at {} ms (head {})", a.1, a.2, b.0, b.2));
            }
        }
    }
}

/// Keeps a failing run's schedule, history, verdict and the nodes' last log lines; returns
/// the directory.
fn keep_run(schedule: &Schedule, history: &[Op], broken: &[String], nodes: &[Node]) -> PathBuf {
    let base = std::env::var_os("PHYSICS_FAULT_KEEP").map(PathBuf::from).unwrap_or_else(|| {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(std::env::var("CARGO_TARGET_DIR").unwrap_or_else(|_| "target".into())).join("fault-schedule")
    });
    let dir = base.join(format!("seed-{}-{}", schedule.seed, std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("schedule.json"), serde_json::to_string_pretty(schedule).unwrap()).unwrap();
    let lines: Vec<String> = history.iter().map(|o| serde_json::to_string(o).unwrap()).collect();
    std::fs::write(dir.join("history.jsonl"), lines.join("\n")).unwrap();
    std::fs::write(dir.join("broken.txt"), broken.join("\n")).unwrap();
    for n in nodes {
        let lines = n.all_stderr();
        let tail = &lines[lines.len().saturating_sub(5000)..];
        std::fs::write(dir.join(format!("node-{}.log", n.name)), tail.join("\n")).unwrap();
    }
    dir
}
