//! `physics-mcp export` and `import`: a simulation's log between a cluster and a SQLite file,
//! so a run moves from a laptop into the cluster and back, and `replay` verifies either way.

use std::path::Path;

use super::Cluster;
use crate::log::whole;
use crate::log::SyncMode;
use crate::sim::Sim;

/// Writes simulation `id`'s log from the cluster into a new SQLite file `out` (refused if it
/// exists): the events, head, blobs and snapshots an embedded server would have written.
/// Returns how many events it holds.
pub fn export(cluster: &Cluster, id: &str, out: &Path) -> Result<usize, String> {
    if !super::valid_id(id) {
        return Err(format!("{} {id}", super::transfer::NO_LOG));
    }
    whole::write_new_file(out, |staged| {
        cluster.materialize(id, staged, SyncMode::Full)?;
        whole::event_count(staged).map_err(|e| e.to_string())
    })
}

/// Puts the simulation in SQLite log `file` into the cluster, under its own id or `new_id`
/// (refused if that id exists there). The log is folded and checked first, so a damaged file
/// never enters the cluster. Returns the id it has there.
pub fn import(cluster: &Cluster, file: &Path, new_id: Option<&str>) -> Result<String, String> {
    let (_dir, staged, id) = whole::copy_as(file, new_id).map_err(|e| if new_id.is_some() { format!("--as: {e}") } else { e })?;
    // Every recorded hash checked (results too) before anything reaches the cluster.
    crate::log::replay::replay(&staged, None, |_, _| {}).map_err(|e| format!("{} does not verify: {e}", file.display()))?;
    let sim = Sim::recover(&staged, SyncMode::Normal).map_err(|e| format!("{} does not verify: {e}", file.display()))?;
    let entry = crate::sim::cluster::index_entry(&sim);
    // No ownership is taken: the first node a call reaches takes it. The subject must be empty
    // (an upload expects sequence 0), so an id the cluster has is refused.
    cluster
        .upload(&id, sim.log(), 0)
        .map_err(|e| if e.contains("already exists") { format!("{e}; pass --as NEW_ID") } else { e })?;
    cluster.index_put(&id, &entry)?;
    Ok(id)
}
