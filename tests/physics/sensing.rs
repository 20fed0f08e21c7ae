//! Sensing and constraints over MCP/HTTP against the real server: rays against known geometry,
//! batches equal to single rays, contact forces that carry a resting box's weight, the four
//! constraint kinds holding what they should (and a revolute pendulum's period), camera
//! matrices equal to pybullet's, and a rendered image whose pixels say what is where.

use crate::common;

use std::path::Path;

use common::{v3, Client, Server};
use serde_json::{json, Value};

async fn start(dir: &Path, extra: &[&str]) -> (Server, Client) {
    let server = Server::start(dir, extra);
    let client = server.client().await;
    (server, client)
}

async fn add(c: &Client, tool: &str, args: Value) -> u64 {
    c.call(tool, args).await["object_id"].as_u64().unwrap()
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() <= tol)
}

/// Asserts a ray's hit: object, fraction, point and normal, each to 1e-4.
async fn expect_hit(c: &Client, sim: &str, from: [f64; 3], to: [f64; 3], object: i64, fraction: f64, normal: [f64; 3]) {
    let r = c.call("ray_test", json!({"sim_id": sim, "ray_from": from, "ray_to": to})).await;
    assert_eq!(r["hit"], json!(true), "{from:?} -> {to:?}: {r}");
    assert_eq!(r["object_id"].as_i64(), Some(object), "{r}");
    let f = r["hit_fraction"].as_f64().unwrap();
    assert!((f - fraction).abs() < 1e-4, "fraction {f} vs {fraction}: {r}");
    let point = [0, 1, 2].map(|k| from[k] + (to[k] - from[k]) * fraction);
    assert!(close(v3(&r["hit_position"]), point, 1e-4), "point vs {point:?}: {r}");
    assert!(close(v3(&r["hit_normal"]), normal, 1e-4), "normal vs {normal:?}: {r}");
}

