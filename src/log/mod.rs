//! The event log: its SQLite storage, the data directory, the one fold routine and replay.

pub mod data_dir;
pub mod fold;
pub mod replay;
pub mod sqlite;
