//! Trajectories: get_trajectory, step_simulation(sample_every) and
//! `replay --trajectory`, all over the one re-simulation core. The reference is independent of
//! it: a fork stepped one step at a time, read with get_object_state / get_joint_state, and
//! compared bit for bit as f32 (`to_bits`).

use crate::common;

use physics_mcp::log::EventLog;
use common::{Client, Server};
use serde_json::{json, Value};

fn f32_bits(v: &Value) -> Option<u32> {
    v.as_f64().map(|x| (x as f32).to_bits())
}

fn bits(v: &Value) -> Vec<Option<u32>> {
    match v {
        Value::Array(a) => a.iter().map(f32_bits).collect(),
        Value::Null => vec![],
        other => vec![f32_bits(other)],
    }
}

async fn head(c: &Client, sim: &str) -> u64 {
    c.call("get_simulation_info", json!({"sim_id": sim})).await["head_seq"].as_u64().unwrap()
}

/// Every object's state (and the arm's joints) as the read tools report them.
async fn observe(c: &Client, sim: &str, objects: &[u64], arm: u64) -> Value {
    let mut out = serde_json::Map::new();
    for id in objects {
        let s = c.state(sim, *id).await;
        let mut o = json!({"position": s["position"], "orientation": s["orientation"],
            "linear_velocity": s["linear_velocity"], "angular_velocity": s["angular_velocity"]});
        if *id == arm {
            let mut q = vec![];
            let mut v = vec![];
            for j in 0..2 {
                let js = c.call("get_joint_state", json!({"sim_id": sim, "object_id": id, "joint_index": j})).await;
                q.push(js["joint_position"].clone());
                v.push(js["joint_velocity"].clone());
            }
            o["joint_positions"] = json!(q);
            o["joint_velocities"] = json!(v);
        }
        out.insert(id.to_string(), o);
    }
    Value::Object(out)
}

/// Asserts sample `i` of trajectory `t` equals the reference observation bit for bit.
fn assert_sample(t: &Value, i: usize, reference: &Value, what: &str) {
    for track in t["objects"].as_array().unwrap() {
        let id = track["object_id"].as_u64().unwrap().to_string();
        let r = &reference[&id];
        let pairs = [
            ("positions", "position"),
            ("orientations", "orientation"),
            ("linear_velocities", "linear_velocity"),
            ("angular_velocities", "angular_velocity"),
            ("joint_positions", "joint_positions"),
            ("joint_velocities", "joint_velocities"),
        ];
        for (col, field) in pairs {
            if track.get(col).is_none() {
                continue;
            }
            assert_eq!(bits(&track[col][i]), bits(&r[field]), "{what}: sample {i}, object {id}, {col}");
        }
    }
}

/// A mixed scene: primitives, a URDF arm under POSITION_CONTROL, a constraint. Returns
/// (sim, objects, arm).
async fn mixed_scene(c: &Client) -> (String, Vec<u64>, u64) {
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let id = |v: Value| v["object_id"].as_u64().unwrap();
    let bx = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [1, 0, 0.5]})).await);
    let ball = id(c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [-1, 0, 0.8]})).await);
    let can = id(c.call("add_cylinder", json!({"sim_id": sim, "radius": 0.1, "height": 0.3, "position": [0, 1.5, 1]})).await);
    let arm = id(c.call("load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "position": [0, -1, 1], "use_fixed_base": true})).await);
    c.call("set_joint_motor_control", json!({"sim_id": sim, "object_id": arm, "joint_index": 0, "control_mode": "POSITION_CONTROL", "target_position": 0.6})).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": can, "child_id": -1, "joint_type": "point2point",
        "child_frame_position": [0, 1.5, 1.3], "parent_frame_position": [0, 0, 0.15]})).await;
    (sim, vec![ground, bx, ball, can, arm], arm)
}

