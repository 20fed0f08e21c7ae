//! With the crash points of debug builds (src/failpoints.rs; `.ci/run` runs this binary's
//! ignored tests): kill -9 in every risky phase loses nothing acknowledged, and the registry's table
//! lock is never held across a create's I/O.

#[path = "../common/mod.rs"]
mod common;

mod crash_loop;
mod lock_order;
