//! Robots over MCP/HTTP against the real server: URDF loading and PyBullet's joint numbering,
//! joint physics (pendulum period, motors and the torque they report), generated URDFs, the
//! blobs that keep a robot replayable after its files are gone, and refusals.

use crate::common;

use std::path::Path;

use common::{Client, Server};
use serde_json::{json, Value};

async fn start(dir: &Path) -> (Server, Client) {
    let server = Server::start(dir, &[]);
    server.copy_fixtures();
    let client = server.client().await;
    (server, client)
}

/// `base` with the fields of `extra` added.
fn merged(mut base: Value, extra: Value) -> Value {
    if let (Some(a), Some(e)) = (base.as_object_mut(), extra.as_object()) {
        a.extend(e.clone());
    }
    base
}

async fn load(c: &Client, sim: &str, file: &str, extra: Value) -> u64 {
    let args = merged(json!({"sim_id": sim, "file_path": file}), extra);
    c.call("load_urdf", args).await["object_id"].as_u64().unwrap()
}

async fn dynamics(c: &Client, sim: &str, id: u64, link: i64) -> Value {
    c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": id, "link_index": link})).await
}

async fn joint(c: &Client, sim: &str, id: u64, j: u64) -> Value {
    c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await
}

async fn q(c: &Client, sim: &str, id: u64, j: u64) -> f64 {
    joint(c, sim, id, j).await["joint_position"].as_f64().unwrap()
}

async fn motor(c: &Client, sim: &str, id: u64, j: u64, args: Value) {
    let a = merged(json!({"sim_id": sim, "object_id": id, "joint_index": j}), args);
    c.call("set_joint_motor_control", a).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn fixtures_load_with_pybullet_numbering() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({})).await;

    // Branching tree listed out of order: depth-first pre-order, children in file order.
    let wb = load(&c, &sim, "wheeled_base.urdf", json!({"position": [0, 0, 1]})).await;
    let expected = [
        ("left_wheel_joint", "continuous", "left_wheel", -1, 0.0, -1.0, 20.0, 30.0),
        ("right_wheel_joint", "continuous", "right_wheel", -1, 0.0, -1.0, 20.0, 30.0),
        ("mast_joint", "fixed", "mast", -1, 0.0, -1.0, 0.0, 0.0),
        ("pan_joint", "revolute", "pan", 2, -1.5, 1.5, 5.0, 2.0),
        ("tilt_joint", "prismatic", "tilt", 3, 0.0, 0.2, 50.0, 0.5),
        ("caster_joint", "continuous", "caster", -1, 0.0, -1.0, 0.0, 0.0),
    ];
    let n = c.call("get_num_joints", json!({"sim_id": sim, "object_id": wb})).await;
    assert_eq!(n["num_joints"], 6);
    for (i, (name, ty, link, parent, lo, hi, effort, vel)) in expected.iter().enumerate() {
        let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": wb, "joint_index": i})).await;
        assert_eq!(info["joint_index"], i as u64);
        assert_eq!(info["joint_name"], *name, "{info}");
        assert_eq!(info["joint_type"], *ty, "{info}");
        assert_eq!(info["link_name"], *link, "{info}");
        assert_eq!(info["parent_index"], *parent, "{info}");
        assert_eq!(info["lower_limit"].as_f64().unwrap(), *lo, "{info}");
        assert_eq!(info["upper_limit"].as_f64().unwrap(), *hi, "{info}");
        assert_eq!(info["max_force"].as_f64().unwrap(), *effort, "{info}");
        assert_eq!(info["max_velocity"].as_f64().unwrap(), *vel, "{info}");
    }

    // The 7-joint arm: names, types, published limits, axes; the flange is a fixed joint 7.
    let arm = load(&c, &sim, "iiwa14.urdf", json!({"use_fixed_base": true, "position": [2, 0, 0]})).await;
    let limits_deg: [f64; 7] = [170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0];
    let axes = [[0, 0, 1], [0, 1, 0], [0, 0, 1], [0, -1, 0], [0, 0, 1], [0, 1, 0], [0, 0, 1]];
    for (i, lim) in limits_deg.iter().enumerate() {
        let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": arm, "joint_index": i})).await;
        assert_eq!(info["joint_name"], format!("iiwa_joint_{}", i + 1));
        assert_eq!(info["joint_type"], "revolute");
        assert_eq!(info["parent_index"], i as i64 - 1);
        let want = lim.to_radians();
        assert!((info["upper_limit"].as_f64().unwrap() - want).abs() < 1e-6, "{info}");
        assert!((info["lower_limit"].as_f64().unwrap() + want).abs() < 1e-6, "{info}");
        assert_eq!(info["joint_axis"], json!(axes[i].map(|x| x as f64)));
    }
    let ee = c.call("get_joint_info", json!({"sim_id": sim, "object_id": arm, "joint_index": 7})).await;
    assert_eq!(ee["joint_type"], "fixed");
    assert_eq!(ee["link_name"], "iiwa_link_ee");

    // Meshes by package:// (STL) and a relative path (OBJ) become real colliders: the mesh
    // robot, dropped on the built-in plane, comes to rest on its 0.2 m cube.
    let ground = load(&c, &sim, "plane.urdf", json!({})).await;
    let bot = load(&c, &sim, "mesh_bot/urdf/mesh_bot.urdf", json!({"position": [-3, 0, 0.5]})).await;
    assert_eq!(c.call("get_num_joints", json!({"sim_id": sim, "object_id": bot})).await["num_joints"], 1);
    assert_eq!(c.call("get_num_joints", json!({"sim_id": sim, "object_id": ground})).await["num_joints"], 0);
    c.step(&sim, 480).await;
    let z = c.state(&sim, bot).await["position"][2].as_f64().unwrap();
    assert!((z - 0.1).abs() < 0.01, "mesh cube rests at z = {z}, expected 0.1");
}

