//! step_simulation's measures are part of its recorded result (event version 8): the step's
//! command holds `measure`, its recorded result the exact answers, and every fold re-derives
//! them — so after a kill -9 the recovered log says what the reply said, `replay` re-checks
//! them (a recorded answer changed in a copy, its hash made to match, is a divergence), and a
//! step recorded under version 7 (measures in the reply only) still folds as it did.

use crate::cancelled_step::replay_cli;
use crate::common;

use common::Server;
use serde_json::{json, Value};

/// A copy of `log` in `dir` with event `seq`'s command and result rewritten by `edit`
/// (and the result hash made to match the new result, as a careful forger would).
fn tampered(log: &std::path::Path, dir: &std::path::Path, name: &str, seq: u64, edit: impl Fn(&mut Value, &mut Value, &mut i64)) -> std::path::PathBuf {
    let copy = dir.join(name);
    std::fs::copy(log, &copy).unwrap();
    let conn = rusqlite::Connection::open(&copy).unwrap();
    let (command, result, mut version): (String, String, i64) = conn
        .query_row("SELECT command, result, version FROM events WHERE seq = ?1", [seq as i64], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap();
    let (mut command, mut result): (Value, Value) = (serde_json::from_str(&command).unwrap(), serde_json::from_str(&result).unwrap());
    edit(&mut command, &mut result, &mut version);
    let result = result.to_string();
    conn.execute(
        "UPDATE events SET command = ?1, result = ?2, result_hash = ?3, version = ?4 WHERE seq = ?5",
        rusqlite::params![command.to_string(), result, physics_mcp::digest::result_hash(&result), version, seq as i64],
    )
    .unwrap();
    copy
}

#[tokio::test(flavor = "multi_thread")]
async fn a_steps_measures_are_recorded_recovered_and_rechecked() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 1]})).await["object_id"].as_u64().unwrap();
    let measure = json!([{"object_id": ball, "what": "lowest_height"}, {"pair": [ball, ground], "what": "first_contact"}]);
    let step = json!({"sim_id": sim, "steps": 150, "measure": measure, "detail": "full"});
    let stepped = c.call("step_simulation", step).await;
    let seq = stepped["head_seq"].as_u64().unwrap();
    assert!(stepped["measures"][1]["time"].as_f64().is_some_and(|t| t > 0.3), "the ball lands: {stepped}");
    // Free fall of 0.9 m (centre 1 m, radius 0.1, ground top at 0) takes √(2·0.9/9.81) s, and
    // the ball then rests on the ground with its centre at its radius.
    let fall = (2.0 * 0.9 / 9.81f64).sqrt();
    let landed = stepped["measures"][1]["time"].as_f64().unwrap();
    assert!((landed - fall).abs() < 0.02, "first contact at {landed} s, free fall says {fall} s");
    let lowest = stepped["measures"][0]["value"].as_f64().unwrap();
    assert!((lowest - 0.1).abs() < 0.01, "lowest centre height {lowest} m, resting says 0.1 m");
    // A plain step after it is recorded as before: no `measure`, no `measures`.
    let plain = c.step(&sim, 10).await;
    assert!(plain.get("measures").is_none(), "{plain}");
    let recorded = |h: &Value, seq: u64| h["events"].as_array().unwrap().iter().find(|e| e["seq"] == seq).unwrap()["summary"]["measures"].clone();
    let history = c.call("get_history", json!({"sim_id": sim, "detail": "full"})).await;
    assert_eq!(recorded(&history, seq), stepped["measures"], "the recorded result holds the reply's exact answers");
    assert_eq!(recorded(&history, seq + 1), Value::Null);
    // The compact reply rounds the same answers.
    let rounded = c.call("step_simulation", json!({"sim_id": sim, "steps": 1, "measure": [{"object_id": ball, "what": "lowest_height"}]})).await;
    let z = rounded["measures"][0]["value"].as_f64().unwrap();
    assert_eq!(z, (z * 1e4).round() / 1e4, "{rounded}");

    // kill -9: recovery folds the log, measuring as it goes; the answers are still the log's.
    let head = c.hash(&sim).await;
    drop(c);
    server.kill();
    let log = dir.path().join("data").join(format!("{sim}.sqlite"));
    let (ok, out) = replay_cli(&log);
    assert!(ok, "{out}");
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    assert_eq!(c.hash(&sim).await, head);
    let history = c.call("get_history", json!({"sim_id": sim, "detail": "full"})).await;
    assert_eq!(recorded(&history, seq), stepped["measures"]);
    let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
    assert_eq!(v["ok"], true, "{v}");
    drop(c);
    server.terminate();

    // A recorded answer changed (its result hash made to match): replay re-measures and differs.
    let scratch = tempfile::tempdir().unwrap();
    let forged = tampered(&log, scratch.path(), "forged.sqlite", seq, |_, r, _| r["measures"][0]["value"] = json!(0.5));
    let (ok, out) = replay_cli(&forged);
    assert!(!ok && out.contains(&format!("DIVERGED at seq {seq} (step_simulation)")) && out.contains("result hash"), "{out}");
    // The same step as version 7 recorded it — `measure` in the arguments only, the result
    // without answers — folds and verifies as before; under version 7 a `measure` in the
    // command (which no version-7 server wrote) is not measured either.
    for keep_measure in [false, true] {
        let v7 = tampered(&log, scratch.path(), &format!("v7-{keep_measure}.sqlite"), seq, |cmd, r, version| {
            if !keep_measure {
                cmd.as_object_mut().unwrap().remove("measure");
            }
            r.as_object_mut().unwrap().remove("measures");
            *version = 7;
        });
        let (ok, out) = replay_cli(&v7);
        assert!(ok, "{out}");
    }
}
