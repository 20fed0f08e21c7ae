//! Cluster mode (`serve --cluster nats://…`) against a real three-server NATS JetStream cluster:
//! the same answers and logs as embedded mode (from one node, and from three nodes called
//! round-robin: any node answers any call), no acknowledged call lost when an owner node or a
//! NATS server is killed (behind a balancer too), a paused owner fenced off, notifications,
//! progress and cancellation carried between nodes, and logs moved in and out with
//! `import`/`export`. Every test needs `nats-server` (`NATS_SERVER`, `PATH`, or the venv named in
//! nats.rs) and is ignored by a plain `cargo test`:
//!
//!   cargo test --test cluster -- --ignored --test-threads=1

#[path = "../common/mod.rs"]
mod common;

mod ledger;
mod lockstep;
mod nats;
mod nodes;

mod any_size;
mod balancer_crash;
mod big_batch;
mod distributed_sweep;
mod destroyed;
mod equivalence;
mod fault_schedule;
mod fenced_everywhere;
mod fencing;
mod import_export;
mod nats_crash;
mod notifications;
mod owner_crash;
mod round_robin;
mod shared_files;
mod smoke;
