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
