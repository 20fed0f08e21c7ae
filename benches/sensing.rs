//! Issue 5 benchmarks (`cargo bench --bench sensing`): a 10,000-ray batch over the collapsed
//! 1000-box pile (one thread and all cores), get_camera_image of a 100-object scene at
//! 320×240 and 640×480 (render + PNG, as the tool does), and the size of a default camera
//! result. `REPORT` lines carry the figures for the closing note;
//! scripts/pybullet_sensing_bench.py measures PyBullet on the same scenes for the ratios.

#[path = "pile.rs"]
mod pile;

use std::time::Instant;

use base64::Engine;
use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::command::{Command, Shape};
use physics_mcp::sim::reads::{self, ReadContext};
use physics_mcp::seeing::sensing::rays;
use physics_mcp::world::scene::Scene;
use physics_mcp::world::World;
use rand::{Rng, SeedableRng};
use serde_json::json;

/// 10,000 rays from above the pile straight through it to below the ground (seeded).
fn pile_rays() -> Vec<([f32; 3], [f32; 3])> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(pile::SEED);
    (0..10_000)
        .map(|_| {
            let (x, y) = (rng.gen_range(-0.5f32..3.0), rng.gen_range(-0.5f32..3.0));
            ([x, y, 5.0], [x + rng.gen_range(-0.3f32..0.3), y + rng.gen_range(-0.3f32..0.3), -1.0])
        })
        .collect()
}

fn collapsed_pile() -> World {
    let mut w = pile::pile_world();
    w.apply(&Command::step(400), &mut |_| true);
    w
}

/// A ground and 99 mixed, coloured shapes on a 10×10 grid (the 100-object scene).
fn scene_100() -> World {
    let (mut w, _) = World::create(&pile::root("scene")).unwrap();
    let mut add = |shape, position: [f32; 3], mass, color| {
        w.apply(&Command::AddBody { shape, position, orientation: [0.0, 0.0, 0.0, 1.0], mass, color, collides: true }, &mut |_| true);
    };
    add(Shape::Box { half_extents: [10.0, 10.0, 0.1] }, [0.0, 0.0, -0.1], 0.0, Some([0.6, 0.6, 0.6, 1.0]));
    for i in 0..99 {
        let p = [(i % 10) as f32 * 0.6 - 2.7, (i / 10) as f32 * 0.6 - 2.7, 0.25];
        let color = Some([(i % 3) as f32 / 2.0, ((i / 3) % 3) as f32 / 2.0, 1.0 - (i % 5) as f32 / 4.0, 1.0]);
        let shape = match i % 4 {
            0 => Shape::Box { half_extents: [0.2, 0.2, 0.2] },
            1 => Shape::Sphere { radius: 0.2 },
            2 => Shape::Cylinder { radius: 0.2, height: 0.4 },
            _ => Shape::Capsule { radius: 0.15, height: 0.2 },
        };
        add(shape, p, 1.0, color);
    }
    w
}

