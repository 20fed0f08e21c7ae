//! render_animation: a looping GIF of any past interval, re-simulated
//! from the log. Its frames are checked against an independent path to the same states —
//! get_camera_image on the live simulation and on `fork_simulation(at_seq)` — decoded with the
//! `png` and `gif` crates, and against physics (a falling box moves down the picture).

use crate::common;

use common::pictures::{image_of, mean_row, png_rgb, Gif};
use common::{Client, Server};
use serde_json::{json, Value};

async fn head(c: &Client, sim: &str) -> u64 {
    c.call("get_simulation_info", json!({"sim_id": sim})).await["head_seq"].as_u64().unwrap()
}

/// render_animation's GIF and summary.
async fn animation(c: &Client, args: Value) -> (Gif, Value) {
    let r = c.raw("render_animation", args.clone()).await;
    assert_ne!(r.is_error, Some(true), "render_animation {args} refused: {r:?}");
    let gif = Gif::decode(&image_of(&r, "image/gif"));
    (gif, r.structured_content.expect("structuredContent"))
}

/// get_camera_image's RGB on `sim` at its head.
async fn camera(c: &Client, sim: &str, w: u32, h: u32, view: &Value) -> Vec<u8> {
    let mut args = json!({"sim_id": sim, "width": w, "height": h});
    if !view.is_null() {
        args["view_matrix"] = view.clone();
    }
    let r = c.raw("get_camera_image", args).await;
    assert_ne!(r.is_error, Some(true), "{r:?}");
    png_rgb(&image_of(&r, "image/png")).2
}

async fn side_view(c: &Client) -> Value {
    c.call(
        "compute_view_matrix",
        json!({"camera_eye_position": [5, -1, 1.5], "camera_target_position": [0, 0, 1.2], "camera_up_vector": [0, 0, 1]}),
    )
    .await["view_matrix"]
        .clone()
}

/// The interval's ends rendered by get_camera_image — the end on the simulation itself, the
/// start on a fork at `from_seq` — equal the GIF's first and last frames index for index,
/// after mapping each PNG pixel to its nearest palette entry (returns the mean per-channel
/// error of the GIF's colours against the PNGs', over both ends).
async fn ends_match(c: &Client, sim: &str, gif: &Gif, summary: &Value, view: &Value, exact: bool) -> f64 {
    let (w, h) = (gif.width as u32, gif.height as u32);
    let fork = c.call("fork_simulation", json!({"sim_id": sim, "at_seq": summary["from_seq"]})).await;
    let first = camera(c, fork["simulation_id"].as_str().unwrap(), w, h, view).await;
    let last = camera(c, sim, w, h, view).await;
    let mut error = 0.0;
    for (k, png) in [(0, &first), (gif.frames.len() - 1, &last)] {
        let frame = &gif.frames[k];
        if exact {
            let mapped: Vec<u8> = png.chunks(3).map(|px| gif.nearest(px)).collect();
            let differ = mapped.iter().zip(frame).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "frame {k}: {differ} pixels differ from get_camera_image's");
        }
        let rgb = gif.rgb(k);
        let sum: u64 = rgb.iter().zip(png.iter()).map(|(a, b)| u64::from(a.abs_diff(*b))).sum();
        error += sum as f64 / rgb.len() as f64 / 2.0;
    }
    error
}

