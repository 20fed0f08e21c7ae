//! The in-process side of `scripts/compare_pybullet.py`: the 1000-box pile of `benches/pile.rs`
//! built through `World::apply` (as the server builds it), stepped 100 steps, then the median
//! ms/step of several runs of steps 100–400 from that state — the bench's own measure — and the
//! pile's ground and boxes exactly as a client sends them, so the script builds the very same
//! scene in PyBullet and over MCP. Prints one JSON object on stdout.
//!
//! `cargo run --release --locked --example compare_pile [RUNS]` (default 5 runs).

// A benchmark reads the clock; the bans in clippy.toml are for the world.
#![allow(clippy::disallowed_methods)]

#[path = "../benches/pile.rs"]
mod pile;

use std::time::Instant;

use physics_mcp::command::{Command, Shape};
use physics_mcp::world::World;
use serde_json::json;

/// Steps of the pile before the timed ones (the boxes are falling onto each other by then).
const WARM: u64 = 100;
/// Steps timed per run: 100–400, as `benches/physics.rs` times them.
const TIMED: u64 = 300;

fn step(w: &mut World, n: u64) {
    w.apply(&Command::step(n), &mut |_| true);
}

/// This process's time on a CPU so far (ns; Linux: the sum over its threads, the stepping
/// pool's included, which do the stepping), so that a busy machine's waits for a core can be
/// told from the work itself; None where the kernel does not tell.
fn cpu_ns() -> Option<u64> {
    let mut total = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

fn median(v: &[f64]) -> f64 {
    let mut sorted = v.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 2]
}

fn main() {
    let runs: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5).max(1);
    // Steps run on one thread (the default, as the server's `--threads 1`), as PyBullet's do.
    let mut w = pile::pile_world();
    step(&mut w, WARM);
    let snap = w.snapshot();
    let (mut ms, mut cpu_ms) = (Vec::new(), Vec::new());
    let mut hash = String::new();
    for _ in 0..runs {
        let mut w = World::restore("pile", false, &snap).expect("the pile's own snapshot restores");
        let (t, cpu) = (Instant::now(), cpu_ns());
        step(&mut w, TIMED);
        ms.push(t.elapsed().as_secs_f64() * 1e3 / TIMED as f64);
        if let (Some(a), Some(b)) = (cpu, cpu_ns()) {
            cpu_ms.push((b - a) as f64 / 1e6 / TIMED as f64);
        }
        hash = w.state_hash();
    }
    // The static ground and the 1000 boxes as a client sends them (raw orientations; the server
    // normalises them exactly as pile_commands does), f32 values widened exactly so that they
    // round-trip through JSON.
    let boxes: Vec<_> = pile::raw_pile()
        .into_iter()
        .filter_map(|c| match c {
            Command::AddBody { shape: Shape::Box { half_extents }, position, orientation, mass, .. } => {
                Some(json!({"half_extents": half_extents, "position": position, "orientation": orientation, "mass": mass}))
            }
            _ => None,
        })
        .collect();
    let out = json!({
        "warm_steps": WARM,
        "timed_steps": TIMED,
        "ms_per_step": median(&ms),
        "runs_ms_per_step": ms,
        "cpu_ms_per_step": (!cpu_ms.is_empty()).then(|| median(&cpu_ms)),
        "state_hash_after": hash,
        "boxes": boxes,
    });
    println!("{out}");
}
