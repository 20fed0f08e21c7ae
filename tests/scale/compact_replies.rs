//! Replies sized for a model by default, everything on request with one switch that means
//! the same on each tool (`detail: "full"`): get_trajectory lists objects that never moved
//! by id instead of repeating their samples and rounds on request; a batch answers each
//! change with its ids and values; run_sweep summarises each object (displacement, peak
//! speed — checked against free fall — as the f32 they come to), samples in get_trajectory's
//! compact form, ranks the variants, and names the parent, never a throwaway fork, in a refusal.

use crate::common;

use common::{Client, Server};
use serde_json::{json, Value};

/// A ground and a 4-box tower; returns (sim, ground id, box ids).
async fn tower(c: &Client) -> (String, u64, Vec<u64>) {
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let mut boxes = Vec::new();
    for i in 0..4 {
        let z = 0.1 + 0.2 * i as f64;
        boxes.push(c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, z]})).await["object_id"].as_u64().unwrap());
    }
    (sim, ground, boxes)
}

fn bytes(v: &Value) -> usize {
    v.to_string().len()
}

#[tokio::test(flavor = "multi_thread")]
async fn a_trajectory_lists_what_never_moved_and_rounds_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let (sim, ground, _) = tower(&c).await;
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [-1, 0, 0.5]})).await["object_id"].as_u64().unwrap();
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": ball, "linear_velocity": [6, 0, 2]})).await;
    c.step(&sim, 240).await;
    let compact = c.call("get_trajectory", json!({"sim_id": sim})).await;
    let full = c.call("get_trajectory", json!({"sim_id": sim, "detail": "full"})).await;
    let ids = |t: &Value| t["objects"].as_array().unwrap().iter().map(|o| o["object_id"].as_u64().unwrap()).collect::<Vec<_>>();
    assert!(compact["unmoved"].as_array().unwrap().contains(&json!(ground)), "the static ground is listed, not sampled: {}", compact["unmoved"]);
    assert!(!ids(&compact).contains(&ground));
    assert!(ids(&compact).contains(&ball));
    assert!(ids(&full).contains(&ground) && full.get("unmoved").is_none(), "full detail keeps every track");
    // Nothing is hidden: every object is in one list or the other.
    assert_eq!(ids(&compact).len() + compact["unmoved"].as_array().unwrap().len(), ids(&full).len());
    // The tracks kept are the exact ones rounded: to 4 decimals by default, to `precision` on
    // request; "full" is every bit (what get_object_state said, tests/seeing/trajectory.rs).
    let track = |t: &Value, id: u64| t["objects"].as_array().unwrap().iter().find(|o| o["object_id"] == id).unwrap().clone();
    let rounded = c.call("get_trajectory", json!({"sim_id": sim, "precision": 3})).await;
    let exact = track(&full, ball);
    for (t, within) in [(&compact, 5e-5), (&rounded, 5e-4)] {
        let r = track(t, ball);
        assert_eq!(r["positions"].as_array().unwrap().len(), exact["positions"].as_array().unwrap().len());
        for col in ["positions", "orientations"] {
            for (a, b) in r[col].as_array().unwrap().iter().zip(exact[col].as_array().unwrap()) {
                for (x, y) in a.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
                    assert!((x.as_f64().unwrap() - y.as_f64().unwrap()).abs() <= within + 1e-12, "{col}: {x} vs {y}");
                }
            }
        }
    }
    assert!(bytes(&rounded) < bytes(&compact) && bytes(&compact) < bytes(&full), "{} < {} < {}", bytes(&rounded), bytes(&compact), bytes(&full));
    let e = c.try_call("get_trajectory", json!({"sim_id": sim, "detail": "all"})).await.unwrap_err();
    assert!(e.contains("detail must be \"compact\" or \"full\""), "{e}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_answers_each_change_with_its_ids_and_values() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    let calls: Vec<Value> = (0..100)
        .map(|i| json!({"tool": "add_box", "arguments": {"dimensions": [0.1, 0.1, 0.1], "position": [i as f64 * 0.3, 0, 0.1]}}))
        .chain([json!({"tool": "step_simulation", "arguments": {"steps": 2}}), json!({"tool": "set_timestep", "arguments": {"timestep": 0.01}}), json!({"tool": "get_object_state", "arguments": {"object_id": 3}})])
        .collect();
    let compact = c.call("batch", json!({"sim_id": sim, "calls": calls})).await;
    let r = compact["results"].as_array().unwrap();
    assert_eq!(r[7], json!({"object_id": 7}));
    assert_eq!(r[100]["steps_taken"], 2);
    assert!(r[100].get("simulation_id").is_none());
    assert_eq!(r[101], json!({"timestep": 0.01}));
    assert!(r[102]["position"].is_array(), "a read keeps its values: {}", r[102]);
    c.call("undo", json!({"sim_id": sim, "count": 102})).await;
    let full = c.call("batch", json!({"sim_id": sim, "calls": calls, "detail": "full"})).await;
    assert_eq!(full["results"][7]["shape"], "box");
    assert_eq!(full["state_hash"], compact["state_hash"], "the same calls, the same world");
    assert!(bytes(&compact) * 3 < bytes(&full), "{} vs {}", bytes(&compact), bytes(&full));
}