#[tokio::test(flavor = "multi_thread")]
async fn a_few_objects_animate_exactly_and_the_gif_keeps_its_promises() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.4, 0.4, 0.4], "position": [0, 0, 1], "color": [0.9, 0.1, 0.1, 1], "orientation": [0.2, 0.1, 0, 1]})).await;
    c.call("add_sphere", json!({"sim_id": sim, "radius": 0.2, "position": [0.3, 0.5, 2], "color": [0.1, 0.3, 0.9, 1]})).await;
    c.call("add_cylinder", json!({"sim_id": sim, "radius": 0.15, "height": 0.5, "position": [-0.4, -0.3, 1.5], "color": [0.2, 0.8, 0.2, 1]})).await;
    c.step(&sim, 30).await;
    let from = head(&c, &sim).await;
    c.step(&sim, 50).await;
    c.call("apply_force", json!({"sim_id": sim, "object_id": 1, "force": [0, 300, 0]})).await;
    c.step(&sim, 47).await;
    let hash = c.hash(&sim).await;
    let view = side_view(&c).await;

    // fps 50: samples 10 steps (41.7 ms) apart are all shown; no overlay, to compare pixels.
    let asked = json!({"sim_id": sim, "from_seq": from, "every": 10, "width": 160, "height": 120, "fps": 50, "overlay": "none", "view_matrix": view});
    let (gif, s) = animation(&c, asked.clone()).await;
    // 97 steps every 10: the start, 9 samples, and the end (a remainder of 7 steps).
    assert_eq!(s["frames"], 11, "{s}");
    assert_eq!(gif.frames.len(), 11);
    assert_eq!((gif.width, gif.height), (160, 120));
    assert_eq!((s["width"].as_u64(), s["height"].as_u64()), (Some(160), Some(120)));
    assert_eq!(s["from_seq"], from);
    assert_eq!(s["to_seq"], head(&c, &sim).await);
    assert_eq!(s["bytes"].as_u64().unwrap() as usize, image_of(&c.raw("render_animation", asked).await, "image/gif").len());
    assert!(gif.loops, "the GIF loops");
    // Real time: the delays add up to the 97 steps' 0.404 s (within a hundredth), none under 20 ms.
    let played: f64 = gif.delays.iter().map(|d| f64::from(*d) / 100.0).sum();
    assert!((played - 97.0 / 240.0).abs() <= 0.01, "{:?}", gif.delays);
    assert!(gif.delays.iter().all(|d| *d >= 2), "{:?}", gif.delays);
    assert!((s["duration_s"].as_f64().unwrap() - played).abs() < 1e-9, "{s}");
    assert!((s["simulated_s"].as_f64().unwrap() - 97.0 / 240.0).abs() < 1e-9, "{s}");
    assert_eq!(s["camera"]["source"], "view_matrix");
    let error = ends_match(&c, &sim, &gif, &s, &view, true).await;
    assert!(error < 1.0, "mean error {error}");

    // The default interval is what the last step did; the default camera is set_camera's.
    c.call("set_camera", json!({"sim_id": sim, "distance": 4, "yaw": 30, "pitch": -20, "target": [0, 0, 0.5]})).await;
    c.step(&sim, 12).await;
    let r = c.raw("render_animation", json!({"sim_id": sim, "width": 96, "height": 72, "overlay": "none"})).await;
    let s2 = r.structured_content.clone().unwrap();
    let gif2 = Gif::decode(&image_of(&r, "image/gif"));
    // 13 samples 4 ms apart: at 30 frames a second the first and the last are shown.
    assert_eq!((s2["every"].as_u64(), s2["frames"].as_u64(), s2["steps"].as_u64()), (Some(1), Some(2), Some(12)), "{s2}");
    assert_eq!(s2["camera"]["source"], "set_camera", "{s2}");
    ends_match(&c, &sim, &gif2, &s2, &Value::Null, true).await;

    // Looking changed nothing.
    assert_ne!(c.hash(&sim).await, hash); // (the step above did)
    let before = c.hash(&sim).await;
    animation(&c, json!({"sim_id": sim, "from_seq": from, "every": 25, "width": 64, "height": 48})).await;
    assert_eq!(c.hash(&sim).await, before);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_falling_box_moves_down_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    c.call("add_box", json!({"sim_id": sim, "dimensions": [0.3, 0.3, 0.3], "position": [0, 0, 2.4], "color": [1, 0, 0, 1]})).await;
    c.step(&sim, 120).await; // 0.5 s: falls 1.2 m, still in the air
    let view = side_view(&c).await;
    let (gif, s) = animation(&c, json!({"sim_id": sim, "every": 20, "width": 160, "height": 120, "view_matrix": view})).await;
    assert_eq!(s["frames"], 7, "{s}");
    let red = |px: &[u8]| px[0] > 60 && px[1] < 40 && px[2] < 40;
    let rows: Vec<f64> = (0..gif.frames.len()).map(|k| mean_row(&gif.rgb(k), gif.width, red).expect("the box is in the picture")).collect();
    assert!(rows.windows(2).all(|w| w[1] > w[0]), "the box's rows go down: {rows:?}");
    // and faster and faster (it accelerates)
    let steps: Vec<f64> = rows.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(steps.last() > steps.first(), "{steps:?}");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_hundred_objects_stay_within_two_levels_and_files_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    for i in 0..100 {
        let (x, y, z) = ((i % 5) as f64 * 0.5 - 1.0, (i / 5 % 5) as f64 * 0.5 - 1.0, 0.5 + (i / 25) as f64 * 0.6);
        let color = [(i * 37 % 100) as f64 / 100.0, (i * 61 % 100) as f64 / 100.0, (i * 13 % 100) as f64 / 100.0, 1.0];
        let tool = if i % 2 == 0 { "add_box" } else { "add_sphere" };
        let shape = if i % 2 == 0 { json!({"dimensions": [0.3, 0.3, 0.3]}) } else { json!({"radius": 0.15}) };
        let mut args = json!({"sim_id": sim, "position": [x, y, z], "color": color, "orientation": [0.1 * (i % 3) as f64, 0.05, 0, 1]});
        args.as_object_mut().unwrap().extend(shape.as_object().unwrap().clone());
        c.call(tool, args).await;
    }
    let from = head(&c, &sim).await;
    c.step(&sim, 80).await;
    let view = c
        .call("compute_view_matrix", json!({"camera_eye_position": [4, -4, 3], "camera_target_position": [0, 0, 0.8], "camera_up_vector": [0, 0, 1]}))
        .await["view_matrix"]
        .clone();
    let (gif, s) = animation(&c, json!({"sim_id": sim, "from_seq": from, "every": 16, "width": 200, "height": 150, "overlay": "none", "view_matrix": view})).await;
    assert_eq!(gif.frames.len(), 6);
    let error = ends_match(&c, &sim, &gif, &s, &view, false).await;
    assert!(error <= 2.0, "mean error {error} levels of 255 (at most 2)");

    // To a file: the same GIF, linked, not inline.
    let r = c.raw("render_animation", json!({"sim_id": sim, "from_seq": from, "every": 16, "width": 200, "height": 150, "overlay": "none", "view_matrix": view, "output_path": "out/pile.gif"})).await;
    assert_ne!(r.is_error, Some(true), "{r:?}");
    assert!(r.content.iter().all(|c| c.as_image().is_none()), "no inline image with output_path");
    let written = std::fs::read(server.workspace.join("out/pile.gif")).unwrap();
    let file = Gif::decode(&written);
    assert_eq!(file.frames, gif.frames);
    assert_eq!(r.structured_content.unwrap()["output_path"], "out/pile.gif");
}

