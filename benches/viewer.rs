//! The live viewer frame benchmark (`cargo bench --bench viewer`): what one frame of the
//! collapsed 1,000-box pile costs the server, the WebGL page's poses frame (scene capture,
//! key, poses, JSON) against the server-rendered 640×480 PNG frame of before, in one run;
//! and the bytes each sends. `REPORT` lines carry the figures for docs/benchmarks.md.

#[path = "pile.rs"]
mod pile;

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::command::Command;
use physics_mcp::seeing::viewer::{ask, png};
use physics_mcp::world::World;

fn collapsed_pile() -> World {
    let mut w = pile::pile_world();
    w.apply(&Command::step(400), &mut |_| true);
    w
}

/// Median seconds of `f` over `n` runs.
fn median(n: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[n / 2]
}

fn bench_viewer_frames(c: &mut Criterion) {
    let w = collapsed_pile();
    let hash = w.state_hash();
    let key = ask::world_frame(&w, &hash, false, None).key;
    let poses_frame = || serde_json::to_string(&ask::world_frame(&w, &hash, false, Some(&key))).unwrap();
    let q = png::FrameQuery { w: Some(640), h: Some(480), ..Default::default() };
    let png_frame = || serde_json::to_string(&png::frame(&w, &hash, false, &q, 4_000_000).unwrap()).unwrap();
    let scene_frame = serde_json::to_string(&ask::world_frame(&w, &hash, false, None)).unwrap();

    let mut g = c.benchmark_group("viewer_frame_pile_1000");
    g.sample_size(20);
    g.bench_function("poses (WebGL page)", |b| b.iter(poses_frame));
    g.bench_function("png 640x480 (before)", |b| b.iter(png_frame));
    g.finish();

    // One run, both measured the same way, for the ratio.
    let (poses_s, png_s) = (median(51, || drop(poses_frame())), median(11, || drop(png_frame())));
    println!(
        "REPORT viewer_frame_pile_1000 poses: {:.3} ms/frame ({:.0} frames/s of server CPU), {} bytes/frame; \
         first frame with the scene {} bytes",
        poses_s * 1e3,
        1.0 / poses_s,
        poses_frame().len(),
        scene_frame.len()
    );
    println!(
        "REPORT viewer_frame_pile_1000 png 640x480: {:.3} ms/frame ({:.0} frames/s), {} bytes/frame; poses are {:.1}x cheaper, {:.1}x smaller",
        png_s * 1e3,
        1.0 / png_s,
        png_frame().len(),
        png_s / poses_s,
        png_frame().len() as f64 / poses_frame().len() as f64
    );
}

criterion_group!(benches, bench_viewer_frames);
criterion_main!(benches);
