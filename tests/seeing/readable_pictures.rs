//! Pictures meant to be read (docs/tools.md "Pictures"): checked on the pixels the server
//! sends, decoded with the `png` and `gif` crates — never against stored screenshots.
//!
//! - the default camera frames what moves (or everything) and says which camera it used;
//! - the ground shows a 1 m checker; a box above the floor casts a shadow that moves with its
//!   height, away from the light;
//! - the key light follows the camera: a red box seen from any side shows red, not maroon;
//! - an animation where the movers move little (a rocked domino) frames the whole row; one
//!   where a mover moves far frames the mover;
//! - animations play at real time (speed scales it), never start blank, carry a time overlay
//!   that changes from frame to frame.

use crate::common;

use common::pictures::{image_of, png_rgb, Gif};
use common::{Client, Server};
use serde_json::{json, Value};

/// get_camera_image's RGB, segmentation and structured result.
async fn look(c: &Client, args: Value) -> (usize, usize, Vec<u8>, Vec<i64>, Value) {
    let mut args = args;
    args["include_segmentation"] = json!(true);
    let r = c.raw("get_camera_image", args.clone()).await;
    assert_ne!(r.is_error, Some(true), "get_camera_image {args}: {r:?}");
    let (w, h, rgb) = png_rgb(&image_of(&r, "image/png"));
    let s = r.structured_content.expect("structuredContent");
    let seg = s["segmentation"].as_array().unwrap().iter().map(|v| v.as_i64().unwrap()).collect();
    (w, h, rgb, seg, s)
}

/// Bounding box (x0, y0, x1, y1) of the pixels where `is` holds.
fn bbox(w: usize, n: usize, is: impl Fn(usize) -> bool) -> Option<(usize, usize, usize, usize)> {
    let mut b: Option<(usize, usize, usize, usize)> = None;
    for i in (0..n).filter(|i| is(*i)) {
        let (x, y) = (i % w, i / w);
        b = Some(b.map_or((x, y, x, y), |(a, c, d, e)| (a.min(x), c.min(y), d.max(x), e.max(y))));
    }
    b
}

fn luminance(px: &[u8]) -> f64 {
    0.299 * f64::from(px[0]) + 0.587 * f64::from(px[1]) + 0.114 * f64::from(px[2])
}

async fn top_down(c: &Client, height: f64) -> Value {
    c.call("compute_view_matrix", json!({"camera_eye_position": [0, 0, height], "camera_target_position": [0, 0, 0], "camera_up_vector": [0, 1, 0]}))
        .await["view_matrix"]
        .clone()
}

#[tokio::test(flavor = "multi_thread")]
async fn the_default_camera_frames_the_scene_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.call("load_urdf", json!({"sim_id": sim, "file_path": "plane.urdf"})).await;
    // A tower of five 0.2 m boxes away from the origin: 10 px high with the old far camera.
    let mut tower = Vec::new();
    for k in 0..5 {
        let r = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.1, 0.1, 0.1], "position": [2, 1, 0.1 + 0.2 * k as f64], "mass": 1})).await;
        tower.push(r["object_id"].as_i64().unwrap());
    }
    let (w, h, _, seg, s) = look(&c, json!({"sim_id": sim, "width": 320, "height": 240})).await;
    assert_eq!(s["camera"]["source"], "framed", "{}", s["camera"]);
    let (x0, y0, x1, y1) = bbox(w, seg.len(), |i| tower.contains(&seg[i])).expect("the tower is in the picture");
    assert!((x1 - x0 + 1) * 3 >= w || (y1 - y0 + 1) * 3 >= h, "the tower spans {}x{} of {w}x{h}", x1 - x0 + 1, y1 - y0 + 1);

    // set_camera then becomes the default.
    c.call("set_camera", json!({"sim_id": sim, "distance": 7, "yaw": 10, "pitch": -20, "target": [0, 0, 0]})).await;
    let (_, _, _, _, s) = look(&c, json!({"sim_id": sim, "width": 128, "height": 96})).await;
    assert_eq!(s["camera"], json!({"source": "set_camera", "distance": 7.0, "yaw": 10.0, "pitch": -20.0, "target": [0.0, 0.0, 0.0]}));
    // set_camera back to the initial camera means "frame it" again; undo goes back to 7 m.
    c.call("set_camera", json!({"sim_id": sim, "distance": 5, "yaw": 50, "pitch": -35, "target": [0, 0, 0]})).await;
    let (_, _, _, _, s) = look(&c, json!({"sim_id": sim, "width": 128, "height": 96})).await;
    assert_eq!(s["camera"]["source"], "framed");
    c.call("undo", json!({"sim_id": sim})).await;
    let (_, _, _, _, s) = look(&c, json!({"sim_id": sim, "width": 128, "height": 96})).await;
    assert_eq!(s["camera"]["source"], "set_camera");
    c.call("undo", json!({"sim_id": sim})).await;
    let (_, _, _, _, s) = look(&c, json!({"sim_id": sim, "width": 128, "height": 96})).await;
    assert_eq!(s["camera"]["source"], "framed");

    // An animation frames what moves (the falling box), not the still tower.
    let falling = c.call("add_sphere", json!({"sim_id": sim, "radius": 0.1, "position": [-1, -1, 1.5], "color": [1, 0, 0, 1]})).await["object_id"].as_i64().unwrap();
    c.step(&sim, 60).await;
    let r = c.raw("render_animation", json!({"sim_id": sim, "overlay": "none"})).await;
    let gif = Gif::decode(&image_of(&r, "image/gif"));
    let used = r.structured_content.unwrap()["camera"].clone();
    assert_eq!(used["source"], "framed");
    // Terms given: the rest framed; a result's camera passes back as it is.
    let r = c.raw("render_animation", json!({"sim_id": sim, "width": 64, "height": 48, "camera": {"yaw": 120}})).await;
    let given = r.structured_content.unwrap()["camera"].clone();
    assert_eq!((given["source"].as_str(), given["yaw"].as_f64(), &given["target"]), (Some("given"), Some(120.0), &used["target"]), "{given}");
    let r = c.raw("render_animation", json!({"sim_id": sim, "width": 64, "height": 48, "camera": given})).await;
    let again = r.structured_content.unwrap()["camera"].clone();
    assert_eq!((&again["distance"], &again["yaw"], &again["pitch"], &again["target"]), (&given["distance"], &given["yaw"], &given["pitch"], &given["target"]));
    let red = |px: &[u8]| px[0] > 120 && px[1] < 60 && px[2] < 60;
    let mut all: Option<(usize, usize, usize, usize)> = None;
    for k in 0..gif.frames.len() {
        let rgb = gif.rgb(k);
        if let Some((a, b, cc, d)) = bbox(gif.width, rgb.len() / 3, |i| red(&rgb[3 * i..3 * i + 3])) {
            all = Some(all.map_or((a, b, cc, d), |(e, f, g, hh)| (e.min(a), f.min(b), g.max(cc), hh.max(d))));
        }
    }
    let (x0, y0, x1, y1) = all.expect("the falling ball is in the frames");
    assert!((x1 - x0 + 1) * 3 >= gif.width || (y1 - y0 + 1) * 3 >= gif.height, "its path spans {}x{}", x1 - x0 + 1, y1 - y0 + 1);
    let _ = falling;
}

