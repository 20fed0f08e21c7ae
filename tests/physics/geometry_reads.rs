//! get_aabb and get_overlapping_objects over MCP/HTTP against pybullet 3.2.7's getAABB and
//! getOverlappingObjects for primitives (values pybullet printed for the same box and sphere:
//! a box of half extents (0.5, 0.2, 0.1) at (1, 2, 3) → (0.5, 1.8, 2.9)–(1.5, 2.2, 3.1); a
//! sphere of radius 0.3 at (0, 0, 1) → (−0.3, −0.3, 0.7)–(0.3, 0.3, 1.3); the box
//! (0.5, 1.5, 2.5)–(1, 2, 3) overlaps the box only), and a robot's links.

use crate::common;

use common::Server;
use serde_json::json;

#[tokio::test(flavor = "multi_thread")]
async fn boxes_and_overlaps_are_pybullets() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let cube = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.5, 0.2, 0.1], "position": [1, 2, 3], "mass": 1})).await["object_id"].clone();
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.3, "position": [0, 0, 1], "mass": 1})).await["object_id"].clone();
    let close = |got: &serde_json::Value, want: [f64; 3]| {
        let got: Vec<f64> = got.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-6)
    };
    let b = c.call("get_aabb", json!({"sim_id": sim, "object_id": cube})).await;
    assert!(close(&b["aabb_min"], [0.5, 1.8, 2.9]) && close(&b["aabb_max"], [1.5, 2.2, 3.1]), "{b}");
    let s = c.call("get_aabb", json!({"sim_id": sim, "object_id": ball})).await;
    assert!(close(&s["aabb_min"], [-0.3, -0.3, 0.7]) && close(&s["aabb_max"], [0.3, 0.3, 1.3]), "{s}");
    let o = c.call("get_overlapping_objects", json!({"sim_id": sim, "aabb_min": [0.5, 1.5, 2.5], "aabb_max": [1, 2, 3]})).await;
    assert_eq!(o["objects"], json!([{"object_id": cube, "link_index": -1}]));
    // A robot: each link's box, and a box around the whole arm finds every link with a shape.
    let arm = c.call("load_urdf", json!({"sim_id": sim, "file_path": "kuka_iiwa/model.urdf", "position": [5, 0, 0], "use_fixed_base": true})).await["object_id"].clone();
    let link = c.call("get_aabb", json!({"sim_id": sim, "object_id": arm, "link_index": 6})).await;
    assert!(link["aabb_min"][2].as_f64().unwrap() > 1.0, "the last link is over 1 m up: {link}");
    let all = c.call("get_overlapping_objects", json!({"sim_id": sim, "aabb_min": [4, -1, -0.1], "aabb_max": [6, 1, 2]})).await;
    assert_eq!(all["objects"].as_array().unwrap().len(), 8, "base and 7 links: {all}");
    let bad = c.try_call("get_overlapping_objects", json!({"sim_id": sim, "aabb_min": [1, 0, 0], "aabb_max": [0, 1, 1]})).await;
    assert!(bad.expect_err("an inverted box is refused").contains("aabb_min"));
    let bad = c.try_call("get_aabb", json!({"sim_id": sim, "object_id": arm, "link_index": 40})).await;
    assert!(bad.expect_err("link 40 is refused").contains("40"));
}

