//! Cluster mode answers exactly as embedded mode: a seeded script of 500+ mixed calls (every
//! kind of change, undo/redo, forks, batches, sweeps, robots from URDF and MJCF, saves and
//! loads, deliberate refusals) runs in lockstep against an embedded server and a cluster node,
//! reply for reply (ids renamed). Then every simulation of the cluster run is exported and must
//! replay, and its events must be the embedded log's, event for event.

use std::path::Path;

use rand::seq::SliceRandom;
use rand::Rng;
use serde_json::{json, Value};

use crate::common::hard::{rng, seed};
use crate::common::Server;
use crate::lockstep::{Ids, Lockstep, Side};
use crate::nats::NatsCluster;
use crate::nodes::{shared_workspace, event_args, events, export_and_verify, Node, Outcome};

/// Calls in the script (at least; the last operation may add a refresh).
const CALLS: usize = 520;
/// At most this many live simulations at once (the default `--max-sims` is 32).
const MAX_SIMS: usize = 8;
/// An id no server made, for refusals.
const UNKNOWN_SIM: &str = "00000000-0000-4000-8000-000000000000";
/// MJCF fixtures the script loads (small ones: the script steps them often).
const MJCF: &[&str] = &["mjcf/inverted_double_pendulum.xml", "mjcf/hopper.xml", "mjcf/inverted_pendulum.xml"];

/// What the script knows of one simulation slot (the same on both servers while they agree).
#[derive(Clone, Default)]
struct Slot {
    alive: bool,
    /// Object ids, as the last get_simulation_info (or add reply) said.
    objects: Vec<u64>,
}

/// The script's generator state: the slots and the files it saved.
struct Script {
    rng: rand_chacha::ChaCha8Rng,
    slots: Vec<Slot>,
    saves: usize,
}

impl Script {
    /// A random live slot.
    fn live(&mut self) -> usize {
        let live: Vec<usize> = (0..self.slots.len()).filter(|&i| self.slots[i].alive).collect();
        *live.choose(&mut self.rng).expect("a live simulation")
    }

    fn live_count(&self) -> usize {
        self.slots.iter().filter(|s| s.alive).count()
    }

    /// One of the slot's objects, or (rarely, or when it has none) an id that does not exist.
    fn object(&mut self, slot: usize) -> u64 {
        let objects = &self.slots[slot].objects;
        if objects.is_empty() || self.rng.gen_bool(0.05) {
            return 4242;
        }
        objects[self.rng.gen_range(0..objects.len())]
    }

    fn position(&mut self) -> Value {
        json!([self.rng.gen_range(-2.0..2.0), self.rng.gen_range(-2.0..2.0), self.rng.gen_range(0.2..3.0)])
    }

    fn add_box(&mut self) -> Value {
        let h = self.rng.gen_range(0.05..0.3);
        let mass = if self.rng.gen_bool(0.1) { 0.0 } else { self.rng.gen_range(0.1..5.0) };
        json!({"dimensions": [h, h * 1.5, h], "position": self.position(), "mass": mass})
    }

    fn add_sphere(&mut self) -> Value {
        json!({"radius": self.rng.gen_range(0.05..0.3), "position": self.position()})
    }

    fn velocity(&mut self, slot: usize) -> Value {
        let v = [self.rng.gen_range(-3.0..3.0), self.rng.gen_range(-3.0..3.0), self.rng.gen_range(0.0..5.0)];
        json!({"sim_id": sim(slot), "object_id": self.object(slot), "linear_velocity": v})
    }

    /// A batch of changes and reads on one simulation (`sim_id` left out inside, as allowed).
    fn batch(&mut self, slot: usize) -> Value {
        let mut calls = vec![json!({"tool": "add_box", "arguments": self.add_box()}), json!({"tool": "step_simulation", "arguments": {"steps": 3}})];
        if !self.slots[slot].objects.is_empty() {
            let o = self.object(slot);
            calls.push(json!({"tool": "get_object_state", "arguments": {"object_id": o}}));
            calls.push(json!({"tool": "set_object_velocity", "arguments": {"object_id": o, "angular_velocity": [0, 0, 2]}}));
        }
        calls.push(json!({"tool": "get_simulation_info", "arguments": {}}));
        json!({"sim_id": sim(slot), "calls": calls})
    }

