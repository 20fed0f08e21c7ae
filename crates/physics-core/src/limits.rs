//! Limits on everything a client can ask for (TigerBeetle's "put a limit on everything").
//! Each is a CLI flag (the server crate's `cli::LimitArgs`, which takes its defaults from
//! [`DEFAULT`]); the defaults are the documented ones (docs/tools.md "Limits and security").

/// Per-server limits, settable from the command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Simulations per data directory.
    pub max_sims: usize,
    /// Objects per simulation (a URDF robot counts as one).
    pub max_objects: usize,
    /// Constraints per simulation.
    pub max_constraints: usize,
    /// Steps per step_simulation call.
    pub max_steps: u64,
    /// Rays per ray_test_batch call.
    pub max_rays: usize,
    /// Pixels per camera image.
    pub max_image_px: usize,
    /// Bytes per tool reply (the serialized JSON-RPC message): the Python MCP SDK drops SSE
    /// events over 1 MiB, so a larger reply would be lost, not just slow.
    pub max_reply_bytes: usize,
    /// Calls that may wait for one busy simulation (docs/guarantees.md "Isolation"): a call past
    /// it is refused at once, so callers queue on a simulation without each holding a thread.
    pub max_waiting: usize,
    /// Re-simulated work one request may ask for, in body-steps (steps × bodies): what
    /// get_trajectory, render_animation, the report and every viewer ask re-simulate is
    /// estimated from the log before any of it runs, and refused past this.
    pub max_work: u64,
    /// Bytes of memory one request may hold beyond the live world, estimated before it runs:
    /// a batch's results and world copy, a sweep's forks in flight and kept.
    pub max_request_bytes: usize,
    /// Bytes per file write_file writes: the default, 3,000,000, sent as base64 (a third more)
    /// with its envelope, fits the HTTP transport's 4 MiB request-body cap.
    pub max_write_bytes: usize,
}

/// the documented defaults: one table for the CLI flags and `Default`.
pub const DEFAULT: Limits = Limits {
    max_sims: 32,
    max_objects: 10_000,
    max_constraints: 1_000,
    max_steps: 1_000_000,
    max_rays: 16_384,
    max_image_px: 1_048_576,
    max_reply_bytes: 1_048_576,
    max_waiting: 64,
    max_work: 200_000_000,
    max_request_bytes: 512 * 1024 * 1024,
    max_write_bytes: 3_000_000,
};

impl Default for Limits {
    fn default() -> Self {
        DEFAULT
    }
}

impl Limits {
    /// No size limits, only validity: for folding a log whose events were accepted under the
    /// limits of their day (a server restarted with a lower `--max-objects` still recovers).
    pub fn unbounded() -> Limits {
        Limits {
            max_sims: usize::MAX,
            max_objects: usize::MAX,
            max_constraints: usize::MAX,
            max_steps: u64::MAX,
            max_rays: usize::MAX,
            max_image_px: usize::MAX,
            max_reply_bytes: usize::MAX,
            max_waiting: usize::MAX,
            max_work: u64::MAX,
            max_request_bytes: usize::MAX,
            max_write_bytes: usize::MAX,
        }
    }
}

/// How far (m) any body, mesh vertex or shape may reach from the origin when a model or an
/// object is added. The engine works in f32 (7.8 mm apart at this distance); beyond it, and
/// with sizes like 1e19 or 1e26 m, its contact and multibody solvers panic on every later step,
/// leaving a simulation that can never step again. Not a CLI flag: no real scene is near it.
pub const MAX_EXTENT_M: f64 = 1e5;

/// Largest speed (m/s, each component) or spin (rad/s) a call may set. The engine caps linear
/// speed at 400 m/s anyway (rapier's `max_linear_velocity`); near 1.8e19 the cap's f32 norm
/// overflows and the body silently freezes where it is, so such a value is refused instead.
pub const MAX_SPEED: f64 = 1e5;

/// Joints one model (URDF or MJCF) may have. One step of an articulation of n links costs
/// O(n³) time and O(n²) memory in the engine's multibody solver, so a 10,000-link chain that
/// fits in a small file made a single step run for hours; real robots have tens of joints.
pub const MAX_MODEL_JOINTS: usize = 512;

/// Actuators, sensors, equality constraints, tendons and contact pairs one MJCF model may have,
/// each: every step walks every actuator and every contact pair, every read of get_sensor_data
/// every sensor, and each equality constraint is a joint the solver carries; Menagerie's
/// largest robots have tens.
pub const MAX_MODEL_ELEMENTS: usize = 1024;

/// How many names a refusal lists when it shows what exists (the rest are counted), so a
/// refusal against a model of many sensors stays one short sentence.
pub const NAMES_SHOWN: usize = 8;

/// `names` as a refusal shows them: the first [`NAMES_SHOWN`], then how many more.
pub fn some_names(names: &[&str]) -> String {
    let shown: Vec<&str> = names.iter().copied().take(NAMES_SHOWN).collect();
    match names.len().saturating_sub(NAMES_SHOWN) {
        0 => format!("{shown:?}"),
        more => format!("{shown:?} and {more} more"),
    }
}

/// Refuses a model with more joints than [`MAX_MODEL_JOINTS`], naming the parameter.
pub fn check_model_joints(joints: usize) -> Result<(), crate::value::Refusal> {
    if joints > MAX_MODEL_JOINTS {
        Err(format!("file_path has {joints} joints; a model may have at most {MAX_MODEL_JOINTS}"))
    } else {
        Ok(())
    }
}
