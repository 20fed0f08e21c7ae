//! load_mjcf over MCP/HTTP against MuJoCo itself (tests/reference/mjcf_mujoco.json, written by
//! scripts/mjcf_reference.py from Gymnasium's models in tests/fixtures/mjcf/): every fixture
//! loads with its `ignored` list; joint names, types and limits and body masses equal MuJoCo's;
//! after reset_joint_state to MuJoCo's configurations every body's frame (get_link_state of its
//! link) equals MuJoCo's xpos/xquat — for the workspace copies and for the same models built
//! in (`mujoco/<model>.xml`). Bodies are matched by order, not name (MuJoCo names an
//! unnamed body ""). Also: refusals naming the problem and changing nothing; undo/redo, fork,
//! save → load and replay of an MJCF robot; a hinge pendulum's period against theory.

use crate::common;

use std::path::Path;

use common::{Client, Server};
use serde_json::{json, Value};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/mjcf_mujoco.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// A JSON array of numbers (shared with builtins.rs).
pub(crate) fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("array expected, got {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Largest difference between two vectors.
pub(crate) fn vec_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// Largest difference between two quaternions up to sign.
pub(crate) fn quat_diff(a: &[f64], b: &[f64]) -> f64 {
    let d = |s: f64| a.iter().zip(b).map(|(x, y)| (x - s * y).abs()).fold(0.0, f64::max);
    d(1.0).min(d(-1.0))
}

/// What each fixture's `ignored` must mention: every model's `<option>` (its actuators are simulated), and
/// what each uses that rapier does not simulate (grep the fixtures for these attributes).
fn expected_ignored(model: &str) -> Vec<&'static str> {
    if model == "mesh_robot" {
        return vec!["<option timestep="];
    }
    let mut v = vec!["<option timestep="];
    v.extend(match model {
        "swimmer" => &["<option viscosity>", "<option density>", "condim=\"1\""][..],
        "hopper" => &["solref", "condim=\"1\""][..],
        "half_cheetah" => &["solref", "solimp", "joint stiffness"][..],
        // Their fixed tendons carry no actuator and nothing of their own: built, nothing ignored.
        "humanoid" | "humanoidstandup" => &["condim=\"1\"", "joint stiffness"][..],
        "pusher" => &["condim=\"1\""][..],
        _ => &[][..],
    });
    v
}

/// The hinge/slide joints of a reference model, in order (our joint indices).
fn dof_joints(m: &Value) -> Vec<Value> {
    m["joints"].as_array().unwrap().iter().filter(|j| j["type"] == "hinge" || j["type"] == "slide").cloned().collect()
}

async fn load(c: &Client, sim: &str, model: &str) -> Value {
    c.call("load_mjcf", json!({"sim_id": sim, "file_path": format!("mjcf/{model}.xml")})).await
}

#[tokio::test(flavor = "multi_thread")]
async fn fixtures_load_and_match_mujoco() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let r = reference();
    for (model, m) in r["models"].as_object().unwrap() {
        matches_mujoco(&c, model, m, &format!("mjcf/{model}.xml")).await;
    }
}

/// Gymnasium's models built in (`mujoco/<model>.xml`), loaded by name on a server whose
/// workspace holds no file, equal MuJoCo as the workspace copies do: the library ships the
/// very files the reference was computed from.
#[tokio::test(flavor = "multi_thread")]
async fn builtin_gymnasium_models_load_by_name_and_match_mujoco() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let r = reference();
    let mut matched = 0;
    for (model, m) in r["models"].as_object().unwrap().iter().filter(|(model, _)| *model != "mesh_robot") {
        matches_mujoco(&c, model, m, &format!("mujoco/{model}.xml")).await;
        matched += 1;
    }
    assert_eq!(matched, 11, "Gymnasium's eleven models");
}