    /// A sweep of two or three variants; kept (new simulations) only when there is room.
    fn sweep(&mut self, slot: usize) -> Value {
        let o = self.object(slot);
        let mut variants = vec![
            json!([]),
            json!([{"tool": "change_dynamics", "arguments": {"object_id": o, "restitution": 0.8}}]),
            json!([{"tool": "apply_force", "arguments": {"object_id": o, "force": [0, 0, 40]}}]),
        ];
        variants.truncate(self.rng.gen_range(2..=3));
        let keep = self.live_count() + variants.len() <= MAX_SIMS && self.rng.gen_bool(0.3);
        json!({"sim_id": sim(slot), "variants": variants, "steps": 20, "observe": {"object_ids": [o]}, "keep": keep})
    }

    /// A call that must be refused (the same way by both servers).
    fn refusal(&mut self, slot: usize) -> (&'static str, Value) {
        let s = sim(slot);
        match self.rng.gen_range(0..8) {
            0 => ("step_simulation", json!({"sim_id": UNKNOWN_SIM, "steps": 1})),
            1 => ("add_box", json!({"sim_id": s, "dimensions": [-1, 1, 1], "position": [0, 0, 1]})),
            2 => ("set_object_velocity", json!({"sim_id": s, "object_id": self.object(slot), "linear_velocity": [1e6, 0, 0]})),
            3 => {
                let calls = json!([{"tool": "add_box", "arguments": self.add_box()}, {"tool": "destroy_simulation", "arguments": {}}]);
                ("batch", json!({"sim_id": s, "calls": calls}))
            }
            4 => ("load_urdf", json!({"sim_id": s, "file_path": "no_such_robot.urdf"})),
            5 => ("fork_simulation", json!({"sim_id": s, "at_seq": 999_999})),
            6 => ("get_object_state", json!({"sim_id": s, "object_id": 4242})),
            _ => ("undo", json!({"sim_id": UNKNOWN_SIM})),
        }
    }
}

/// The placeholder for slot `i`'s id (bound per server by `Side::bind`).
fn sim(i: usize) -> String {
    format!("$sim:{i}")
}

/// Object ids in a get_simulation_info reply.
fn object_ids(info: &Value) -> Vec<u64> {
    info["objects"].as_array().map(|a| a.iter().filter_map(|o| o["object_id"].as_u64()).collect()).unwrap_or_default()
}

/// The script: runs `CALLS` calls through `run`, choosing each from what the replies so far
/// said (server a's; server b's were just checked equal).
async fn run_script(run: &mut Lockstep, script: &mut Script) {
    opening(run, script).await;
    while run.calls < CALLS {
        let slot = script.live();
        let dice = script.rng.gen_range(0..100);
        match dice {
            0..=17 => {
                let steps = script.rng.gen_range(1..=20);
                run.call("step_simulation", json!({"sim_id": sim(slot), "steps": steps})).await;
            }
            18..=31 => add(run, script, slot, "add_box").await,
            32..=39 => add(run, script, slot, "add_sphere").await,
            40..=47 => {
                let args = script.velocity(slot);
                run.call("set_object_velocity", args).await;
            }
            48..=52 => {
                let count = script.rng.gen_range(1..=2);
                run.call("undo", json!({"sim_id": sim(slot), "count": count})).await;
                if script.rng.gen_bool(0.5) {
                    run.call("redo", json!({"sim_id": sim(slot)})).await;
                }
                refresh(run, script, slot).await;
            }
            53..=56 => {
                let count = script.rng.gen_range(1..=2);
                run.call("redo", json!({"sim_id": sim(slot), "count": count})).await;
                refresh(run, script, slot).await;
            }
            57..=62 => refresh(run, script, slot).await,
            63..=67 => {
                let o = script.object(slot);
                run.call("get_object_state", json!({"sim_id": sim(slot), "object_id": o})).await;
            }
            68..=70 if script.live_count() < MAX_SIMS => {
                let name = format!("fork {}", run.calls);
                let made = run.call("fork_simulation", json!({"sim_id": sim(slot), "name": name})).await;
                let objects = script.slots[slot].objects.clone();
                adopt(run, script, &made, objects).await;
            }
            71..=74 => {
                let args = script.batch(slot);
                run.call("batch", args).await;
                refresh(run, script, slot).await;
            }
            75..=76 => {
                let args = script.sweep(slot);
                let before = run.a.sims.len();
                run.call("run_sweep", args).await;
                for _ in before..run.a.sims.len() {
                    script.slots.push(Slot { alive: true, objects: Vec::new() });
                    refresh(run, script, script.slots.len() - 1).await;
                }
            }
            77..=78 => load_robot(run, script, slot, "load_urdf", "two_link_arm.urdf").await,
            79..=80 => {
                let file = *MJCF.choose(&mut script.rng).unwrap();
                load_robot(run, script, slot, "load_mjcf", file).await;
            }
            81 if script.live_count() < MAX_SIMS => save_and_load(run, script, slot).await,
            82 if script.live_count() > 3 && slot >= 2 => {
                run.call("destroy_simulation", json!({"sim_id": sim(slot)})).await;
                script.slots[slot].alive = false;
            }
            83 if script.live_count() < MAX_SIMS => {
                let g = script.rng.gen_range(-12.0..-5.0);
                create(run, script, json!({"gravity": [0, 0, g], "name": format!("made at call {}", run.calls)})).await;
            }
            84 => {
                run.call("list_simulations", json!({})).await;
            }
            85..=91 => {
                let (tool, args) = script.refusal(slot);
                let got = run.call(tool, args.clone()).await;
                assert!(matches!(got, Outcome::Refused(_)), "{tool} {args} should be refused, got {got:?}");
            }
            _ => {
                let o = script.object(slot);
                run.call("apply_force", json!({"sim_id": sim(slot), "object_id": o, "force": [0, 0, 30]})).await;
            }
        }
    }
}