#[tokio::test(flavor = "multi_thread")]
async fn rays_hit_known_geometry_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await as i64;
    let cube = add(&c, "add_box", json!({"sim_id": sim, "position": [0, 0, 1], "dimensions": [0.5, 0.5, 0.5], "mass": 0})).await as i64;
    let ball = add(&c, "add_sphere", json!({"sim_id": sim, "position": [3, 0, 1], "radius": 0.5, "mass": 0})).await as i64;
    let can = add(&c, "add_cylinder", json!({"sim_id": sim, "position": [0, 3, 1], "radius": 0.5, "height": 1.0, "mass": 0})).await as i64;
    let pill = add(&c, "add_capsule", json!({"sim_id": sim, "position": [-3, 0, 1], "radius": 0.25, "height": 1.0, "mass": 0})).await as i64;

    expect_hit(&c, &sim, [0.0, 0.0, 5.0], [0.0, 0.0, -5.0], cube, 0.35, [0.0, 0.0, 1.0]).await;
    expect_hit(&c, &sim, [-2.5, 0.2, 1.0], [2.5, 0.2, 1.0], cube, 0.4, [-1.0, 0.0, 0.0]).await;
    expect_hit(&c, &sim, [3.0, -5.0, 1.0], [3.0, 5.0, 1.0], ball, 0.45, [0.0, -1.0, 0.0]).await;
    // 45° onto the sphere: it enters at the point nearest along the ray.
    let s = std::f64::consts::FRAC_1_SQRT_2;
    expect_hit(&c, &sim, [4.0, 0.0, 2.0], [2.0, 0.0, 0.0], ball, (2f64.sqrt() - 0.5) / 8f64.sqrt(), [s, 0.0, s]).await;
    expect_hit(&c, &sim, [0.0, 3.0, 5.0], [0.0, 3.0, -5.0], can, 0.35, [0.0, 0.0, 1.0]).await;
    expect_hit(&c, &sim, [0.0, -2.0, 1.0], [0.0, 8.0, 1.0], cube, 0.15, [0.0, -1.0, 0.0]).await;
    expect_hit(&c, &sim, [5.0, 3.0, 1.2], [-5.0, 3.0, 1.2], can, 0.45, [1.0, 0.0, 0.0]).await;
    // The capsule's cap: top of the segment at z = 1.5, radius 0.25 → surface at z = 1.75.
    expect_hit(&c, &sim, [-3.0, 0.0, 5.0], [-3.0, 0.0, 1.0], pill, 0.8125, [0.0, 0.0, 1.0]).await;
    expect_hit(&c, &sim, [10.0, 10.0, 1.0], [10.0, 10.0, -1.0], ground, 0.5, [0.0, 0.0, 1.0]).await;
    // Starting inside the cube: the cube is not reported, the ground below is.
    expect_hit(&c, &sim, [0.0, 0.0, 1.0], [0.0, 0.0, -5.0], ground, 1.0 / 6.0, [0.0, 0.0, 1.0]).await;

    // Misses and zero-length rays: PyBullet's empty result.
    for (from, to) in [([10.0, 10.0, 1.0], [10.0, 10.0, 5.0]), ([0.0, 0.0, 3.0], [0.0, 0.0, 3.0])] {
        let r = c.call("ray_test", json!({"sim_id": sim, "ray_from": from, "ray_to": to})).await;
        assert_eq!(r["hit"], json!(false), "{r}");
        assert_eq!(r["object_id"], json!(-1));
        assert_eq!(r["hit_fraction"].as_f64(), Some(1.0));
    }

    // A pose set without stepping is seen at once.
    c.call("set_object_pose", json!({"sim_id": sim, "object_id": cube, "position": [0, 0, 2]})).await;
    expect_hit(&c, &sim, [0.0, 0.0, 5.0], [0.0, 0.0, -5.0], cube, 0.25, [0.0, 0.0, 1.0]).await;

    // Robots: the link hit is reported by its PyBullet index.
    server.copy_fixtures();
    let arm = add(&c, "load_urdf", json!({"sim_id": sim, "file_path": "two_link_arm.urdf", "position": [0, -3, 1], "use_fixed_base": true})).await;
    for (x, link, top) in [(0.0, -1, 1.05), (0.25, 0, 1.02), (0.7, 1, 1.015)] {
        let r = c.call("ray_test", json!({"sim_id": sim, "ray_from": [x, -3, 2], "ray_to": [x, -3, 0.5]})).await;
        assert_eq!(r["object_id"].as_u64(), Some(arm), "{r}");
        assert_eq!(r["link_index"].as_i64(), Some(link), "{r}");
        assert!((v3(&r["hit_position"])[2] - top).abs() < 1e-4, "{r}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn a_batch_equals_its_rays_one_by_one() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..60 {
        let (x, y, z) = ((i % 4) as f64 * 0.3, ((i / 4) % 4) as f64 * 0.3, 0.2 + (i / 16) as f64 * 0.3);
        let tool = ["add_box", "add_sphere", "add_cylinder", "add_capsule"][i % 4];
        let args = match tool {
            "add_box" => json!({"sim_id": sim, "position": [x, y, z], "dimensions": [0.1, 0.1, 0.1]}),
            "add_sphere" => json!({"sim_id": sim, "position": [x, y, z], "radius": 0.1}),
            _ => json!({"sim_id": sim, "position": [x, y, z], "radius": 0.08, "height": 0.1}),
        };
        add(&c, tool, args).await;
    }
    c.step(&sim, 240).await;
    // Deterministic pseudo-random rays from a ring above the pile down through it.
    let mut seed = 12345u64;
    let mut rnd = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut from, mut to) = (Vec::new(), Vec::new());
    for _ in 0..1000 {
        from.push([rnd() * 3.0 - 1.0, rnd() * 3.0 - 1.0, 1.5 + rnd()]);
        to.push([rnd() * 1.2 - 0.1, rnd() * 1.2 - 0.1, -0.2 + rnd() * 0.5]);
    }
    let batch = c.call("ray_test_batch", json!({"sim_id": sim, "rays_from": from, "rays_to": to})).await;
    let results = batch["results"].as_array().unwrap();
    assert_eq!(results.len(), 1000);
    let mut hits = 0;
    for (i, r) in results.iter().enumerate() {
        let one = c.call("ray_test", json!({"sim_id": sim, "ray_from": from[i], "ray_to": to[i]})).await;
        assert_eq!(&one, r, "ray {i}");
        hits += usize::from(r["hit"] == json!(true));
    }
    assert!(hits > 500 && hits < 1000, "most rays, not all, end in the pile or the ground: {hits}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_resting_box_is_carried_by_its_contact_forces() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.ground(&sim).await;
    let mass = 2.0;
    let cube = add(&c, "add_box", json!({"sim_id": sim, "position": [0, 0, 0.3], "dimensions": [0.2, 0.2, 0.2], "mass": mass})).await;
    let far = add(&c, "add_sphere", json!({"sim_id": sim, "position": [5, 5, 0.3], "radius": 0.1})).await;
    c.step(&sim, 480).await;

    let all = c.call("get_all_collisions", json!({"sim_id": sim})).await;
    let pair = |a: u64, b: u64| json!({"sim_id": sim, "obj_a": a, "obj_b": b});
    let box_on_ground = c.call("get_collisions_for_pair", pair(cube, ground)).await;
    let contacts = box_on_ground["contacts"].as_array().unwrap();
    assert!(contacts.len() >= 4, "{box_on_ground}");
    let total: f64 = contacts.iter().map(|k| k["normal_force"].as_f64().unwrap()).sum();
    assert!(((total - mass * 9.81) / (mass * 9.81)).abs() < 0.05, "sum of normal forces {total}");
    for k in contacts {
        assert_eq!(k["object_a"].as_u64(), Some(cube));
        assert_eq!(k["object_b"].as_u64(), Some(ground));
        assert!(close(v3(&k["contact_normal"]), [0.0, 0.0, 1.0], 1e-3), "normal from B (ground) to A (box): {k}");
        assert!(v3(&k["position_on_b"])[2].abs() < 2e-3, "B's point is on the ground's top: {k}");
        assert!(k["contact_distance"].as_f64().unwrap().abs() < 0.01, "{k}");
    }
    // Reversed pair: same points, A and B swapped, normal flipped.
    let reversed = c.call("get_collisions_for_pair", pair(ground, cube)).await;
    let reversed = reversed["contacts"].as_array().unwrap();
    assert_eq!(reversed.len(), contacts.len());
    for k in reversed {
        assert_eq!(k["object_a"].as_u64(), Some(ground));
        assert!(close(v3(&k["contact_normal"]), [0.0, 0.0, -1.0], 1e-3), "{k}");
    }
    // Filters: the resting sphere far away touches only the ground, never the box.
    let none = c.call("get_collisions_for_pair", pair(cube, far)).await;
    assert_eq!(none["contacts"].as_array().unwrap().len(), 0);
    let sphere_ground = c.call("get_collisions_for_pair", pair(far, ground)).await;
    assert!(!sphere_ground["contacts"].as_array().unwrap().is_empty());
    // get_all_collisions holds both pairs and nothing else.
    let all = all["contacts"].as_array().unwrap();
    assert_eq!(all.len(), contacts.len() + sphere_ground["contacts"].as_array().unwrap().len());
    for k in all {
        let ids = (k["object_a"].as_u64().unwrap(), k["object_b"].as_u64().unwrap());
        assert!(ids == (ground, cube) || ids == (ground, far), "{k}");
    }
    let err = c.try_call("get_collisions_for_pair", pair(cube, 99)).await.unwrap_err();
    assert!(err.contains("Object 99 not found"), "{err}");
}

