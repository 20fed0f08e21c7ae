//! Bad input gets one clear sentence and changes nothing: table-driven refusals, seeded fuzzing
//! of every tool's arguments, hostile logs and saved files, and replies held to the budget
//! without contradicting the log.

#[path = "../common/mod.rs"]
mod common;

mod bad_inputs;
mod fuzz_tools;
mod hostile_saved_files;
mod log_and_cli_edges;
mod reply_budget;
mod reply_matches_log;