fn closest_reference() -> serde_json::Value {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference/pybullet_closest_points.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Adds one primitive of the reference (massless: nothing moves).
async fn add_shape(c: &common::Client, sim: &str, s: &serde_json::Value) -> serde_json::Value {
    let mut args = json!({"sim_id": sim, "position": s["position"], "orientation": s["orientation"], "mass": 0});
    let tool = match s["kind"].as_str().unwrap() {
        "box" => {
            args["dimensions"] = s["half_extents"].clone();
            "add_box"
        }
        "sphere" => {
            args["radius"] = s["radius"].clone();
            "add_sphere"
        }
        _ => {
            args["radius"] = s["radius"].clone();
            args["height"] = s["height"].clone();
            "add_capsule"
        }
    };
    c.call(tool, args).await["object_id"].clone()
}

/// The smallest contact_distance of a get_closest_points result, with its point.
fn nearest(r: &serde_json::Value) -> Option<serde_json::Value> {
    let d = |p: &serde_json::Value| p["contact_distance"].as_f64().unwrap();
    r["points"].as_array().unwrap().iter().min_by(|a, b| d(a).total_cmp(&d(b))).cloned()
}

/// get_closest_points against pybullet 3.2.7's getClosestPoints and the exact geometry
/// (tests/reference/pybullet_closest_points.json, scripts/closest_points_fixtures.py): for 27
/// random pairs of boxes, spheres and capsules, apart and overlapping, the distance within
/// 1e-4 m of the exact one (where the script computes it) and of PyBullet's — within 1e-3 m of
/// PyBullet's for a pair with a box, whose GJK answers are themselves up to 0.85 mm from the
/// exact distance; the points are the distance apart along the normal; for each link of a bent
/// KUKA iiwa and a sphere beside it, the distance is PyBullet's plus its 1 mm collision margin
/// on mesh hulls, within 0.2 mm; bad links and distances are refused.
#[tokio::test(flavor = "multi_thread")]
async fn closest_points_are_pybullets() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let r = closest_reference();
    let range = r["distance"].clone();
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let v = |p: &serde_json::Value| -> [f64; 3] { common::v3(p) };
    for (k, case) in r["primitives"].as_array().unwrap().iter().enumerate() {
        let (a, b) = (add_shape(&c, &sim, &case["a"]).await, add_shape(&c, &sim, &case["b"]).await);
        let got = c.call("get_closest_points", json!({"sim_id": sim, "body_a": a, "body_b": b, "distance": range})).await;
        let at = format!("case {k} ({} vs {})", case["a"]["kind"], case["b"]["kind"]);
        let near = nearest(&got).unwrap_or_else(|| panic!("{at}: no points: {got}"));
        let d = near["contact_distance"].as_f64().unwrap();
        if let Some(exact) = case["exact"].as_f64() {
            assert!((d - exact).abs() < 1e-4, "{at}: {d} vs exact {exact}");
        }
        let boxed = case["a"]["kind"] == "box" || case["b"]["kind"] == "box";
        let want = case["contact_distance"].as_f64().expect("every reference pair is within range");
        assert!((d - want).abs() < if boxed { 1e-3 } else { 1e-4 }, "{at}: {d} vs pybullet {want}");
        let (pa, pb, n) = (v(&near["position_on_a"]), v(&near["position_on_b"]), v(&near["contact_normal_on_b"]));
        assert!((n.iter().map(|x| x * x).sum::<f64>().sqrt() - 1.0).abs() < 1e-5, "{at}: normal {n:?}");
        assert!((0..3).all(|i| (pa[i] - pb[i] - d * n[i]).abs() < 1e-4), "{at}: A's point is B's plus the distance along the normal: {near}");
        let short = c.call("get_closest_points", json!({"sim_id": sim, "body_a": a, "body_b": b, "distance": (d - 0.01).max(0.0)})).await;
        assert_eq!(short["points"].as_array().unwrap().is_empty(), d > 0.01, "{at}: a pair farther than distance is left out");
        for id in [a, b] {
            c.call("remove_object", json!({"sim_id": sim, "object_id": id})).await;
        }
    }
    let robot = &r["robot"];
    let arm = c.call("load_urdf", json!({"sim_id": sim, "file_path": robot["robot"], "use_fixed_base": true})).await["object_id"].clone();
    for (j, q) in robot["positions"].as_array().unwrap().iter().enumerate() {
        c.call("reset_joint_state", json!({"sim_id": sim, "object_id": arm, "joint_index": j, "target_value": q})).await;
    }
    let ball = c.call("add_sphere", json!({"sim_id": sim, "radius": robot["sphere"]["radius"], "position": robot["sphere"]["position"], "mass": 0})).await["object_id"].clone();
    for link in robot["links"].as_array().unwrap() {
        let l = &link["link_index"];
        let got = c.call("get_closest_points", json!({"sim_id": sim, "body_a": arm, "body_b": ball, "distance": range, "link_index_a": l})).await;
        let want = link["contact_distance"].as_f64().unwrap();
        let d = nearest(&got).expect("every link is within range")["contact_distance"].as_f64().unwrap();
        assert!((d - want - 1e-3).abs() < 2e-4, "link {l}: {d} vs pybullet {want} (+ its 1 mm margin)");
        assert!(got["points"].as_array().unwrap().iter().all(|p| &p["link_index_a"] == l && p["link_index_b"] == json!(-1)));
    }
    let all = c.call("get_closest_points", json!({"sim_id": sim, "body_a": arm, "body_b": ball, "distance": range})).await;
    assert_eq!(all["points"].as_array().unwrap().len(), robot["links"].as_array().unwrap().len(), "one point per link with a shape: {all}");
    let bad = c.try_call("get_closest_points", json!({"sim_id": sim, "body_a": arm, "body_b": ball, "distance": 1, "link_index_a": 40})).await;
    assert!(bad.expect_err("link 40 is refused").contains("link_index_a"));
    let bad = c.try_call("get_closest_points", json!({"sim_id": sim, "body_a": arm, "body_b": ball, "distance": -1})).await;
    assert!(bad.expect_err("a negative distance is refused").contains("distance"));
}
