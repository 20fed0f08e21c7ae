//! physics-core: the deterministic core of physics-mcp — a pure fold from commands to state.
//!
//! Nothing here reads a clock, randomness, the environment or files, spawns a thread or
//! iterates a hash map: `clippy.toml` beside this crate's `Cargo.toml` bans them, and CI runs
//! clippy on every target with `-D warnings`. The server crate (SQLite log, MCP adapters,
//! CLI) re-exports these modules, so they are also `physics_mcp::world`, `physics_mcp::command`, ….
//!
//! # Layout
//! - `value`   — parsing tool arguments (vectors, quaternions, numbers) with clear refusals.
//! - `command` — `Command`, the validated form of every state-changing call, and its checks.
//! - `world`   — the deterministic state machine over rapier3d: `apply`, `state_hash`,
//!   `snapshot`/`restore`.
//! - `outputs` — the structured results of the tools (with JSON schemas).
//! - `digest`  — content hashes of snapshots and blobs (blake3, parallel when large).
//! - `engine`  — the engine build every root event records: a crate → version map of the
//!   result-affecting crates, taken from `Cargo.lock` by `build.rs` at compile time.
//! - `measure` — what a `measure` asks (step_simulation's is part of its command).
//! - `limits`  — the limits every request is checked against (a plain struct; the CLI's flags
//!   for them live in the server crate).
#![warn(missing_docs)]

pub mod command;
pub mod digest;
pub mod engine;
pub mod limits;
pub mod measure;
pub mod outputs;
pub mod value;
pub mod world;