fn camera_args(width: u32, height: u32) -> serde_json::Map<String, serde_json::Value> {
    let view = physics_mcp::seeing::sensing::camera::view_matrix([5.0, -5.0, 4.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    let proj = physics_mcp::seeing::sensing::camera::projection_matrix(60.0, f64::from(width) / f64::from(height), 0.1, 100.0);
    json!({"sim_id": "bench", "width": width, "height": height, "view_matrix": view.to_vec(), "projection_matrix": proj.to_vec()})
        .as_object()
        .cloned()
        .unwrap()
}

fn camera_matrix(args: &serde_json::Map<String, serde_json::Value>, name: &str) -> [f64; 16] {
    let v: Vec<f64> = args[name].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    v.try_into().unwrap()
}

/// get_camera_image's parameters, parsed as the tool parses them.
fn cam(args: &serde_json::Map<String, serde_json::Value>) -> physics_mcp::params::CameraImage {
    physics_mcp::params::parse("get_camera_image", args).unwrap()
}

fn cx(w: &World) -> ReadContext<'_> {
    ReadContext { world: w, head_seq: 0, last_seq: 0, state_hash: "", rules: physics_mcp::command::EVENT_VERSION }
}

fn median_ms(mut f: impl FnMut(), runs: usize) -> f64 {
    let mut v: Vec<f64> = (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench_rays(c: &mut Criterion) {
    let w = collapsed_pile();
    let rays = pile_rays();
    let mut g = c.benchmark_group("rays");
    g.sample_size(20);
    g.bench_function("batch_10000_all_cores", |b| {
        b.iter(|| rays::cast_batch(&Scene::new(&w), &rays))
    });
    g.bench_function("batch_10000_one_thread", |b| {
        b.iter(|| {
            let scene = Scene::new(&w);
            rays.iter().map(|(f, t)| rays::cast(&scene, *f, *t)).collect::<Vec<_>>()
        })
    });
    g.bench_function("single_ray_test_x100_fresh_index_each", |b| {
        b.iter(|| rays.iter().take(100).map(|(f, t)| rays::cast(&Scene::new(&w), *f, *t)).collect::<Vec<_>>())
    });
    g.bench_function("single_ray_test_x100_unchanged_world", |b| {
        b.iter(|| rays.iter().take(100).map(|(f, t)| rays::ray_test(&w, *f, *t)).collect::<Vec<_>>())
    });
    g.finish();
    let all = median_ms(|| drop(rays::cast_batch(&Scene::new(&w), &rays)), 30);
    let one = median_ms(
        || {
            let scene = Scene::new(&w);
            drop(rays.iter().map(|(f, t)| rays::cast(&scene, *f, *t)).collect::<Vec<_>>())
        },
        30,
    );
    // Single ray_test calls on an unchanged world (an agent probing a scene ray by ray): the
    // tool's path (the world's scene index, built once per state) against an index built for
    // every call (what each ray_test did before), and the build alone.
    type Ray = ([f32; 3], [f32; 3]);
    let per_call = |f: &dyn Fn(&Ray)| median_ms(|| rays.iter().take(100).for_each(f), 30) * 10.0;
    let fresh = per_call(&|(f, t)| {
        std::hint::black_box(rays::cast(&Scene::new(&w), *f, *t));
    });
    let cached = per_call(&|(f, t)| {
        std::hint::black_box(rays::ray_test(&w, *f, *t));
    });
    let build = median_ms(|| drop(Scene::new(&w)), 30) * 1e3;
    println!(
        "REPORT rays: single ray_test over the collapsed 1000-box pile, unchanged world: {cached:.1} µs per call with the world's index, {fresh:.1} µs with a fresh index per call (index build {build:.0} µs; medians of 30 runs of 100 calls)"
    );
    let hits = rays::cast_batch(w.scene(), &rays).iter().filter(|h| h.hit).count();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("REPORT rays: 10000-ray batch over the collapsed 1000-box pile: {all:.2} ms on {threads} threads, {one:.2} ms on one ({hits} hits)");
}

fn bench_camera(c: &mut Criterion) {
    let w = scene_100();
    let mut g = c.benchmark_group("camera");
    g.sample_size(20);
    for (wd, ht) in [(320, 240), (640, 480)] {
        let args = camera_args(wd, ht);
        g.bench_function(format!("image_{wd}x{ht}"), |b| {
            b.iter(|| reads::camera_image(&cx(&w), &cam(&args), usize::MAX).unwrap())
        });
        let ms = median_ms(|| drop(reads::camera_image(&cx(&w), &cam(&args), usize::MAX).unwrap()), 30);
        let r = reads::camera_image(&cx(&w), &cam(&args), usize::MAX).unwrap();
        let (view, proj) = (
            camera_matrix(&args, "view_matrix"),
            camera_matrix(&args, "projection_matrix"),
        );
        let render_ms = median_ms(|| drop(physics_mcp::seeing::sensing::render::render(&w, wd, ht, &view, &proj)), 30);
        let frame = physics_mcp::seeing::sensing::render::render(&w, wd, ht, &view, &proj);
        let png_ms = median_ms(|| drop(frame.png().unwrap()), 30);
        println!("REPORT camera: {wd}x{ht} phases: rasterise {render_ms:.2} ms, PNG {png_ms:.2} ms");
        println!(
            "REPORT camera: 100-object scene {wd}x{ht}: {ms:.2} ms (render + PNG), PNG {} bytes, {} objects visible",
            r.png.len(),
            r.summary.visible_objects.len()
        );
    }
    g.finish();
    // The default result: 320×240 from the viewer camera, no arrays — what the MCP reply holds
    // (base64 PNG plus the structured JSON twice: structuredContent and its text rendering).
    let mut args = camera_args(320, 240);
    args.remove("view_matrix");
    args.remove("projection_matrix");
    let r = reads::camera_image(&cx(&w), &cam(&args), usize::MAX).unwrap();
    let b64 = base64::engine::general_purpose::STANDARD.encode(&r.png).len();
    let structured = serde_json::to_string(&r.summary).unwrap().len();
    println!(
        "REPORT camera: default result (320x240, viewer camera, no arrays): {} bytes (PNG {} bytes, base64 {b64}, structured JSON {structured} x2)",
        b64 + 2 * structured,
        r.png.len()
    );
}

criterion_group!(benches, bench_rays, bench_camera);
criterion_main!(benches);
