//! `physics-mcp export` and `import`: a simulation's log between a cluster and a SQLite file,
//! so a run moves from a laptop into the cluster and back, and `replay` verifies either way.

use std::path::Path;

use super::{Cluster, IndexEntry};
use crate::log::sqlite::Log;
use crate::log::{Event, EventLog, Kind, SyncMode};
use crate::sim::Sim;

/// Writes simulation `id`'s log from the cluster into a new SQLite file `out` (refused if it
/// exists): the events, head, blobs and snapshots an embedded server would have written.
/// Returns how many events it holds.
pub fn export(cluster: &Cluster, id: &str, out: &Path) -> Result<usize, String> {
    if out.exists() {
        return Err(format!("{} already exists", out.display()));
    }
    let dir = tempfile::tempdir_in(
        out.parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new(".")),
    )
    .map_err(|e| format!("cannot write beside {}: {e}", out.display()))?;
    let staged = dir.path().join("export.sqlite");
    cluster.materialize(id, &staged, SyncMode::Full)?;
    let events = Log::open_read_only(&staged)
        .and_then(|l| l.all_events())
        .map_err(|e| e.to_string())?
        .len();
    std::fs::rename(&staged, out).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    Ok(events)
}

/// Puts the simulation in SQLite log `file` into the cluster, under its own id or `new_id`
/// (refused if that id exists there). The log is folded and checked first, so a damaged file
/// never enters the cluster. Returns the id it has there.
pub fn import(cluster: &Cluster, file: &Path, new_id: Option<&str>) -> Result<String, String> {
    let source = Log::open_read_only(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let old_id = source.simulation_id().map_err(|e| e.to_string())?;
    let id = new_id.unwrap_or(&old_id).to_string();
    if id.is_empty() || id.len() > 64 || !id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(format!(
            "--as must be 1 to 64 letters, digits, '-' or '_' (a file name and a NATS key), not {id:?}"
        ));
    }
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let staged = dir.path().join(format!("{id}.sqlite"));
    copy_renamed(&source, &staged, &old_id, &id)?;
    drop(source);
    let sim =
        Sim::recover(&staged, SyncMode::Normal).map_err(|e| format!("{} does not verify: {e}", file.display()))?;
    let entry = IndexEntry {
        name: sim.world().name().map(str::to_string),
        objects: sim.world().object_count(),
        simulation_time: sim.world().current_time(),
    };
    let epoch = cluster
        .acquire(&id)
        .map_err(|_| format!("a simulation with id {id} already exists in the cluster; pass --as NEW_ID"))?;
    let uploaded = cluster
        .upload(&id, sim.storage(), epoch)
        .and_then(|_| cluster.index_put(&id, &entry));
    cluster.release(&id);
    uploaded.map(|()| id)
}

/// Copies a log into a new file, as simulation `new_id`: its own roots' commands and results
/// name the new id (their result hashes recomputed); nothing else changes.
fn copy_renamed(source: &Log, to: &Path, old_id: &str, new_id: &str) -> Result<(), String> {
    let mut log = Log::create(to, new_id, SyncMode::Normal).map_err(|e| e.to_string())?;
    for (hash, bytes) in source.blobs().map_err(|e| e.to_string())? {
        log.put_blob(&hash, &bytes).map_err(|e| e.to_string())?;
    }
    let mut events = source.all_events().map_err(|e| e.to_string())?;
    if old_id != new_id {
        for e in events.iter_mut().filter(|e| e.kind == Kind::Root && !e.inherited) {
            rename_root(e, old_id, new_id)?;
        }
    }
    let mut snaps = Vec::new();
    for seq in source.snapshot_seqs().map_err(|e| e.to_string())? {
        if let Some((bytes, hash)) = source.snapshot_at(seq).map_err(|e| e.to_string())? {
            snaps.push((seq, bytes, hash));
        }
    }
    let snaps: Vec<_> = snaps.iter().map(|(s, b, h)| (*s, b.as_slice(), h.as_str())).collect();
    if events.is_empty() {
        return Err("the log holds no events".into());
    }
    log.import_commit(&events, source.head_seq(), &snaps)
        .map_err(|e| e.to_string())
}

/// A root event of `old_id` as one of `new_id`.
fn rename_root(e: &mut Event, old_id: &str, new_id: &str) -> Result<(), String> {
    let swap = |text: &str| -> Result<String, String> {
        let mut v: serde_json::Value =
            serde_json::from_str(text).map_err(|err| format!("event {} does not decode: {err}", e.seq))?;
        if let Some(obj) = v.as_object_mut() {
            if obj.get("simulation_id").and_then(|s| s.as_str()) == Some(old_id) {
                obj.insert("simulation_id".into(), new_id.into());
            }
        }
        Ok(v.to_string())
    };
    if let Some(command) = &e.command {
        e.command = Some(swap(command)?);
    }
    if let Some(result) = &e.result {
        let renamed = swap(result)?;
        e.result_hash = Some(crate::digest::result_hash(&renamed));
        e.result = Some(renamed);
    }
    Ok(())
}
