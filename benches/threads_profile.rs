//! A profiling target, not a figure: steps the settled 1000-box pile (or, with `arms`, the 64
//! URDF arms) for 1,000 steps on the thread count given (default 2), so `perf record` sees the
//! stepping pool alone. docs/benchmarks.md "Threads" reads its profile:
//!
//!     cargo bench --bench threads_profile --no-run
//!     perf record -F 999 -o /tmp/perf.data target/release/deps/threads_profile-* 2 pile
//!     perf report -i /tmp/perf.data --sort comm,sym
//!
//! A number instead of `pile` or `arms` steps the pile's first N boxes (with its ground).
//! Two more arguments set the steps and the chunk each is timed in: `2 pile 20 1` prints the
//! first 20 steps after the restore one by one.

// A benchmark reads the clock and its arguments; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "pile.rs"]
mod pile;

use physics_mcp::command::Command;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let threads: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(2);
    let mut w = match args.get(1).map(String::as_str) {
        Some("arms") => pile::arms_world(),
        Some(n) if n.parse::<usize>().is_ok() => {
            let (mut w, _) = physics_mcp::world::World::create(&pile::root("small")).unwrap();
            for c in pile::pile_commands().into_iter().take(1 + n.parse::<usize>().unwrap()) {
                w.apply(&c, &mut |_| true);
            }
            w
        }
        _ => pile::pile_world(),
    };
    w.apply(&Command::step(100), &mut |_| true);
    physics_mcp::cli::step_on_threads(threads).expect("stepping threads");
    let mut w = physics_mcp::world::World::restore("scene", false, &w.snapshot()).unwrap();
    // Optional: steps (default 1,000) and a chunk size, to see the cost after the restore step by
    // step (e.g. `2 pile 20 1`).
    let steps: u64 = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(1000);
    let chunk: u64 = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(steps).clamp(1, steps);
    let t = std::time::Instant::now();
    let mut chunks = Vec::new();
    for _ in 0..steps / chunk {
        let c = std::time::Instant::now();
        w.apply(&Command::step(chunk), &mut |_| true);
        chunks.push(format!("{:.3}", c.elapsed().as_secs_f64() * 1e3 / chunk as f64));
    }
    let ms_per_step = t.elapsed().as_secs_f64() * 1e3 / (steps / chunk * chunk) as f64;
    println!("{threads} threads: {ms_per_step:.3} ms/step (chunks: {}), hash {}", chunks.join(" "), w.state_hash());
}