/// Relative pose of `b` in `a`'s frame: (position, rotation angle of the relative rotation).
fn relative(a: &Value, b: &Value) -> ([f64; 3], [f64; 4]) {
    let q = |v: &Value| {
        let a = v.as_array().unwrap();
        [0, 1, 2, 3].map(|k| a[k].as_f64().unwrap())
    };
    let (pa, qa, pb, qb) = (v3(&a["position"]), q(&a["orientation"]), v3(&b["position"]), q(&b["orientation"]));
    let conj = [-qa[0], -qa[1], -qa[2], qa[3]];
    (rotate(conj, [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]]), mul(conj, qb))
}

fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
        a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
        a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
        a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
    ]
}

fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let p = mul(mul(q, [v[0], v[1], v[2], 0.0]), [-q[0], -q[1], -q[2], q[3]]);
    [p[0], p[1], p[2]]
}

fn angle_between(a: [f64; 4], b: [f64; 4]) -> f64 {
    let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]).abs().min(1.0);
    2.0 * d.acos()
}

#[tokio::test(flavor = "multi_thread")]
async fn constraints_hold_what_they_should() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let boxed = |p: [f64; 3]| json!({"sim_id": sim, "position": p, "dimensions": [0.1, 0.1, 0.1], "mass": 1});

    // Fixed: two boxes welded side by side fall, land and tumble as one.
    let a = add(&c, "add_box", boxed([0.0, 0.0, 1.0])).await;
    let b = add(&c, "add_box", boxed([0.3, 0.0, 1.0])).await;
    let fixed = c.call("create_constraint", json!({"sim_id": sim, "parent_id": a, "child_id": b, "joint_type": "fixed",
        "parent_frame_position": [0.15, 0, 0], "child_frame_position": [-0.15, 0, 0]})).await;
    assert_eq!(fixed["joint_type"], json!("fixed"));
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": a, "angular_velocity": [0, 3, 1]})).await;
    let before = relative(&c.state(&sim, a).await, &c.state(&sim, b).await);

    // Prismatic along x from a static rail: thrown sideways and up, the slider keeps y and z.
    let rail = add(&c, "add_box", json!({"sim_id": sim, "position": [0, 2, 1], "dimensions": [0.05, 0.05, 0.05], "mass": 0})).await;
    let slider = add(&c, "add_box", boxed([0.0, 2.0, 1.0])).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": rail, "child_id": slider, "joint_type": "prismatic", "joint_axis": [1, 0, 0]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": slider, "linear_velocity": [0.5, 2, 3]})).await;

    // Spherical to the world: a box hung by its top corner swings, the corner stays put.
    let bob = add(&c, "add_box", boxed([0.0, -2.0, 1.0])).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": bob, "child_id": -1, "joint_type": "spherical",
        "parent_frame_position": [0.1, 0.1, 0.1], "child_frame_position": [0.1, -1.9, 1.1]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": bob, "linear_velocity": [1, 0.5, 0]})).await;

    for _ in 0..4 {
        c.step(&sim, 250).await;
        let (sa, sb) = (c.state(&sim, a).await, c.state(&sim, b).await);
        let now = relative(&sa, &sb);
        assert!(close(now.0, before.0, 1e-3), "fixed: relative position {:?} vs {:?}", now.0, before.0);
        assert!(angle_between(now.1, before.1) < 1e-3, "fixed: relative rotation moved");
        let s = c.state(&sim, slider).await;
        let p = v3(&s["position"]);
        assert!((p[1] - 2.0).abs() < 1e-3 && (p[2] - 1.0).abs() < 1e-3, "prismatic left its axis: {p:?}");
        let st = c.state(&sim, bob).await;
        let q = st["orientation"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect::<Vec<_>>();
        let corner = rotate([q[0], q[1], q[2], q[3]], [0.1, 0.1, 0.1]);
        let pos = v3(&st["position"]);
        let anchor = [pos[0] + corner[0], pos[1] + corner[1], pos[2] + corner[2]];
        assert!(close(anchor, [0.1, -1.9, 1.1], 1e-3), "spherical anchor drifted: {anchor:?}");
    }
    let slid = v3(&c.state(&sim, slider).await["position"])[0];
    assert!(slid > 0.5, "the slider moved along x: {slid}");
    let bob_speed = v3(&c.state(&sim, bob).await["linear_velocity"]);
    assert!(bob_speed.iter().any(|v| v.abs() > 0.05), "the bob swings");

    // Removing an object takes its constraints with it; ids are not reused.
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["constraints"].as_array().unwrap().len(), 3);
    c.call("remove_object", json!({"sim_id": sim, "object_id": b})).await;
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let ids: Vec<u64> = info["constraints"].as_array().unwrap().iter().map(|k| k["constraint_id"].as_u64().unwrap()).collect();
    assert_eq!(ids, vec![1, 2]);
    let next = c.call("create_constraint", json!({"sim_id": sim, "parent_id": a, "child_id": -1, "joint_type": "fixed"})).await;
    assert_eq!(next["constraint_id"].as_u64(), Some(3));
}