/// What pybullet 3.2.7 reports for the robot fixtures (`scripts/urdf_fixtures.py` wrote it).
fn pybullet_reference() -> Value {
    serde_json::from_str(include_str!("../fixtures/pybullet_urdf.json")).expect("pybullet_urdf.json")
}

/// Every robot fixture as pybullet 3.2.7 itself reports it (`scripts/urdf_fixtures.py` wrote
/// `tests/fixtures/pybullet_urdf.json`): joint count, every joint's index, name, type, limits,
/// effort, velocity, axis, link name and parent, and every link's mass, inertia diagonal and
/// centre of mass. PyBullet calls a continuous joint "revolute" (with the limits its `<limit>`
/// gives, else the (0, −1) pair); the script labels those the file calls continuous.
/// Links with an `<inertial>` are compared with pybullet's URDF_USE_INERTIA_FROM_FILE load,
/// links without one with its default load (the script says why).
#[tokio::test(flavor = "multi_thread")]
async fn every_fixture_matches_what_pybullet_reports() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let reference = pybullet_reference();
    // f32 storage: agreement to 1e−6 relative (inertias span 1e−7 … 1 kg·m²).
    let close = |a: &Value, b: &Value| {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        (a - b).abs() <= 1e-6 * b.abs() + 1e-12
    };
    let close3 = |a: &Value, b: &Value| (0..3).all(|k| close(&a[k], &b[k]));
    let sim = c.new_sim(json!({})).await;
    let robots = reference["robots"].as_object().unwrap();
    assert_eq!(robots.len(), 5);
    for (k, (file, want)) in robots.iter().enumerate() {
        let id = load(&c, &sim, file, json!({"position": [3.0 * k as f64, 0, 1], "use_fixed_base": true})).await;
        let n = c.call("get_num_joints", json!({"sim_id": sim, "object_id": id})).await;
        assert_eq!(n["num_joints"], want["num_joints"], "{file}");
        for wj in want["joints"].as_array().unwrap() {
            let j = wj["joint_index"].as_u64().unwrap();
            let got = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
            let at = format!("{file} joint {j}: ours {got}, pybullet {wj}");
            for field in ["joint_index", "joint_name", "link_name", "parent_index"] {
                assert_eq!(got[field], wj[field], "{field} of {at}");
            }
            for field in ["lower_limit", "upper_limit", "max_force", "max_velocity"] {
                assert!(close(&got[field], &wj[field]), "{field} of {at}");
            }
            assert!(close3(&got["joint_axis"], &wj["joint_axis"]), "joint_axis of {at}");
            let types_agree = match wj["joint_type"].as_str().unwrap() {
                "revolute_or_continuous" => got["joint_type"] == "continuous",
                t => got["joint_type"] == t,
            };
            assert!(types_agree, "joint_type of {at}");
        }
        for wl in want["links"].as_array().unwrap() {
            let link = wl["link_index"].as_i64().unwrap();
            if link == -1 {
                continue; // the base is fixed here (use_fixed_base): compared below, unfixed
            }
            let got = dynamics(&c, &sim, id, link).await;
            let at = format!("{file} link {link}: ours {got}, pybullet {wl}");
            assert!(close(&got["mass"], &wl["mass"]), "mass of {at}");
            assert!(close3(&got["local_inertia_diagonal"], &wl["local_inertia_diagonal"]), "inertia of {at}");
            assert!(close3(&got["local_inertia_pos"], &wl["local_inertia_pos"]), "centre of mass of {at}");
        }
        let free = load(&c, &sim, file, json!({"position": [3.0 * k as f64, 5, 1]})).await;
        let (got, wl) = (dynamics(&c, &sim, free, -1).await, &want["links"][0]);
        let at = format!("{file} base: ours {got}, pybullet {wl}");
        assert!(close(&got["mass"], &wl["mass"]), "mass of {at}");
        assert!(close3(&got["local_inertia_diagonal"], &wl["local_inertia_diagonal"]), "inertia of {at}");
        assert!(close3(&got["local_inertia_pos"], &wl["local_inertia_pos"]), "centre of mass of {at}");
    }
}

