//! Crash points for the crash-loop test (`tests/failpoints/crash_loop.rs`): in a debug build
//! (every test build), `crash_point!("name")` aborts the process at that spot when the
//! `FAILPOINTS` environment variable enables it (`FAILPOINTS="snapshot_write=return"`), so
//! kills land inside the risky phases (snapshot write, checkpoint, create/fork/load, save)
//! rather than only between calls. Unset, a point costs a lookup in an empty table. In a
//! release build the macro expands to nothing: releases carry no fail points. (It was a cargo
//! feature, which built the whole crate a second time in CI for two tests.)

/// Aborts the process here (no destructors, no flush: like kill -9) in a debug build when
/// `FAILPOINTS` enables this point; nothing otherwise.
#[macro_export]
macro_rules! crash_point {
    ($name:literal) => {
        #[cfg(debug_assertions)]
        {
            fail::eval::<(), _>($name, |_| {
                eprintln!("physics-mcp: crash point {} reached", $name);
                std::process::abort()
            });
        }
    };
}

/// A spot where a test holds one thread (`fail::cfg_callback`, or `sleep`/`pause` through
/// `FAILPOINTS`) to force an interleaving that timing alone would rarely give; nothing in a
/// release build, nothing when unset.
#[macro_export]
macro_rules! hold_point {
    ($name:literal) => {
        #[cfg(debug_assertions)]
        {
            fail::eval::<(), _>($name, |_| ());
        }
    };
}

/// Reads `FAILPOINTS` once at start (debug builds only); the returned guard keeps
/// them configured for the life of the process.
#[cfg(debug_assertions)]
pub fn setup() -> fail::FailScenario<'static> {
    fail::FailScenario::setup()
}