/// The interval's events after the scene: a step, a teleport and a force mid-interval, a step.
async fn interval_events(c: &Client, sim: &str, objects: &[u64], single: bool) {
    let step = |n: u64| async move {
        if single {
            for _ in 0..n {
                c.step(sim, 1).await;
            }
        } else {
            c.step(sim, n).await;
        }
    };
    step(20).await;
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": objects[2], "position": [-1, 0.2, 1.2]})).await;
    c.call("apply_force", json!({"sim_id": sim, "object_id": objects[1], "force": [30, 0, 60]})).await;
    step(25).await;
}

#[tokio::test(flavor = "multi_thread")]
async fn trajectory_equals_stepping_one_step_at_a_time_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let (sim, objects, arm) = mixed_scene(&c).await;
    let from = head(&c, &sim).await;
    interval_events(&c, &sim, &objects, false).await;
    let to = head(&c, &sim).await;

    // The reference: a fork at from_seq, stepped one step at a time, read after every step.
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": from})).await["simulation_id"].as_str().unwrap().to_string();
    let mut reference = vec![observe(&c, &fork, &objects, arm).await];
    for _ in 0..20 {
        c.step(&fork, 1).await;
        reference.push(observe(&c, &fork, &objects, arm).await);
    }
    c.call("set_object_pose", json!({"sim_id": fork, "object_id": objects[2], "position": [-1, 0.2, 1.2]})).await;
    c.call("apply_force", json!({"sim_id": fork, "object_id": objects[1], "force": [30, 0, 60]})).await;
    for _ in 0..25 {
        c.step(&fork, 1).await;
        reference.push(observe(&c, &fork, &objects, arm).await);
    }
    assert_eq!(c.hash(&fork).await, c.hash(&sim).await);

    for every in [1u64, 4, 7, 20, 100] {
        let t = c.call("get_trajectory", json!({"sim_id": sim, "detail": "full", "from_seq": from, "to_seq": to, "every": every, "include_velocities": true})).await;
        let steps0 = t["steps"][0].as_u64().unwrap();
        let n = t["samples"].as_u64().unwrap() as usize;
        let expected: Vec<u64> = (0..=45).filter(|k| k % every == 0).chain((45 % every != 0).then_some(45)).collect();
        let got: Vec<u64> = t["steps"].as_array().unwrap().iter().map(|s| s.as_u64().unwrap() - steps0).collect();
        assert_eq!(got, expected, "every {every}");
        assert_eq!(n, expected.len());
        assert_eq!(t["objects"].as_array().unwrap().len(), objects.len());
        for (i, k) in expected.iter().enumerate() {
            assert_sample(&t, i, &reference[*k as usize], &format!("every {every}"));
        }
        assert_eq!(t["seqs"][0].as_u64(), Some(from));
        assert_eq!(t["seqs"][n - 1].as_u64(), Some(to));
    }
    // Defaults: the last step only, about 100 samples; a subset of objects, no velocities.
    let t = c.call("get_trajectory", json!({"sim_id": sim, "detail": "full", "object_ids": [objects[1]]})).await;
    assert_eq!(t["from_seq"].as_u64(), Some(to - 1));
    assert_eq!(t["every"], 1);
    assert_eq!(t["samples"], 26);
    assert!(t["objects"][0].get("linear_velocities").is_none());
    assert_sample(&t, 25, &reference[45], "defaults");
}

