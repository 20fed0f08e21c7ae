//! A log as a whole, for moving it elsewhere and back (cluster mode, `export`, `import`):
//! written into a new SQLite file commit by commit, a file staged beside its final name and
//! renamed when complete, and a copy of a file under another simulation id.

use std::path::{Path, PathBuf};

use super::sqlite::Log;
use super::{Event, EventLog, Kind, StoreError, SyncMode};

/// One commit of a log with everything it needs: its events (inherited ones flagged), the
/// head after it, its snapshots (seq, bytes, content hash) and the blobs its events name.
#[derive(Default)]
pub struct CommitParts {
    /// The events, in seq order.
    pub events: Vec<Event>,
    /// The head after the commit.
    pub head: u64,
    /// Snapshots taken with it.
    pub snapshots: Vec<(u64, Vec<u8>, String)>,
    /// Blobs (hash, bytes) its events name.
    pub blobs: Vec<(String, Vec<u8>)>,
}

/// Writes a new SQLite log of simulation `id` at `path` from its commits, in order (a file
/// there is refused).
pub fn write_log(path: &Path, id: &str, sync: SyncMode, commits: Vec<CommitParts>) -> Result<(), StoreError> {
    let mut log = Log::create(path, id, sync)?;
    for c in commits {
        for (hash, bytes) in &c.blobs {
            log.put_blob(hash, bytes)?;
        }
        if c.events.is_empty() {
            continue;
        }
        let snaps: Vec<_> = c.snapshots.iter().map(|(s, b, h)| (*s, b.as_slice(), h.as_str())).collect();
        log.import_commit(&c.events, c.head, &snaps)?;
    }
    Ok(())
}

/// Everything of a log as one commit: all its events, its head, every snapshot and blob.
pub fn as_one_commit(log: &dyn EventLog) -> Result<CommitParts, StoreError> {
    let mut snapshots = Vec::new();
    for seq in log.snapshot_seqs()? {
        if let Some((bytes, hash)) = log.snapshot_at(seq)? {
            snapshots.push((seq, bytes, hash));
        }
    }
    Ok(CommitParts { events: log.all_events()?, head: log.head_seq(), snapshots, blobs: log.blobs()? })
}

/// Writes a new file `out` through `write(staged)`: staged in a directory beside it and
/// renamed into place once complete, so a failure leaves nothing at `out`; an existing `out`
/// is refused.
pub fn write_new_file<T>(out: &Path, write: impl FnOnce(&Path) -> Result<T, String>) -> Result<T, String> {
    if out.exists() {
        return Err(format!("{} already exists", out.display()));
    }
    let beside = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let dir = tempfile::tempdir_in(beside).map_err(|e| format!("cannot write beside {}: {e}", out.display()))?;
    let staged = dir.path().join("staged.sqlite");
    let made = write(&staged)?;
    std::fs::rename(&staged, out).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    Ok(made)
}

/// How many events the log at `path` holds.
pub fn event_count(path: &Path) -> Result<usize, StoreError> {
    Ok(Log::open_read_only(path)?.all_events()?.len())
}

/// A copy of the log `file` as simulation `new_id` (its own id when `None`), in a temporary
/// directory (kept as long as the returned handle): every event of its own (not inherited from
/// an ancestor) names the new id wherever it named the old one — arguments, command, result,
/// summary — with its result hash recomputed (a read's, which hashes a result not kept, is
/// dropped: `replay` then re-runs the read without checking it); the ids are UUID-like, so a
/// textual replacement touches nothing else. Returns the copy's path and the id it has.
pub fn copy_as(file: &Path, new_id: Option<&str>) -> Result<(tempfile::TempDir, PathBuf, String), String> {
    let source = Log::open_read_only(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let old_id = source.simulation_id().map_err(|e| e.to_string())?;
    let id = new_id.unwrap_or(&old_id).to_string();
    if id.is_empty() || id.len() > 64 || !id.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(format!("the id must be 1 to 64 letters, digits, '-' or '_' (a file name and a NATS key), not {id:?}"));
    }
    let mut whole = as_one_commit(&source).map_err(|e| e.to_string())?;
    if whole.events.is_empty() {
        return Err(format!("{} holds no events", file.display()));
    }
    if old_id != id {
        for e in whole.events.iter_mut().filter(|e| !e.inherited) {
            rename(e, &old_id, &id);
        }
    }
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let path = dir.path().join(format!("{id}.sqlite"));
    write_log(&path, &id, SyncMode::Normal, vec![whole]).map_err(|e| e.to_string())?;
    Ok((dir, path, id))
}

/// An event of `old_id` as one of `new_id`.
fn rename(e: &mut Event, old_id: &str, new_id: &str) {
    let swap = |text: &mut String| *text = text.replace(old_id, new_id);
    swap(&mut e.arguments);
    for field in [&mut e.command, &mut e.result, &mut e.summary].into_iter().flatten() {
        swap(field);
    }
    match (&e.result, &e.result_hash) {
        (Some(result), Some(_)) => e.result_hash = Some(crate::digest::result_hash(result)),
        // A read records the hash of what it returned, not the result itself: one that named
        // the old id cannot be re-hashed here, so a renamed copy's reads go unchecked.
        (None, Some(_)) if e.kind == Kind::Read => e.result_hash = None,
        _ => {}
    }
}
