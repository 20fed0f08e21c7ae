//! Shutdown, process-wide: once SIGTERM/SIGINT arrives (or stdio's input ends), every running
//! step stops at its next step exactly as a client's cancellation stops it (the steps taken
//! are what the log records), re-simulations and sweeps stop, and the server flushes what is
//! buffered and exits — within [`DEADLINE`], whatever was running (docs/guarantees).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How long shutdown may take from the signal to the exit.
pub const DEADLINE: Duration = Duration::from_secs(10);

/// How long, of [`DEADLINE`], open connections are given to finish their replies.
pub const GRACE: Duration = Duration::from_secs(5);

static REQUESTED: AtomicBool = AtomicBool::new(false);
static BEGAN: OnceLock<Instant> = OnceLock::new();

/// Begins shutdown (the first call fixes when): from now on running work stops at its next
/// check.
pub fn begin() {
    BEGAN.get_or_init(Instant::now);
    REQUESTED.store(true, Ordering::Relaxed);
}

/// When shutdown began (now, if it has not): `DEADLINE` counts from here.
pub fn began() -> Instant {
    *BEGAN.get_or_init(Instant::now)
}

/// Whether shutdown has begun (checked by step controls and re-simulations).
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// The sentence a call stopped by shutdown is refused with.
pub const STOPPED: &str = "The server is shutting down; the call was stopped";