/// The small-angle period of a revolute pendulum hung from the world, and the free fall of
/// its bob once the constraint is removed.
#[tokio::test(flavor = "multi_thread")]
async fn revolute_pendulum_swings_with_the_period_of_theory() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    let (l, r, theta0) = (1.0f64, 0.05f64, 0.1f64);
    let pivot = [0.0, 0.0, 2.0];
    // The bob, turned by θ0 about x, hangs from the pivot along its own +z axis.
    let (s, co) = (theta0.sin(), theta0.cos());
    let q = [(theta0 / 2.0).sin(), 0.0, 0.0, (theta0 / 2.0).cos()];
    let pos = [pivot[0], pivot[1] + l * s, pivot[2] - l * co];
    let bob = add(&c, "add_sphere", json!({"sim_id": sim, "position": pos, "orientation": q, "radius": r, "mass": 1})).await;
    c.call("change_dynamics", json!({"sim_id": sim, "object_id": bob, "linear_damping": 0, "angular_damping": 0})).await;
    let k = c.call("create_constraint", json!({"sim_id": sim, "parent_id": bob, "child_id": -1, "joint_type": "revolute",
        "joint_axis": [1, 0, 0], "parent_frame_position": [0, 0, l], "child_frame_position": pivot})).await;
    assert_eq!(k["joint_type"], json!("revolute"));

    // Time successive upward zero crossings of y.
    let dt = 1.0 / 240.0;
    let (mut prev, mut t, mut crossings) = (pos[1], 0.0, Vec::new());
    while crossings.len() < 4 && t < 12.0 {
        c.step(&sim, 1).await;
        t += dt;
        let p = v3(&c.state(&sim, bob).await["position"]);
        assert!(p[0].abs() < 1e-3, "the bob stays in the plane normal to the axis: {p:?}");
        let dist = ((p[1] - pivot[1]).powi(2) + (p[2] - pivot[2]).powi(2)).sqrt();
        assert!((dist - l).abs() < 1e-3, "rod length {dist}");
        if prev < 0.0 && p[1] >= 0.0 {
            crossings.push(t - dt * p[1] / (p[1] - prev));
        }
        prev = p[1];
    }
    assert_eq!(crossings.len(), 4, "the pendulum swings");
    let period = (crossings[3] - crossings[0]) / 3.0;
    let inertia = 0.4 * r * r + l * l;
    let theory = 2.0 * std::f64::consts::PI * (inertia / (9.81 * l)).sqrt();
    assert!(((period - theory) / theory).abs() < 0.02, "period {period} vs theory {theory}");

    // Without the constraint the bob falls freely: Δz = ½ g t² (damping 0).
    c.call("remove_constraint", json!({"sim_id": sim, "constraint_id": 0})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": bob, "linear_velocity": [0, 0, 0], "angular_velocity": [0, 0, 0]})).await;
    let z0 = v3(&c.state(&sim, bob).await["position"])[2];
    c.step(&sim, 120).await;
    let fall = z0 - v3(&c.state(&sim, bob).await["position"])[2];
    let theory = 0.5 * 9.81 * 0.5f64.powi(2);
    assert!(((fall - theory) / theory).abs() < 0.01, "fell {fall} vs {theory}");
}