/// A continuous joint reports the lower/upper its `<limit>` gives (r2d2's
/// head_swivel: [−0.38, 0]) but, as in PyBullet, they do not bound its motion — a velocity
/// motor drives it past its upper limit, while a revolute joint with the same limits stops.
/// The positions are pybullet's own (`"motion"` in `tests/fixtures/pybullet_urdf.json`).
#[tokio::test(flavor = "multi_thread")]
async fn issue_10_continuous_joint_limits_are_reported_but_not_enforced() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let reference = pybullet_reference();
    let motion = &reference["motion"];
    let sim = c.new_sim(json!({})).await;
    let file = motion["file"].as_str().unwrap();
    let id = load(&c, &sim, file, json!({"use_fixed_base": motion["use_fixed_base"]})).await;
    let joints = motion["joints"].as_array().unwrap();
    for wj in joints {
        let j = wj["joint_index"].as_u64().unwrap();
        let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
        assert_eq!([&info["lower_limit"], &info["upper_limit"]], [&wj["lower_limit"], &wj["upper_limit"]], "{info} vs {wj}");
        let mode = json!({"control_mode": motion["control_mode"], "target_velocity": motion["target_velocity"],
                          "force": motion["force"]});
        motor(&c, &sim, id, j, mode).await;
    }
    c.step(&sim, motion["steps"].as_u64().unwrap()).await;
    for wj in joints {
        let (j, name) = (wj["joint_index"].as_u64().unwrap(), &wj["joint_name"]);
        let (got, want) = (q(&c, &sim, id, j).await, wj["joint_position"].as_f64().unwrap());
        let upper = wj["upper_limit"].as_f64().unwrap();
        eprintln!("REPORT {name}: position {got} after the velocity motor, pybullet {want}, upper limit {upper}");
        assert!((got - want).abs() < 0.01, "{name}: position {got}, pybullet {want}");
        if name == "limited_swivel" {
            assert!(!wj["limits_enforced"].as_bool().unwrap() && got > upper + 0.9, "{name} passes its upper limit");
        }
    }
}

/// Compatibility (docs/log-format.md): a load_urdf event recorded before continuous joints reported their
/// file limits decodes without `continuous_limits_from_file`, re-encodes byte for byte, and
/// folds to the robot it always did — every continuous joint at [0, −1] — so an old log's
/// state hashes still match. The same load as a new event reports the file's limits and
/// hashes differently.
#[test]
fn issue_10_old_load_urdf_events_keep_continuous_limits_at_none() {
    use physics_mcp::command::{Blob, BlobSource, Command};
    struct Bytes(Vec<u8>);
    impl BlobSource for Bytes {
        fn blob(&self, _hash: &str) -> Option<Vec<u8>> {
            Some(self.0.clone())
        }
    }
    let text = include_bytes!("../fixtures/continuous_limits.urdf").to_vec();
    let old_json = format!(
        r#"{{"op":"load_urdf","file_path":"continuous_limits.urdf","urdf":"{}","meshes":{{}},"position":[0.0,0.0,0.0],"orientation":[0.0,0.0,0.0,1.0],"fixed_base":true}}"#,
        Blob::new(text.clone()).hash
    );
    let mut old: Command = serde_json::from_str(&old_json).unwrap();
    assert_eq!(serde_json::to_string(&old).unwrap(), old_json, "an old event re-encodes unchanged");
    old.hydrate(&Bytes(text)).unwrap();
    let Command::LoadUrdf { continuous_limits_from_file, .. } = &old else { panic!("{old:?}") };
    assert!(!continuous_limits_from_file);
    let mut new = old.clone();
    if let Command::LoadUrdf { continuous_limits_from_file, .. } = &mut new {
        *continuous_limits_from_file = true;
    }

    let (mut old_world, mut new_world) = (common::empty_world("old"), common::empty_world("new"));
    old_world.apply(&old, &mut |_| true);
    new_world.apply(&new, &mut |_| true);
    let limits = |w: &physics_mcp::world::World, j: usize| {
        let info = w.joint_info(0, j).unwrap();
        [info.lower_limit, info.upper_limit]
    };
    for j in 0..5 {
        assert_eq!(limits(&old_world, j), [0.0, -1.0], "old event, continuous joint {j}");
    }
    assert_eq!(limits(&old_world, 5), [-0.38, 0.0], "old event, revolute joint");
    assert_eq!(limits(&new_world, 0), [-0.38, 0.0]);
    assert_eq!(limits(&new_world, 3), [-0.5, -1.0]);
    assert_eq!(limits(&new_world, 4), [0.0, 0.25]);
    assert_ne!(old_world.state_hash(), new_world.state_hash());
}

