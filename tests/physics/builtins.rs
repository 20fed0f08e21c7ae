//! The built-in model library over MCP/HTTP, on servers whose workspace holds no model file:
//!
//! - every built-in list_models lists loads by name with one call and rests on the ground for
//!   2 s without exploding (no penetration over 5 mm at any half second, no link faster than
//!   1 m/s at the end; arms hold their pose with position motors, as a PyBullet user's would;
//!   a quadruped without motors may fold, not fly; MJCF models run with their own options, as
//!   in MuJoCo);
//! - the URDF ones equal pybullet 3.2.7 (tests/reference/pybullet_builtins.json, written by
//!   scripts/builtin_reference.py from the same files): joint table, link masses, and every
//!   link's frame and centre-of-mass frame at 0 and after reset_joint_state (the MJCF ones are
//!   checked against MuJoCo in tests/physics/mjcf.rs);
//! - list_models and the `models://builtin` resource give the same list, whose figures agree
//!   with pybullet's and MuJoCo's;
//! - a missing file is refused naming the nearest built-ins, a built-in given to the other
//!   format's tool names the right one, and a workspace file of a built-in's name wins.

use crate::common;

use std::collections::BTreeMap;
use std::path::Path;

use crate::mjcf::{floats, quat_diff, vec_diff};
use common::{Client, Server};
use serde_json::{json, Value};

fn reference(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference").join(name);
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// A link's mass here for pybullet's `mass`: a link pybullet gives 0 kg is one an
/// articulation cannot move, so ours has 0.001 kg (docs/tools.md "Robots"); any other as given.
fn ours_for(mass: f64) -> f64 {
    if mass == 0.0 {
        0.001
    } else {
        mass
    }
}

/// `v` turned by the unit quaternion `q` (x, y, z, w).
fn rotate(q: &[f64], v: &[f64]) -> Vec<f64> {
    let (u, w) = ([q[0], q[1], q[2]], q[3]);
    let cross = |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = cross(u, [v[0], v[1], v[2]]).map(|x| 2.0 * x);
    let ut = cross(u, t);
    (0..3).map(|i| v[i] + w * t[i] + ut[i]).collect()
}

/// f32 storage: agreement to 1e−6 relative.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs() + 1e-9
}

async fn models(c: &Client, filter: Option<&str>) -> Vec<Value> {
    let args = filter.map_or(json!({}), |f| json!({"filter": f}));
    c.call("list_models", args).await["models"].as_array().unwrap().clone()
}

#[tokio::test(flavor = "multi_thread")]
async fn urdf_builtins_load_by_name_and_equal_pybullet() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let r = reference("pybullet_builtins.json");
    let listed: Vec<String> = models(&c, Some("urdf")).await.iter().map(|m| m["name"].as_str().unwrap().to_string()).collect();
    for (file, want) in r["models"].as_object().unwrap() {
        assert!(listed.contains(file), "{file} is in the reference but list_models does not list it");
        let sim = c.new_sim(json!({})).await;
        let args = json!({"sim_id": sim, "file_path": file, "position": r["base_position"],
                          "orientation": r["base_orientation"], "use_fixed_base": true});
        let id = c.call("load_urdf", args).await["object_id"].as_u64().unwrap();
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
                assert!(close(got[field].as_f64().unwrap(), wj[field].as_f64().unwrap()), "{field} of {at}");
            }
            // pybullet reports the axis in the child link's inertial frame (its principal axes
            // when the file's tensor is not diagonal); ours is in the link frame, as the file
            // writes it: pybullet's turned by its own inertial frame.
            let axis = rotate(&floats(&wj["local_inertial_orientation"]), &floats(&wj["joint_axis"]));
            assert!(vec_diff(&floats(&got["joint_axis"]), &axis) < 1e-6, "joint_axis of {at}");
            let types_agree = match wj["joint_type"].as_str().unwrap() {
                "revolute_or_continuous" => got["joint_type"] == "continuous",
                t => got["joint_type"] == t,
            };
            assert!(types_agree, "joint_type of {at}");
        }
        for wl in want["masses"].as_array().unwrap().iter().filter(|l| l["link_index"].as_i64().unwrap() >= 0) {
            let link = wl["link_index"].as_i64().unwrap();
            let got = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
            let want_mass = ours_for(wl["mass"].as_f64().unwrap());
            assert!(close(got["mass"].as_f64().unwrap(), want_mass), "{file} link {link}: mass {} vs pybullet {}", got["mass"], wl["mass"]);
        }
        let mut compared = 0;
        for conf in want["configurations"].as_array().unwrap() {
            for reset in conf["resets"].as_array().unwrap() {
                let a = json!({"sim_id": sim, "object_id": id, "joint_index": reset["joint_index"], "target_value": reset["target_value"]});
                c.call("reset_joint_state", a).await;
            }
            for wl in conf["links"].as_array().unwrap() {
                let link = wl["link_index"].as_i64().unwrap();
                let got = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
                let at = format!("{file} link {link} after {} resets", conf["resets"].as_array().unwrap().len());
                for k in ["link_world_position", "com_world_position"] {
                    let d = vec_diff(&floats(&got[k]), &floats(&wl[k]));
                    assert!(d < 2e-5, "{at}: {k} {} vs pybullet {} (off by {d})", got[k], wl[k]);
                }
                // A centre-of-mass frame pybullet turns from the link frame (an <inertial> rpy,
                // a tensor not diagonal) is a frame of principal axes, which one is each
                // engine's choice (ours keeps the link frame where the tensor is diagonal in
                // it, as r2d2's isotropic legs): not compared there.
                let principal = link >= 0 && want["joints"][link as usize]["local_inertial_orientation"] != json!([0.0, 0.0, 0.0, 1.0]);
                let orientations: &[&str] = if principal { &["link_world_orientation"] } else { &["link_world_orientation", "com_world_orientation"] };
                for &k in orientations {
                    let d = quat_diff(&floats(&got[k]), &floats(&wl[k]));
                    assert!(d < 2e-5, "{at}: {k} {} vs pybullet {} (off by {d})", got[k], wl[k]);
                }
                compared += 1;
            }
        }
        eprintln!("REPORT {file}: {} joints, {compared} link frames equal pybullet's", want["num_joints"]);
    }
}

