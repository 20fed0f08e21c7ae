//! Trust at the edges: models read no file behind the log's back, outputs never replace a file,
//! a request's files are read once within a budget before its simulation is locked, one client
//! cannot sink the others, a shutdown always ends, a server started anywhere keeps its files
//! somewhere usable, a client writes files only where and as it may, and the source tree keeps
//! the rules that make these checkable.

#[path = "../common/mod.rs"]
mod common;

mod architecture;
mod file_fuzz;
mod interleavings;
mod bounded_requests;
mod default_dirs;
mod isolation;
mod noisy_neighbour;
mod isolation_sessions;
mod isolation_viewer;
mod model_files;
mod output_files;
mod shutdown;
mod write_files;
