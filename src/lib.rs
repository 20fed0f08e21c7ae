//! physics-mcp: an MCP server for deterministic, replayable rigid-body simulations.
//!
//! # Layout
//! The deterministic core is its own crate, `crates/physics-core` (re-exported here, so these
//! are also `physics_mcp::world`, …); its `clippy.toml` bans clocks, randomness, the
//! environment, files, threads and hash maps there:
//! - `value`   — parsing tool arguments (vectors, quaternions, numbers) with clear refusals.
//! - `command` — `Command`, the validated form of every state-changing call, and its checks.
//! - `world`   — the deterministic state machine over rapier3d: `apply`, `state_hash`,
//!   `snapshot`/`restore`. No I/O, no clock, no randomness.
//! - `outputs` — the structured results of the tools (with JSON schemas).
//! - `digest`  — content hashes of snapshots and blobs (blake3, parallel when large).
//! - `limits`  — the limits every request is checked against.
//!
//! The server, in this crate, by layer (each may use the ones above it, never below;
//! docs/design.md has the code map and the rules, tests/edges/architecture.rs checks them):
//! - `params`  — every tool's argument types and lenient values: the log's argument schema.
//! - `files`   — the only code that opens a user's path: sandbox, bounded reads, the write
//!   policy, URDF and MJCF with their meshes, the save format, NPY.
//! - `log`     — the event log behind one trait (`EventLog`; SQLite today), the data
//!   directory, the one fold routine and replay.
//! - `sim`     — `Sim` (log + world), the `Registry` and its lock order, the one apply path,
//!   timeline (undo/redo/fork/verify), sweeps, reads, save/load, the reply budget.
//! - `seeing`  — sensing, trajectories, animations, the session report and the web viewer.
//! - `mcp`     — the MCP protocol (transports, sessions, subscriptions, logging, resources,
//!   prompts) and `mcp::tools`, one thin adapter file per tool family.
//! - `cli`, `client`, `secret`, `shutdown`, `failpoints` — flags, `physics-mcp call`, the
//!   token from a file or the environment, the process-wide shutdown, test-only crash points.
#![warn(missing_docs)]

pub use physics_core::{command, digest, engine, limits, measure, outputs, value, world};

pub mod cli;
pub mod cluster;
pub mod client;
pub mod failpoints;
pub mod files;
pub mod log;
pub mod mcp;
pub mod params;
pub mod secret;
pub mod seeing;
pub mod shutdown;
pub mod sim;