#[tokio::test(flavor = "multi_thread")]
async fn constraints_are_state_undo_save_and_load_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    let a = add(&c, "add_box", json!({"sim_id": sim, "position": [0, 0, 1], "dimensions": [0.1, 0.1, 0.1]})).await;
    let b = add(&c, "add_sphere", json!({"sim_id": sim, "position": [0, 0, 0.5], "radius": 0.1})).await;
    let h0 = c.hash(&sim).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": a, "child_id": -1, "joint_type": "spherical", "child_frame_position": [0, 0, 1]})).await;
    let h1 = c.hash(&sim).await;
    assert_ne!(h0, h1, "a constraint is part of the state hash");
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": a, "child_id": b, "joint_type": "revolute", "joint_axis": [0, 1, 0],
        "parent_frame_position": [0, 0, -0.25], "child_frame_position": [0, 0, 0.25]})).await;
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": b, "linear_velocity": [1, 0, 0]})).await;
    c.step(&sim, 300).await;
    let h2 = c.hash(&sim).await;

    c.call("undo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.hash(&sim).await, h1);
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["constraints"].as_array().unwrap().len(), 1);
    c.call("redo", json!({"sim_id": sim, "count": 3})).await;
    assert_eq!(c.hash(&sim).await, h2);

    c.call("save_simulation", json!({"sim_id": sim, "file_path": "joined.json"})).await;
    let loaded = c.call("load_simulation", json!({"file_path": "joined.json"})).await;
    let copy = loaded["simulation_id"].as_str().unwrap().to_string();
    assert_eq!(loaded["state_hash"].as_str(), Some(h2.as_str()));
    c.step(&sim, 200).await;
    c.step(&copy, 200).await;
    assert_eq!(c.hash(&sim).await, c.hash(&copy).await, "the loaded copy evolves bit for bit like the original");

    let removed = c.call("remove_constraint", json!({"sim_id": sim, "constraint_id": 1})).await;
    assert!(removed["message"].as_str().unwrap().contains("removed"));
    assert_ne!(c.hash(&sim).await, c.hash(&copy).await);
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_sensing_and_constraint_inputs_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &["--max-rays", "10", "--max-image-px", "10000"]).await;
    let sim = c.new_sim(json!({})).await;
    let a = add(&c, "add_box", json!({"sim_id": sim, "position": [0, 0, 1], "dimensions": [0.1, 0.1, 0.1]})).await;
    c.call("create_constraint", json!({"sim_id": sim, "parent_id": a, "child_id": -1, "joint_type": "fixed"})).await;
    let hash = c.hash(&sim).await;
    let s = sim.as_str();
    let cases: Vec<(&str, Value, &str)> = vec![
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": a, "joint_type": "fixed"}), "parent itself"),
        ("create_constraint", json!({"sim_id": s, "parent_id": 7, "child_id": -1, "joint_type": "fixed"}), "Object 7 not found"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": 9, "joint_type": "fixed"}), "Object 9 not found"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": -2, "joint_type": "fixed"}), "child_id"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": -1, "joint_type": "weld"}), "joint_type"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": -1, "joint_type": "revolute", "joint_axis": [0, 0, 0]}), "joint_axis"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": -1, "joint_type": "fixed", "parent_frame_orientation": [0, 0, 0, 0]}), "parent_frame_orientation"),
        ("create_constraint", json!({"sim_id": s, "parent_id": a, "child_id": -1, "joint_type": "fixed", "child_frame_position": [1, 2]}), "child_frame_position"),
        ("remove_constraint", json!({"sim_id": s, "constraint_id": 5}), "Constraint 5 not found"),
        ("remove_constraint", json!({"sim_id": s, "constraint_id": -1}), "constraint_id"),
        ("ray_test", json!({"sim_id": s, "ray_from": [0, 0], "ray_to": [0, 0, 1]}), "ray_from"),
        ("ray_test", json!({"sim_id": s, "ray_from": [0, 0, "x"], "ray_to": [0, 0, 1]}), "ray_from"),
        ("ray_test_batch", json!({"sim_id": s, "rays_from": [[0, 0, 1], [0, 0, 2]], "rays_to": [[0, 0, 0]]}), "same length"),
        ("ray_test_batch", json!({"sim_id": s, "rays_from": [], "rays_to": []}), "at least one"),
        ("ray_test_batch", json!({"sim_id": s, "rays_from": vec![[0, 0, 1]; 11], "rays_to": vec![[0, 0, 0]; 11]}), "--max-rays"),
        ("ray_test_batch", json!({"sim_id": s, "rays_from": [[0, 0, 1]], "rays_to": [[0, 0, null]]}), "rays_to[0]"),
        ("get_collisions_for_pair", json!({"sim_id": s, "obj_a": a, "obj_b": 42}), "Object 42 not found"),
        ("compute_projection_matrix", json!({"fov": 0, "aspect": 1, "near_plane": 0.1, "far_plane": 10}), "fov"),
        ("compute_projection_matrix", json!({"fov": 180, "aspect": 1, "near_plane": 0.1, "far_plane": 10}), "fov"),
        ("compute_projection_matrix", json!({"fov": 60, "aspect": 0, "near_plane": 0.1, "far_plane": 10}), "aspect"),
        ("compute_projection_matrix", json!({"fov": 60, "aspect": 1, "near_plane": 0, "far_plane": 10}), "near_plane"),
        ("compute_projection_matrix", json!({"fov": 60, "aspect": 1, "near_plane": 1, "far_plane": 1}), "far_plane"),
        ("compute_view_matrix", json!({"camera_eye_position": [1, 1, 1], "camera_target_position": [1, 1, 1], "camera_up_vector": [0, 0, 1]}), "must differ"),
        ("compute_view_matrix", json!({"camera_eye_position": [0, 0, 1], "camera_target_position": [0, 0, 0], "camera_up_vector": [0, 0, 1]}), "parallel"),
        ("compute_view_matrix_from_yaw_pitch", json!({"distance": 1, "yaw": 0, "pitch": 0, "target_position": [0, 0, 0], "up_axis_index": 3}), "up_axis_index"),
        ("get_camera_image", json!({"sim_id": s, "width": 101, "height": 100}), "--max-image-px"),
        ("get_camera_image", json!({"sim_id": s, "width": 0, "height": 10}), "width"),
        ("get_camera_image", json!({"sim_id": s, "width": 10, "height": 10, "view_matrix": [1, 0, 0]}), "view_matrix"),
        ("get_camera_image", json!({"sim_id": s, "width": 10, "height": 10, "projection_matrix": "nope"}), "projection_matrix"),
    ];
    for (tool, args, needle) in cases {
        let err = c.try_call(tool, args.clone()).await.expect_err(&format!("{tool} {args} must be refused"));
        assert!(err.contains(needle), "{tool} {args}: {err:?} should mention {needle:?}");
        assert!(!err.contains('\n'), "one sentence: {err}");
    }
    assert_eq!(c.hash(&sim).await, hash, "refusals change nothing");
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    assert_eq!(info["constraints"].as_array().unwrap().len(), 1);
    assert_eq!(info["objects"].as_array().unwrap().len(), 1);
}