/// The script's fixed start, so that every seed covers every kind of call at least once:
/// two simulations, a robot from each format, a batch, undo and redo, a fork, a kept sweep, a
/// save and its load. The random part follows.
async fn opening(run: &mut Lockstep, script: &mut Script) {
    create(run, script, json!({})).await;
    create(run, script, json!({"name": "second"})).await;
    add(run, script, 0, "add_box").await;
    add(run, script, 0, "add_sphere").await;
    load_robot(run, script, 0, "load_urdf", "two_link_arm.urdf").await;
    load_robot(run, script, 1, "load_mjcf", MJCF[0]).await;
    run.call("step_simulation", json!({"sim_id": sim(0), "steps": 10})).await;
    let args = script.batch(0);
    run.call("batch", args).await;
    run.call("undo", json!({"sim_id": sim(0), "count": 2})).await;
    run.call("redo", json!({"sim_id": sim(0)})).await;
    refresh(run, script, 0).await;
    let made = run.call("fork_simulation", json!({"sim_id": sim(0), "name": "opening fork"})).await;
    let objects = script.slots[0].objects.clone();
    adopt(run, script, &made, objects).await;
    let o = script.slots[0].objects[1];
    let sweep = json!({"sim_id": sim(0), "steps": 20, "keep": true, "observe": {"object_ids": [o]},
        "variants": [[{"tool": "apply_force", "arguments": {"object_id": o, "force": [0, 0, 40]}}]]});
    run.call("run_sweep", sweep).await;
    script.slots.push(Slot { alive: true, objects: Vec::new() });
    refresh(run, script, script.slots.len() - 1).await;
    save_and_load(run, script, 1).await;
}

/// create_simulation with `args`, a ground, and a new slot for it.
async fn create(run: &mut Lockstep, script: &mut Script, args: Value) {
    let made = run.call("create_simulation", args).await;
    adopt(run, script, &made, Vec::new()).await;
    let slot = script.slots.len() - 1;
    let ground = run.call("add_box", json!({"sim_id": sim(slot), "dimensions": [10, 10, 0.5], "position": [0, 0, -0.5], "mass": 0})).await;
    note_object(script, slot, &ground);
}

/// A new slot for the simulation a call just made (`made` must be accepted).
async fn adopt(run: &mut Lockstep, script: &mut Script, made: &Outcome, objects: Vec<u64>) {
    assert!(matches!(made, Outcome::Ok(_)), "expected a new simulation, got {made:?}");
    assert_eq!(run.a.sims.len(), script.slots.len() + 1, "one new simulation");
    script.slots.push(Slot { alive: true, objects });
}