/// Loads `file_path` (MJCF model `model` of the reference, whose entry is `m`) and checks it
/// against MuJoCo: its `ignored` notes, joints, masses, and body frames at MuJoCo's
/// configurations.
async fn matches_mujoco(c: &Client, model: &str, m: &Value, file_path: &str) {
    {
        let sim = c.new_sim(json!({})).await;
        let loaded = c.call("load_mjcf", json!({"sim_id": sim, "file_path": file_path})).await;
        let id = loaded["object_id"].as_u64().unwrap();
        // ignored: every expected note is there.
        let ignored: Vec<String> = loaded["ignored"].as_array().unwrap().iter().map(|s| s.as_str().unwrap().to_string()).collect();
        for want in expected_ignored(model) {
            assert!(ignored.iter().any(|s| s.contains(want)), "{model}: ignored {ignored:?} lacks {want}");
        }
        // Joints: count, names, types, limits.
        let joints = dof_joints(m);
        assert_eq!(loaded["num_joints"].as_u64().unwrap() as usize, joints.len(), "{model}: num_joints");
        for (i, j) in joints.iter().enumerate() {
            let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": i})).await;
            assert_eq!(info["joint_name"], j["name"], "{model} joint {i}");
            let ty = info["joint_type"].as_str().unwrap();
            match j["type"].as_str().unwrap() {
                "hinge" => assert!(ty == "revolute" || ty == "continuous", "{model} joint {i}: {ty}"),
                _ => assert_eq!(ty, "prismatic", "{model} joint {i}"),
            }
            let (lo, hi) = (info["lower_limit"].as_f64().unwrap(), info["upper_limit"].as_f64().unwrap());
            if j["limited"].as_bool().unwrap() {
                let range = floats(&j["range"]);
                assert!((lo - range[0]).abs() < 1e-6 && (hi - range[1]).abs() < 1e-6, "{model} joint {i}: [{lo}, {hi}] vs {range:?}");
            } else {
                assert_eq!((lo, hi), (0.0, -1.0), "{model} joint {i}: unlimited");
            }
        }
        // Bodies: one entry per MuJoCo body, in order; masses per link equal the sum of the
        // bodies it carries.
        let bodies = loaded["bodies"].as_array().unwrap();
        let ref_bodies = m["bodies"].as_array().unwrap();
        assert_eq!(bodies.len(), ref_bodies.len(), "{model}: bodies");
        let free = m["joints"].as_array().unwrap().iter().any(|j| j["type"] == "free");
        let mut mass_of_link = std::collections::BTreeMap::<i64, f64>::new();
        for (b, rb) in bodies.iter().zip(ref_bodies) {
            *mass_of_link.entry(b["link_index"].as_i64().unwrap()).or_default() += rb["mass"].as_f64().unwrap();
        }
        for (link, want) in &mass_of_link {
            if *link < 0 && !free {
                continue; // the static worldbody
            }
            let d = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
            let got = d["mass"].as_f64().unwrap();
            assert!((got - want).abs() <= 1e-5 * want.max(1e-3), "{model} link {link}: mass {got} vs MuJoCo {want}");
        }
        if model == "mesh_robot" {
            // No armature here: each body's principal inertia equals MuJoCo's too (meshes by
            // every <mesh inertia> rule).
            for (k, (b, rb)) in bodies.iter().zip(ref_bodies).enumerate() {
                let link = b["link_index"].as_i64().unwrap();
                let d = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
                let mut got = floats(&d["local_inertia_diagonal"]);
                let mut want = floats(&rb["inertia"]);
                got.sort_by(f64::total_cmp);
                want.sort_by(f64::total_cmp);
                let off = vec_diff(&got, &want);
                assert!(off <= 1e-5 * want[2], "{model} body {k}: principal inertia {got:?} vs MuJoCo {want:?}");
            }
        }
        // Which bodies have a frame of their own (a joint, or the free root).
        let link_of_name = |name: &str| -> i64 {
            if name == "world" {
                return -2;
            }
            let k = ref_bodies.iter().position(|b| b["name"] == name).unwrap();
            bodies[k]["link_index"].as_i64().unwrap()
        };
        let own: Vec<bool> = bodies
            .iter()
            .zip(ref_bodies)
            .map(|(b, rb)| {
                let link = b["link_index"].as_i64().unwrap();
                let parent = link_of_name(rb["parent"].as_str().unwrap());
                link != parent && !(parent == -2 && link == -1 && !free)
            })
            .collect();
        // Kinematics at qpos0 and at MuJoCo's random configurations.
        let mut compared = 0;
        for (ci, conf) in m["configurations"].as_array().unwrap().iter().enumerate() {
            for (i, j) in joints.iter().enumerate() {
                if let Some(q) = conf["qpos"].get(j["name"].as_str().unwrap()) {
                    c.call("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": i, "target_value": q})).await;
                }
            }
            for (i, j) in joints.iter().enumerate() {
                let want = conf["qpos"].get(j["name"].as_str().unwrap()).and_then(Value::as_f64).unwrap_or(j["ref"].as_f64().unwrap());
                let s = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": i})).await;
                let got = s["joint_position"].as_f64().unwrap();
                assert!((got - want).abs() < 1e-5, "{model} configuration {ci} joint {i}: qpos {got} vs {want}");
            }
            for (k, frame) in conf["frames"].as_array().unwrap().iter().enumerate() {
                if !own[k] {
                    continue;
                }
                let link = bodies[k]["link_index"].as_i64().unwrap();
                let s = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
                let at = format!("{model} configuration {ci} body {k} ({}) link {link}", frame["body"]);
                let d = vec_diff(&floats(&s["link_world_position"]), &floats(&frame["xpos"]));
                assert!(d < 1e-5, "{at}: position {} vs MuJoCo {} (off by {d})", s["link_world_position"], frame["xpos"]);
                let d = quat_diff(&floats(&s["link_world_orientation"]), &floats(&frame["xquat"]));
                assert!(d < 1e-5, "{at}: orientation {} vs MuJoCo {} (off by {d})", s["link_world_orientation"], frame["xquat"]);
                if model == "mesh_robot" {
                    // One body per link: its centre of mass is MuJoCo's xipos (mesh placement).
                    let d = vec_diff(&floats(&s["com_world_position"]), &floats(&frame["xipos"]));
                    assert!(d < 1e-5, "{at}: centre of mass {} vs MuJoCo {} (off by {d})", s["com_world_position"], frame["xipos"]);
                }
                compared += 1;
            }
        }
        // Every body with a joint (or the free root) was compared in every configuration.
        let framed = own.iter().filter(|o| **o).count();
        assert!(framed >= joints.len().min(1), "{model}: no body compared");
        assert_eq!(compared, framed * m["configurations"].as_array().unwrap().len(), "{model}");
        eprintln!("REPORT {file_path}: {framed} body frames x {} configurations equal MuJoCo's", m["configurations"].as_array().unwrap().len());
    }
}

