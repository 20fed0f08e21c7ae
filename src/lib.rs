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
//! The server, in this crate:
//! - `reads`   — the read-only tools, shared by the MCP adapters and replay.
//! - `fold`    — the one fold routine (decode → check → apply → compare the recorded hash).
//! - `store`   — the SQLite event log of one simulation: events, head, snapshots, blobs.
//! - `sim`     — `Sim` = log + world (decide → apply → append → reply) and the `Registry`.
//! - `timeline` — undo, redo, history, verify and fork: operations on the log.
//! - `mcp`     — rmcp adapters: JSON arguments → `Command` → `Sim` → MCP result; HTTP, stdio.
//! - `replay`  — replay, history and diff of a log (the CLI).
//! - `save`    — the saved-file format, save and load.
//! - `workspace` — the path sandbox for user files.
//! - `urdf_files` — reading URDFs and meshes (and the built-in assets) for load_urdf;
//!   writing generate_revolute_joint's URDFs.
//! - `sensing` — rays, contacts, camera matrices and the CPU renderer (read-only).
//! - `report`  — a recorded session as a self-contained HTML page; `replay --render`.
//! - `animation` — frames of re-simulated intervals → looping GIFs (palette, encoder).
//! - `trajectory` — the pose sampler over the re-simulation core (get_trajectory, CSV/JSONL).
//! - `failpoints` — crash points for the crash-loop test (feature `failpoints` only).
//! - `cli`     — command-line flags for core structs (`LimitArgs` → `Limits`).
//! - `npy`     — NumPy `.npy` files for get_camera_image's depth and segmentation arrays.
#![warn(missing_docs)]

pub use physics_core::{command, digest, engine, limits, outputs, value, world};

pub mod cli;
pub mod client;
pub mod failpoints;
pub mod files;
pub mod log;
pub mod mcp;
pub mod params;
pub mod seeing;
pub mod shutdown;
pub mod sim;
