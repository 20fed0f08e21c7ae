//! Issue 11 benchmarks (`cargo bench --bench seeing_time`): render_animation's work — 120
//! frames at 320×240 of 100 objects dropped on a ground, every=4 — against the physics of the
//! same interval alone (the core re-simulating with no observer work), and `report` on the
//! recorded session in `replays/` with the most events; and the renderer alone: each of the
//! 120 captured scenes drawn on one thread (sky, checker, shadows), the cost SPEC bounds per
//! 320×240 frame per core. `REPORT` lines carry the figures.

#[path = "pile.rs"]
mod pile;

#[path = "../tests/common/mod.rs"]
mod common;

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use physics_mcp::seeing::animation::{self, Camera};
use physics_mcp::command::{Command, Shape, EVENT_VERSION};
use physics_mcp::log::fold::{self, Interval, Lent};
use physics_mcp::log::sqlite::{Event, Kind};
use physics_mcp::world::World;

/// Steps of the interval: the start and a frame every 4 steps make 120 frames.
const STEPS: u64 = 476;

fn event(seq: u64, kind: Kind, tool: &str, w: &World) -> Event {
    Event {
        seq,
        kind,
        parent: seq.checked_sub(1).filter(|p| *p > 0),
        tool: tool.into(),
        arguments: "{}".into(),
        command: None,
        version: EVENT_VERSION,
        ok: true,
        mutates: true,
        inherited: false,
        result: None,
        result_hash: None,
        state_hash: w.state_hash(),
        engine: None,
        summary: None,
    }
}

/// A ground and 100 coloured shapes dropped from up to 2 m, lent as a log would lend it: the
/// snapshot at the drop, then one step event of `STEPS` steps with its recorded hash.
fn dropped_100() -> Lent {
    let (mut w, _) = World::create(&pile::root("anim")).unwrap();
    let add = |w: &mut World, shape, position: [f32; 3], mass, color| {
        w.apply(&Command::AddBody { shape, position, orientation: [0.1, 0.2, 0.0, 0.97], mass, color, collides: true }, &mut |_| true);
    };
    add(&mut w, Shape::Box { half_extents: [10.0, 10.0, 0.1] }, [0.0, 0.0, -0.1], 0.0, Some([0.6, 0.6, 0.6, 1.0]));
    for i in 0..100 {
        let p = [(i % 10) as f32 * 0.6 - 2.7, (i / 10) as f32 * 0.6 - 2.7, 0.4 + (i % 7) as f32 * 0.25];
        let color = Some([(i % 3) as f32 / 2.0, ((i / 3) % 3) as f32 / 2.0, 1.0 - (i % 5) as f32 / 4.0, 1.0]);
        let shape = match i % 4 {
            0 => Shape::Box { half_extents: [0.2, 0.2, 0.2] },
            1 => Shape::Sphere { radius: 0.2 },
            2 => Shape::Cylinder { radius: 0.2, height: 0.4 },
            _ => Shape::Capsule { radius: 0.15, height: 0.2 },
        };
        add(&mut w, shape, p, 1.0, color);
    }
    let start = w.snapshot();
    let first = event(1, Kind::Root, "create_simulation", &w);
    let step = Command::step(STEPS);
    w.apply(&step, &mut |_| true);
    let last = event(2, Kind::Change, "step_simulation", &w);
    Lent {
        id: "anim".into(),
        start: Some(start),
        chain: vec![(first, Command::CreateSimulation { simulation_id: "anim".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(physics_mcp::engine::ENGINE_RULE) }), (last, step)],
        interval: Interval { from_seq: 1, to_seq: 2 },
        until_step: None,
        snapshots: Vec::new(),
    }
}

fn camera() -> Camera {
    let view = physics_mcp::seeing::sensing::camera::view_matrix([6.0, -6.0, 5.0], [0.0, 0.0, 0.3], [0.0, 0.0, 1.0]);
    let mut cam = Camera::sized(320, 240);
    cam.asked.view = Some(view);
    cam
}

/// Every frame shown: 50 a second, at a quarter speed (samples 16.7 ms apart play 67 ms apart).
const ALL_FRAMES: animation::Pacing = animation::Pacing { fps: 50, speed: 0.25 };

/// The replay with the most events.
fn longest_replay() -> std::path::PathBuf {
    let mut logs: Vec<(usize, std::path::PathBuf)> = common::recorded_logs()
        .into_iter()
        .map(|p| (physics_mcp::log::replay::events(&p).unwrap().len(), p))
        .collect();
    logs.sort();
    logs.pop().unwrap().1
}

fn bench(c: &mut Criterion) {
    let lent = dropped_100();
    let cam = camera();
    assert_eq!(animation::sample_count(&lent, 4), 120);
    let physics = || fold::resimulate(&lent, 4, &mut |_, _| true).unwrap();
    let animate = || animation::animate(&lent, 4, &cam, ALL_FRAMES).unwrap();

    // Side by side in one run, for the REPORT line.
    let time = |f: &dyn Fn()| {
        let runs = 5;
        let t = Instant::now();
        for _ in 0..runs {
            f();
        }
        t.elapsed().as_secs_f64() * 1e3 / runs as f64
    };
    let physics_ms = time(&|| {
        physics();
    });
    let anim = animate();
    let total_ms = time(&|| {
        animate();
    });
    println!(
        "REPORT render_animation: 120 frames 320x240, 100 objects, every=4: {total_ms:.0} ms in all, physics alone {physics_ms:.0} ms, beyond physics {:.0} ms on {} threads; GIF {} bytes ({:.0} KiB)",
        total_ms - physics_ms,
        rayon::current_num_threads(),
        anim.gif.len(),
        anim.gif.len() as f64 / 1024.0
    );
    assert_eq!(anim.frames, 120);
    // The renderer alone, one thread: each captured scene drawn once with the animation's camera.
    let shots = animation::capture(&lent, 4, &mut |_| {}).unwrap();
    let scenes: Vec<_> = shots.iter().map(|s| &s.scene).collect();
    let (view, proj, _) = cam.fix(&scenes);
    let t = Instant::now();
    for s in &shots {
        std::hint::black_box(cam.rgb(&s.scene, s.seq, &view, &proj));
    }
    let per_frame = t.elapsed().as_secs_f64() * 1e3 / shots.len() as f64;
    let t = Instant::now();
    for s in &shots {
        std::hint::black_box(physics_mcp::seeing::sensing::render::render_scene(&s.scene, 320, 240, &view, &proj));
    }
    let bare_ms = t.elapsed().as_secs_f64() * 1e3 / shots.len() as f64;
    println!("REPORT render: {per_frame:.2} ms per 320x240 frame on one thread with the overlay, {bare_ms:.2} ms without (100 objects and a ground; sky, checker, shadows)");
    let replay = longest_replay();
    let t = Instant::now();
    let page = physics_mcp::seeing::report::html(&physics_mcp::seeing::report::gather(&replay, |_, _| {}).unwrap()).unwrap();
    println!("REPORT report: {} ({} events): {:.0} ms, page {} bytes", replay.display(), physics_mcp::log::replay::events(&replay).unwrap().len(), t.elapsed().as_secs_f64() * 1e3, page.len());

    let mut g = c.benchmark_group("seeing_time");
    g.sample_size(10);
    g.bench_function("physics_of_the_interval", |b| b.iter(physics));
    g.bench_function("render_animation_120x320x240_100_objects", |b| b.iter(animate));
    g.bench_function("report_longest_replay", |b| {
        b.iter(|| physics_mcp::seeing::report::html(&physics_mcp::seeing::report::gather(&replay, |_, _| {}).unwrap()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
