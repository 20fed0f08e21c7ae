//! Crash points for the crash-loop test (`tests/failpoints/crash_loop.rs`): with the test-only cargo
//! feature `failpoints`, `crash_point!("name")` aborts the process at that spot when the
//! `FAILPOINTS` environment variable enables it (`FAILPOINTS="snapshot_write=return"`), so
//! kills land inside the risky phases (snapshot write, checkpoint, create/fork/load, save)
//! rather than only between calls. Without the feature the macro expands to nothing: release
//! builds carry no fail points.

/// Aborts the process here (no destructors, no flush: like kill -9) when the `failpoints`
/// feature is on and `FAILPOINTS` enables this point; nothing otherwise.
#[macro_export]
macro_rules! crash_point {
    ($name:literal) => {
        #[cfg(feature = "failpoints")]
        {
            fail::eval::<(), _>($name, |_| {
                eprintln!("physics-mcp: crash point {} reached", $name);
                std::process::abort()
            });
        }
    };
}

/// Reads `FAILPOINTS` once at start (feature `failpoints` only); the returned guard keeps
/// them configured for the life of the process.
#[cfg(feature = "failpoints")]
pub fn setup() -> fail::FailScenario<'static> {
    fail::FailScenario::setup()
}
