//! Physical facts checked through the real server over MCP/HTTP.

use crate::common;

use common::{rel, v3, Client, Server};
use serde_json::json;

const DT: f64 = 1.0 / 240.0;

async fn setup() -> (tempfile::TempDir, Server, Client) {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let client = server.client().await;
    (dir, server, client)
}

async fn undamped(c: &Client, sim: &str, id: u64) {
    c.call(
        "change_dynamics",
        json!({"sim_id": sim, "object_id": id, "linear_damping": 0, "angular_damping": 0}),
    )
    .await;
}

#[tokio::test(flavor = "multi_thread")]
async fn dropped_box_comes_to_rest_on_the_ground() {
    let (_d, _s, c) = setup().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let b = c
        .call("add_box", json!({"sim_id": sim, "dimensions": [0.5, 0.5, 0.5], "position": [0, 0, 2]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    c.step(&sim, 960).await;
    let st = c.state(&sim, b).await;
    let p = v3(&st["position"]);
    assert!((p[2] - 0.5).abs() <= 0.01, "box rests at z = {} (expected 0.5 ± 0.01)", p[2]);
    assert!(v3(&st["linear_velocity"]).iter().all(|v| v.abs() < 1e-2), "still moving: {st}");
}

#[tokio::test(flavor = "multi_thread")]
async fn free_fall_matches_half_g_t_squared() {
    let (_d, _s, c) = setup().await;
    let sim = c.new_sim(json!({})).await;
    let b = c
        .call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [0, 0, 10]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    undamped(&c, &sim, b).await;
    c.step(&sim, 120).await; // 0.5 s
    let z = v3(&c.state(&sim, b).await["position"])[2];
    let fallen = 10.0 - z;
    let theory = 0.5 * 9.81 * 0.5f64.powi(2);
    assert!(rel(fallen, theory) < 0.01, "fell {fallen} m, theory {theory} m");
}

#[tokio::test(flavor = "multi_thread")]
async fn velocity_in_zero_gravity_moves_v_times_t() {
    let (_d, _s, c) = setup().await;
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let b = c
        .call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [0, 0, 0]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    undamped(&c, &sim, b).await;
    c.call(
        "set_object_velocity",
        json!({"sim_id": sim, "object_id": b, "linear_velocity": [1.5, -0.5, 0.25]}),
    )
    .await;
    c.step(&sim, 240).await;
    let p = v3(&c.state(&sim, b).await["position"]);
    for (got, v) in p.iter().zip([1.5, -0.5, 0.25]) {
        assert!(rel(*got, v * 240.0 * DT) < 0.005, "moved {p:?}");
    }
}

/// Δv after one step of apply_force, for a body of `mass` (set through change_dynamics).
async fn delta_v_of_one_force_step(c: &Client, mass: f64) -> (f64, f64) {
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let b = c
        .call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 0]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    undamped(c, &sim, b).await;
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": b, "mass": mass})).await;
    let info = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": b})).await;
    assert_eq!(info["mass"].as_f64().unwrap(), mass);
    c.call("apply_force", json!({"sim_id": sim, "object_id": b, "force": [12, 0, 0]})).await;
    c.step(&sim, 1).await;
    let v1 = v3(&c.state(&sim, b).await["linear_velocity"])[0];
    c.step(&sim, 1).await;
    let v2 = v3(&c.state(&sim, b).await["linear_velocity"])[0];
    (v1, v2)
}

#[tokio::test(flavor = "multi_thread")]
async fn apply_force_acts_for_exactly_one_step_and_mass_changes_take_effect() {
    let (_d, _s, c) = setup().await;
    let (v1, v2) = delta_v_of_one_force_step(&c, 1.0).await;
    let theory = 12.0 * DT / 1.0;
    assert!(rel(v1, theory) <= 1e-4, "Δv = {v1}, theory {theory}");
    assert!(((v2 - v1) / v1).abs() <= 1e-6, "force still acting: {v1} then {v2}");
    let (w1, _) = delta_v_of_one_force_step(&c, 2.0).await;
    assert!(rel(w1, v1 / 2.0) <= 1e-4, "mass 2 gives Δv {w1}, expected half of {v1}");
}

/// What a ball dropped from 1 m did after its first contact with the ground.
struct Rebound {
    /// Highest point its bottom reached after that contact (m).
    peak: f64,
    /// Whether it moved upward after the contact (a real bounce).
    rose: bool,
    /// Its bottom's height and vertical velocity when the run ended.
    end: (f64, f64),
}

async fn rebound(c: &Client, ground_restitution: Option<f64>) -> Rebound {
    let sim = c.new_sim(json!({})).await;
    let g = c.ground(&sim).await;
    if let Some(r) = ground_restitution {
        c.call("change_dynamics", json!({"sim_id": sim, "object_id": g, "restitution": r})).await;
    }
    let r = 0.1;
    let ball = c
        .call("add_sphere", json!({"sim_id": sim, "radius": r, "position": [0, 0, 1.0 + r]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    c.call(
        "change_dynamics",
        json!({"sim_id": sim, "object_id": ball, "restitution": 0.9, "linear_damping": 0}),
    )
    .await;
    let (mut landed, mut rose) = (false, false);
    let mut peak: f64 = 0.0;
    let mut end = (f64::NAN, f64::NAN);
    for _ in 0..200 {
        c.step(&sim, 4).await;
        let st = c.state(&sim, ball).await;
        let z = v3(&st["position"])[2] - r;
        let vz = v3(&st["linear_velocity"])[2];
        end = (z, vz);
        if !landed && z < 0.05 {
            landed = true;
        }
        if landed {
            peak = peak.max(z);
            rose |= vz > 0.1;
            if vz < 0.0 && peak > 0.05 {
                break;
            }
        }
    }
    // A ball that never reached the ground would report a rebound of 0 and pass as "dead".
    assert!(landed, "the ball never reached the ground (ground restitution {ground_restitution:?}): ended at {end:?}");
    Rebound { peak, rose, end }
}

#[tokio::test(flavor = "multi_thread")]
async fn restitution_combines_by_multiplying() {
    let (_d, _s, c) = setup().await;
    let bouncy = rebound(&c, Some(1.0)).await;
    assert!(bouncy.rose, "with a restitution-1 ground the ball never moved up again");
    assert!(bouncy.peak > 0.5, "rebound {} m of 1 m drop (theory 0.81)", bouncy.peak);
    let dead = rebound(&c, None).await;
    assert!(dead.peak < 0.02, "with a restitution-0 ground the ball rebounded {} m", dead.peak);
    // It stopped on the ground (not still falling, not stuck in the air).
    let (z, vz) = dead.end;
    assert!(z.abs() < 0.01 && vz.abs() < 0.05, "with a restitution-0 ground the ball ended at z {z} m, vz {vz} m/s");
}

async fn slide_distance(c: &Client, mu_box: f64) -> (f64, f64) {
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let h = 0.1;
    let b = c
        .call("add_box", json!({"sim_id": sim, "dimensions": [h, h, h], "position": [0, 0, h]}))
        .await["object_id"]
        .as_u64()
        .unwrap();
    c.call(
        "change_dynamics",
        json!({"sim_id": sim, "object_id": b, "lateral_friction": mu_box,
               "linear_damping": 0, "angular_damping": 0}),
    )
    .await;
    let info = c.call("get_dynamics_info", json!({"sim_id": sim, "object_id": b})).await;
    assert_eq!(info["lateral_friction"].as_f64().unwrap(), mu_box);
    c.step(&sim, 24).await; // settle
    let x0 = v3(&c.state(&sim, b).await["position"])[0];
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": b, "linear_velocity": [2, 0, 0]}))
        .await;
    c.step(&sim, 1200).await;
    let x1 = v3(&c.state(&sim, b).await["position"])[0];
    let mu = mu_box * 0.5; // ground keeps the default 0.5; Bullet's rule multiplies
    (x1 - x0, 2.0f64.powi(2) / (2.0 * mu * 9.81))
}

#[tokio::test(flavor = "multi_thread")]
async fn sliding_box_stops_where_coulomb_friction_says() {
    let (_d, _s, c) = setup().await;
    for mu in [0.2, 0.8] {
        let (d, theory) = slide_distance(&c, mu).await;
        assert!(rel(d, theory) < 0.05, "μ_box {mu}: slid {d} m, theory {theory} m");
    }
}
