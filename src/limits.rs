//! Limits on everything a client can ask for (TigerBeetle's "put a limit on everything").
//! Each is a CLI flag; the defaults are SPEC's.

use clap::Args;

/// Per-server limits, settable from the command line.
#[derive(Args, Clone, Debug)]
pub struct Limits {
    /// Simulations per data directory.
    #[arg(long, default_value_t = 32)]
    pub max_sims: usize,
    /// Objects per simulation (a URDF robot counts as one).
    #[arg(long, default_value_t = 10_000)]
    pub max_objects: usize,
    /// Constraints per simulation.
    #[arg(long, default_value_t = 1_000)]
    pub max_constraints: usize,
    /// Steps per step_simulation call.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_steps: u64,
    /// Rays per ray_test_batch call.
    #[arg(long, default_value_t = 16_384)]
    pub max_rays: usize,
    /// Pixels per camera image.
    #[arg(long, default_value_t = 1_048_576)]
    pub max_image_px: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_sims: 32,
            max_objects: 10_000,
            max_constraints: 1_000,
            max_steps: 1_000_000,
            max_rays: 16_384,
            max_image_px: 1_048_576,
        }
    }
}