#[tokio::test(flavor = "multi_thread")]
async fn a_sweep_summarises_ranks_and_names_the_parent_in_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    // A ball in free fall from rest for 0.5 s (no ground): peak speed g·t, displacement g·t²/2.
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 10]})).await["object_id"].as_u64().unwrap();
    let still = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [5, 0, 0], "mass": 0})).await["object_id"].as_u64().unwrap();
    let throw = |vz: f64| json!([{"tool": "set_object_velocity", "arguments": {"object_id": ball, "linear_velocity": [0, 0, vz]}}]);
    let out = c.call("run_sweep", json!({"sim_id": sim, "variants": [[], throw(3.0), throw(-3.0)], "steps": 120,
        "rank_by": {"object_id": ball, "metric": "peak_speed"}})).await;
    let v0 = &out["variants"][0];
    assert_eq!(v0["unmoved"], json!([still]), "{v0}");
    let o = &v0["objects"][0];
    assert_eq!(o["object_id"], ball);
    // Free fall with PyBullet's linear damping c = 0.04 /s: v = (g/c)(1 − e^(−ct)),
    // z = (g/c)t − (g/c²)(1 − e^(−ct)); within 0.5 % at 1/240 s steps.
    let (g, t, k) = (9.81f64, 120.0 / 240.0, 0.04f64);
    let (v, z) = (g / k * (1.0 - (-k * t).exp()), g / k * t - g / (k * k) * (1.0 - (-k * t).exp()));
    let peak = o["peak_speed"].as_f64().unwrap();
    let moved = o["displacement"].as_f64().unwrap();
    assert!((peak - v).abs() < 0.005 * v, "peak speed {peak} vs {v}");
    assert!((moved - z).abs() < 0.005 * z, "displacement {moved} vs {z}");
    // Thrown down is fastest, thrown up slowest.
    assert_eq!(out["ranking"], json!([2, 0, 1]));
    // A refusal names the variant, the call and the simulation the agent knows.
    let e = c
        .try_call("run_sweep", json!({"sim_id": sim, "variants": [[], [{"tool": "apply_force", "arguments": {"object_id": 999, "force": [1, 0, 0]}}]], "steps": 1}))
        .await
        .unwrap_err();
    assert!(e.contains("variants[1]") && e.contains("calls[0]") && e.contains(&sim), "{e}");
    let full = c.call("run_sweep", json!({"sim_id": sim, "variants": [[]], "steps": 120, "detail": "full"})).await;
    assert_eq!(full["variants"][0]["objects"].as_array().unwrap().len(), 2);
    // The compact summary gives the f32 the exact figures come to (the poses' own precision).
    let exact = &full["variants"][0]["objects"][0];
    for key in ["displacement", "peak_speed"] {
        let x = exact[key].as_f64().unwrap();
        let shown: f64 = format!("{}", x as f32).parse().unwrap();
        assert_eq!(o[key].as_f64(), Some(shown), "{key}: {x} shown as {}", o[key]);
    }
    assert!(exact["displacement"].to_string().len() > o["displacement"].to_string().len(), "{exact} {o}");
    // Its samples are get_trajectory's compact default: 4 decimals, the still box by id only.
    let sampled = c.call("run_sweep", json!({"sim_id": sim, "variants": [[]], "steps": 12, "observe": {"every": 4}})).await;
    let t = &sampled["variants"][0]["trajectory"];
    assert_eq!(t["unmoved"], json!([still]), "{t}");
    for x in t["objects"][0]["positions"].as_array().unwrap().iter().flat_map(|p| p.as_array().unwrap()) {
        let x = x.as_f64().unwrap();
        assert_eq!((x * 1e4).round() / 1e4, x, "{x} has more than 4 decimals");
    }
    let e = c.try_call("run_sweep", json!({"sim_id": sim, "variants": [[]], "steps": 1, "rank_by": {"object_id": ball, "metric": "height"}})).await.unwrap_err();
    assert!(e.contains("rank_by.metric"), "{e}");
}