#[tokio::test(flavor = "multi_thread")]
async fn camera_matrices_equal_pybullets() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/camera_matrices.json")).unwrap();
    let fx: Value = serde_json::from_str(&text).unwrap();
    let same = |got: &Value, want: &Value, what: &str| {
        let (g, w) = (got.as_array().unwrap(), want.as_array().unwrap());
        assert_eq!(g.len(), 16);
        for k in 0..16 {
            let (a, b) = (g[k].as_f64().unwrap(), w[k].as_f64().unwrap());
            assert!((a - b).abs() <= 1e-5, "{what}: element {k}: {a} vs pybullet {b}");
        }
    };
    let mut n = 0;
    for v in fx["view"].as_array().unwrap() {
        let r = c.call("compute_view_matrix", json!({"camera_eye_position": v["eye"], "camera_target_position": v["target"], "camera_up_vector": v["up"]})).await;
        same(&r["view_matrix"], &v["matrix"], &format!("view {v}"));
        n += 1;
    }
    for v in fx["yaw_pitch"].as_array().unwrap() {
        let r = c.call("compute_view_matrix_from_yaw_pitch", json!({"distance": v["distance"], "yaw": v["yaw"], "pitch": v["pitch"],
            "target_position": v["target"], "up_axis_index": v["up_axis_index"]})).await;
        same(&r["view_matrix"], &v["matrix"], &format!("yaw/pitch {v}"));
        n += 1;
    }
    for v in fx["projection"].as_array().unwrap() {
        let r = c.call("compute_projection_matrix", json!({"fov": v["fov"], "aspect": v["aspect"], "near_plane": v["near"], "far_plane": v["far"]})).await;
        same(&r["projection_matrix"], &v["matrix"], &format!("projection {v}"));
        n += 1;
    }
    assert_eq!(n, 120);
}

#[tokio::test(flavor = "multi_thread")]
async fn camera_image_shows_a_red_box_on_a_gray_ground() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    let ground = c.call("add_box", json!({"sim_id": sim, "position": [0, 0, -0.5], "dimensions": [20, 20, 0.5], "mass": 0, "color": [0.5, 0.5, 0.5, 1]})).await["object_id"].as_i64().unwrap();
    let cube = c.call("add_box", json!({"sim_id": sim, "position": [0, 0, 0.25], "dimensions": [0.25, 0.25, 0.25], "mass": 0, "color": [1, 0, 0, 1]})).await["object_id"].as_i64().unwrap();
    // Looking at the box's top-face centre from 2 m straight above it (slightly tilted up-vector).
    let eye = [0.0, 0.0, 2.5];
    let view = c.call("compute_view_matrix", json!({"camera_eye_position": eye, "camera_target_position": [0, 0, 0.5], "camera_up_vector": [0, 1, 0]})).await["view_matrix"].clone();
    let proj = c.call("compute_projection_matrix", json!({"fov": 60, "aspect": 160.0 / 120.0, "near_plane": 0.1, "far_plane": 50})).await["projection_matrix"].clone();
    let (w, h) = (160usize, 120usize);
    let raw = c.raw("get_camera_image", json!({"sim_id": sim, "width": w, "height": h, "view_matrix": view, "projection_matrix": proj,
        "renderer": "ER_TINY_RENDERER", "include_depth": true, "include_segmentation": true})).await;
    assert_ne!(raw.is_error, Some(true));
    let image = raw.content.iter().find_map(|c| c.as_image()).expect("an image content");
    assert_eq!(image.mime_type, "image/png");
    use base64::Engine;
    let png_bytes = base64::engine::general_purpose::STANDARD.decode(&image.data).unwrap();
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let frame = reader.next_frame(&mut buf).unwrap();
    assert_eq!((frame.width as usize, frame.height as usize), (w, h));
    assert_eq!(frame.color_type, png::ColorType::Rgb);
    let px = |x: usize, y: usize| {
        let i = 3 * (y * w + x);
        [buf[i] as i32, buf[i + 1] as i32, buf[i + 2] as i32]
    };
    let center = px(w / 2, h / 2);
    assert!(center[0] > 120 && center[0] > 2 * center[1] && center[0] > 2 * center[2], "center pixel is red: {center:?}");
    let corner = px(0, 0);
    assert!((corner[0] - corner[1]).abs() < 8 && (corner[1] - corner[2]).abs() < 8, "corner is gray ground or white background: {corner:?}");

    let s = raw.structured_content.expect("structured");
    let seg = s["segmentation"].as_array().unwrap();
    let depth = s["depth"].as_array().unwrap();
    assert_eq!(seg.len(), w * h);
    assert_eq!(depth.len(), w * h);
    let at = |x: usize, y: usize| y * w + x;
    assert_eq!(seg[at(w / 2, h / 2)].as_i64(), Some(cube));
    assert!([ground, -1].contains(&seg[at(0, 0)].as_i64().unwrap()));
    let d = depth[at(w / 2, h / 2)].as_f64().unwrap();
    assert!((d - 2.0).abs() / 2.0 < 0.01, "depth at the center {d} vs 2.0 m to the box top");
    // A ground pixel: the view axis is vertical, so depth is the eye's height over z = 0.
    let dg = depth[at(2, 2)].as_f64().unwrap();
    assert!((dg - 2.5).abs() / 2.5 < 0.01, "ground depth {dg}");
    let visible = s["visible_objects"].as_array().unwrap();
    let pixels = |id: i64| visible.iter().find(|v| v["object_id"].as_i64() == Some(id)).map(|v| v["pixels"].as_u64().unwrap());
    // The box's top (0.5 m square at 2 m, fov 60° over 120 px) covers ≈ (0.5 / (2·2·tan 30°) · 120)² px.
    let side = 0.5 / (2.0 * 2.0 * (30f64).to_radians().tan()) * 120.0;
    let expect = side * side;
    let got = pixels(cube).unwrap() as f64;
    assert!((got - expect).abs() / expect < 0.1, "box covers {got} px vs {expect}");
    assert_eq!(pixels(ground).unwrap() + got as u64, (w * h) as u64);
    let range = s["depth_range"].as_array().unwrap();
    assert!((range[0].as_f64().unwrap() - 2.0).abs() < 0.02);

    // Without the flags the arrays stay out of the result.
    let small = c.call("get_camera_image", json!({"sim_id": sim, "width": 32, "height": 24})).await;
    assert!(small.get("depth").is_none() && small.get("segmentation").is_none(), "{small}");
    assert_eq!(small["width"].as_u64(), Some(32));

    // URDF meshes are drawn too: the mesh robot (STL and OBJ hulls) beside the box.
    server.copy_fixtures();
    let bot = c.call("load_urdf", json!({"sim_id": sim, "file_path": "mesh_bot/urdf/mesh_bot.urdf", "position": [0.8, 0, 0.3], "use_fixed_base": true})).await["object_id"].as_i64().unwrap();
    let seen = c.call("get_camera_image", json!({"sim_id": sim, "width": w, "height": h, "view_matrix": view, "projection_matrix": proj})).await;
    let bot_px = seen["visible_objects"].as_array().unwrap().iter().find(|v| v["object_id"].as_i64() == Some(bot)).map(|v| v["pixels"].as_u64().unwrap());
    assert!(bot_px.unwrap_or(0) > 50, "the mesh robot is drawn: {seen}");
}

