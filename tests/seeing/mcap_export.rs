//! Opening a run in Foxglove: get_trajectory with an `.mcap` output_path and `replay --mcap`
//! write the interval as Foxglove messages — `/scene` (SceneUpdate), `/tf` (FrameTransforms),
//! `/contacts` from the command line — on a time axis of simulated time. Read back with the
//! `mcap` crate's reader, every message checked against the Foxglove JSON schema the file
//! carries, and the poses compared with get_trajectory's own numbers.

use std::collections::BTreeMap;

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// What a file holds: per topic, (log time, publish time, message) in file order; and per
/// topic its schema's name, encoding and text.
struct Read {
    messages: BTreeMap<String, Vec<(u64, u64, Value)>>,
    schemas: BTreeMap<String, (String, String, Value)>,
}

fn read(bytes: &[u8]) -> Read {
    let mut messages: BTreeMap<String, Vec<(u64, u64, Value)>> = BTreeMap::new();
    let mut schemas = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        assert_eq!(m.channel.message_encoding, "json", "{topic}");
        let s = m.channel.schema.as_ref().expect("every channel has a schema");
        let text: Value = serde_json::from_slice(&s.data).unwrap();
        schemas.entry(topic.clone()).or_insert_with(|| (s.name.clone(), s.encoding.clone(), text));
        let v: Value = serde_json::from_slice(&m.data).unwrap();
        messages.entry(topic).or_default().push((m.log_time, m.publish_time, v));
    }
    // Every message is valid against the schema its channel names (Foxglove's own).
    for (topic, list) in &messages {
        let validator = jsonschema::validator_for(&schemas[topic].2).unwrap();
        for (_, _, v) in list {
            let errors: Vec<String> = validator.iter_errors(v).map(|e| e.to_string()).collect();
            assert!(errors.is_empty(), "{topic}: {errors:?}");
        }
    }
    Read { messages, schemas }
}

fn nanos(t: &Value) -> u64 {
    (t.as_f64().unwrap() * 1e9).round() as u64
}

async fn head(c: &Client, sim: &str) -> u64 {
    c.call("get_simulation_info", json!({"sim_id": sim})).await["head_seq"].as_u64().unwrap()
}

/// The transform of `frame` in a FrameTransforms message, as [x, y, z] and [x, y, z, w].
fn transform(tf: &Value, frame: &str) -> Option<(Value, Value)> {
    let t = tf["transforms"].as_array()?.iter().find(|t| t["child_frame_id"] == frame)?;
    let (p, q) = (&t["translation"], &t["rotation"]);
    Some((json!([p["x"], p["y"], p["z"]]), json!([q["x"], q["y"], q["z"], q["w"]])))
}