#[tokio::test(flavor = "multi_thread")]
async fn sampled_step_is_a_plain_step_with_get_trajectorys_samples() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let (sim, objects, _) = mixed_scene(&c).await;
    let at = head(&c, &sim).await;
    let plain = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": at})).await["simulation_id"].as_str().unwrap().to_string();
    for (steps, every) in [(37u64, 5u64), (10, 10), (3, 1)] {
        let sampled = c.call("step_simulation", json!({"sim_id": sim, "steps": steps, "sample_every": every, "detail": "full"})).await;
        let stepped = c.step(&plain, steps).await;
        assert_eq!(c.hash(&sim).await, c.hash(&plain).await, "same state as a plain step");
        let traj = sampled["trajectory"].clone();
        let mut plain_result = sampled.clone();
        plain_result.as_object_mut().unwrap().remove("trajectory");
        // The fork's events are numbered on from its own root: where it landed differs.
        plain_result["simulation_id"] = stepped["simulation_id"].clone();
        plain_result["head_seq"] = stepped["head_seq"].clone();
        assert_eq!(plain_result, stepped, "the step's own result is a plain step's");
        let t = c.call("get_trajectory", json!({"sim_id": sim, "detail": "full", "every": every})).await;
        assert_eq!(traj, t, "step_simulation's samples are get_trajectory's over that event");
        assert_eq!(t["objects"].as_array().unwrap().len(), objects.len());
    }
    // By default the samples are get_trajectory's default: compact (4 decimals, still objects
    // listed in `unmoved`); `precision` as there.
    for (precision, decimals) in [(None, 4), (Some(2), 2)] {
        let mut args = json!({"sim_id": sim, "steps": 24, "sample_every": 6});
        let mut asked = json!({"sim_id": sim, "every": 6});
        if let Some(p) = precision {
            args["precision"] = json!(p);
            asked["precision"] = json!(p);
        }
        let sampled = c.call("step_simulation", args).await;
        c.step(&plain, 24).await;
        let t = c.call("get_trajectory", asked).await;
        assert_eq!(sampled["trajectory"], t, "compact like get_trajectory's default");
        let scale = 10f64.powi(decimals);
        for o in t["objects"].as_array().unwrap() {
            for x in o["positions"].as_array().unwrap().iter().flat_map(|p| p.as_array().unwrap()) {
                let x = x.as_f64().unwrap();
                assert_eq!((x * scale).round() / scale, x, "{x} has at most {decimals} decimals");
            }
        }
        assert!(!t["unmoved"].as_array().unwrap().is_empty(), "the still objects are listed apart: {t}");
    }
    // Only some objects.
    let sampled = c.call("step_simulation", json!({"sim_id": sim, "steps": 4, "sample_objects": [objects[2]], "detail": "full"})).await;
    assert_eq!(sampled["trajectory"]["objects"].as_array().unwrap().len(), 1);
    c.step(&plain, 4).await;
    assert_eq!(c.hash(&sim).await, c.hash(&plain).await);
    // The recorded events are plain steps: replay re-checks every result and state hash.
    let path = server.data.join(format!("{sim}.sqlite"));
    server.terminate();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[tokio::test(flavor = "multi_thread")]
async fn fork_intervals_reach_inherited_events_and_survive_a_kill() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 1]})).await;
    let from = head(&c, &sim).await;
    c.step(&sim, 30).await;
    c.call("apply_force", json!({"sim_id": sim, "object_id": 1, "force": [0, 50, 0]})).await;
    c.step(&sim, 30).await;
    let at = head(&c, &sim).await;
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": at})).await["simulation_id"].as_str().unwrap().to_string();
    c.step(&fork, 40).await;
    let to = head(&c, &fork).await;
    let args = json!({"sim_id": fork, "detail": "full", "from_seq": from, "to_seq": to, "every": 6, "include_velocities": true});
    let t = c.call("get_trajectory", args.clone()).await;
    assert_eq!(t["samples"], 2 + 100 / 6);
    // The inherited part equals the parent's own trajectory over it.
    let p = c.call("get_trajectory", json!({"sim_id": sim, "detail": "full", "from_seq": from, "to_seq": at, "every": 6, "include_velocities": true})).await;
    let n = p["samples"].as_u64().unwrap() as usize - 1; // the parent's last sample is its end state
    for (col, track) in [("positions", 1), ("linear_velocities", 1)] {
        assert_eq!(t["objects"][track][col].as_array().unwrap()[..n], p["objects"][track][col].as_array().unwrap()[..n]);
    }
    // After kill -9 and a restart: the same samples.
    let (data, ws) = (server.data.clone(), server.workspace.clone());
    server.kill();
    let again = Server::start(dir.path(), &[]);
    assert_eq!((again.data.clone(), again.workspace.clone()), (data, ws));
    let c = again.client().await;
    assert_eq!(c.call("get_trajectory", args).await, t);
}