/// A pendulum URDF: static pivot, one link of mass `m` whose centre hangs `d` below the pivot,
/// box inertia about its centre; the joint (`kind`: revolute with limits far beyond the swing,
/// or continuous) turns about y.
fn pendulum_urdf(kind: &str, m: f64, d: f64, iyy: f64) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="pendulum">
  <link name="pivot"/>
  <link name="bob">
    <inertial><origin xyz="0 0 {z}"/><mass value="{m}"/><inertia ixx="{iyy}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{iyy}"/></inertial>
    <collision><origin xyz="0 0 {z}"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="hinge" type="{kind}">
    <parent link="pivot"/><child link="bob"/>
    <origin xyz="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="100"/>
  </joint>
</robot>
"#,
        z = -d
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn free_pendulum_has_the_small_angle_period() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path()).await;
    let (m, d, iyy) = (1.0, 0.5, 0.002);
    for kind in ["revolute", "continuous"] {
        let file = format!("pendulum_{kind}.urdf");
        std::fs::write(server.workspace.join(&file), pendulum_urdf(kind, m, d, iyy)).unwrap();
        let sim = c.new_sim(json!({})).await;
        let p = load(&c, &sim, &file, json!({"position": [0, 0, 2], "use_fixed_base": true})).await;
        let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": p, "joint_index": 0})).await;
        assert_eq!(info["joint_type"], kind);
        // A one-step horizontal push on the bob: a small swing (a few degrees).
        c.call("apply_force", json!({"sim_id": sim, "object_id": p, "link_index": 0, "force": [30, 0, 0]})).await;
        let dt = 1.0 / 240.0;
        let mut crossings = Vec::new();
        let mut prev = 0.0;
        let mut amplitude: f64 = 0.0;
        for k in 1..=1200 {
            c.step(&sim, 2).await;
            let x = q(&c, &sim, p, 0).await;
            amplitude = amplitude.max(x.abs());
            let t = k as f64 * 2.0 * dt;
            if k > 1 && prev < 0.0 && x >= 0.0 {
                crossings.push(t - 2.0 * dt * x / (x - prev));
            }
            prev = x;
        }
        assert!(amplitude > 0.02 && amplitude < 0.2, "{kind}: swing amplitude {amplitude} rad");
        assert!(crossings.len() >= 3, "{kind}: crossings {crossings:?}");
        let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let i_pivot = iyy + m * d * d;
        let theory = 2.0 * std::f64::consts::PI * (i_pivot / (m * 9.81 * d)).sqrt();
        let err = (measured - theory).abs() / theory;
        eprintln!("REPORT {kind} pendulum period {measured:.5} s, theory {theory:.5} s, error {:.3} %, amplitude {amplitude:.3} rad", err * 100.0);
        assert!(err < 0.02, "{kind}: period {measured:.4} s vs theory {theory:.4} s ({:.2} %)", err * 100.0);
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn motors_position_velocity_torque_and_reported_torque() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;

    // POSITION_CONTROL, default gains, lifts/lowers the shoulder to 1 rad under gravity.
    let sim = c.new_sim(json!({})).await;
    let arm = load(&c, &sim, "two_link_arm.urdf", json!({"position": [0, 0, 1]})).await;
    motor(&c, &sim, arm, 0, json!({"control_mode": "POSITION_CONTROL", "target_position": 1.0})).await;
    motor(&c, &sim, arm, 1, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.0})).await;
    c.step(&sim, 480).await;
    let shoulder = q(&c, &sim, arm, 0).await;
    assert!((shoulder - 1.0).abs() < 0.01, "shoulder at {shoulder} after 2 s");

    // Held horizontal against gravity: the shoulder's motor carries both links' weight,
    // g·(m1·0.25 + m2·(0.5 + 0.2)); the elbow carries g·m2·0.2.
    let sim = c.new_sim(json!({})).await;
    let arm = load(&c, &sim, "two_link_arm.urdf", json!({"position": [0, 0, 1]})).await;
    motor(&c, &sim, arm, 0, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.0})).await;
    motor(&c, &sim, arm, 1, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.0})).await;
    c.step(&sim, 240).await;
    let s = joint(&c, &sim, arm, 0).await;
    let e = joint(&c, &sim, arm, 1).await;
    let (ts, te) = (s["motor_torque"].as_f64().unwrap(), e["motor_torque"].as_f64().unwrap());
    let (ws, we) = (9.81 * (1.0 * 0.25 + 0.5 * 0.7), 9.81 * 0.5 * 0.2);
    eprintln!("REPORT held arm motor_torque shoulder {ts} (|m g d| = {ws}), elbow {te} (|m g d| = {we})");
    assert!(s["joint_position"].as_f64().unwrap().abs() < 0.01, "{s}");
    assert!((ts.abs() - ws).abs() / ws < 0.05, "shoulder motor_torque {ts}, expected ±{ws}");
    assert!((te.abs() - we).abs() / we < 0.05, "elbow motor_torque {te}, expected ±{we}");
    assert_eq!(s["reaction_forces"], json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));

    // VELOCITY_CONTROL holds 1 rad/s while gravity's torque on the horizontal link changes.
    motor(&c, &sim, arm, 0, json!({"control_mode": "VELOCITY_CONTROL", "target_velocity": -1.0})).await;
    for _ in 0..6 {
        c.step(&sim, 40).await;
        let v = joint(&c, &sim, arm, 0).await["joint_velocity"].as_f64().unwrap();
        assert!((v + 1.0).abs() < 0.02, "shoulder velocity {v}, target -1");
    }

    // TORQUE_CONTROL on a free, undamped joint (no gravity): α = τ / I.
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let g = c
        .call(
            "generate_revolute_joint",
            json!({"parent_shape": "box", "child_shape": "box", "parent_dimensions": [0.1, 0.1, 0.1],
                   "child_dimensions": [0.3, 0.05, 0.05], "child_mass": 2.0, "joint_axis": [0, 0, 1],
                   "joint_origin": [0, 0, 0.3], "joint_lower_limit": -100, "joint_upper_limit": 100}),
        )
        .await;
    assert_eq!(g["joint_type"], "revolute");
    let path = g["urdf_path"].as_str().unwrap().to_string();
    assert!(path.contains("generated/revolute_"), "{path}");
    let pair = load(&c, &sim, &path, json!({"use_fixed_base": true})).await;
    let tau = 0.5;
    motor(&c, &sim, pair, 0, json!({"control_mode": "TORQUE_CONTROL", "force": tau})).await;
    c.step(&sim, 120).await;
    let st = joint(&c, &sim, pair, 0).await;
    let i_zz = 2.0 / 3.0 * (0.3f64 * 0.3 + 0.05 * 0.05);
    let alpha = st["joint_velocity"].as_f64().unwrap() / 0.5;
    eprintln!("REPORT torque control alpha {alpha} vs tau/I {}", tau / i_zz);
    assert!((alpha - tau / i_zz).abs() / (tau / i_zz) < 0.02, "alpha {alpha} vs {}", tau / i_zz);
    assert_eq!(st["motor_torque"].as_f64().unwrap(), tau);
}

