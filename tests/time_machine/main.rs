//! Every simulation is its log: undo, redo, fork and verify, snapshots that round-trip bit for
//! bit and thin over long histories, seeded properties over random call sequences, the recorded
//! sessions in replays/ replaying to their hashes, logs of earlier releases, engine builds, and
//! cancelled steps logged as taken.

#[path = "../common/mod.rs"]
mod common;

mod cancelled_step;
mod compat_v1;
mod engine_build;
mod fork_chains;
mod incremental_hash;
mod properties;
mod recorded_measures;
mod record_replays;
mod replays;
mod snapshot_roundtrip;
mod snapshot_thinning;
mod timeline;
