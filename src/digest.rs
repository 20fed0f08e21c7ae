//! Content hashes (blake3, hex) of snapshots and blobs. Large inputs are hashed on all cores
//! (blake3's tree hashing gives the same digest however it is split): a 1000-body snapshot is
//! several MB, and its hash sits on the path of every snapshot and restore.

/// Inputs at least this large are hashed in parallel.
const PARALLEL_FROM: usize = 256 * 1024;

/// blake3 of `bytes`, as lowercase hex.
pub fn content_hash(bytes: &[u8]) -> String {
    if bytes.len() >= PARALLEL_FROM {
        blake3::Hasher::new().update_rayon(bytes).finalize().to_hex().to_string()
    } else {
        blake3::hash(bytes).to_hex().to_string()
    }
}
