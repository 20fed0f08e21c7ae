//! The files layer: the only code of the server that opens a path a user named — tool
//! arguments (`file_path`, `output_path`), the files a model names inside itself (MJCF
//! includes and meshes, URDF meshes) and the command line's inputs and outputs. A test
//! (`tests/edges/architecture.rs`) fails on file-system calls anywhere else but the log's own
//! storage (`log/`).
//!
//! - `sandbox` — resolving a user path inside the workspace (and out of the data directory).
//! - `read`    — regular files only, bounded from the open handle; one request reads each
//!   file once, within a byte budget.
//! - `write`   — one policy: outputs are created new, a tool's own files are replaced only
//!   when they are its own, the command line replaces only with `--force`, a client's own
//!   files (write_file) are created new unless it says to replace them.
//! - `library` — the built-in models (the basic assets and the installed model library),
//!   found by name when the workspace has no such file.
//! - `model_files` — where a model's own files (meshes, includes) are found: the workspace,
//!   or the library for a built-in.
//! - `listing` — list_files: what the workspace holds.
//!
//! Third-party parsers (urdf-rs, mjcf-rs, mesh readers) are handed bytes read here, never a
//! path: a fold reads nothing but the log.

pub mod library;
pub mod listing;
pub mod mjcf;
pub mod model_files;
pub mod npy;
pub mod read;
mod sandbox;
pub mod save_format;
pub mod urdf;
pub mod write;

pub use read::Reader;
pub use sandbox::Sandbox;