#[tokio::test(flavor = "multi_thread")]
async fn robot_survives_save_load_undo_and_restart_after_its_files_are_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({})).await;
    load(&c, &sim, "plane.urdf", json!({})).await;
    let arm = load(&c, &sim, "two_link_arm.urdf", json!({"position": [0, 0, 1]})).await;
    let bot = load(&c, &sim, "mesh_bot/urdf/mesh_bot.urdf", json!({"position": [1, 0, 0.5]})).await;
    motor(&c, &sim, arm, 0, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.5})).await;
    c.step(&sim, 100).await;
    let before_motor = c.hash(&sim).await;
    motor(&c, &sim, arm, 1, json!({"control_mode": "VELOCITY_CONTROL", "target_velocity": 0.3, "force": 5})).await;
    c.step(&sim, 100).await;
    let h = c.hash(&sim).await;

    // The files are gone: everything below works from the log's blobs.
    std::fs::remove_file(server.workspace.join("two_link_arm.urdf")).unwrap();
    std::fs::remove_dir_all(server.workspace.join("mesh_bot")).unwrap();

    c.call("save_simulation", json!({"sim_id": sim, "file_path": "robot.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "robot.json"})).await;
    let copy = loaded["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c.hash(&copy).await, h, "loaded state differs");
    c.step(&sim, 60).await;
    c.step(&copy, 60).await;
    let h2 = c.hash(&sim).await;
    assert_eq!(c.hash(&copy).await, h2, "loaded copy evolves differently");
    assert_eq!(joint(&c, &sim, arm, 1).await, joint(&c, &copy, arm, 1).await);

    // Undo three changes (step, motor, step): back to the state before the second motor.
    c.call("undo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.hash(&sim).await, before_motor);
    c.call("redo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.hash(&sim).await, h2);

    // A killed server comes back with the robots exactly as they were.
    let data = server.data.clone();
    server.kill();
    let server = Server::start(dir.path(), &[]);
    assert_eq!(server.data, data);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, h2);
    c.step(&sim, 30).await;
    c.step(&copy, 30).await;
    assert_eq!(c.hash(&sim).await, c.hash(&copy).await);
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    assert!(c.state(&sim, bot).await["position"][2].as_f64().unwrap() > 0.05);
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_robot_inputs_are_refused_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path()).await;
    let ws = &server.workspace;
    std::fs::write(ws.join("broken.urdf"), "<robot name=\"x\"><link name=\"a\"></robot>").unwrap();
    std::fs::write(
        ws.join("nomesh.urdf"),
        r#"<robot name="x"><link name="a"><collision><geometry><mesh filename="meshes/missing.stl"/></geometry></collision></link></robot>"#,
    )
    .unwrap();
    std::fs::write(ws.join("notstl.stl"), "this is not an STL file at all").unwrap();
    std::fs::write(
        ws.join("badmesh.urdf"),
        r#"<robot name="x"><link name="a"><collision><geometry><mesh filename="notstl.stl"/></geometry></collision></link></robot>"#,
    )
    .unwrap();
    std::fs::write(
        ws.join("loop.urdf"),
        r#"<robot name="x"><link name="a"/><link name="b"/>
           <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
           <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint></robot>"#,
    )
    .unwrap();
    let sim = c.new_sim(json!({})).await;
    let arm = load(&c, &sim, "two_link_arm.urdf", json!({})).await;
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [3, 0, 1]})).await["object_id"]
        .as_u64()
        .unwrap();
    let hash = c.hash(&sim).await;
    let s = sim.as_str();
    let cases: Vec<(&str, Value, &str)> = vec![
        ("load_urdf", json!({"sim_id": s, "file_path": "missing.urdf"}), "does not exist"),
        ("load_urdf", json!({"sim_id": s, "file_path": "../outside.urdf"}), "Access denied"),
        ("load_urdf", json!({"sim_id": s, "file_path": "/etc/passwd"}), "Access denied"),
        ("load_urdf", json!({"sim_id": s, "file_path": "broken.urdf"}), "not a valid URDF"),
        ("load_urdf", json!({"sim_id": s, "file_path": "nomesh.urdf"}), "missing.stl"),
        ("load_urdf", json!({"sim_id": s, "file_path": "badmesh.urdf"}), "notstl.stl"),
        ("load_urdf", json!({"sim_id": s, "file_path": "loop.urdf"}), "root link"),
        ("load_urdf", json!({"sim_id": s, "file_path": "plane.urdf", "position": [0, 0]}), "position"),
        ("get_joint_info", json!({"sim_id": s, "object_id": arm, "joint_index": 2}), "Joint index 2 out of range"),
        ("get_joint_state", json!({"sim_id": s, "object_id": arm, "joint_index": -1}), "out of range"),
        ("get_joint_info", json!({"sim_id": s, "object_id": ball, "joint_index": 0}), "has 0 joints"),
        ("get_joint_state", json!({"sim_id": s, "object_id": 99, "joint_index": 0}), "Object 99 not found"),
        ("set_joint_motor_control", json!({"sim_id": s, "object_id": arm, "joint_index": 5, "control_mode": "VELOCITY_CONTROL"}), "out of range"),
        ("set_joint_motor_control", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "control_mode": "PD_CONTROL"}), "control_mode"),
        ("set_joint_motor_control", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "control_mode": "POSITION_CONTROL"}), "target_position"),
        ("set_joint_motor_control", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "control_mode": "TORQUE_CONTROL"}), "force"),
        ("set_joint_motor_control", json!({"sim_id": s, "object_id": arm, "joint_index": 0, "control_mode": "VELOCITY_CONTROL", "force": -1}), "force"),
        ("calculate_inverse_kinematics", json!({"sim_id": s, "object_id": arm, "end_effector_link_index": 4, "target_position": [0.5, 0, 0]}), "out of range"),
        ("calculate_inverse_kinematics", json!({"sim_id": s, "object_id": arm, "end_effector_link_index": 1, "target_position": [0.5, 0, 0], "rest_poses": [0]}), "rest_poses"),
        ("apply_force", json!({"sim_id": s, "object_id": arm, "link_index": 2, "force": [1, 0, 0]}), "link_index 2"),
        ("change_dynamics", json!({"sim_id": s, "object_id": arm, "link_index": 0, "mass": 0}), "base only"),
        ("generate_revolute_joint", json!({"parent_shape": "cone", "child_shape": "box", "parent_dimensions": [1], "child_dimensions": [1, 1, 1]}), "parent_shape"),
        ("generate_revolute_joint", json!({"parent_shape": "box", "child_shape": "box", "parent_dimensions": [1, 1], "child_dimensions": [1, 1, 1]}), "parent_dimensions"),
        ("generate_revolute_joint", json!({"parent_shape": "box", "child_shape": "box", "parent_dimensions": [1, 1, 1], "child_dimensions": [1, 1, 1], "output_path": "../escape.urdf"}), "Access denied"),
    ];
    for (tool, args, needle) in cases {
        let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} was accepted"));
        assert!(err.contains(needle), "{tool} {args}: {err:?} does not mention {needle:?}");
    }
    assert_eq!(c.hash(&sim).await, hash, "a refused call changed the world");
    let info = c.call("get_simulation_info", json!({"sim_id": s})).await;
    assert_eq!(info["objects"].as_array().unwrap().len(), 2);
    assert!(!server.workspace.parent().unwrap().join("escape.urdf").exists());
}