/// Parses a `replay --trajectory` CSV into (sample, object) → the 13 numbers (None = empty).
fn csv_rows(text: &str) -> Vec<(usize, u64, Vec<Option<f64>>, String)> {
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let nums = f[5..18].iter().map(|x| (!x.is_empty()).then(|| x.parse::<f64>().unwrap())).collect();
            (f[0].parse().unwrap(), f[4].parse().unwrap(), nums, f[18].to_string())
        })
        .collect()
}

#[tokio::test(flavor = "multi_thread")]
async fn replay_trajectory_on_every_recorded_log_equals_get_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    let mut logs = vec![];
    for p in common::recorded_logs() {
        {
            // A copy, named as the server names a simulation's log (`<id>.sqlite`; it skips
            // files named otherwise): the recorded logs are never touched.
            let id = physics_mcp::log::sqlite::Log::open_read_only(&p).unwrap().simulation_id().unwrap();
            let copy = data.join(format!("{id}.sqlite"));
            std::fs::copy(&p, &copy).unwrap();
            let out_csv = dir.path().join(format!("{}.csv", p.file_stem().unwrap().to_string_lossy()));
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_physics-mcp"))
                .arg("replay")
                .arg(&p)
                .arg("--trajectory")
                .arg(&out_csv)
                .output()
                .unwrap();
            assert!(out.status.success(), "{}: {}", p.display(), String::from_utf8_lossy(&out.stderr));
            logs.push(out_csv);
        }
    }
    assert!(logs.len() >= 10);
    // The same logs served: get_trajectory over the same interval gives the same numbers.
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sims = c.call("list_simulations", json!({})).await;
    let mut compared = 0;
    for s in sims["simulations"].as_array().unwrap() {
        let sim = s["simulation_id"].as_str().unwrap();
        // Which CSV: the one whose interval ends at this simulation's head with its hash.
        let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
        for csv in &logs {
            let text = std::fs::read_to_string(csv).unwrap();
            let rows = csv_rows(&text);
            let first_seq: u64 = text.lines().nth(1).unwrap().split(',').nth(3).unwrap().parse().unwrap();
            let t = c
                .try_call("get_trajectory", json!({"sim_id": sim, "detail": "full", "from_seq": first_seq, "to_seq": info["head_seq"], "include_velocities": true}))
                .await;
            let Ok(t) = t else { continue };
            let tracks = t["objects"].as_array().unwrap();
            if rows.len() != t["samples"].as_u64().unwrap() as usize * tracks.len() {
                continue;
            }
            let matches = rows.iter().all(|(i, id, nums, joints)| {
                let track = tracks.iter().find(|o| o["object_id"] == *id).unwrap();
                let mut want = vec![];
                for col in ["positions", "orientations", "linear_velocities", "angular_velocities"] {
                    want.extend(bits(&track[col][*i]).into_iter().map(Some));
                    if track[col][*i].is_null() {
                        want.extend(std::iter::repeat_n(None, if col == "orientations" { 4 } else { 3 }));
                    }
                }
                let got: Vec<Option<Option<u32>>> = nums.iter().map(|x| x.map(|x| Some((x as f32).to_bits()))).collect();
                let jq: Vec<Option<u32>> = track.get("joint_positions").map(|j| bits(&j[*i])).unwrap_or_default();
                let got_j: Vec<Option<u32>> = joints.split(';').filter(|s| !s.is_empty()).map(|x| Some((x.parse::<f64>().unwrap() as f32).to_bits())).collect();
                got == want && jq == got_j
            });
            if matches {
                compared += 1;
                break;
            }
        }
    }
    assert_eq!(compared, logs.len(), "every log's CSV equals get_trajectory's samples");
}

