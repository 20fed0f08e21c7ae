//! The calls agents reach for, against what they must mean physically: a marker (`collides:
//! false`) touches nothing yet rays and the camera see it; PyBullet's collision filters
//! (group/mask and per pair) decide which parts touch; set_joint_motor_control_array is the
//! single-joint calls made at once (the same state hash). Each is a logged change: undone,
//! verified and replayed like any other.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

async fn z(c: &Client, sim: &str, id: u64) -> f64 {
    c.state(sim, id).await["position"][2].as_f64().unwrap()
}

async fn sphere(c: &Client, sim: &str, x: f64, extra: Value) -> u64 {
    let mut args = json!({"sim_id": sim, "radius": 0.1, "position": [x, 0, 1]});
    args.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
    c.call("add_sphere", args).await["object_id"].as_u64().unwrap()
}

/// The simulation verifies, and after the server stops its log replays to every hash.
async fn verifies_and_replays(c: Client, server: Server, dir: &std::path::Path, sim: &str) {
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    drop(c);
    server.terminate();
    common::assert_replays(&dir.join("data"), sim);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_marker_touches_nothing_but_rays_and_the_camera_see_it() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let hash_before = c.hash(&sim).await;
    // A static marker box right where a ball falls, and a ball beside it with no marker.
    let marker = c
        .call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.05], "position": [0, 0, 0.5], "mass": 0, "collides": false, "color": [1, 0, 0]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    let through = sphere(&c, &sim, 0.0, json!({})).await;
    let blocked = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.05], "position": [2, 0, 0.5], "mass": 0})).await["object_id"].as_u64().unwrap();
    let stopped = sphere(&c, &sim, 2.0, json!({})).await;
    c.step(&sim, 480).await;
    // Resting on the ground (radius 0.1) below the marker; on the solid plate (top at 0.55) beside it.
    assert!((z(&c, &sim, through).await - 0.1).abs() < 0.01, "the ball fell through the marker");
    assert!((z(&c, &sim, stopped).await - 0.65).abs() < 0.01, "the ball rests on the solid plate");
    let _ = blocked;
    // A ray straight down through the marker hits it, at its top face.
    let r = c.call("ray_test", json!({"sim_id": sim, "ray_from": [0.2, 0, 2], "ray_to": [0.2, 0, 0]})).await;
    assert_eq!(r["object_id"].as_u64(), Some(marker), "{r}");
    assert!((r["hit_position"][2].as_f64().unwrap() - 0.55).abs() < 1e-4, "{r}");
    // The camera's segmentation sees it from above.
    let view = c.call("compute_view_matrix", json!({"camera_eye_position": [0, 0, 3], "camera_target_position": [0, 0, 0], "camera_up_vector": [0, 1, 0]})).await["view_matrix"].clone();
    let img = c.call("get_camera_image", json!({"sim_id": sim, "width": 64, "height": 48, "view_matrix": view, "include_segmentation": true})).await;
    let seg = img["segmentation"].as_array().unwrap();
    assert_eq!(seg[24 * 64 + 32].as_u64(), Some(marker), "the centre pixel is the marker");
    // Undone, the marker is gone and the state is what it was.
    c.call("undo", json!({"sim_id": sim, "count": 5})).await;
    assert_eq!(c.hash(&sim).await, hash_before);
    verifies_and_replays(c, server, dir.path(), &sim).await;
}

/// One drop or stack case of PyBullet's own run (tests/fixtures/pybullet_filter_defaults.json):
/// does the filtered body rest where PyBullet's did?
async fn rests_as_pybullet(c: &Client, case: &Value) -> (bool, bool) {
    let sim = c.new_sim(json!({})).await;
    let filter = |id: u64, g: &Value, m: &Value| json!({"sim_id": sim, "object_id": id, "collision_filter_group": g, "collision_filter_mask": m});
    if let Some(support) = case["support"].as_str() {
        match support {
            "plane.urdf" => c.call("load_urdf", json!({"sim_id": sim, "file_path": "plane.urdf"})).await,
            _ => c.call("add_box", json!({"sim_id": sim, "dimensions": [2, 2, 0.05], "position": [0, 0, -0.05], "mass": 0})).await,
        };
        let ball = sphere(c, &sim, 0.0, json!({})).await;
        if !case["sphere_group"].is_null() {
            c.call("set_collision_filter_group_mask", filter(ball, &case["sphere_group"], &case["sphere_mask"])).await;
        }
        c.step(&sim, 480).await;
        ((z(c, &sim, ball).await - 0.1).abs() < 0.01, case["resting"].as_bool().unwrap())
    } else {
        c.call("load_urdf", json!({"sim_id": sim, "file_path": "plane.urdf"})).await;
        for h in [0.1, 0.3] {
            c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, h]})).await;
        }
        if !case["top_mask"].is_null() {
            c.call("set_collision_filter_group_mask", filter(2, &case["top_group"], &case["top_mask"])).await;
        }
        c.step(&sim, 480).await;
        ((z(c, &sim, 2).await - 0.3).abs() < 0.01, case["top_resting_on_bottom"].as_bool().unwrap())
    }
}