/// set_camera and enable_debug_visualization are recorded state (hashed, undone); set_camera
/// is the camera get_camera_image uses when it is given no matrices.
#[tokio::test(flavor = "multi_thread")]
async fn set_camera_is_state_and_the_default_image_camera() {
    let dir = tempfile::tempdir().unwrap();
    let (_server, c) = start(dir.path(), &[]).await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    add(&c, "add_box", json!({"sim_id": sim, "position": [0.5, 0, 0.3], "dimensions": [0.3, 0.2, 0.3], "mass": 0, "color": [0, 0, 1, 1]})).await;
    let h0 = c.hash(&sim).await;
    let image = |extra: Value| {
        let mut args = json!({"sim_id": sim, "width": 64, "height": 48, "include_segmentation": true, "include_depth": true});
        args.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        args
    };
    let before = c.call("get_camera_image", image(json!({}))).await;

    c.call("set_camera", json!({"sim_id": sim, "distance": 3, "yaw": 30, "pitch": -40, "target": [0.2, 0, 0]})).await;
    let h1 = c.hash(&sim).await;
    assert_ne!(h0, h1, "the camera is part of the state hash");
    let default_view = c.call("get_camera_image", image(json!({}))).await;
    let view = c.call("compute_view_matrix_from_yaw_pitch", json!({"distance": 3, "yaw": 30, "pitch": -40, "target_position": [0.2, 0, 0]})).await["view_matrix"].clone();
    let proj = c.call("compute_projection_matrix", json!({"fov": 60, "aspect": 64.0 / 48.0, "near_plane": 0.01, "far_plane": 100})).await["projection_matrix"].clone();
    let explicit = c.call("get_camera_image", image(json!({"view_matrix": view, "projection_matrix": proj}))).await;
    assert_eq!(default_view["segmentation"], explicit["segmentation"]);
    assert_eq!(default_view["visible_objects"], explicit["visible_objects"]);
    assert_ne!(before["segmentation"], default_view["segmentation"], "the camera moved");

    c.call("enable_debug_visualization", json!({"sim_id": sim, "show_frames": true})).await;
    let h2 = c.hash(&sim).await;
    assert_ne!(h1, h2);
    for (tool, args, needle) in [
        ("set_camera", json!({"sim_id": sim, "distance": 0, "yaw": 0, "pitch": 0, "target": [0, 0, 0]}), "distance"),
        ("set_camera", json!({"sim_id": sim, "distance": 2, "yaw": "north", "pitch": 0, "target": [0, 0, 0]}), "yaw"),
        ("set_camera", json!({"sim_id": sim, "distance": 2, "yaw": 0, "pitch": 0, "target": [0, 0]}), "target"),
        ("enable_debug_visualization", json!({"sim_id": sim, "show_frames": "yes"}), "show_frames"),
    ] {
        let err = c.try_call(tool, args).await.unwrap_err();
        assert!(err.contains(needle), "{err}");
    }
    assert_eq!(c.hash(&sim).await, h2, "refusals change nothing");
    c.call("undo", json!({"sim_id": sim, "count": 2})).await;
    assert_eq!(c.hash(&sim).await, h0);
    let again = c.call("get_camera_image", image(json!({}))).await;
    assert_eq!(again["segmentation"], before["segmentation"], "undo restored the camera");
}