#[tokio::test(flavor = "multi_thread")]
async fn the_ground_has_a_checker_and_a_lifted_box_casts_a_moving_shadow() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({"gravity": [0, 0, 0]})).await;
    let ground = c.ground(&sim).await as i64;
    let view = top_down(&c, 8.0).await;
    let (w, h, rgb, seg, _) = look(&c, json!({"sim_id": sim, "width": 320, "height": 240, "view_matrix": view})).await;
    // A row across the floor alternates between two brightnesses: the 1 m squares.
    let row = h / 2;
    let lum: Vec<f64> = (0..w).map(|x| luminance(&rgb[3 * (row * w + x)..3 * (row * w + x) + 3])).collect();
    assert!((0..w).all(|x| seg[row * w + x] == ground));
    let (lo, hi) = (lum.iter().cloned().fold(f64::INFINITY, f64::min), lum.iter().cloned().fold(0.0, f64::max));
    assert!(hi - lo > 15.0, "two shades on the floor: {lo}..{hi}");
    let mid = (lo + hi) / 2.0;
    let flips = lum.windows(2).filter(|p| (p[0] > mid) != (p[1] > mid)).count();
    assert!(flips >= 4, "the shade changes at every metre across ~9 m: {flips} changes");

    // A box held above the floor (no gravity) casts a shadow; lifted higher, the shadow moves
    // further from it, away from the light (which comes from +x, +y, above).
    let plain = rgb;
    let b = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.3], "position": [0, 0, 0.6], "mass": 1})).await["object_id"].as_i64().unwrap();
    let mut centres = Vec::new();
    for z in [0.6, 1.6] {
        c.call("set_object_pose", json!({"sim_id": sim, "object_id": b, "position": [0, 0, z]})).await;
        let (_, _, rgb, seg, _) = look(&c, json!({"sim_id": sim, "width": 320, "height": 240, "view_matrix": view})).await;
        let shadow: Vec<usize> = (0..w * h).filter(|i| seg[*i] == ground && luminance(&rgb[3 * i..3 * i + 3]) < 0.8 * luminance(&plain[3 * i..3 * i + 3])).collect();
        assert!(shadow.len() > 50, "a shadow under the box at z = {z}: {} pixels", shadow.len());
        let n = shadow.len() as f64;
        centres.push((shadow.iter().map(|i| (i % w) as f64).sum::<f64>() / n, shadow.iter().map(|i| (i / w) as f64).sum::<f64>() / n));
    }
    let (low, high) = (centres[0], centres[1]);
    // Top-down with y up: −x is left, −y is down the picture.
    assert!(high.0 < low.0 - 5.0 && high.1 > low.1 + 5.0, "the shadow moves away from the light as the box rises: {low:?} → {high:?}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_domino_that_barely_rocks_does_not_crop_its_row_out() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let mut row = Vec::new();
    for k in 0..10 {
        let r = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.02, 0.1, 0.2], "position": [0.3 * f64::from(k), 0, 0.2], "mass": 0.1})).await;
        row.push(r["object_id"].as_i64().unwrap());
    }
    c.step(&sim, 5).await;
    let target_x = |v: &Value| v["camera"]["target"][0].as_f64().unwrap();
    // Rocked: a few centimetres against a row 2.7 m long.
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": row[0], "angular_velocity": [0, 0.6, 0]})).await;
    c.step(&sim, 30).await;
    let rocked = c.call("render_animation", json!({"sim_id": sim, "width": 64, "height": 48})).await;
    assert!((target_x(&rocked) - 1.35).abs() < 0.2, "the row's middle is looked at: {}", rocked["camera"]);
    // Thrown up 0.4 m: the picture is about it.
    c.call("set_object_velocity", json!({"sim_id": sim, "object_id": row[0], "linear_velocity": [0, 0, 3]})).await;
    c.step(&sim, 40).await;
    let thrown = c.call("render_animation", json!({"sim_id": sim, "width": 64, "height": 48})).await;
    assert!(target_x(&thrown).abs() < 0.2, "the thrown domino is looked at: {}", thrown["camera"]);
}

