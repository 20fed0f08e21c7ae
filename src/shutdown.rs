//! Shutdown, process-wide: once SIGTERM/SIGINT arrives (or stdio's input ends), every running
//! step stops at its next step exactly as a client's cancellation stops it (the steps taken
//! are what the log records), re-simulations and sweeps stop, and the server flushes what is
//! buffered and exits — within [`DEADLINE`], whatever was running (docs/guarantees).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How long shutdown may take from the signal to the exit.
pub const DEADLINE: Duration = Duration::from_secs(10);

/// How long, of [`DEADLINE`], open connections are given to finish their replies.
pub const GRACE: Duration = Duration::from_secs(5);

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Begins shutdown: from now on running work stops at its next check.
pub fn begin() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Whether shutdown has begun (checked by step controls and re-simulations).
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// The sentence a call stopped by shutdown is refused with.
pub const STOPPED: &str = "The server is shutting down; the call was stopped";