/// A file in the old server's format (no history) re-creates its constraints, with the file's
/// object ids mapped to the re-created objects', and they hold; a constraint naming an object
/// the file does not have is refused and nothing is created.
#[tokio::test(flavor = "multi_thread")]
async fn old_server_files_recreate_their_constraints() {
    let dir = tempfile::tempdir().unwrap();
    let (server, c) = start(dir.path(), &[]).await;
    let file = json!({
        "gravity": [0, 0, -9.81],
        "objects": [
            {"object_id": 7, "type": "primitive", "shape": "box", "dimensions": [0.1, 0.1, 0.1], "mass": 1, "position": [0, 0, 1]},
            {"object_id": 9, "type": "primitive", "shape": "sphere", "dimensions": [0.1], "mass": 1, "position": [0.6, 0, 1]}
        ],
        "constraints": [
            {"parent_id": 7, "child_id": -1, "joint_type": "fixed", "child_frame_position": [0, 0, 1]},
            {"parent_id": 9, "child_id": 7, "joint_type": "point2point", "parent_frame_position": [-0.3, 0, 0], "child_frame_position": [0.3, 0, 0]}
        ]
    });
    std::fs::write(server.workspace.join("old.json"), file.to_string()).unwrap();
    let loaded = c.call("load_simulation", json!({"file_path": "old.json"})).await;
    let sim = loaded["simulation_id"].as_str().unwrap().to_string();
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let kinds: Vec<(u64, i64, String)> = info["constraints"].as_array().unwrap().iter()
        .map(|k| (k["parent_id"].as_u64().unwrap(), k["child_id"].as_i64().unwrap(), k["joint_type"].as_str().unwrap().to_string()))
        .collect();
    assert_eq!(kinds, vec![(0, -1, "fixed".to_string()), (1, 0, "spherical".to_string())]);
    c.step(&sim, 480).await;
    let cube = v3(&c.state(&sim, 0).await["position"]);
    assert!(close(cube, [0.0, 0.0, 1.0], 1e-3), "the box stays fixed to the world: {cube:?}");
    // The spherical joint keeps the ball's anchor on the box's while the ball swings down.
    let quat = |st: &Value| {
        let q = st["orientation"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect::<Vec<_>>();
        [q[0], q[1], q[2], q[3]]
    };
    let (box_state, ball_state) = (c.state(&sim, 0).await, c.state(&sim, 1).await);
    let ball = v3(&ball_state["position"]);
    let on_ball = rotate(quat(&ball_state), [-0.3, 0.0, 0.0]);
    let on_box = rotate(quat(&box_state), [0.3, 0.0, 0.0]);
    let gap = (0..3).map(|k| (ball[k] + on_ball[k] - cube[k] - on_box[k]).powi(2)).sum::<f64>().sqrt();
    assert!(gap < 1e-3, "spherical anchors {gap} m apart");
    let moved = ((ball[0] - 0.6).powi(2) + (ball[2] - 1.0).powi(2)).sqrt();
    assert!(moved > 0.1, "the ball swings about its anchor under gravity: {ball:?}");

    let mut bad = file.clone();
    bad["constraints"][0]["parent_id"] = json!(42);
    std::fs::write(server.workspace.join("bad.json"), bad.to_string()).unwrap();
    let before = c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len();
    let err = c.try_call("load_simulation", json!({"file_path": "bad.json"})).await.unwrap_err();
    assert!(err.contains("constraints[0].parent_id"), "{err}");
    assert_eq!(c.call("list_simulations", json!({})).await["simulations"].as_array().unwrap().len(), before);
}

/// A box dropped flat slides ~16 mm while it settles; rapier keeps the ground-side contact
/// anchors of the landing while bodies creep. Reported contacts are where the shapes touch now:
/// the two points of each contact agree (on A = on B + normal·distance) and sit under the
/// box's corners where it rests.
#[tokio::test(flavor = "multi_thread")]
async fn contact_points_follow_a_box_that_slid_after_landing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [5, 5, 0.1], "position": [0, 0, -0.1], "mass": 0})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 0.5]})).await;
    c.step(&sim, 240).await;
    let at = common::v3(&c.state(&sim, 1).await["position"]);
    let contacts = c.call("get_all_collisions", json!({"sim_id": sim})).await["contacts"].as_array().unwrap().clone();
    assert_eq!(contacts.len(), 4);
    for k in contacts {
        let (a, b, n) = (common::v3(&k["position_on_a"]), common::v3(&k["position_on_b"]), common::v3(&k["contact_normal"]));
        let d = k["contact_distance"].as_f64().unwrap();
        for i in 0..3 {
            assert!((a[i] - (b[i] + n[i] * d)).abs() < 1e-4, "on A {a:?} is not on B {b:?} + n·d: {k}");
        }
        for i in 0..2 {
            assert!(((b[i] - at[i]).abs() - 0.2).abs() < 1e-3, "contact {b:?} is not under a corner of the box at {at:?}");
        }
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn every_depth_value_is_the_f32_it_is_background_included() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 0.5]})).await;
    let s = c.call("get_camera_image", json!({"sim_id": sim, "width": 32, "height": 24, "include_depth": true, "include_segmentation": true})).await;
    let (depth, seg) = (s["depth"].as_array().unwrap(), s["segmentation"].as_array().unwrap());
    assert!(seg.iter().any(|v| v.as_i64() == Some(-1)), "some sky in the picture");
    for (d, id) in depth.iter().zip(seg) {
        let d = d.as_f64().unwrap();
        assert_eq!(format!("{}", d as f32).parse::<f64>().unwrap(), d, "{d} is an f32 in its shortest form");
        if id.as_i64() == Some(-1) {
            assert_eq!(d, 100.0, "the background is the far plane, 100 m");
        }
    }
}