#[tokio::test(flavor = "multi_thread")]
async fn link_dynamics_are_reported_changed_and_felt() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({})).await;
    let arm = load(&c, &sim, "two_link_arm.urdf", json!({"position": [0, 0, 1]})).await;
    let info = |link: i64| dynamics(&c, &sim, arm, link);
    let upper = info(0).await;
    assert_eq!(upper["mass"], 1.0);
    assert_eq!(upper["local_inertia_pos"], json!([0.25, 0.0, 0.0]));
    assert_eq!(upper["body_type"], "dynamic");
    assert_eq!(info(-1).await["body_type"], "static", "a base of mass 0 is static");
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": arm, "link_index": 0, "mass": 2.0, "lateral_friction": 0.8})).await;
    let upper = info(0).await;
    assert_eq!(upper["mass"], 2.0);
    assert_eq!(upper["lateral_friction"], 0.8);
    assert_eq!(upper["local_inertia_pos"], json!([0.25, 0.0, 0.0]), "the centre of mass stays");
    assert_eq!(info(1).await["mass"], 0.5, "the other link is unchanged");
    // The heavier upper arm is felt by the motor holding the arm: g·(2·0.25 + 0.5·0.7).
    motor(&c, &sim, arm, 0, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.0})).await;
    motor(&c, &sim, arm, 1, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.0})).await;
    c.step(&sim, 240).await;
    let t = joint(&c, &sim, arm, 0).await["motor_torque"].as_f64().unwrap();
    let want = 9.81 * (2.0 * 0.25 + 0.5 * 0.7);
    assert!((t.abs() - want).abs() / want < 0.05, "shoulder torque {t}, expected ±{want}");
    // A one-step upward force on the forearm's tip lifts it: the elbow turns negative.
    motor(&c, &sim, arm, 1, json!({"control_mode": "TORQUE_CONTROL", "force": 0.0})).await;
    c.call("apply_force", json!({"sim_id": sim, "object_id": arm, "link_index": 1, "force": [0, 0, 200], "position": [0.9, 0, 1]})).await;
    c.step(&sim, 1).await;
    let v = joint(&c, &sim, arm, 1).await["joint_velocity"].as_f64().unwrap();
    assert!(v < -1.0, "elbow velocity after the push {v}");
    // The robot's base reads as an object state.
    let st = c.state(&sim, arm).await;
    assert_eq!(st["position"], json!([0.0, 0.0, 1.0]));
}

