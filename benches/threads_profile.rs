//! A profiling target, not a figure: steps the settled 1000-box pile (or, with `arms`, the 64
//! URDF arms) for 1,000 steps on the thread count given (default 2), so `perf record` sees the
//! stepping pool alone. docs/benchmarks.md "Threads" reads its profile:
//!
//!     cargo bench --bench threads_profile --no-run
//!     perf record -F 999 -o /tmp/perf.data target/release/deps/threads_profile-* 2 pile
//!     perf report -i /tmp/perf.data --sort comm,sym

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
        _ => pile::pile_world(),
    };
    w.apply(&Command::StepSimulation { steps: 100 }, &mut |_| true);
    physics_mcp::cli::step_on_threads(threads).expect("stepping threads");
    let mut w = physics_mcp::world::World::restore("scene", false, &w.snapshot()).unwrap();
    let t = std::time::Instant::now();
    w.apply(&Command::StepSimulation { steps: 1000 }, &mut |_| true);
    let ms_per_step = t.elapsed().as_secs_f64() * 1e3 / 1000.0;
    println!("{threads} threads: {ms_per_step:.3} ms/step, hash {}", w.state_hash());
}