#[tokio::test(flavor = "multi_thread")]
async fn refusals_name_the_parameter_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // A reply budget the full-velocity table of this scene does not fit.
    let server = Server::start(dir.path(), &["--max-reply-bytes", "500000"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..4 {
        c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [i, 0, 1]})).await;
    }
    let root = 1;
    c.step(&sim, 1000).await;
    let read_seq = {
        c.state(&sim, 1).await;
        c.call("get_history", json!({"sim_id": sim, "limit": 1000})).await["events"].as_array().unwrap().last().unwrap()["seq"].as_u64().unwrap()
    };
    let to = head(&c, &sim).await;
    let hash = c.hash(&sim).await;
    let many: Vec<u64> = vec![1; 1000];
    let cases = [
        ("get_trajectory", json!({"sim_id": sim, "from_seq": read_seq}), "from_seq"),
        ("get_trajectory", json!({"sim_id": sim, "to_seq": 99999}), "to_seq"),
        ("get_trajectory", json!({"sim_id": sim, "from_seq": to, "to_seq": root}), "from_seq"),
        ("get_trajectory", json!({"sim_id": sim, "every": 0}), "every"),
        ("get_trajectory", json!({"sim_id": sim, "every": -3}), "every"),
        ("get_trajectory", json!({"sim_id": sim, "object_ids": [77]}), "object_ids"),
        ("get_trajectory", json!({"sim_id": sim, "object_ids": many, "every": 1}), "too many samples"),
        ("get_trajectory", json!({"sim_id": sim, "detail": "full", "every": 1, "include_velocities": true}), "output_path"),
        ("get_trajectory", json!({"sim_id": sim, "output_path": "t.txt"}), "output_path"),
        ("get_trajectory", json!({"sim_id": sim, "output_path": "../t.csv"}), "output_path"),
        ("step_simulation", json!({"sim_id": sim, "steps": 5, "sample_every": 0}), "sample_every"),
        ("step_simulation", json!({"sim_id": sim, "steps": 5, "sample_objects": [42]}), "sample_objects"),
        ("step_simulation", json!({"sim_id": sim, "steps": 100000, "sample_every": 1}), "sample_every"),
    ];
    for (tool, args, needle) in cases {
        let e = c.try_call(tool, args.clone()).await.unwrap_err();
        assert!(e.contains(needle), "{tool} {args}: {e}");
        assert_eq!(c.hash(&sim).await, hash, "{tool} {args} changed the state");
        assert_eq!(head(&c, &sim).await, to);
    }
    assert!(!server.workspace.join("t.txt").exists());
    // The budget's advice works: the whole table to a file, then never overwritten.
    let t = c.call("get_trajectory", json!({"sim_id": sim, "every": 1, "include_velocities": true, "output_path": "out/t.csv"})).await;
    assert_eq!(t["samples"], 1001);
    assert!(t.get("objects").is_none());
    let text = std::fs::read_to_string(server.workspace.join("out/t.csv")).unwrap();
    assert_eq!(text.lines().count(), 1 + 1001 * 5);
    let e = c.try_call("get_trajectory", json!({"sim_id": sim, "output_path": "out/t.csv"})).await.unwrap_err();
    assert!(e.contains("already exists"), "{e}");
    let j = c.call("get_trajectory", json!({"sim_id": sim, "every": 100, "output_path": "t.jsonl"})).await;
    let lines = std::fs::read_to_string(server.workspace.join("t.jsonl")).unwrap();
    assert_eq!(lines.lines().count() as u64, j["samples"].as_u64().unwrap());
    assert_eq!(c.hash(&sim).await, hash);
}
