//! Measures (docs/tools.md "Measures") against analytic physics: a ball thrown up peaks at
//! z0 + v²/2g (seen at every step, not only at samples), a dropped ball passes a height and
//! touches the ground when free fall says, a box spinning at a known rate tilts past 45° at
//! π/4 s, a drifting box travels v·t, a tilted box reads its tilt. The same answers come from
//! step_simulation, get_trajectory (re-simulated from the log) and run_sweep, which ranks its
//! variants by one and echoes what each varied. Bad measures are refused naming the entry and
//! change nothing. One server for the whole file.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

const G: f64 = 9.81;
const DT: f64 = 1.0 / 240.0;

/// A body with no damping, so free flight is analytic.
async fn undamped(c: &Client, sim: &str, tool: &str, args: Value) -> u64 {
    let mut a = json!({"sim_id": sim});
    a.as_object_mut().unwrap().extend(args.as_object().unwrap().clone());
    let id = c.call(tool, a).await["object_id"].as_u64().unwrap();
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": id, "linear_damping": 0, "angular_damping": 0})).await;
    id
}

fn answer(r: &Value, i: usize) -> (Option<f64>, Option<f64>) {
    let m = &r["measures"][i];
    (m["value"].as_f64(), m["time"].as_f64())
}

#[tokio::test(flavor = "multi_thread")]
async fn measures_answer_what_free_flight_and_free_fall_say() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;

    // Thrown up at 3 m/s from z = 1: peak 1 + 9/2g at 3/g s (within a step's travel).
    let sim = c.new_sim(json!({})).await;
    let ball = undamped(&c, &sim, "add_sphere", json!({"radius": 0.1, "position": [0, 0, 1]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": ball, "linear_velocity": [0, 0, 3]})).await;
    let peak = json!([{"object_id": ball, "what": "peak_height"}, {"object_id": ball, "what": "lowest_height"}, {"object_id": ball, "what": "travel"}]);
    let stepped = c.call("step_simulation", json!({"sim_id": sim, "steps": 120, "measure": peak, "detail": "full"})).await;
    assert!(stepped.get("trajectory").is_none(), "measure alone asks for no samples: {stepped}");
    let (top, when) = answer(&stepped, 0);
    let (top, when) = (top.unwrap(), when.unwrap());
    assert!((top - (1.0 + 9.0 / (2.0 * G))).abs() < 3.0 * DT, "peak {top}");
    assert!((when - 3.0 / G).abs() < 2.0 * DT, "peak at {when}");
    // Up to the peak and down again to where it is now: the path, not the displacement.
    let now = c.state(&sim, ball).await["position"][2].as_f64().unwrap();
    let (low, _) = answer(&stepped, 1);
    assert_eq!(low, Some(now.min(1.0)));
    let travel = answer(&stepped, 2).0.unwrap();
    assert!((travel - ((top - 1.0) + (top - now))).abs() < 1e-4, "travel {travel}");
    // Every step, not only samples: samples every 50 steps miss the top.
    let sampled = c.call("get_trajectory", json!({"sim_id": sim, "every": 50, "object_ids": [ball], "detail": "full", "measure": peak})).await;
    let zs: Vec<f64> = sampled["objects"][0]["positions"].as_array().unwrap().iter().map(|p| p[2].as_f64().unwrap()).collect();
    assert!(zs.iter().all(|z| *z < top), "the samples never reach the peak: {zs:?}");
    // get_trajectory re-simulates the same answers from the log, bit for bit.
    assert_eq!(sampled["measures"], stepped["measures"]);
    // `fields`: only the heights, one number a sample, the same as the full positions' z.
    let heights = c.call("get_trajectory", json!({"sim_id": sim, "every": 50, "object_ids": [ball], "detail": "full", "fields": ["z"]})).await;
    let track = &heights["objects"][0];
    assert!(track.get("positions").is_none() && track.get("orientations").is_none(), "{track}");
    let z: Vec<f64> = track["z"].as_array().unwrap().iter().map(|z| z.as_f64().unwrap()).collect();
    assert_eq!(z, zs);
    let e = c.try_call("get_trajectory", json!({"sim_id": sim, "fields": ["height"]})).await.unwrap_err();
    assert!(e.contains("fields: unknown field \"height\"; the fields are positions, x, y, z"), "{e}");
    // The compact default rounds them to 4 decimals.
    let compact = c.call("get_trajectory", json!({"sim_id": sim, "measure": peak})).await;
    assert!(compact.get("objects").is_none(), "measure alone: no samples: {compact}");
    assert!((compact["measures"][0]["value"].as_f64().unwrap() - top).abs() <= 5e-5);

    // Dropped from z = 1 onto the ground: below 0.5 at √(2·0.5/g), touching (radius 0.1) at √(2·0.9/g).
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let ball = undamped(&c, &sim, "add_sphere", json!({"radius": 0.1, "position": [0, 0, 1]})).await;
    let asked = json!([
        {"object_id": ball, "what": "first", "when": {"height_below": 0.5}},
        {"pair": [ball, ground], "what": "first_contact"},
        {"object_id": ball, "what": "first", "when": {"height_above": 2}},
        {"object_id": ball, "what": "settled", "when": {"speed_below": 0.01}},
    ]);
    let r = c.call("step_simulation", json!({"sim_id": sim, "steps": 240, "measure": asked, "sample_every": 60, "fields": ["z"]})).await;
    let tracks = r["trajectory"]["objects"].as_array().unwrap();
    assert!(tracks.len() == 1 && tracks[0]["z"].as_array().unwrap().len() == 5 && tracks[0].get("orientations").is_none(), "only the ball moves, by its heights: {r}");
    assert_eq!(r["trajectory"]["unmoved"], json!([ground]));
    let (z, t) = answer(&r, 0);
    assert!((t.unwrap() - (1.0 / G).sqrt()).abs() < 2.0 * DT && z.unwrap() < 0.5, "{r}");
    let t = answer(&r, 1).1.unwrap();
    assert!((t - (1.8 / G).sqrt()).abs() < 3.0 * DT, "first contact at {t}");
    assert_eq!(answer(&r, 2), (None, None), "never above 2 m");
    // At rest at the start, it did not settle then: it settled after landing (and any bounce).
    let (v, t) = answer(&r, 3);
    assert!(v.unwrap() < 0.01 && t.unwrap() > (1.8 / G).sqrt(), "{r}");
    let now = c.state(&sim, ball).await["linear_velocity"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap().powi(2)).sum::<f64>().sqrt();
    assert!(now < 0.01);

    // Without gravity: a box spinning at 1 rad/s about x tilts past 45° at π/4 s; a box drifting
    // at 1 m/s travels 1 m in 1 s; a box set at 30° reads 30°.
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let spin = undamped(&c, &sim, "add_box", json!({"dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 1]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": spin, "angular_velocity": [1, 0, 0]})).await;
    let drift = undamped(&c, &sim, "add_box", json!({"dimensions": [0.1, 0.1, 0.1], "position": [3, 0, 1]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": drift, "linear_velocity": [1, 0, 0]})).await;
    let h = (15f64).to_radians();
    let tilted = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [-3, 0, 1], "orientation": [h.sin(), 0, 0, h.cos()]})).await["object_id"].as_u64().unwrap();
    let asked = json!([
        {"object_id": spin, "what": "first", "when": {"tilt_above": 45}},
        {"object_id": drift, "what": "travel"},
        {"object_id": tilted, "what": "final_tilt"},
        {"object_id": drift, "what": "first", "when": {"speed_below": 0.5}},
    ]);
    let r = c.call("step_simulation", json!({"sim_id": sim, "steps": 240, "measure": asked})).await;
    let (tilt, t) = answer(&r, 0);
    assert!((t.unwrap() - std::f64::consts::FRAC_PI_4).abs() < 1.5 * DT && tilt.unwrap() > 45.0, "{r}");
    assert!((answer(&r, 1).0.unwrap() - 1.0).abs() < 1e-3, "{r}");
    assert!((answer(&r, 2).0.unwrap() - 30.0).abs() < 1e-3, "{r}");
    assert_eq!(answer(&r, 3), (None, None), "it never slows down");

    // Refused, naming the entry, changing nothing.
    let steps_before = c.call("get_simulation_info", json!({"sim_id": sim})).await["steps"].clone();
    let hash = c.hash(&sim).await;
    for (bad, said) in [
        (json!([{"object_id": 99, "what": "peak_height"}]), "measure[0]: object 99 does not exist"),
        (json!([{"object_id": spin, "what": "first"}]), "measure[0]: first needs when"),
        (json!([{"object_id": spin, "what": "tallest"}]), "measure[0]: unknown variant `tallest`"),
    ] {
        let e = c.try_call("step_simulation", json!({"sim_id": sim, "steps": 10, "measure": bad})).await.unwrap_err();
        assert!(e.contains(said), "{e}");
    }
    assert_eq!(c.hash(&sim).await, hash);
    assert_eq!(c.call("get_simulation_info", json!({"sim_id": sim})).await["steps"], steps_before);
    let e = c.try_call("get_trajectory", json!({"sim_id": sim, "measure": [{"object_id": 42, "what": "travel"}]})).await.unwrap_err();
    assert!(e.contains("measure[0]: object 42 does not exist at any step"), "{e}");

    // run_sweep: thrown up at 1, 2, 3 m/s; ranked by the measured peak, each echoing its speed.
    let sim = c.new_sim(json!({})).await;
    let ball = undamped(&c, &sim, "add_sphere", json!({"radius": 0.1, "position": [0, 0, 1]})).await;
    let variants: Vec<Value> = [1.0, 2.0, 3.0]
        .iter()
        .map(|v| json!([{"tool": "set_object_velocity", "arguments": {"object_id": ball, "linear_velocity": [0, 0, v]}}]))
        .collect();
    let swept = c
        .call("run_sweep", json!({"sim_id": sim, "variants": variants, "steps": 120, "observe": {"object_ids": [ball], "measure": [{"object_id": ball, "what": "peak_height"}]}, "rank_by": {"measure": 0}}))
        .await;
    assert_eq!(swept["ranking"], json!([2, 1, 0]), "{swept}");
    for (i, v) in [1.0, 2.0, 3.0].iter().enumerate() {
        let variant = &swept["variants"][i];
        assert_eq!(variant["varied"], json!({"set_object_velocity.linear_velocity": [0, 0, v]}), "{variant}");
        let top = variant["measures"][0]["value"].as_f64().unwrap();
        assert!((top - (1.0 + v * v / (2.0 * G))).abs() < 3.0 * DT, "variant {i}: peak {top}");
    }
    let e = c.try_call("run_sweep", json!({"sim_id": sim, "variants": [[]], "steps": 1, "rank_by": {"measure": 0}})).await.unwrap_err();
    assert!(e.contains("rank_by.measure must be an index into observe.measure"), "{e}");
}
