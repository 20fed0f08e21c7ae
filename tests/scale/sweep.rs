//! run_sweep (docs/tools.md "Scale") over HTTP against the real server: 8 variants
//! (friction, restitution, a motor target, an applied force) each equal fork + the same calls
//! plus step done by hand, state hash for state hash; the swept simulation is unchanged; forks not
//! kept are gone from list_simulations and from the data directory; kept ones are ordinary
//! simulations; every refusal creates nothing and leaves nothing behind.

use crate::common;

use common::hard::{assert_unchanged, fingerprint};
use common::Server;
use serde_json::{json, Value};

/// The data directory's files, sorted (a sweep must leave none of its own behind).
fn files(dir: &std::path::Path) -> Vec<String> {
    let mut f: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.ends_with("-wal") && !n.ends_with("-shm"))
        .collect();
    f.sort();
    f
}

fn call(tool: &str, arguments: Value) -> Value {
    json!({"tool": tool, "arguments": arguments})
}

/// A scene with something for each kind of variant: a sliding box, a bouncing ball, an arm.
async fn scene(c: &common::Client) -> String {
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    c.ground(s).await; // 0
    c.call("add_box", json!({"sim_id": s, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 0.1]})).await; // 1
    c.call("set_object_velocity", json!({"sim_id": s, "object_id": 1, "linear_velocity": [2, 0, 0]})).await;
    c.call("add_sphere", json!({"sim_id": s, "radius": 0.1, "position": [1, 1, 1]})).await; // 2
    c.call("load_urdf", json!({"sim_id": s, "file_path": "two_link_arm.urdf", "position": [-1, -1, 1], "use_fixed_base": true})).await; // 3
    sim
}

fn variants() -> Vec<Vec<Value>> {
    let motor = |t: f64| call("set_joint_motor_control", json!({"object_id": 3, "joint_index": 0, "control_mode": "POSITION_CONTROL", "target_position": t}));
    vec![
        vec![],
        vec![call("change_dynamics", json!({"object_id": 1, "lateral_friction": 0.1}))],
        vec![call("change_dynamics", json!({"object_id": 1, "lateral_friction": 2.0}))],
        vec![call("change_dynamics", json!({"object_id": 2, "restitution": 0.9})), call("change_dynamics", json!({"object_id": 0, "restitution": 0.9}))],
        vec![motor(0.5)],
        vec![motor(-1.0), call("step_simulation", json!({"steps": 10})), motor(1.0)],
        vec![call("apply_force", json!({"object_id": 2, "force": [0, 0, 500]}))],
        vec![call("apply_force", json!({"object_id": 1, "force": [0, 300, 0]})), call("get_object_state", json!({"object_id": 1}))],
    ]
}

#[tokio::test(flavor = "multi_thread")]
async fn every_variant_equals_the_same_done_by_hand_and_the_swept_simulation_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = scene(&c).await;
    let s = sim.as_str();
    let before = fingerprint(&c, s).await;
    let listed = c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len();
    let data_files = files(&server.data);

    let out = c
        .call("run_sweep", json!({"sim_id": s, "variants": variants(), "steps": 240, "observe": {"object_ids": [1, 2], "include_velocities": true, "every": 60}}))
        .await;
    let swept = out["variants"].as_array().unwrap();
    assert_eq!(swept.len(), 8);

    // The swept simulation: same hash and head; the sweep is one read event on it.
    assert_unchanged(&c, s, &before, "run_sweep").await;
    // Not kept: not listed, and no file of theirs left in the data directory.
    assert_eq!(c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), listed);
    assert_eq!(files(&server.data), data_files);

    let mut hashes = std::collections::BTreeSet::new();
    for (i, (v, calls)) in swept.iter().zip(variants()).enumerate() {
        assert_eq!(v["index"], json!(i));
        assert!(v.get("simulation_id").is_none(), "not kept: {v}");
        let objects = v["objects"].as_array().unwrap();
        assert_eq!(objects.len(), 2);
        assert!(objects[0]["linear_velocity"].is_array());
        let samples = &v["trajectory"];
        assert!(samples.is_object(), "observe.every gives a trajectory: {v}");

        // By hand: fork at the head, the same calls, the same steps.
        let fork = c.call("fork_simulation", json!({"sim_id": s})).await["simulation_id"].as_str().unwrap().to_string();
        for call in calls {
            let mut a = call["arguments"].clone();
            a["sim_id"] = json!(fork);
            c.call(call["tool"].as_str().unwrap(), a).await;
        }
        c.step(&fork, 240).await;
        assert_eq!(v["state_hash"].as_str().unwrap(), c.hash(&fork).await, "variant {i}");
        let by_hand = c.state(&fork, 1).await;
        assert_eq!(objects[0]["position"], by_hand["position"], "variant {i}");
        hashes.insert(v["state_hash"].as_str().unwrap().to_string());
        c.call("destroy_simulation", json!({"sim_id": fork})).await;
    }
    assert_eq!(hashes.len(), 8, "each variant changed something");
    // The swept simulation's log, with the sweep as a read event in it, replays.
    server.terminate();
    common::assert_replays(&dir.path().join("data"), s);
}