/// add_box or add_sphere on `slot`.
async fn add(run: &mut Lockstep, script: &mut Script, slot: usize, tool: &str) {
    let mut args = if tool == "add_box" { script.add_box() } else { script.add_sphere() };
    args["sim_id"] = json!(sim(slot));
    let got = run.call(tool, args).await;
    note_object(script, slot, &got);
}

/// load_urdf/load_mjcf of a workspace fixture at a random place.
async fn load_robot(run: &mut Lockstep, script: &mut Script, slot: usize, tool: &str, file: &str) {
    let position = script.position();
    let fixed = script.rng.gen_bool(0.5);
    let got = run.call(tool, json!({"sim_id": sim(slot), "file_path": file, "position": position, "use_fixed_base": fixed})).await;
    note_object(script, slot, &got);
}

/// save_simulation to a fresh workspace file, then load_simulation of it (a new slot).
async fn save_and_load(run: &mut Lockstep, script: &mut Script, slot: usize) {
    script.saves += 1;
    let file = format!("saves/equivalence_{}.json", script.saves);
    run.call("save_simulation", json!({"sim_id": sim(slot), "file_path": file})).await;
    let made = run.call("load_simulation", json!({"file_path": file, "name": "loaded"})).await;
    adopt(run, script, &made, Vec::new()).await;
    refresh(run, script, script.slots.len() - 1).await;
}

/// Adds the object an accepted add/load reply names to the slot's list.
fn note_object(script: &mut Script, slot: usize, got: &Outcome) {
    if let Outcome::Ok(v) = got {
        if let Some(id) = v["object_id"].as_u64() {
            script.slots[slot].objects.push(id);
        }
    }
}

/// get_simulation_info on `slot` (a compared call like any other), and its object list.
async fn refresh(run: &mut Lockstep, script: &mut Script, slot: usize) {
    if let Outcome::Ok(info) = run.call("get_simulation_info", json!({"sim_id": sim(slot)})).await {
        script.slots[slot].objects = object_ids(&info);
    }
}

/// Runs the script on two servers' clients (or groups of nodes, tests/cluster/round_robin.rs);
/// returns the run and the live slots.
pub(crate) async fn lockstep(a: Side, b: Side, seed: u64) -> (Lockstep, Vec<usize>) {
    let mut run = Lockstep::new(a, b);
    let mut script = Script { rng: rng(seed), slots: Vec::new(), saves: 0 };
    run_script(&mut run, &mut script).await;
    run.call("list_simulations", json!({})).await;
    let live: Vec<usize> = (0..script.slots.len()).filter(|&i| script.slots[i].alive).collect();
    for &slot in &live {
        run.call("get_simulation_info", json!({"sim_id": sim(slot)})).await;
    }
    let made = script.slots.len();
    eprintln!("{} calls in lockstep, {made} simulations made, {} live; per tool (accepted, refused): {:?}", run.calls, live.len(), run.tally);
    assert_covers(&run);
    (run, live)
}

/// Tools the script must have seen accepted at least once (else the seed made a thin script).
const MUST_SUCCEED: &[&str] = &[
    "create_simulation", "add_box", "add_sphere", "step_simulation", "set_object_velocity", "undo", "redo",
    "fork_simulation", "batch", "run_sweep", "load_urdf", "load_mjcf", "save_simulation", "load_simulation",
];

/// Panics unless every tool of `MUST_SUCCEED` was accepted and at least 20 calls were refused.
fn assert_covers(run: &Lockstep) {
    for tool in MUST_SUCCEED {
        assert!(run.tally.get(*tool).is_some_and(|t| t.0 > 0), "the script never got {tool} accepted: {:?}", run.tally);
    }
    let refused: usize = run.tally.values().map(|t| t.1).sum();
    assert!(refused >= 20, "only {refused} refusals in the script");
}