#[tokio::test(flavor = "multi_thread")]
async fn bad_requests_are_refused_with_one_sentence_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &["--max-image-px", "20000"]);
    let c = server.client().await;
    let sim = c.new_sim(json!({})).await;
    c.ground(&sim).await;
    let add = head(&c, &sim).await;
    c.step(&sim, 700).await;
    let step = head(&c, &sim).await;
    c.call("get_simulation_info", json!({"sim_id": sim})).await;
    let history = c.call("get_history", json!({"sim_id": sim, "limit": 100})).await;
    let read_seq = history["events"].as_array().unwrap().iter().find(|e| e["kind"] == "read").expect("a read event")["seq"].clone();
    let hash = c.hash(&sim).await;
    let cases = [
        (json!({"every": 0}), "every"),
        (json!({"fps": 0}), "fps"),
        (json!({"fps": 51}), "fps"),
        (json!({"width": 0}), "width"),
        (json!({"width": 200, "height": 200}), "--max-image-px"),
        (json!({"from_seq": step, "to_seq": add}), "from_seq"),
        (json!({"to_seq": 999}), "to_seq"),
        (json!({"to_seq": read_seq}), "to_seq"),
        (json!({"from_seq": add, "every": 1, "width": 32, "height": 24}), "every"),
        (json!({"output_path": "a.png"}), "output_path"),
        (json!({"output_path": "../a.gif"}), "output_path"),
        (json!({"view_matrix": [1, 2, 3]}), "view_matrix"),
        (json!({"speed": 0}), "speed"),
        (json!({"speed": 1000}), "speed"),
        (json!({"overlay": "clock"}), "overlay"),
        (json!({"camera": {"distance": -1}}), "camera.distance"),
        (json!({"camera": {"zoom": 2}}), "camera"),
        (json!({"camera": {"yaw": 30}, "view_matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, -5, 1]}), "view_matrix"),
    ];
    for (extra, word) in cases {
        let mut args = json!({"sim_id": sim, "width": 32, "height": 24});
        args.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        let err = c.try_call("render_animation", args.clone()).await.expect_err(&format!("{args} must be refused"));
        assert!(err.contains(word), "{args}: {err:?} names {word}");
        assert!(!err.contains('\n'), "one sentence: {err:?}");
    }
    assert_eq!(c.hash(&sim).await, hash);
}
