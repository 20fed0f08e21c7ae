//! Many calls at once: batches all or nothing, sweeps over forks side by side, and twenty
//! concurrent clients losing and inventing nothing.

#[path = "../common/mod.rs"]
mod common;

mod batch;
mod compact_replies;
mod concurrent_clients;
mod sweep;
