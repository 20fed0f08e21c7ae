//! What survives: saved files loading exactly (ours and the old server's), restarts and kill -9
//! losing nothing acknowledged, corrupt files never served, and a full disk changing nothing.

#[path = "../common/mod.rs"]
mod common;

mod corrupt_files;
mod full_disk;
mod old_server_files;
mod recovery;
mod save_load;