/// Where each built-in starts in the rest test: its base position, and whether it is an arm
/// bolted down and held (use_fixed_base, position motors at 0 on every movable joint).
fn start_of(name: &str) -> Option<([f64; 3], bool)> {
    let low = [0.0, 0.0, 0.1];
    Some(match name {
        "plane.urdf" | "table/table.urdf" | "table_square/table_square.urdf" | "tray/traybox.urdf" => ([0.0; 3], false),
        "kuka_iiwa/model.urdf" | "franka_panda/panda.urdf" => ([0.0; 3], true),
        "cube.urdf" | "sphere.urdf" | "sphere2.urdf" => ([0.0, 0.0, 0.6], false),
        "r2d2.urdf" | "a1/a1.urdf" => ([0.0, 0.0, 0.5], false),
        "racecar/racecar.urdf" | "husky/husky.urdf" => ([0.0, 0.0, 0.2], false),
        "cartpole.urdf" => ([0.0, 0.0, 1.0], false),
        "lego/lego.urdf" | "domino/domino.urdf" | "jenga/jenga.urdf" | "cube_small.urdf" | "sphere_small.urdf" => (low, false),
        mjcf if mjcf.starts_with("mujoco/") => ([0.0; 3], false),
        _ => return None,
    })
}

#[tokio::test(flavor = "multi_thread")]
async fn every_builtin_loads_by_name_and_rests_for_two_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let listed = models(&c, None).await;
    assert!(listed.len() >= 23, "{} built-ins", listed.len());
    let mut failures = Vec::new();
    for m in &listed {
        let name = m["name"].as_str().unwrap();
        let (position, held) = start_of(name).unwrap_or_else(|| panic!("{name}: add where it starts to start_of"));
        let sim = c.new_sim(json!({})).await;
        let id = if m["format"] == "mjcf" {
            // MuJoCo's own timestep and gravity (pusher's is 0), as the model runs in MuJoCo;
            // its floor or arena is in the model.
            let args = json!({"sim_id": sim, "file_path": name, "use_model_options": true});
            c.call("load_mjcf", args).await["object_id"].as_u64().unwrap()
        } else {
            if name != "plane.urdf" {
                c.call("load_urdf", json!({"sim_id": sim, "file_path": "plane.urdf"})).await;
            }
            let args = json!({"sim_id": sim, "file_path": name, "position": position, "use_fixed_base": held});
            c.call("load_urdf", args).await["object_id"].as_u64().unwrap()
        };
        let joints = c.call("get_num_joints", json!({"sim_id": sim, "object_id": id})).await["num_joints"].as_u64().unwrap();
        if held {
            let mut movable = Vec::new();
            for j in 0..joints {
                let info = c.call("get_joint_info", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
                if info["joint_type"] != "fixed" {
                    movable.push(j);
                }
            }
            let zeros = vec![0.0; movable.len()];
            let hold = json!({"sim_id": sim, "object_id": id, "joint_indices": movable, "control_mode": "POSITION_CONTROL", "target_positions": zeros});
            c.call("set_joint_motor_control_array", hold).await;
        }
        let dt = c.call("get_simulation_info", json!({"sim_id": sim})).await["timestep"].as_f64().unwrap();
        let quarter = (0.5 / dt).round() as u64;
        let mut deepest = Vec::new();
        for _ in 0..4 {
            c.step(&sim, quarter).await;
            let contacts = c.call("get_all_collisions", json!({"sim_id": sim})).await;
            let depth = contacts["contacts"].as_array().unwrap().iter().map(|k| -k["contact_distance"].as_f64().unwrap()).fold(0.0, f64::max);
            deepest.push(depth);
        }
        let mut fastest = (0.0f64, -1i64);
        for link in -1..joints as i64 {
            let s = c.call("get_link_state", json!({"sim_id": sim, "object_id": id, "link_index": link})).await;
            let speed = floats(&s["linear_velocity"]).iter().map(|v| v * v).sum::<f64>().sqrt();
            if speed > fastest.0 {
                fastest = (speed, link);
            }
        }
        let worst = deepest.iter().copied().fold(0.0, f64::max);
        eprintln!("REPORT {name}: dt {dt:.4} s, deepest contact per 0.5 s {:?} mm, fastest link {} at {:.3} m/s after 2 s",
                  deepest.iter().map(|d| (d * 1e4).round() / 10.0).collect::<Vec<_>>(), fastest.1, fastest.0);
        if worst > 0.005 {
            failures.push(format!("{name}: a contact {:.1} mm deep", worst * 1e3));
        }
        if fastest.0 > 1.0 {
            failures.push(format!("{name}: link {} moves at {:.2} m/s after 2 s", fastest.1, fastest.0));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[tokio::test(flavor = "multi_thread")]
async fn list_models_and_its_resource_list_every_builtin_with_the_references_figures() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let listed = models(&c, None).await;
    let by_name: BTreeMap<&str, &Value> = listed.iter().map(|m| (m["name"].as_str().unwrap(), m)).collect();
    assert_eq!(by_name.len(), listed.len(), "names are unique");
    // At least 20 besides plane, cube and sphere: pybullet_data's and Gymnasium's.
    assert!(listed.len() >= 23, "{} models", listed.len());
    for m in &listed {
        let name = m["name"].as_str().unwrap();
        let format = if name.ends_with(".xml") { "mjcf" } else { "urdf" };
        assert_eq!(m["format"], format, "{m}");
        for field in ["description", "license"] {
            assert!(!m[field].as_str().unwrap().is_empty(), "{name}: {field}");
        }
        let (joints, dofs) = (m["joints"].as_u64().unwrap(), m["dofs"].as_u64().unwrap());
        assert!(dofs <= joints, "{m}");
    }
    // URDF figures against pybullet's (its masses from a load with a free base).
    let pb = reference("pybullet_builtins.json");
    for (file, want) in pb["models"].as_object().unwrap() {
        let m = by_name[file.as_str()];
        assert_eq!(m["joints"], want["num_joints"], "{file}");
        let dofs = want["joints"].as_array().unwrap().iter().filter(|j| j["joint_type"] != "fixed").count();
        assert_eq!(m["dofs"].as_u64().unwrap() as usize, dofs, "{file}");
        let masses = want["masses"].as_array().unwrap();
        let base = masses[0]["mass"].as_f64().unwrap();
        assert_eq!(m["fixed_base"].as_bool().unwrap(), base == 0.0, "{file}: a base of mass 0 stands fixed");
        // Links pybullet gives 0 kg are 0.001 kg here (they move); a static base does not count.
        let moving: f64 = masses.iter().skip(1).map(|l| ours_for(l["mass"].as_f64().unwrap())).sum::<f64>() + base;
        let got = m["mass"].as_f64().unwrap();
        assert!((got - moving).abs() <= 1e-5 * moving.max(1.0), "{file}: mass {got} vs pybullet {moving}");
    }
    // MJCF figures against MuJoCo's.
    let mj = reference("mjcf_mujoco.json");
    let mut mjcf = 0;
    for (model, want) in mj["models"].as_object().unwrap().iter().filter(|(model, _)| *model != "mesh_robot") {
        let name = format!("mujoco/{model}.xml");
        let m = by_name[name.as_str()];
        let kinds: Vec<&str> = want["joints"].as_array().unwrap().iter().map(|j| j["type"].as_str().unwrap()).collect();
        let moving = kinds.iter().filter(|k| matches!(**k, "hinge" | "slide")).count();
        assert_eq!((m["joints"].as_u64().unwrap() as usize, m["dofs"].as_u64().unwrap() as usize), (moving, moving), "{name}");
        assert_eq!(m["fixed_base"].as_bool().unwrap(), !kinds.contains(&"free"), "{name}: free base");
        let mass: f64 = want["bodies"].as_array().unwrap().iter().map(|b| b["mass"].as_f64().unwrap()).sum();
        let got = m["mass"].as_f64().unwrap();
        assert!((got - mass).abs() <= 1e-5 * mass, "{name}: mass {got} vs MuJoCo {mass}");
        mjcf += 1;
    }
    assert_eq!(mjcf, 11, "Gymnasium's eleven models");
    // A filter keeps what mentions it, in any case.
    let mujoco = models(&c, Some("MuJoCo")).await;
    assert!(mujoco.len() >= 11 && mujoco.iter().all(|m| serde_json::to_string(m).unwrap().to_lowercase().contains("mujoco")), "{mujoco:?}");
    assert!(models(&c, Some("no such model anywhere")).await.is_empty());
    assert_eq!(models(&c, Some("KUKA")).await.len(), 1);
    // The resource: the same list, listed among the resources.
    let resources = c.service.list_all_resources().await.unwrap();
    assert!(resources.iter().any(|r| r.uri == "models://builtin"), "{resources:?}");
    let read = c.service.read_resource(rmcp::model::ReadResourceRequestParams::new("models://builtin")).await.unwrap();
    let text = match &read.contents[0] {
        rmcp::model::ResourceContents::TextResourceContents { text, .. } => text.clone(),
        other => panic!("{other:?}"),
    };
    let from_resource: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(from_resource["models"], json!(listed));
}

#[tokio::test(flavor = "multi_thread")]
async fn a_missing_model_names_the_nearest_builtins_and_a_workspace_file_wins() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let before = c.hash(&sim).await;
    for (tool, path, nearest) in [
        ("load_urdf", "kuka.urdf", "kuka_iiwa/model.urdf"),
        ("load_urdf", "panda.urdf", "franka_panda/panda.urdf"),
        ("load_mjcf", "ant.xml", "mujoco/ant.xml"),
        ("load_mjcf", "mujoco/humanoid_v5.xml", "mujoco/humanoid.xml"),
    ] {
        let why = c.try_call(tool, json!({"sim_id": sim, "file_path": path})).await.unwrap_err();
        assert!(why.contains(&format!("{nearest} (built in)")), "{tool} {path}: {why}");
        assert!(why.contains("list_models") && why.contains("write_file"), "{tool} {path} says how to add a file: {why}");
    }
    let why = c.try_call("load_urdf", json!({"sim_id": sim, "file_path": "mujoco/ant.xml"})).await.unwrap_err();
    assert!(why.contains("load it with load_mjcf"), "{why}");
    let why = c.try_call("load_mjcf", json!({"sim_id": sim, "file_path": "r2d2.urdf"})).await.unwrap_err();
    assert!(why.contains("load it with load_urdf"), "{why}");
    // A library mesh is not a model: only the catalog's models load by name.
    assert!(c.try_call("load_urdf", json!({"sim_id": sim, "file_path": "l_finger.stl"})).await.is_err());
    assert_eq!(c.hash(&sim).await, before, "refusals change nothing");

    // The workspace's own r2d2.urdf (a single box) wins over the built-in (15 joints).
    let own = r#"<robot name="mine"><link name="b"><inertial><mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial><collision><geometry><box size="1 1 1"/></geometry></collision></link></robot>"#;
    c.call("write_file", json!({"path": "r2d2.urdf", "content": own})).await;
    let mine = c.call("load_urdf", json!({"sim_id": sim, "file_path": "r2d2.urdf"})).await;
    assert_eq!(mine["num_joints"], 0, "{mine}");
    let built_in = c.call("load_urdf", json!({"sim_id": sim, "file_path": "r2d2.urdf", "position": [3, 0, 0]})).await;
    assert_eq!(built_in["num_joints"], 0, "still the workspace's while it is there");
    std::fs::remove_file(server.workspace.join("r2d2.urdf")).unwrap();
    let built_in = c.call("load_urdf", json!({"sim_id": sim, "file_path": "r2d2.urdf", "position": [6, 0, 0]})).await;
    assert_eq!(built_in["num_joints"], 15, "the built-in once the workspace has none");
}