/// set_collision_filter_group_mask against PyBullet's own run: a pair touches when either
/// part's group meets the other's mask, static parts being group 2, mask all but 2 (found by
/// scripts/pybullet_filter_defaults.py; the first release tested both ways, every part at
/// group 1 — its recorded logs still fold that way, replays/markers_filters_motors.sqlite).
#[tokio::test(flavor = "multi_thread")]
async fn group_and_mask_touch_exactly_where_pybullet_s_did() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let reference: Value = serde_json::from_str(&std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/pybullet_filter_defaults.json")).unwrap()).unwrap();
    let cases: Vec<&Value> = reference["drop_tests"].as_array().unwrap().iter().chain(reference["stacked_dynamic_boxes"].as_array().unwrap()).collect();
    assert!(cases.len() >= 25, "the reference has {} cases", cases.len());
    let mut wrong = Vec::new();
    for case in &cases {
        let (ours, pybullet) = rests_as_pybullet(&c, case).await;
        if ours != pybullet {
            wrong.push(format!("{} on {}: ours rests {ours}, PyBullet's {pybullet}", case["case"], case["support"]));
        }
    }
    assert!(wrong.is_empty(), "{} of {} cases differ from PyBullet: {wrong:#?}", wrong.len(), cases.len());
}

#[tokio::test(flavor = "multi_thread")]
async fn collision_filters_decide_which_parts_touch_as_pybullet_defines_them() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let masked = sphere(&c, &sim, -1.0, json!({})).await;
    let paired = sphere(&c, &sim, 0.0, json!({})).await;
    let plain = sphere(&c, &sim, 1.0, json!({})).await;
    let hash_plain = c.hash(&sim).await;
    // Group 2, mask 1 against the static ground (group 2, mask all but 2): 2 & !2 and 2 & 1 — no.
    c.call("set_collision_filter_group_mask", json!({"sim_id": sim, "object_id": masked, "collision_filter_group": 2, "collision_filter_mask": 1})).await;
    c.call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": paired, "object_id_b": ground, "enable_collision": false})).await;
    assert_ne!(c.hash(&sim).await, hash_plain, "filters are hashed state");
    c.step(&sim, 240).await;
    assert!(z(&c, &sim, masked).await < -0.5, "group 2 / mask 1 falls through the static ground");
    assert!(z(&c, &sim, paired).await < -0.5, "the disabled pair falls through");
    assert!((z(&c, &sim, plain).await - 0.1).abs() < 0.01, "the unfiltered ball rests on the ground");
    // Bad parts are refused naming the parameter, changing nothing.
    let head = c.hash(&sim).await;
    let e = c.try_call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": plain, "object_id_b": plain, "enable_collision": false})).await.unwrap_err();
    assert!(e.contains("same part"), "{e}");
    let e = c.try_call("set_collision_filter_group_mask", json!({"sim_id": sim, "object_id": plain, "link_index": 3, "collision_filter_group": 1, "collision_filter_mask": 1})).await.unwrap_err();
    assert!(e.contains("link"), "{e}");
    assert_eq!(c.hash(&sim).await, head);
    // Undo the step and both filters: back to the plain world's hash; re-enabled, the pair rests.
    c.call("undo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.hash(&sim).await, hash_plain);
    c.call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": paired, "object_id_b": ground, "enable_collision": false})).await;
    c.call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": ground, "object_id_b": paired, "enable_collision": true})).await;
    // A pair enabled explicitly touches whatever the masks say (PyBullet's pair filter wins).
    c.call("set_collision_filter_group_mask", json!({"sim_id": sim, "object_id": masked, "collision_filter_group": 2, "collision_filter_mask": 1})).await;
    c.call("set_collision_filter_pair", json!({"sim_id": sim, "object_id_a": masked, "object_id_b": ground, "enable_collision": true})).await;
    c.step(&sim, 240).await;
    assert!((z(&c, &sim, paired).await - 0.1).abs() < 0.01, "re-enabled, the pair touches again");
    assert!((z(&c, &sim, masked).await - 0.1).abs() < 0.01, "an enabled pair overrides the masks");
    verifies_and_replays(c, server, dir.path(), &sim).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn a_motor_array_is_the_single_joint_calls_made_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let mut hashes = Vec::new();
    for array in [false, true] {
        let sim = c.new_sim(json!({})).await;
        let arm = c.call("load_urdf", json!({"sim_id": sim, "file_path": "iiwa14.urdf", "use_fixed_base": true})).await["object_id"].as_u64().unwrap();
        let targets = [0.3, -0.4, 0.2, 1.0, -0.5, 0.6, 0.1];
        if array {
            c.call("set_joint_motor_control_array", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 1, 2, 3, 4, 5, 6],
                "control_mode": "POSITION_CONTROL", "target_positions": targets, "forces": [300, 300, 300, 300, 300, 300, 300]})).await;
        } else {
            for (j, t) in targets.iter().enumerate() {
                c.call("set_joint_motor_control", json!({"sim_id": sim, "object_id": arm, "joint_index": j, "control_mode": "POSITION_CONTROL", "target_position": t, "force": 300})).await;
            }
        }
        c.step(&sim, 480).await;
        let j3 = c.call("get_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": 3})).await;
        assert!((j3["joint_position"].as_f64().unwrap() - 1.0).abs() < 0.05, "joint 3 reached its target: {j3}");
        hashes.push(c.hash(&sim).await);
        if array {
            // One change: one undo takes every motor back.
            let e = c.try_call("set_joint_motor_control_array", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 1], "control_mode": "POSITION_CONTROL", "target_positions": [0.1]})).await.unwrap_err();
            assert!(e.contains("target_positions must have one entry per joint index (2)"), "{e}");
            let e = c.try_call("set_joint_motor_control_array", json!({"sim_id": sim, "object_id": arm, "joint_indices": [0, 99], "control_mode": "VELOCITY_CONTROL"})).await.unwrap_err();
            assert!(e.contains("99"), "{e}");
            let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
            assert_eq!(v["ok"], true, "{v}");
        }
    }
    assert_eq!(hashes[0], hashes[1], "seven single calls and one array call leave the same world");
}

