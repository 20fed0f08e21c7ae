//! With the test-only crash points compiled in (feature `failpoints`; `.ci/run` runs this
//! binary): kill -9 in every risky phase loses nothing acknowledged, and the registry's table
//! lock is never held across a create's I/O.

#[path = "../common/mod.rs"]
mod common;

mod crash_loop;
mod lock_order;
