//! Writes this crate's engine build (`engine::ENGINE_BUILD`) from the workspace's Cargo.lock:
//! the versions of every crate in physics-core's locked dependency closure that can change a
//! fold's result (src/engine/lock.rs decides which, and the text). It runs when the crate is
//! compiled, never in a fold, so the library itself still reads no file.

#[path = "src/engine/lock.rs"]
mod lock;

// The build script is the one place in this crate that reads a file and the environment
// (clippy.toml bans both for the library): Cargo.lock in, OUT_DIR/engine_build.txt out.
#[expect(clippy::disallowed_methods, reason = "the build script reads Cargo.lock and writes into OUT_DIR at compile time")]
fn main() {
    // Read when the script runs, not baked in when it is compiled: one compiled script may be
    // shared by checkouts at other paths (worktrees sharing a target directory).
    let manifest_dir = std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let lock_path = std::path::Path::new(&manifest_dir).join("../../Cargo.lock");
    println!("cargo::rerun-if-changed={}", lock_path.display());
    let lock = std::fs::read_to_string(&lock_path).unwrap_or_else(|e| panic!("cannot read {}: {e}", lock_path.display()));
    let map = lock::engine_map(&lock).unwrap_or_else(|e| panic!("{}: {e}", lock_path.display()));
    let out = std::path::Path::new(&std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("engine_build.txt");
    std::fs::write(&out, lock::encode(&map)).unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}
