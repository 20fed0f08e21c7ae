//! Shared pieces of the hardening tests: a replayable seed, and the per-simulation
//! fingerprint (state hash, head, history length) that a refused call must leave unchanged.

use rand::SeedableRng;
use serde_json::{json, Value};

use super::Client;

/// The test's seed: `PHYSICS_SEED` when set (to replay a failure), else fresh. Printed as
/// `seed=N` so a failing run says how to replay it.
pub fn seed() -> u64 {
    let seed = std::env::var("PHYSICS_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(rand::random::<u64>);
    eprintln!("seed={seed} (replay with PHYSICS_SEED={seed})");
    seed
}

/// A deterministic generator from `seed`.
pub fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// What a refused call must not move: the state hash and head, with the last seq to count
/// later state-changing events from.
#[derive(Debug, PartialEq, Eq, Clone)]
pub struct Fingerprint {
    /// get_simulation_info's state_hash.
    pub state_hash: String,
    /// The head of the log.
    pub head_seq: u64,
    /// The last event appended (any kind).
    pub last_seq: u64,
}

/// The fingerprint of `sim`, read through the tools.
pub async fn fingerprint(c: &Client, sim: &str) -> Fingerprint {
    let info = c.call("get_simulation_info", json!({"sim_id": sim})).await;
    Fingerprint {
        state_hash: info["state_hash"].as_str().unwrap_or_default().to_string(),
        head_seq: info["head_seq"].as_u64().unwrap_or_default(),
        last_seq: info["last_seq"].as_u64().unwrap_or_default(),
    }
}

/// State-changing events (root, change, move) logged after `since` (up to 1,000 looked at).
pub async fn changes_since(c: &Client, sim: &str, since: u64) -> usize {
    let h = c.call("get_history", json!({"sim_id": sim, "since_seq": since, "limit": 1000})).await;
    h["events"]
        .as_array()
        .map(|es| es.iter().filter(|e| matches!(e["kind"].as_str(), Some("root" | "change" | "move"))).count())
        .unwrap_or(0)
}

/// Asserts a refused call changed nothing: same hash and head as `before`, and no
/// state-changing event logged since.
pub async fn assert_unchanged(c: &Client, sim: &str, before: &Fingerprint, what: &str) {
    let after = fingerprint(c, sim).await;
    assert_eq!((&after.state_hash, after.head_seq), (&before.state_hash, before.head_seq), "{what} changed {sim}");
    assert_eq!(changes_since(c, sim, before.last_seq).await, 0, "{what} logged a change on {sim}");
}

/// Ids of list_simulations' `simulations` and `damaged`.
pub fn listed(list: &Value) -> (Vec<String>, Vec<(String, String)>) {
    let ids = list["simulations"].as_array().unwrap().iter().map(|s| s["simulation_id"].as_str().unwrap().to_string()).collect();
    let damaged = list["damaged"]
        .as_array()
        .map(|d| {
            d.iter()
                .map(|s| (s["simulation_id"].as_str().unwrap().to_string(), s["reason"].as_str().unwrap().to_string()))
                .collect()
        })
        .unwrap_or_default();
    (ids, damaged)
}

/// Whether the server process has exited (a crash point fired).
pub fn exited(server: &mut super::Server) -> bool {
    server.child.try_wait().ok().flatten().is_some()
}

/// The server's process id (for reading its peak memory).
pub fn pid(server: &super::Server) -> u32 {
    server.child.id()
}
