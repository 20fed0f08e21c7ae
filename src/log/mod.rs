//! The event log: what every backend of it provides ([`EventLog`]), its SQLite storage
//! (`sqlite`), the data directory (`data_dir`) and where it goes by default (`default_dirs`), the one fold routine (`fold`), `replay`, and
//! the one-line summary a read event records (`summary`).
//!
//! A simulation *is* its log; the world in memory is a cache equal to the fold of it. The
//! trait is what the rest of the server uses a log through: appends fenced by the seq they
//! expect to follow, reads of events and chains, blobs and snapshots, the head. SQLite is
//! the embedded backend; in cluster mode a SQLite log is the cache of a replicated log of
//! record that every commit reaches first ([`Replica`], `crate::cluster`, docs/cluster.md).

pub mod data_dir;
pub mod default_dirs;
pub mod fold;
pub mod replay;
pub mod sqlite;
pub mod summary;
pub mod whole;

pub use sqlite::{Event, Kind, Snap, StoreError, SyncMode};

/// What a SQLite log sends to the log of record it mirrors (cluster mode, `crate::cluster`):
/// every commit, before the SQLite transaction, so nothing is acknowledged that the log of
/// record lacks. The SQLite file is then a cache of it that any node can rebuild.
pub trait Replica: Send {
    /// Makes a blob durable in the log of record (before the event that names it).
    fn put_blob(&mut self, hash: &str, bytes: &[u8]) -> Result<(), StoreError>;
    /// Appends one commit, all or nothing: `events` (each with whether it is inherited: a
    /// fork's copied chain is recorded flagged), the new `head` and the snapshots taken with
    /// it. Refused ([`StoreError::Fenced`]) when another owner wrote since.
    fn append(&mut self, events: &[(&Event, bool)], head: u64, snapshots: &[Snap]) -> Result<(), StoreError>;
    /// Records in the log of record that the simulation is destroyed, fenced like an append
    /// (destroy_simulation, before anything of it is removed); nothing is appended after it.
    fn seal(&mut self) -> Result<(), StoreError>;
}

/// Why an append was not made.
#[derive(Debug, thiserror::Error)]
pub enum AppendError {
    /// The log does not end where the caller expected: another writer appended first (or the
    /// caller lost track). Nothing was written.
    #[error("the log ends at event {actual}, not at event {expected} as the append expected")]
    Conflict {
        /// The last seq the append expected.
        expected: u64,
        /// The log's last seq.
        actual: u64,
    },
    /// The backend failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// What any backend of the event log provides. Events are numbered by seq (1, 2, …); the
/// head is the state-changing event the world reflects; read and refused events may be
/// buffered (`append_lazy`) and are committed with the next append or a `flush`.
pub trait EventLog: crate::command::BlobSource + Send {
    /// The simulation this log is of.
    fn simulation_id(&self) -> Result<String, StoreError>;
    /// The seq of the last event appended (committed or buffered).
    fn last_seq(&self) -> u64;
    /// The state-changing event the world reflects.
    fn head_seq(&self) -> u64;
    /// The seq the next event gets.
    fn next_seq(&self) -> u64 {
        self.last_seq() + 1
    }

    /// Commits `events` (consecutive seqs following the log's end — else a conflict, writing
    /// nothing), the buffered events, `head` as the new head and `snapshots`, all or nothing;
    /// returns once durable.
    fn append(&mut self, events: &[Event], head: u64, snapshots: &[Snap]) -> Result<(), AppendError>;
    /// Buffers a read or refused event (committed with the next append or flush).
    fn append_lazy(&mut self, event: Event) -> Result<(), StoreError>;
    /// Commits buffered events.
    fn flush(&mut self) -> Result<(), StoreError>;

    /// One event by seq.
    fn event(&self, seq: u64) -> Result<Option<Event>, StoreError>;
    /// Events with seq > `since`, ascending, at most `limit`.
    fn events_since(&self, since: u64, limit: usize) -> Result<Vec<Event>, StoreError>;
    /// Every event in seq order.
    fn all_events(&self) -> Result<Vec<Event>, StoreError>;
    /// The chain of state-changing events from the root to `head`, root first.
    fn chain_to(&self, head: u64) -> Result<Vec<Event>, StoreError>;
    /// The chain back from `head` (newest first), stopping after the first event `stop`
    /// accepts.
    fn chain_back(&self, head: u64, stop: &mut dyn FnMut(&Event) -> bool) -> Result<Vec<Event>, StoreError>;
    /// The head the last own root, change or move left (recovery checks the stored head).
    fn head_by_events(&self) -> Result<Option<u64>, StoreError>;
    /// This simulation's own root command (its gui flag).
    fn own_root_command(&self) -> Result<Option<String>, StoreError>;

    /// Stores a blob under its hash (before the event that uses it).
    fn put_blob(&mut self, hash: &str, bytes: &[u8]) -> Result<(), StoreError>;
    /// A blob's bytes.
    fn get_blob(&self, hash: &str) -> Option<Vec<u8>>;
    /// Every blob (hash, bytes): what a whole log carries when it moves (cluster, export).
    fn blobs(&self) -> Result<Vec<(String, Vec<u8>)>, StoreError>;
    /// Arguments as recorded: inline, or a blob reference when large.
    fn store_arguments(&mut self, args_json: String) -> String;

    /// The snapshot at `seq` (bytes, content hash).
    fn snapshot_at(&self, seq: u64) -> Result<Option<(Vec<u8>, String)>, StoreError>;
    /// Every snapshot's seq.
    fn snapshot_seqs(&self) -> Result<Vec<u64>, StoreError>;
    /// The seqs of the snapshots on the chain to `head`, newest first.
    fn chain_snapshot_seqs(&self, head: u64) -> Result<Vec<u64>, StoreError>;
    /// Deletes snapshots (thinning).
    fn delete_snapshots(&mut self, seqs: &[u64]) -> Result<(), StoreError>;
}
