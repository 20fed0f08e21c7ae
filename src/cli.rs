//! Command-line flags that fill core structs. The core (`physics_core`) has no clap, so the
//! flags for `Limits` live here; their defaults come from the core's one table,
//! `limits::DEFAULT`, so the CLI and `Limits::default()` cannot drift.

use clap::Args;

use crate::limits::{Limits, DEFAULT};

/// Per-server limits, as command-line flags (converted into [`Limits`]).
#[derive(Args, Clone, Debug)]
pub struct LimitArgs {
    /// Simulations per data directory.
    #[arg(long, default_value_t = DEFAULT.max_sims)]
    pub max_sims: usize,
    /// Objects per simulation (a URDF robot counts as one).
    #[arg(long, default_value_t = DEFAULT.max_objects)]
    pub max_objects: usize,
    /// Constraints per simulation.
    #[arg(long, default_value_t = DEFAULT.max_constraints)]
    pub max_constraints: usize,
    /// Steps per step_simulation call.
    #[arg(long, default_value_t = DEFAULT.max_steps)]
    pub max_steps: u64,
    /// Rays per ray_test_batch call.
    #[arg(long, default_value_t = DEFAULT.max_rays)]
    pub max_rays: usize,
    /// Pixels per camera image.
    #[arg(long, default_value_t = DEFAULT.max_image_px)]
    pub max_image_px: usize,
    /// Bytes per tool reply (the JSON-RPC message); larger results are refused, saying what
    /// to change (fewer rays, a smaller image, `every`, or `output_path`).
    #[arg(long, default_value_t = DEFAULT.max_reply_bytes, value_parser = reply_bytes)]
    pub max_reply_bytes: usize,
    /// Calls that may wait for one busy simulation; more are refused at once ("busy; retry").
    #[arg(long, default_value_t = DEFAULT.max_waiting)]
    pub max_waiting: usize,
    /// Re-simulated body-steps (steps × bodies) one request may cost: trajectories,
    /// animations, viewer asks; estimated from the log before the work and refused past it.
    #[arg(long, default_value_t = DEFAULT.max_work)]
    pub max_work: u64,
    /// Bytes of memory one request may hold beyond the live world (a batch's results, a
    /// sweep's forks), estimated before the work and refused past it.
    #[arg(long, default_value_t = DEFAULT.max_request_bytes)]
    pub max_request_bytes: usize,
    /// Bytes per file write_file writes (the HTTP request-body cap grows to hold it as base64).
    #[arg(long, default_value_t = DEFAULT.max_write_bytes)]
    pub max_write_bytes: usize,
}

/// `--max-reply-bytes`: at least `budget::MIN_REPLY_BYTES`, so every state-changing reply,
/// shortened, fits.
fn reply_bytes(s: &str) -> Result<usize, String> {
    let n: usize = s.trim().parse().map_err(|_| format!("must be a number of bytes; got {s}"))?;
    let min = crate::sim::budget::MIN_REPLY_BYTES;
    if n < min {
        return Err(format!("must be at least {min} bytes; got {n}"));
    }
    Ok(n)
}

/// `--threads N`: every step command of this process runs on N threads from now on (the
/// calling thread's pool of N, physics-core's `world/threads.rs`), whichever world it steps —
/// created, recovered, undone, forked, loaded or replayed. Refuses 0.
pub fn step_on_threads(n: usize) -> Result<(), String> {
    if n == 0 {
        return Err("must be at least 1".into());
    }
    crate::world::set_step_threads(n);
    Ok(())
}

impl From<LimitArgs> for Limits {
    fn from(a: LimitArgs) -> Limits {
        // Destructured, so a field added to one struct and not the other does not compile.
        let LimitArgs {
            max_sims,
            max_objects,
            max_constraints,
            max_steps,
            max_rays,
            max_image_px,
            max_reply_bytes,
            max_waiting,
            max_work,
            max_request_bytes,
            max_write_bytes,
        } = a;
        Limits {
            max_sims,
            max_objects,
            max_constraints,
            max_steps,
            max_rays,
            max_image_px,
            max_reply_bytes,
            max_waiting,
            max_work,
            max_request_bytes,
            max_write_bytes,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        limits: LimitArgs,
    }

    #[test]
    fn flag_defaults_are_the_core_defaults() {
        let cli = Cli::parse_from(["physics-mcp"]);
        assert_eq!(Limits::from(cli.limits), Limits::default());
    }

    #[test]
    fn flags_set_the_limits() {
        let cli = Cli::parse_from(["physics-mcp", "--max-objects", "7", "--max-steps", "9"]);
        let l = Limits::from(cli.limits);
        assert_eq!((l.max_objects, l.max_steps), (7, 9));
        assert_eq!(l.max_rays, DEFAULT.max_rays);
    }
}

/// Which interval of a log's head chain `replay --trajectory` (and `--render`) looks at:
/// the whole chain unless told otherwise (docs/tools.md "Seeing time").
#[derive(Args, Clone, Debug, Default)]
pub struct IntervalArgs {
    /// Steps between samples (default: about 100 samples).
    #[arg(long)]
    pub every: Option<u64>,
    /// Start after this state-changing event (default: the chain's first).
    #[arg(long)]
    pub from: Option<u64>,
    /// End at this state-changing event (default: the head).
    #[arg(long)]
    pub to: Option<u64>,
}