/// Every state-changing result says where it landed — the event it became (`head_seq`, the
/// head right after it, as get_simulation_info reports) and the simulated time after it — so
/// an agent names an interval for get_trajectory from two results, without get_history. The
/// recorded results hold them (event version 3): verify and replay re-check them.
#[tokio::test(flavor = "multi_thread")]
async fn every_change_says_where_it_landed_and_names_an_interval() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let created = c.call("create_simulation", json!({})).await;
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    assert_eq!((created["head_seq"].as_u64(), created["time"].as_f64()), (Some(1), Some(0.0)), "{created}");
    let calls = [
        ("add_box", json!({"dimensions": [5, 5, 0.05], "position": [0, 0, -0.05], "mass": 0})),
        ("add_sphere", json!({"radius": 0.1, "position": [0, 0, 1]})),
        ("step_simulation", json!({"steps": 30})),
        ("set_timestep", json!({"timestep": 0.01})),
        ("change_dynamics", json!({"object_id": 1, "restitution": 0.5})),
        ("set_camera", json!({"distance": 3, "yaw": 30, "pitch": -20, "target": [0, 0, 0]})),
        ("step_simulation", json!({"steps": 20})),
    ];
    let mut landed = Vec::new();
    for (tool, mut args) in calls {
        args["sim_id"] = json!(sim);
        let r = c.call(tool, args).await;
        let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
        assert_eq!(r["head_seq"], info["head_seq"], "{tool}: {r}");
        assert_eq!(r["time"], info["current_time"], "{tool}: {r}");
        landed.push((r["head_seq"].as_u64().unwrap(), r["time"].as_f64().unwrap()));
    }
    // Seqs ascend (reads between them take seqs too) and time moves only with steps.
    assert!(landed.windows(2).all(|w| w[1].0 > w[0].0), "{landed:?}");
    assert_eq!(landed[2].1, landed[1].1 + 30.0 / 240.0, "{landed:?}");
    assert_eq!(landed[6].1, landed[5].1 + 20.0 * 0.01, "{landed:?}");
    // The interval from the sphere's arrival to the last step, named from the results alone.
    let (from, to) = (landed[1].0, landed[6].0);
    let t = c.call("get_trajectory", json!({"sim_id": sim, "from_seq": from, "to_seq": to, "object_ids": [1]})).await;
    assert_eq!((t["from_seq"].as_u64(), t["to_seq"].as_u64()), (Some(from), Some(to)), "{t}");
    assert_eq!(t["times"].as_array().unwrap().last().unwrap().as_f64(), Some(landed[6].1), "{t}");
    // A batch's calls each say their own event; the last is the batch's head.
    let b = c
        .call("batch", json!({"sim_id": sim, "detail": "full", "calls": [
            {"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [1, 0, 1]}},
            {"tool": "get_simulation_info", "arguments": {}},
            {"tool": "step_simulation", "arguments": {"steps": 2}}]}))
        .await;
    let (first, last) = (b["results"][0]["head_seq"].as_u64().unwrap(), b["results"][2]["head_seq"].as_u64().unwrap());
    assert_eq!((last, b["head_seq"].as_u64().unwrap()), (first + 2, last), "{b}");
    assert_eq!(b["time"], b["results"][2]["time"], "{b}");
    // A fork's and a load's own root land after the chain they inherit, at its time.
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": landed[6].0})).await;
    assert_eq!((fork["head_seq"].as_u64(), fork["time"].as_f64()), (Some(landed[6].0 + 1), Some(landed[6].1)), "{fork}");
    let fork_id = fork["simulation_id"].as_str().unwrap();
    assert_eq!(c.call("get_simulation_info", json!({"sim_id": fork_id})).await["head_seq"], fork["head_seq"]);
    c.call("save_simulation", json!({"sim_id": fork_id, "file_path": "landed.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "landed.json"})).await;
    let info = c.call("get_simulation_info", json!({"sim_id": loaded["simulation_id"]})).await;
    assert_eq!((&loaded["head_seq"], &loaded["time"]), (&info["head_seq"], &info["current_time"]), "{loaded}");
    // After an undo, a new change lands past every event so far, on the undone-to head.
    let undone = c.call("undo", json!({"sim_id": sim})).await;
    let r = c.call("apply_force", json!({"sim_id": sim, "object_id": 1, "force": [1, 0, 0]})).await;
    assert!(r["head_seq"].as_u64().unwrap() > last + 1, "{r} after {undone}");
    verifies_and_replays(c, server, dir.path(), &sim).await;
}

/// A simulation's optional `name` (create, fork, load) is shown wherever its id is — the
/// call's result, list_simulations, get_simulation_info — survives undo and a restart, and is
/// not part of the state: a named simulation hashes as an unnamed one. A fork or load is
/// named by its own call only. A bad name is refused naming `name` and creates nothing.
#[tokio::test(flavor = "multi_thread")]
async fn a_simulation_name_is_shown_with_its_id_and_is_not_state() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let created = c.call("create_simulation", json!({"name": "tower A"})).await;
    assert_eq!(created["name"], "tower A", "{created}");
    let sim = created["simulation_id"].as_str().unwrap().to_string();
    let plain = c.new_sim(json!({})).await;
    for s in [&sim, &plain] {
        c.ground(s).await;
        sphere(&c, s, 0.0, json!({})).await;
        c.step(s, 10).await;
    }
    assert_eq!(c.hash(&sim).await, c.hash(&plain).await, "a name is not state");
    let listed = |list: &Value, id: &str| list["simulations"].as_array().unwrap().iter().find(|r| r["simulation_id"] == id).cloned().unwrap();
    let list = c.call("list_simulations", json!({})).await;
    assert_eq!(listed(&list, &sim)["name"], "tower A");
    assert!(listed(&list, &plain).get("name").is_none(), "{list}");
    c.call("undo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.call("get_simulation_info", json!({"sim_id": sim})).await["name"], "tower A");
    // A fork and a load carry the name their own call gives, or none.
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "name": "tower B"})).await;
    assert_eq!(fork["name"], "tower B", "{fork}");
    let unnamed = c.call("fork_simulation", json!({"sim_id": sim})).await;
    assert!(unnamed.get("name").is_none(), "{unnamed}");
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "named.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "named.json", "name": "tower C"})).await;
    assert_eq!(loaded["name"], "tower C", "{loaded}");
    // Refused, naming the parameter; nothing is created.
    let before = c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len();
    for bad in [json!(""), json!("   "), json!("two\nlines"), json!("x".repeat(101)), json!("a\u{2028}b"), json!("\u{202E}evil")] {
        let why = c.try_call("create_simulation", json!({"name": bad})).await.unwrap_err();
        assert!(why.starts_with("name must be"), "{why}");
        let why = c.try_call("fork_simulation", json!({"sim_id": sim, "name": bad})).await.unwrap_err();
        assert!(why.contains("name must be"), "{why}");
    }
    assert_eq!(c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), before);
    // After a restart every name is as it was.
    let fork_id = fork["simulation_id"].as_str().unwrap().to_string();
    drop(c);
    server.terminate();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    for (id, name) in [(&sim, "tower A"), (&fork_id, "tower B")] {
        assert_eq!(c.call("get_simulation_info", json!({"sim_id": id})).await["name"], name);
    }
    verifies_and_replays(c, server, dir.path(), &sim).await;
}