#[tokio::test(flavor = "multi_thread")]
async fn a_robot_base_can_be_teleported_and_pushed() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let bot = load(&c, &sim, "wheeled_base.urdf", json!({"position": [0, 0, 1]})).await;
    motor(&c, &sim, bot, 3, json!({"control_mode": "POSITION_CONTROL", "target_position": 0.5})).await;
    c.step(&sim, 120).await;
    let pan = q(&c, &sim, bot, 3).await;
    // Teleport the free base: it lands where asked and the joints keep their positions.
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": bot, "position": [5, -2, 3], "orientation": [0, 0, 0.3826834, 0.9238795]})).await;
    let st = c.state(&sim, bot).await;
    assert_eq!(st["position"], json!([5.0, -2.0, 3.0]));
    assert!((q(&c, &sim, bot, 3).await - pan).abs() < 1e-6);
    // A base velocity carries the whole robot (no gravity): x grows by v·t.
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": bot, "linear_velocity": [1, 0, 0]})).await;
    c.step(&sim, 240).await;
    let x = c.state(&sim, bot).await["position"][0].as_f64().unwrap();
    assert!((x - 6.0).abs() < 0.02, "base x {x}, expected 6");
}

/// A link with no `<inertial>` gets PyBullet's stand-in: 1 kg at the link origin with the
/// inertia of its collision shapes (values read from pybullet 3.2.7 for this very file), so a
/// base without one is dynamic and falls unless fixed.
#[tokio::test(flavor = "multi_thread")]
async fn links_without_inertial_get_pybullets_one_kilogram() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path()).await;
    std::fs::write(
        server.workspace.join("noinertial.urdf"),
        r#"<robot name="x">
  <link name="root"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="child"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="root"/><child link="child"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"#,
    )
    .unwrap();
    let sim = c.new_sim(json!({})).await;
    let r = load(&c, &sim, "noinertial.urdf", json!({"position": [0, 0, 2]})).await;
    let info = |link: i64| dynamics(&c, &sim, r, link);
    let (base, child) = (info(-1).await, info(0).await);
    assert_eq!(base["mass"], 1.0);
    assert_eq!(base["body_type"], "dynamic");
    assert_eq!(child["mass"], 1.0);
    for (v, want) in [(&base, 0.0016666667), (&child, 0.001)] {
        for x in v["local_inertia_diagonal"].as_array().unwrap() {
            assert!((x.as_f64().unwrap() - want).abs() < 1e-6, "{v}");
        }
    }
    c.step(&sim, 240).await;
    let z = c.state(&sim, r).await["position"][2].as_f64().unwrap();
    assert!(z < 0.0, "the unfixed base fell: z = {z}");
}

