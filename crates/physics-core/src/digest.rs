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

/// blake3 of a result's JSON text, as lowercase hex: what an event records and `replay`
/// recomputes (one definition, so the two cannot drift).
pub fn result_hash(json: &str) -> String {
    blake3::hash(json.as_bytes()).to_hex().to_string()
}