#[tokio::test(flavor = "multi_thread")]
async fn the_faces_a_camera_sees_are_lit_from_whichever_side_it_looks() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let b = c.call("add_box", json!({"sim_id": sim, "dimensions": [0.15, 0.15, 0.15], "position": [0, 0, 0.15], "color": [1, 0, 0]})).await["object_id"].as_i64().unwrap();
    for yaw in [0, 90, 180, 270] {
        c.call("set_camera", json!({"sim_id": sim, "distance": 1.2, "yaw": yaw, "pitch": -25, "target": [0, 0, 0.15]})).await;
        let (_, _, rgb, seg, _) = look(&c, json!({"sim_id": sim, "width": 128, "height": 96})).await;
        let mut red: Vec<u8> = (0..seg.len()).filter(|i| seg[*i] == b).map(|i| rgb[3 * i]).collect();
        assert!(red.len() > 400, "the box fills part of the picture from yaw {yaw}: {} pixels", red.len());
        red.sort_unstable();
        // Unlit, a red face is 0.35 × 255 ≈ 89 (maroon); lit squarely from the side, ≈ 168.
        let median = red[red.len() / 2];
        assert!(median >= 150, "the red box seen from yaw {yaw} is dark: median red {median}");
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn animations_play_at_real_time_start_with_something_and_show_the_time() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.2, 0.2, 0.2], "position": [0, 0, 2], "color": [0.9, 0.1, 0.1, 1]})).await;
    c.step(&sim, 480).await; // 2 s
    let history = c.call("get_history", json!({"sim_id": sim, "limit": 100})).await;
    let root = history["events"].as_array().unwrap().iter().map(|e| e["seq"].as_u64().unwrap()).min().unwrap();

    for (speed, expected) in [(1.0, 2.0), (2.0, 1.0), (0.5, 4.0)] {
        let r = c.raw("render_animation", json!({"sim_id": sim, "speed": speed, "width": 160, "height": 120})).await;
        let s = r.structured_content.clone().unwrap();
        let gif = Gif::decode(&image_of(&r, "image/gif"));
        let played: f64 = gif.delays.iter().map(|d| f64::from(*d) / 100.0).sum();
        assert!((played - expected).abs() <= 0.02 * expected, "speed {speed}: plays {played} s, expected {expected}: {s}");
        assert!(gif.delays.iter().all(|d| *d >= 2), "no delay under 20 ms: {:?}", gif.delays);
        assert_eq!(s["simulated_s"].as_f64(), Some(2.0), "{s}");
    }

    // The whole chain from create: the empty world is not shown, so the first frame has the
    // box; the overlay's corner changes as time passes.
    let r = c.raw("render_animation", json!({"sim_id": sim, "from_seq": root, "width": 320, "height": 240})).await;
    let gif = Gif::decode(&image_of(&r, "image/gif"));
    let red = |px: &[u8]| px[0] > 120 && px[1] < 60 && px[2] < 60;
    let first = gif.rgb(0);
    assert!(first.chunks(3).any(red), "the first frame shows the box");
    let corner = |rgb: &[u8]| -> Vec<u8> { (200..240).flat_map(|y| (0..200).flat_map(move |x| rgb[3 * (y * 320 + x)..3 * (y * 320 + x) + 3].to_vec())).collect() };
    let last = gif.rgb(gif.frames.len() - 1);
    assert_ne!(corner(&first), corner(&last), "the time overlay changes");
    let bare = c.raw("render_animation", json!({"sim_id": sim, "from_seq": root, "width": 320, "height": 240, "overlay": "none"})).await;
    let bare = Gif::decode(&image_of(&bare, "image/gif"));
    assert_ne!(corner(&bare.rgb(0)), corner(&first), "the overlay is drawn in that corner");
}
