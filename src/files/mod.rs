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
//!   when they are its own, the command line replaces only with `--force`.
//!
//! Third-party parsers (urdf-rs, mjcf-rs, mesh readers) are handed bytes read here, never a
//! path: a fold reads nothing but the log.

pub mod mjcf;
pub mod npy;
pub mod read;
mod sandbox;
pub mod save_format;
pub mod urdf;
pub mod write;

pub use read::Reader;
pub use sandbox::Sandbox;