/// Compares two logs of the same simulation made by two servers, event for event, with ids
/// renamed (each log's own renaming from `ia`/`ib`, the servers' directory renamings: the same
/// when the logs agree).
pub(crate) fn assert_same_events(a: &Path, b: &Path, mut ia: Ids, mut ib: Ids) {
    let (ea, eb) = (events(a), events(b));
    for (x, y) in ea.iter().zip(&eb) {
        let view = |e: &physics_mcp::log::sqlite::Event, ids: &mut Ids| {
            json!({
                "seq": e.seq, "kind": e.kind.as_str(), "parent": e.parent, "tool": e.tool,
                "arguments": ids.value(&event_args(e)), "raw_arguments": ids.text(&e.arguments),
                "command": e.command.as_deref().map(|c| ids.text(c)), "version": e.version, "ok": e.ok,
                "mutates": e.mutates, "inherited": e.inherited, "result": e.result.as_deref().map(|r| ids.text(r)),
                "state_hash": e.state_hash, "engine": e.engine, "summary": e.summary.as_deref().map(|s| ids.text(s)),
            })
        };
        let (vx, vy) = (view(x, &mut ia), view(y, &mut ib));
        assert_eq!(vx, vy, "{} and {} differ at seq {}", a.display(), b.display(), x.seq);
    }
    assert_eq!(ea.len(), eb.len(), "{} has {} events, {} has {}", a.display(), ea.len(), b.display(), eb.len());
}

#[tokio::test(flavor = "multi_thread")]
#[ignore = "needs nats-server: cargo test --test cluster -- --ignored"]
async fn embedded_and_cluster_answer_alike_and_the_exported_logs_replay() {
    let seed = seed();
    let nats = NatsCluster::start();
    let emb_dir = tempfile::tempdir().unwrap();
    let embedded = Server::start(emb_dir.path(), &[]);
    embedded.copy_fixtures();
    let root = tempfile::tempdir().unwrap();
    let workspace = shared_workspace(root.path());
    let mut node = Node::start(root.path(), "a", &nats, &workspace, &[]);
    node.server().copy_fixtures();

    let a = Side::new("embedded", &embedded, embedded.client().await);
    let b = Side::new("cluster", node.server(), node.client().await);
    let (run, live) = lockstep(a, b, seed).await;
    assert!(run.calls >= 500);

    // Every live simulation of the cluster run: exported, replayed, and the embedded log's twin.
    // Both servers stop first: a server buffers read and refused events until its next write
    // or its shutdown (docs/log-format.md), so only then are the logs complete.
    embedded.terminate();
    node.terminate();
    assert_exports_match(&nats, &run, &live, emb_dir.path());
}

/// Every live slot's log exported from the cluster (side b) replays and holds the embedded
/// server's (side a, its data under `embedded_dir`) events, event for event.
pub(crate) fn assert_exports_match(nats: &NatsCluster, run: &Lockstep, live: &[usize], embedded_dir: &Path) {
    let out = tempfile::tempdir().unwrap();
    for &slot in live {
        let (file, _) = export_and_verify(&nats.urls(), &run.b.sims[slot], out.path(), &format!("slot{slot}"));
        let embedded_log = embedded_dir.join("data").join(format!("{}.sqlite", run.a.sims[slot]));
        assert_same_events(&embedded_log, &file, run.a.ids.fresh(), run.b.ids.fresh());
    }
}

/// The control for the test above: the same script against two embedded servers must agree
/// too, or a difference found there is the script's (a volatile field, a random id) and not the
/// cluster's. No NATS needed.
#[tokio::test(flavor = "multi_thread")]
#[ignore = "the control of the cluster equivalence test: cargo test --test cluster -- --ignored"]
async fn two_embedded_servers_agree_on_the_script() {
    crate::nodes::assert_no_ambient_cluster();
    let seed = seed();
    let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (s1, s2) = (Server::start(d1.path(), &[]), Server::start(d2.path(), &[]));
    s1.copy_fixtures();
    s2.copy_fixtures();
    let (run, live) = lockstep(Side::new("first", &s1, s1.client().await), Side::new("second", &s2, s2.client().await), seed).await;
    s1.terminate();
    s2.terminate();
    for &slot in &live {
        let log = |d: &Path, id: &str| d.join("data").join(format!("{id}.sqlite"));
        assert_same_events(&log(d1.path(), &run.a.sims[slot]), &log(d2.path(), &run.b.sims[slot]), run.a.ids.fresh(), run.b.ids.fresh());
    }
}