/// IK end to end: the answer for a reachable target, sent over HTTP, is reached (< 1 mm), stays
/// in the URDF limits, and — driven by POSITION_CONTROL motors with default gains under
/// gravity — is where the arm's joints settle. Without rest_poses the solver starts from the
/// current configuration: asked again once the arm is there, it has almost nothing left to do.
#[tokio::test(flavor = "multi_thread")]
async fn ik_answer_over_http_is_where_position_motors_take_the_arm() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({})).await;
    let arm = load(&c, &sim, "iiwa14.urdf", json!({"use_fixed_base": true, "position": [0, 0, 0.5]})).await;
    let ask = |rest: Option<Value>| {
        let mut a = json!({"sim_id": sim, "object_id": arm, "end_effector_link_index": 7,
                           "target_position": [0.45, 0.25, 1.1], "target_orientation": [1, 0, 0, 0]});
        if let Some(r) = rest {
            a["rest_poses"] = r;
        }
        c.call("calculate_inverse_kinematics", a)
    };
    let sol = ask(Some(json!([0, 0, 0, 0, 0, 0, 0]))).await;
    let answer: Vec<f64> = sol["joint_positions"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    assert_eq!(answer.len(), 7);
    assert!(sol["position_error"].as_f64().unwrap() < 1e-3, "{sol}");
    assert!(sol["orientation_error"].as_f64().unwrap() < 0.01, "{sol}");
    for (j, v) in answer.iter().enumerate() {
        let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": arm, "joint_index": j})).await;
        assert!(*v >= info["lower_limit"].as_f64().unwrap() && *v <= info["upper_limit"].as_f64().unwrap(), "{sol}");
    }
    // Asking leaves the world alone; the same question gets the same answer.
    let h = c.hash(&sim).await;
    assert_eq!(ask(Some(json!([0, 0, 0, 0, 0, 0, 0]))).await, sol);
    assert_eq!(c.hash(&sim).await, h);

    for (j, v) in answer.iter().enumerate() {
        motor(&c, &sim, arm, j as u64, json!({"control_mode": "POSITION_CONTROL", "target_position": v})).await;
    }
    c.step(&sim, 720).await;
    for (j, v) in answer.iter().enumerate() {
        let got = q(&c, &sim, arm, j as u64).await;
        assert!((got - v).abs() < 0.01, "joint {j} at {got}, IK said {v}");
    }
    let again = ask(None).await;
    assert!(again["position_error"].as_f64().unwrap() < 1e-3, "{again}");
    let (first, second) = (sol["iterations"].as_u64().unwrap(), again["iterations"].as_u64().unwrap());
    assert!(second < first, "from the current configuration {second} iterations, from zeros {first}");
}

/// The built-in assets load by name when the workspace has no such file: PyBullet's cube.urdf
/// (1 m, 1 kg) and sphere2.urdf (r = 0.5 m) dropped on plane.urdf come to rest on it.
#[tokio::test(flavor = "multi_thread")]
async fn builtin_cube_and_sphere_rest_on_the_builtin_plane() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path()).await;
    let sim = c.new_sim(json!({})).await;
    load(&c, &sim, "plane.urdf", json!({})).await;
    let cube = load(&c, &sim, "cube.urdf", json!({"position": [0, 0, 2]})).await;
    let ball = load(&c, &sim, "sphere.urdf", json!({"position": [3, 0, 1.5]})).await;
    assert_eq!(dynamics(&c, &sim, cube, -1).await["mass"], 1.0);
    c.step(&sim, 720).await;
    for (id, rest) in [(cube, 0.5), (ball, 0.5)] {
        let z = c.state(&sim, id).await["position"][2].as_f64().unwrap();
        assert!((z - rest).abs() < 0.01, "object {id} rests at z = {z}, expected {rest}");
    }
}