/// A pendulum: a 1 kg point-like sphere on a massless-looking rod, hinged at the world, with
/// optional armature and damping. The rod is a tiny capsule so the bob dominates the inertia.
fn pendulum_xml(armature: f64, damping: f64) -> String {
    format!(
        r#"<mujoco model="pendulum">
  <worldbody>
    <body name="pole" pos="0 0 2">
      <joint name="hinge" type="hinge" axis="0 1 0" pos="0 0 0" armature="{armature}" damping="{damping}"/>
      <geom name="bob" type="sphere" size="0.01" pos="0 0 -1" mass="1" contype="0" conaffinity="0"/>
      <geom name="bob_c" type="sphere" size="0.01" pos="0 0 -1" mass="0" contype="2" conaffinity="2"/>
    </body>
  </worldbody>
</mujoco>"#
    )
}

#[tokio::test(flavor = "multi_thread")]
async fn a_hinge_pendulum_swings_at_its_theoretical_period() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    for (armature, damping) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.05)] {
        std::fs::write(server.workspace.join("pendulum.xml"), pendulum_xml(armature, damping)).unwrap();
        let sim = c.new_sim(json!({})).await;
        c.call("set_timestep", json!({"sim_id": sim, "timestep": 0.001})).await;
        let id = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "pendulum.xml"})).await["object_id"].as_u64().unwrap();
        let amplitude: f64 = 0.1;
        c.call("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 0, "target_value": amplitude})).await;
        // Sample q every 10 ms for 5 s; the period is twice the mean gap between zero crossings.
        let mut crossings = Vec::new();
        let mut peaks = Vec::new();
        let (mut prev, mut t): (f64, f64) = (amplitude, 0.0);
        let mut peak: f64 = 0.0;
        for _ in 0..500 {
            c.step(&sim, 10).await;
            t += 0.01;
            let q = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": 0})).await["joint_position"]
                .as_f64()
                .unwrap();
            peak = peak.max(q.abs());
            if prev.signum() != q.signum() && q != 0.0 {
                crossings.push(t - 0.01 * q.abs() / (q.abs() + prev.abs()));
                peaks.push(peak);
                peak = 0.0;
            }
            prev = q;
        }
        assert!(crossings.len() >= 4, "too few swings: {crossings:?}");
        let gaps: Vec<f64> = crossings.windows(2).map(|w| w[1] - w[0]).collect();
        let period = 2.0 * gaps.iter().sum::<f64>() / gaps.len() as f64;
        // Small-angle period of a point mass at 1 m with the bob's own inertia and armature.
        let inertia = 1.0 + 0.4 * 0.01 * 0.01 + armature;
        let theory = 2.0 * std::f64::consts::PI * (inertia / 9.81).sqrt() * (1.0 + amplitude * amplitude / 16.0);
        eprintln!("REPORT pendulum armature {armature} damping {damping}: period {period} vs theory {theory}");
        if damping == 0.0 {
            assert!((period - theory).abs() / theory < 0.01, "armature {armature}: period {period} vs theory {theory}");
            let last = *peaks.last().unwrap();
            assert!(last > 0.97 * amplitude, "undamped amplitude decayed to {last}");
        } else {
            // Damped: amplitude decays as exp(-d t / (2 I)); check the ratio over the run.
            let first = peaks[1];
            let last = *peaks.last().unwrap();
            let dt = crossings[crossings.len() - 1] - crossings[1];
            let want = (-damping * dt / (2.0 * inertia)).exp();
            let got = last / first;
            eprintln!("REPORT pendulum decay {got} vs theory {want}");
            assert!((got - want).abs() < 0.03, "decay {got} vs theory {want}");
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_mjcf_inputs_are_refused_naming_the_problem_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let ws = &server.workspace;
    let write = |name: &str, text: &str| std::fs::write(ws.join(name), text).unwrap();
    let body = |inner: &str| format!("<mujoco><worldbody><body name=\"b\">{inner}<geom size=\"0.1\"/></body></worldbody></mujoco>");
    write("urdf_not_mjcf.xml", "<robot name=\"r\"><link name=\"a\"/></robot>");
    write("malformed.xml", "<mujoco><worldbody><body></worldbody></mujoco>");
    // A ball joint loads from event version 9 on (mjcf_ball_pair.rs); a free joint below the top
    // level is still refused.
    write("inner_free.xml", "<mujoco><worldbody><body name=\"a\"><geom size=\"0.1\"/><body name=\"b\"><freejoint/><geom size=\"0.1\"/></body></body></worldbody></mujoco>");
    write("spatial.xml", "<mujoco><worldbody/><tendon><spatial name=\"t\"/></tendon></mujoco>");
    write("flex.xml", "<mujoco><deformable><flex name=\"f\"/></deformable><worldbody/></mujoco>");
    write("composite.xml", "<mujoco><worldbody><composite type=\"rope\"/></worldbody></mujoco>");
    write("plugin.xml", "<mujoco><extension><plugin plugin=\"p\"/></extension><worldbody/></mujoco>");
    let mesh_model = |file: &str| {
        format!("<mujoco><asset><mesh name=\"m\" file=\"{file}\"/></asset><worldbody><body><geom name=\"hull\" type=\"mesh\" mesh=\"m\"/></body></worldbody></mujoco>")
    };
    write("mesh_missing.xml", &mesh_model("nowhere.stl"));
    write("mesh_escaping.xml", &mesh_model("../../outside.stl"));
    write("mesh_malformed.xml", &mesh_model("broken.obj"));
    write("broken.obj", "v 0 0 0\nv 1 0 0\nf 1 2 7\n");
    write("mesh_flat.xml", &mesh_model("flat.obj"));
    write("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
    write("mesh_format.xml", &mesh_model("m.msh"));
    write("m.msh", "binary");
    write("mesh_huge.xml", &mesh_model("huge.stl"));
    std::fs::File::create(ws.join("huge.stl")).unwrap().set_len(65 << 20).unwrap();
    write("mesh_undeclared.xml", "<mujoco><worldbody><body><geom name=\"g\" type=\"mesh\" mesh=\"nope\"/></body></worldbody></mujoco>");
    write("mesh_fitted.xml", "<mujoco><asset><mesh name=\"m\" file=\"mjcf/meshes/tetra.stl\"/></asset><worldbody><body><geom name=\"fit\" type=\"box\" mesh=\"m\"/></body></worldbody></mujoco>");
    write("missing_include.xml", "<mujoco><include file=\"nowhere.xml\"/><worldbody/></mujoco>");
    write("escaping_include.xml", "<mujoco><include file=\"../../outside.xml\"/><worldbody/></mujoco>");
    write("self_include.xml", "<mujoco><include file=\"self_include.xml\"/><worldbody/></mujoco>");
    write("free_below.xml", &format!("<mujoco><worldbody><body name=\"a\"><joint type=\"hinge\"/><geom size=\"0.1\"/>{}</body></worldbody></mujoco>", "<body name=\"c\"><freejoint name=\"f\"/><geom size=\"0.1\"/></body>"));
    write("zero_axis.xml", &body("<joint name=\"z\" type=\"hinge\" axis=\"0 0 0\"/>"));
    write("not_utf8.xml", "");
    std::fs::write(ws.join("not_utf8.xml"), [0x3c, 0x6d, 0xff, 0xfe]).unwrap();
    let big = format!("<mujoco><!-- {} --><worldbody/></mujoco>", "x".repeat(9 << 20));
    write("huge.xml", &big);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let ant = load(&c, s, "ant").await["object_id"].as_u64().unwrap();
    let hash = c.hash(s).await;
    let file = |f: &str| json!({"sim_id": s, "file_path": f});
    let cases: Vec<(Value, &str)> = vec![
        (file("missing.xml"), "does not exist"),
        (file("../outside.xml"), "Access denied"),
        (file("/etc/passwd"), "Access denied"),
        (file("urdf_not_mjcf.xml"), "not an MJCF model"),
        (file("malformed.xml"), "not well-formed XML"),
        (file("inner_free.xml"), "free joint below the top level"),
        (file("spatial.xml"), "<spatial>"),
        (file("flex.xml"), "<flex>"),
        (file("composite.xml"), "<composite>"),
        (file("plugin.xml"), "<plugin>"),
        (file("mesh_missing.xml"), "mesh nowhere.stl of mesh_missing.xml cannot be read"),
        (file("mesh_escaping.xml"), "Access denied"),
        (file("mesh_malformed.xml"), "mesh broken.obj"),
        (file("mesh_flat.xml"), "mesh m has no volume"),
        (file("mesh_format.xml"), "mesh m.msh has an unsupported format"),
        (file("mesh_huge.xml"), "mesh huge.stl of mesh_huge.xml is 68157440 bytes"),
        (file("mesh_undeclared.xml"), "geom g names mesh nope"),
        (file("mesh_fitted.xml"), "geom fit fits a primitive to mesh m"),
        (file("missing_include.xml"), "nowhere.xml"),
        (file("escaping_include.xml"), "Access denied"),
        (file("self_include.xml"), "cycle"),
        (file("free_below.xml"), "free joint"),
        (file("zero_axis.xml"), "joint z has a zero or invalid axis"),
        (file("not_utf8.xml"), "not UTF-8"),
        (file("huge.xml"), "limit"),
        (json!({"sim_id": s, "file_path": "mjcf/ant.xml", "keyframe": "nope"}), "keyframe nope"),
        (json!({"sim_id": s, "file_path": "mjcf/ant.xml", "position": [0, 0]}), "position"),
        (json!({"sim_id": s, "file_path": "mjcf/ant.xml", "orientation": [0, 0, 0, 0]}), "orientation"),
        (json!({"sim_id": s, "file_path": "mjcf/ant.xml", "scale": 2}), "`scale`"),
        (json!({"sim_id": s}), "file_path"),
    ];
    for (args, words) in cases {
        let err = c.try_call("load_mjcf", args.clone()).await.expect_err(&format!("{args} should be refused"));
        assert!(err.contains(words), "{args}: refusal {err:?} should mention {words:?}");
        assert_eq!(c.hash(s).await, hash, "{args}: a refusal changed the state");
    }
    let n = c.call("get_simulation_info", json!({"sim_id": s})).await;
    let objects = n["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 1, "only the ant: {n}");
    assert_eq!(objects[0]["object_id"].as_u64(), Some(ant));
}

fn replay_cli(log: &Path) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(log).output().unwrap();
    (out.status.success(), format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
}

#[tokio::test(flavor = "multi_thread")]
async fn an_mjcf_robot_survives_undo_fork_save_load_restart_and_replay() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let s = sim.as_str();
    let walker = load(&c, s, "walker2d").await["object_id"].as_u64().unwrap();
    let ant = c.call("load_mjcf", json!({"sim_id": s, "file_path": "mjcf/ant.xml", "position": [3, 0, 0]})).await["object_id"]
        .as_u64()
        .unwrap();
    // Meshes travel as blobs: the mesh robot comes back after its files are deleted too.
    let meshes = c.call("load_mjcf", json!({"sim_id": s, "file_path": "mjcf/mesh_robot.xml", "position": [6, 0, 0]})).await;
    assert_eq!(meshes["num_joints"], 3, "{meshes}");
    c.call("set_joint_motor_control", json!({"sim_id": s, "object_id": walker, "joint_index": 3, "control_mode": "VELOCITY_CONTROL", "target_velocity": 1, "force": 50})).await;
    c.step(s, 50).await;
    let before = c.hash(s).await;
    c.call("reset_joint_state", json!({"sim_id": s, "object_id": ant, "joint_index": 1, "target_value": 0.8})).await;
    c.step(s, 50).await;
    let h = c.hash(s).await;
    assert_ne!(h, before);
    c.call("undo", json!({"sim_id": s, "count": 2})).await;
    assert_eq!(c.hash(s).await, before, "undo");
    c.call("redo", json!({"sim_id": s, "count": 2})).await;
    assert_eq!(c.hash(s).await, h, "redo");

    // The files are gone from here on: everything comes from the log.
    let fork = c.call("fork_simulation", json!({"sim_id": s})).await["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c.hash(&fork).await, h, "fork");
    c.call("save_simulation", json!({"sim_id": s, "file_path": "mjcf_robots.json"})).await;
    let saved: Value = serde_json::from_slice(&std::fs::read(server.workspace.join("mjcf_robots.json")).unwrap()).unwrap();
    let text = saved.to_string();
    assert!(text.contains("\"type\":\"mjcf\"") && text.contains("\"mjcf_path\":\"mjcf/walker2d.xml\""), "saved file: {text:.400}");
    std::fs::remove_dir_all(server.workspace.join("mjcf")).unwrap();
    let copy = c.call("load_simulation", json!({"file_path": "mjcf_robots.json"})).await["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c.hash(&copy).await, h, "save → load");
    for sim in [s, fork.as_str(), copy.as_str()] {
        c.step(sim, 40).await;
    }
    let h2 = c.hash(s).await;
    assert_eq!(c.hash(&fork).await, h2, "fork evolves differently");
    assert_eq!(c.hash(&copy).await, h2, "loaded copy evolves differently");

    // Another server loads the saved file too.
    let dir2 = tempfile::tempdir().unwrap();
    let other = Server::start(dir2.path(), &[]);
    std::fs::copy(server.workspace.join("mjcf_robots.json"), other.workspace.join("mjcf_robots.json")).unwrap();
    let c2 = other.client().await;
    let there = c2.call("load_simulation", json!({"file_path": "mjcf_robots.json"})).await["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(c2.hash(&there).await, h, "save → load on another server");
    drop(c2);
    other.kill();

    // kill -9: the CLI replays the log bit for bit, and a restart serves the same state.
    drop(c);
    server.kill();
    let (ok, out) = replay_cli(&dir.path().join("data").join(format!("{sim}.sqlite")));
    assert!(ok, "replay failed: {out}");
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, h2, "restart");
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
}

/// Three spheres on vertical slides over a floor: `a` may touch the floor (contype 1), `b` may
/// not (contype 2, conaffinity 2: no bit shared with the floor's 1, in either direction), `c`
/// may by its bits but an `<exclude>` turns its contacts with the worldbody off.
const CONTYPE_XML: &str = r#"<mujoco model="contype">
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" contype="1" conaffinity="1"/>
    <body name="slider_a" pos="0 0 0.5">
      <joint name="za" type="slide" axis="0 0 1"/>
      <geom name="a" type="sphere" size="0.1" mass="1" contype="1" conaffinity="0"/>
    </body>
    <body name="slider_b" pos="1 0 0.5">
      <joint name="zb" type="slide" axis="0 0 1"/>
      <geom name="b" type="sphere" size="0.1" mass="1" contype="2" conaffinity="2"/>
    </body>
    <body name="slider_c" pos="2 0 0.5">
      <joint name="zc" type="slide" axis="0 0 1"/>
      <geom name="c" type="sphere" size="0.1" mass="1"/>
    </body>
  </worldbody>
  <contact>
    <exclude body1="world" body2="slider_c"/>
  </contact>
  <keyframe>
    <key name="low" qpos="-0.2 -0.1 0"/>
  </keyframe>
</mujoco>"#;

#[tokio::test(flavor = "multi_thread")]
async fn keyframes_set_qpos_and_contype_conaffinity_and_exclude_filter_contacts() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    std::fs::write(server.workspace.join("contype.xml"), CONTYPE_XML).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let id = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "contype.xml", "keyframe": "low"})).await["object_id"]
        .as_u64()
        .unwrap();
    for (joint, want) in [(0, -0.2), (1, -0.1)] {
        let s = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": joint})).await;
        let got = s["joint_position"].as_f64().unwrap();
        assert!((got - want).abs() < 1e-6, "keyframe joint {joint}: {got} vs {want}");
        let l = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": joint})).await;
        let z = l["link_world_position"][2].as_f64().unwrap();
        assert!((z - (0.5 + want)).abs() < 1e-6, "keyframe link {joint} at z {z}");
    }
    c.step(&sim, 480).await;
    let z = |l: Value| l["link_world_position"][2].as_f64().unwrap();
    let a = z(c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": 0})).await);
    let b = z(c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": 1})).await);
    assert!((a - 0.1).abs() < 0.02, "sphere a should rest on the floor (contype 1 meets its conaffinity 1): z {a}");
    assert!(b < -1.0, "sphere b should fall through the floor (no shared bit): z {b}");
    let cz = z(c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": 2})).await);
    assert!(cz < -1.0, "sphere c should fall through the floor (<exclude body1=world body2=slider_c>): z {cz}");

    // A free root: the keyframe's 7 free-joint values place the base (within the load frame),
    // then the hinge.
    let free = r#"<mujoco><worldbody><body name="root" pos="0 0 3"><freejoint/><geom size="0.1"/>
        <body name="arm" pos="0.5 0 0"><joint name="h" axis="0 0 1"/><geom size="0.05"/></body></body></worldbody>
        <keyframe><key name="k" qpos="1 2 0.5 0.70710678 0 0 0.70710678 0.25"/></keyframe></mujoco>"#;
    std::fs::write(server.workspace.join("free.xml"), free).unwrap();
    let sim2 = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let args = json!({"sim_id": sim2, "file_path": "free.xml", "keyframe": "k", "position": [10, 0, 0], "use_fixed_base": true});
    let f = c.call("load_mjcf", args).await["object_id"].as_u64().unwrap();
    let base = c.call("get_link_state", json!({"sim_id": sim2, "object_id": f, "link_index": -1})).await;
    let p = floats(&base["link_world_position"]);
    assert!(vec_diff(&p, &[11.0, 2.0, 0.5]) < 1e-5, "free root at {p:?}");
    let o = floats(&base["link_world_orientation"]);
    assert!(quat_diff(&o, &[0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2]) < 1e-5, "free root turned {o:?}");
    let h = c.call("get_joint_state", json!({"sim_id": sim2, "object_id": f, "joint_index": 0})).await;
    assert!((h["joint_position"].as_f64().unwrap() - 0.25).abs() < 1e-6, "{h}");
    let arm = floats(&c.call("get_link_state", json!({"sim_id": sim2, "object_id": f, "link_index": 0})).await["link_world_position"]);
    assert!(vec_diff(&arm, &[11.0, 2.5, 0.5]) < 1e-5, "arm at {arm:?} (0.5 m along the turned x axis)");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_saved_file_without_history_reloads_its_mjcf_robot_from_the_workspace() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("load_mjcf", json!({"sim_id": sim, "file_path": "mjcf/reacher.xml", "position": [1, 2, 0]})).await;
    c.call("save_simulation", json!({"sim_id": sim, "file_path": "reacher.json"})).await;
    let path = server.workspace.join("reacher.json");
    let mut saved: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    saved.as_object_mut().unwrap().remove("history");
    std::fs::write(&path, saved.to_string()).unwrap();
    let copy = c.call("load_simulation", json!({"file_path": "reacher.json"})).await["simulation_id"].as_str().unwrap().to_string();
    let info = c.call("get_simulation_info", json!({"sim_id": copy})).await;
    let o = &info["objects"][0];
    assert_eq!(o["type"], "mjcf", "{info}");
    assert_eq!(o["shape"], "mjcf/reacher.xml", "{info}");
    assert_eq!(floats(&o["position"]), vec![1.0, 2.0, 0.0], "{info}");
    let n = c.call("get_num_joints", json!({"sim_id": copy, "object_id": 0})).await;
    assert_eq!(n["num_joints"], 4, "{n}");
}

/// A free body whose only geom is a mesh cube (vertices only: MuJoCo makes its faces from the
/// hull) falls onto the floor and rests on its hull, 0.1 m up; the same cube as a visual mesh
/// (contype 0) carries the mass but falls through.
#[tokio::test(flavor = "multi_thread")]
async fn a_mesh_geom_collides_as_its_convex_hull() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let cube = |contype: u32| {
        format!(
            r#"<mujoco><asset><mesh name="cube" vertex="-.1 -.1 -.1  .1 -.1 -.1  .1 .1 -.1  -.1 .1 -.1  -.1 -.1 .1  .1 -.1 .1  .1 .1 .1  -.1 .1 .1"/></asset>
  <worldbody><geom name="floor" type="plane" size="0 0 1"/>
    <body name="box" pos="0 0 0.5"><freejoint/><geom name="c" type="mesh" mesh="cube" contype="{contype}" conaffinity="{contype}"/></body>
  </worldbody></mujoco>"#
        )
    };
    std::fs::write(server.workspace.join("cube.xml"), cube(1)).unwrap();
    std::fs::write(server.workspace.join("ghost.xml"), cube(0)).unwrap();
    let c = server.client().await;
    for (file, rests) in [("cube.xml", true), ("ghost.xml", false)] {
        let sim = c.new_sim(json!({})).await;
        let id = c.call("load_mjcf", json!({"sim_id": sim, "file_path": file})).await["object_id"].as_u64().unwrap();
        let d = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": id, "link_index": -1})).await;
        let mass = d["mass"].as_f64().unwrap();
        assert!((mass - 8.0).abs() < 1e-4, "{file}: a 0.2 m cube of water is 8 kg; got {mass}");
        c.step(&sim, 480).await;
        let s = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": -1})).await;
        let z = s["link_world_position"][2].as_f64().unwrap();
        if rests {
            assert!((z - 0.1).abs() < 0.01, "{file}: the cube should rest on its hull at z 0.1; z {z}");
        } else {
            assert!(z < -1.0, "{file}: a visual mesh does not collide; z {z}");
        }
    }
}

/// IK on an MJCF arm whose joints pivot away from their bodies' origins (`pos`) and carry a
/// `ref`, with two joints in one body: the answer, set by reset_joint_state, puts the
/// end-effector's frame on the target a reached configuration gave.
#[tokio::test(flavor = "multi_thread")]
async fn ik_on_an_mjcf_arm_with_joint_pivots_and_refs_reaches_the_target() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let arm = r#"<mujoco model="offset_arm"><compiler angle="radian"/><worldbody>
      <body name="upper" pos="0 0 1">
        <joint name="shoulder" type="hinge" axis="0 1 0" pos="0 0 0.1" ref="0.2" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
        <body name="fore" pos="0.4 0 0">
          <joint name="elbow" type="hinge" axis="0 1 0" pos="-0.05 0 0.02" range="-2 2"/>
          <joint name="twist" type="hinge" axis="1 0 0" pos="0.1 0 0" ref="-0.3" range="-2 2"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
          <body name="hand" pos="0.3 0 0">
            <joint name="wrist" type="hinge" axis="0 0 1" pos="0.02 0.01 0" range="-2 2"/>
            <geom type="box" size="0.05 0.02 0.02" pos="0.05 0 0"/>
          </body>
        </body>
      </body></worldbody></mujoco>"#;
    std::fs::write(server.workspace.join("offset_arm.xml"), arm).unwrap();
    let c = server.client().await;
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let id = c.call("load_mjcf", json!({"sim_id": sim, "file_path": "offset_arm.xml", "position": [0.3, -0.2, 0]})).await["object_id"].as_u64().unwrap();
    let reached = [0.7, -0.5, 0.4, 0.9];
    let set = |q: [f64; 4]| {
        let c = &c;
        let sim = sim.clone();
        async move {
            for (i, v) in q.iter().enumerate() {
                c.call("reset_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": i, "target_value": v})).await;
            }
        }
    };
    set(reached).await;
    let ee = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": 3})).await;
    let (pos, orn) = (floats(&ee["link_world_position"]), floats(&ee["link_world_orientation"]));
    set([0.2, 0.0, -0.3, 0.0]).await;
    let ik = c
        .call("calculate_inverse_kinematics", json!({"sim_id": sim, "object_id": id, "end_effector_link_index": 3, "target_position": pos, "target_orientation": orn}))
        .await;
    let q = floats(&ik["joint_positions"]);
    assert!(ik["position_error"].as_f64().unwrap() < 1e-4, "{ik}");
    set([q[0], q[1], q[2], q[3]]).await;
    let got = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": 3})).await;
    let d = vec_diff(&floats(&got["link_world_position"]), &pos);
    assert!(d < 1e-4, "IK answer {q:?} puts the hand at {} not {pos:?} (off by {d})", got["link_world_position"]);
    let d = quat_diff(&floats(&got["link_world_orientation"]), &orn);
    assert!(d < 1e-3, "IK answer {q:?} turns the hand to {} not {orn:?}", got["link_world_orientation"]);
}