#[tokio::test(flavor = "multi_thread")]
async fn kept_variants_are_ordinary_simulations() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = scene(&c).await;
    let out = c.call("run_sweep", json!({"sim_id": sim, "variants": [[], [call("apply_force", json!({"object_id": 2, "force": [0, 0, 500]}))]], "steps": 30, "keep": true})).await;
    let kept: Vec<String> = out["variants"].as_array().unwrap().iter().map(|v| v["simulation_id"].as_str().unwrap().to_string()).collect();
    let listed = c.call("list_simulations", json!({})).await;
    for (id, v) in kept.iter().zip(out["variants"].as_array().unwrap()) {
        assert!(listed.to_string().contains(id.as_str()), "{id} listed");
        assert_eq!(c.hash(id).await, v["state_hash"].as_str().unwrap());
        // A kept fork is a real simulation: undo takes back its step, it steps on.
        c.call("undo", json!({"sim_id": id})).await;
        c.step(id, 5).await;
    }
    // Objects observed by default: all of them, those that did not move listed by id only.
    let v0 = &out["variants"][0];
    assert_eq!(v0["objects"].as_array().unwrap().len() + v0["unmoved"].as_array().map_or(0, Vec::len), 4, "{v0}");
    // And it survives a restart like any simulation.
    let h = c.hash(&kept[1]).await;
    server.kill();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&kept[1]).await, h);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_refused_sweep_creates_nothing_and_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-steps", "1000", "--max-sims", "4"]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = scene(&c).await;
    let s = sim.as_str();
    let before = fingerprint(&c, s).await;
    let data_files = files(&server.data);
    let empty: Vec<Vec<Value>> = (0..257).map(|_| vec![]).collect();
    let rows: Vec<(Value, Vec<&str>)> = vec![
        (json!({"sim_id": s, "variants": [], "steps": 10}), vec!["variants", "got 0"]),
        (json!({"sim_id": s, "variants": empty, "steps": 10}), vec!["variants", "256", "257"]),
        (json!({"sim_id": s, "variants": [[]], "steps": 1001}), vec!["steps", "--max-steps"]),
        (json!({"sim_id": s, "variants": [[]], "steps": -1}), vec!["steps"]),
        (
            json!({"sim_id": s, "variants": [[], [], [call("apply_force", json!({"object_id": 1, "force": [1, 0, 0]})), call("change_dynamics", json!({"object_id": 42, "mass": 2}))]], "steps": 10}),
            vec!["variants[2]", "calls[1]", "change_dynamics", "42"],
        ),
        (json!({"sim_id": s, "variants": [[call("fork_simulation", json!({}))]], "steps": 10}), vec!["variants[0]", "calls[0]", "fork_simulation"]),
        (json!({"sim_id": s, "variants": [[], [], [], []], "steps": 10, "keep": true}), vec!["keep", "--max-sims"]),
        (json!({"sim_id": s, "variants": [[]], "steps": 10, "observe": {"object_ids": [77]}}), vec!["variants[0]", "77"]),
        (json!({"sim_id": s, "variants": [[]], "steps": 10, "observe": {"every": 0}}), vec!["observe.every"]),
    ];
    for (args, words) in rows {
        let why = c.try_call("run_sweep", args).await.expect_err("the sweep must be refused");
        for w in words {
            assert!(why.contains(w), "{why:?} should mention {w:?}");
        }
        assert_unchanged(&c, s, &before, &why).await;
        assert_eq!(files(&server.data), data_files, "{why}");
        assert_eq!(c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), 1);
    }
}