#[tokio::test(flavor = "multi_thread")]
async fn an_interval_exports_to_mcap_on_simulated_time_with_the_poses_get_trajectory_gives() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    server.copy_fixtures();
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let id = |v: Value| v["object_id"].as_u64().unwrap();
    let bx = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.2, 0.3], "position": [0, 0, 1], "color": [1, 0, 0, 1]})).await);
    let ball = id(c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [1, 0, 0.5]})).await);
    let pill = id(c.call("add_capsule", json!({"sim_id": sim, "radius": 0.05, "height": 0.2, "position": [-1, 0, 0.5]})).await);
    let arm = id(c.call("load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "position": [0, -1, 1], "use_fixed_base": true})).await);
    let from = head(&c, &sim).await;
    c.step(&sim, 20).await;
    let late = id(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.05, 0.05, 0.05], "position": [0, 1, 0.5]})).await);
    c.step(&sim, 200).await;
    let to = head(&c, &sim).await;
    let hash = c.hash(&sim).await;
    let every = 5;

    let asked = json!({"sim_id": sim, "from_seq": from, "to_seq": to, "every": every});
    let mut with_path = asked.clone();
    with_path["output_path"] = json!("runs/a.mcap");
    let summary = c.call("get_trajectory", with_path.clone()).await;
    assert_eq!(summary["output_path"], "runs/a.mcap");
    assert!(summary.get("objects").is_none(), "{summary}");
    let mut full = asked.clone();
    full["detail"] = json!("full");
    let t = c.call("get_trajectory", full).await;
    let samples = t["samples"].as_u64().unwrap() as usize;
    assert_eq!(summary["samples"].as_u64().unwrap() as usize, samples);
    assert_eq!(samples, 1 + 220 / every as usize);

    let bytes = std::fs::read(server.workspace.join("runs/a.mcap")).unwrap();
    let r = read(&bytes);
    assert_eq!(r.messages.keys().collect::<Vec<_>>(), ["/scene", "/tf"], "contacts only when asked, from the command line");
    assert_eq!(r.schemas["/scene"].0, "foxglove.SceneUpdate");
    assert_eq!(r.schemas["/tf"].0, "foxglove.FrameTransforms");
    assert!(r.schemas.values().all(|(_, encoding, text)| encoding == "jsonschema" && text["title"].is_string()));

    // Time axis: simulated time in ns, log time = publish time, never going back.
    for list in r.messages.values() {
        assert!(list.iter().all(|(log, publish, _)| log == publish));
        assert!(list.windows(2).all(|w| w[0].0 <= w[1].0));
    }
    // A transform per sample, at the sample's simulated time, plus one where the scene changed
    // between samples (the late box appears when it was added).
    let tf = &r.messages["/tf"];
    assert_eq!(tf.len(), samples + 1);
    let sample_times: Vec<u64> = t["times"].as_array().unwrap().iter().map(nanos).collect();
    let mut tf_times: Vec<u64> = tf.iter().map(|m| m.0).collect();
    tf_times.dedup();
    let mut expected = sample_times.clone();
    expected.dedup();
    assert_eq!(tf_times, expected, "the added box's scene change is at the time of the sample before it");
    let in_samples: Vec<&Value> = {
        // The extra transform is the one with the late box at the time of sample 4 (step 20).
        let at = sample_times[4];
        let mut v: Vec<&Value> = tf.iter().map(|m| &m.2).collect();
        let extra = tf.iter().position(|m| m.0 == at && transform(&m.2, &format!("object_{late}")).is_some()).unwrap();
        v.remove(extra);
        v
    };
    // Every sample's poses are get_trajectory's, number for number.
    let tracks = t["objects"].as_array().unwrap();
    for track in tracks {
        let oid = track["object_id"].as_u64().unwrap();
        for (i, msg) in in_samples.iter().enumerate() {
            let got = transform(msg, &format!("object_{oid}"));
            match &track["positions"][i] {
                Value::Null => assert!(got.is_none(), "object {oid} sample {i}"),
                p => assert_eq!(got, Some((p.clone(), track["orientations"][i].clone())), "object {oid} sample {i}"),
            }
        }
    }
    let moved = tracks.iter().find(|o| o["object_id"] == bx).unwrap();
    assert_ne!(moved["positions"][0], moved["positions"][samples - 1], "the box falls");
    // The arm's links have frames of their own.
    assert!(transform(in_samples[0], &format!("object_{arm}/link_1")).is_some());

    // The scene: everything at the start, then only the late box, at the time it was added.
    let scene = &r.messages["/scene"];
    assert_eq!(scene.len(), 2);
    assert_eq!(scene[0].0, sample_times[0]);
    let first = scene[0].2["entities"].as_array().unwrap();
    let entity = |id: String| first.iter().find(|e| e["id"] == id).cloned().unwrap_or_else(|| panic!("no entity {id}"));
    for o in [ground, bx, ball, pill, arm] {
        let e = entity(format!("object_{o}"));
        assert_eq!(e["frame_id"], e["id"]);
        assert_eq!(e["frame_locked"], true);
    }
    let cube = &entity(format!("object_{bx}"))["cubes"][0];
    assert_eq!(cube["size"], json!({"x": 0.2, "y": 0.4, "z": 0.6}), "half-extents doubled");
    assert_eq!(cube["color"], json!({"r": 1.0, "g": 0.0, "b": 0.0, "a": 1.0}));
    assert_eq!(entity(format!("object_{ball}"))["spheres"][0]["size"], json!({"x": 0.2, "y": 0.2, "z": 0.2}));
    let capsule = entity(format!("object_{pill}"));
    assert_eq!((capsule["cylinders"].as_array().unwrap().len(), capsule["spheres"].as_array().unwrap().len()), (1, 2));
    assert_eq!(capsule["cylinders"][0]["size"]["z"], 0.2);
    assert!(first.iter().any(|e| e["id"] == format!("object_{arm}/link_1")));
    let later: Vec<&Value> = scene[1].2["entities"].as_array().unwrap().iter().collect();
    assert_eq!(later.len(), 1);
    assert_eq!(later[0]["id"], format!("object_{late}"));
    assert_eq!(scene[1].0, sample_times[4]);

    // Never over an existing file; a wrong extension is one sentence naming output_path.
    let e = c.try_call("get_trajectory", with_path).await.unwrap_err();
    assert!(e.contains("already exists"), "{e}");
    let e = c.try_call("get_trajectory", json!({"sim_id": sim, "output_path": "runs/b.mcapx"})).await.unwrap_err();
    assert!(e.starts_with("output_path must end in .csv, .jsonl or .mcap"), "{e}");
    assert!(!server.workspace.join("runs/b.mcapx").exists());
    assert_eq!(std::fs::read(server.workspace.join("runs/a.mcap")).unwrap(), bytes);
    assert_eq!(c.hash(&sim).await, hash, "exporting changes nothing");

    // The command line: the whole chain of the log's head, with contacts, after checking it.
    let log = server.data.join(format!("{sim}.sqlite"));
    server.terminate();
    let out = dir.path().join("whole.mcap");
    let run = std::process::Command::new(common::bin())
        .arg("replay")
        .arg(&log)
        .arg("--mcap")
        .arg(&out)
        .arg("--contacts")
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let whole = read(&std::fs::read(&out).unwrap());
    assert_eq!(whole.messages.keys().collect::<Vec<_>>(), ["/contacts", "/scene", "/tf"]);
    assert_eq!(whole.schemas["/contacts"].0, "foxglove.SceneUpdate");
    let contacts = &whole.messages["/contacts"];
    let touching = contacts.last().unwrap().2["entities"][0]["spheres"].as_array().unwrap().len();
    assert!(touching > 0, "the box rests on the ground at the end");
    // Not over an existing file without --force.
    let again = std::process::Command::new(common::bin()).arg("replay").arg(&log).arg("--mcap").arg(&out).output().unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    let wrong = std::process::Command::new(common::bin()).arg("replay").arg(&log).arg("--mcap").arg(dir.path().join("x.json")).output().unwrap();
    assert!(String::from_utf8_lossy(&wrong.stderr).contains("--mcap must end in .mcap"), "{}", String::from_utf8_lossy(&wrong.stderr));
}
