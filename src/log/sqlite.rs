//! The event log of one simulation: a SQLite file (WAL) holding events, the head, snapshots
//! and blobs. All SQL text lives in this module.
//!
//! State-changing events (root, change, move) are committed — together with any buffered read
//! and refused events, the head and an optional snapshot — in one transaction before the call
//! replies. Read and refused events are buffered and committed with the next write, every
//! `LAZY_FLUSH_AT` events, or on `flush` (they may be lost if the process is killed; docs/log-format.md
//! allows that). `--sync normal` survives a killed process (WAL); `--sync full` also fsyncs
//! every commit, for power loss.

pub use super::data_dir;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::EventLog;

use rusqlite::{params, Connection, OptionalExtension};

/// Schema migrations, applied in order; `PRAGMA user_version` counts those applied.
const MIGRATIONS: &[&str] = &[
    include_str!("../../migrations/0001_init.sql"),
    include_str!("../../migrations/0002_engine_build.sql"),
    include_str!("../../migrations/0003_read_summary.sql"),
];

/// The first schema version whose events have the `engine` column (read-only opens of older
/// files read it as NULL: roots made before builds were recorded).
const ENGINE_COLUMN_SINCE: i64 = 2;

/// The first schema version whose events have the `summary` column (read-only opens of older
/// files read it as NULL: reads made before their summaries were recorded).
const SUMMARY_COLUMN_SINCE: i64 = 3;

/// Buffered read/refused events are committed once this many are waiting.
const LAZY_FLUSH_AT: usize = 256;

/// Arguments longer than this are stored as a blob and referenced from the event.
pub const INLINE_ARGS_MAX: usize = 64 * 1024;

/// Durability of commits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Default)]
pub enum SyncMode {
    /// Survives a killed process (WAL, synchronous=NORMAL).
    #[default]
    Normal,
    /// Also survives power loss: fsync on every commit (synchronous=FULL).
    Full,
}

/// What an event is (docs/log-format.md "Events, heads and hashes").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// create/load/fork: the first state of this simulation.
    Root,
    /// An accepted state-changing call.
    Change,
    /// An accepted undo/redo.
    Move,
    /// Any other accepted call.
    Read,
    /// Any rejected call.
    Refused,
}

impl Kind {
    /// The name stored in the log.
    pub fn as_str(self) -> &'static str {
        match self {
            Kind::Root => "root",
            Kind::Change => "change",
            Kind::Move => "move",
            Kind::Read => "read",
            Kind::Refused => "refused",
        }
    }

    /// The kind a stored name stands for (`None`: not a kind; a damaged or hostile record).
    pub fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "root" => Kind::Root,
            "change" => Kind::Change,
            "move" => Kind::Move,
            "read" => Kind::Read,
            "refused" => Kind::Refused,
            _ => return None,
        })
    }

    /// Root and change events change the world and form the tree.
    pub fn is_state_changing(self) -> bool {
        matches!(self, Kind::Root | Kind::Change)
    }
}

/// One event row.
#[derive(Clone, Debug)]
pub struct Event {
    /// Position in the log (1, 2, …).
    pub seq: u64,
    /// What kind of event it is.
    pub kind: Kind,
    /// For root/change: the head it was applied on.
    pub parent: Option<u64>,
    /// The tool called.
    pub tool: String,
    /// The client's arguments (JSON text, or a blob reference).
    pub arguments: String,
    /// The validated command (JSON text) for root/change events.
    pub command: Option<String>,
    /// Event encoding version.
    pub version: u32,
    /// Accepted or refused.
    pub ok: bool,
    /// Whether it changed the world (root/change).
    pub mutates: bool,
    /// Copied from an ancestor simulation.
    pub inherited: bool,
    /// Result JSON (state-changing) or refusal sentence.
    pub result: Option<String>,
    /// blake3 of the result JSON.
    pub result_hash: Option<String>,
    /// The state hash after this event.
    pub state_hash: String,
    /// Root events: the engine build that made them (`physics_core::engine::ENGINE_BUILD`
    /// of that binary); `None` on other events and on roots recorded before builds were.
    pub engine: Option<String>,
    /// Read events: a one-line summary of what they returned (`log::summary::one_line`);
    /// `None` on other events and on reads recorded before schema v3. Part of no hash.
    pub summary: Option<String>,
}

impl Event {
    /// An event of `kind` at `seq` with nothing decided yet (no parent, command, result or
    /// hash): what every call's event starts as, alone or in a batch.
    pub fn blank(seq: u64, kind: Kind, tool: &str, arguments: String) -> Event {
        Event {
            seq,
            kind,
            parent: None,
            tool: tool.into(),
            arguments,
            command: None,
            version: crate::command::EVENT_VERSION,
            ok: kind != Kind::Refused,
            mutates: kind.is_state_changing(),
            inherited: false,
            result: None,
            result_hash: None,
            state_hash: String::new(),
            engine: None,
            summary: None,
        }
    }

    /// A root event (create, fork, load): its command, result and state, and the engine build
    /// that made it (docs/log-format.md "Compatibility of logs and files": every root records it).
    pub fn root(seq: u64, parent: Option<u64>, tool: &str, arguments: String, command: &crate::command::Command, result_json: String, state_hash: &str) -> Result<Event, String> {
        let mut e = Event::blank(seq, Kind::Root, tool, arguments);
        e.parent = parent;
        e.command = Some(serde_json::to_string(command).map_err(|err| err.to_string())?);
        e.result_hash = Some(crate::digest::result_hash(&result_json));
        e.result = Some(result_json);
        e.state_hash = state_hash.to_string();
        e.engine = Some(crate::engine::ENGINE_BUILD.into());
        Ok(e)
    }
}

/// Errors of the log layer (I/O and SQLite), reported to clients as one sentence.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// SQLite failed.
    #[error("log database error: {0}")]
    Sql(#[from] rusqlite::Error),
    /// The file's contents are not a valid log.
    #[error("log is corrupt: {0}")]
    Corrupt(String),
    /// A file operation failed.
    #[error("file system error: {0}")]
    Io(#[from] std::io::Error),
    /// The log of record (cluster mode) refused the append: another node owns the simulation
    /// now, or this node's lease on it ran out.
    #[error("this node no longer owns the simulation: {0}")]
    Fenced(String),
    /// The log of record (cluster mode) could not be reached or failed.
    #[error("the cluster log failed: {0}")]
    Cluster(String),
}

/// Suffix of a log being created (create, fork, load) before its root commits: start-up
/// skips and deletes such files, so a kill mid-creation leaves nothing half-made behind.
pub const PARTIAL_SUFFIX: &str = "partial";

/// Where a log for `final_path` is written until its root commits.
pub fn partial_path(final_path: &Path) -> PathBuf {
    final_path.with_extension(PARTIAL_SUFFIX)
}

/// Whether a file name in the data directory is a left-over partial log or its companion.
pub fn is_partial(name: &str) -> bool {
    [PARTIAL_SUFFIX, "partial-wal", "partial-shm", "partial-seq", "partial-journal"]
        .iter()
        .any(|s| name.strip_suffix(s).is_some_and(|rest| rest.ends_with('.')))
}

/// `path` with `suffix` appended (SQLite's companions: `-wal`, `-shm`; ours: `-seq`).
fn companion(path: &Path, suffix: &str) -> PathBuf {
    let mut p = path.to_path_buf().into_os_string();
    p.push(suffix);
    PathBuf::from(p)
}

/// Companion files of a log that belong to it (deleted with it); `-journal` exists only while
/// a new file is switched to WAL mode.
pub const COMPANIONS: [&str; 4] = ["-wal", "-shm", SEQ_SUFFIX, "-journal"];

/// The acknowledgement file beside a log (`<id>.sqlite-seq`): the seq of the last
/// state-changing event committed, as 8 little-endian bytes, written after each commit and
/// before the reply. A log that ends before it lost acknowledged commits (a deleted or cut
/// WAL): SQLite alone would open it as a consistent older state.
const SEQ_SUFFIX: &str = "-seq";

/// The acknowledged seq recorded beside `path`, if the file is there and whole.
fn acknowledged_seq(path: &Path) -> Option<u64> {
    let bytes = std::fs::read(companion(path, SEQ_SUFFIX)).ok()?;
    Some(u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?))
}

/// Overwrites the acknowledgement file with `seq` (in place: one 8-byte write).
fn record_acknowledged(file: &std::fs::File, seq: u64) -> std::io::Result<()> {
    use std::os::unix::fs::FileExt;
    file.write_all_at(&seq.to_le_bytes(), 0)
}

/// How long a connection waits for a lock (rusqlite's default, restored after a truncation
/// that must not wait).
const DEFAULT_BUSY_MS: u64 = 5_000;

/// Commits between background checkpoints when no snapshot triggers one sooner. Each commit of
/// a small event writes about two 64 KB pages to the WAL, so this bounds the WAL to ~20 MB
/// between checkpoints (plus the snapshots written meanwhile).
const CHECKPOINT_EVERY_COMMITS: u32 = 128;

/// The open log of one simulation.
pub struct Log {
    conn: Connection,
    path: PathBuf,
    last_seq: u64,
    head_seq: u64,
    pending: Vec<Event>,
    commits_since_checkpoint: u32,
    checkpointing: Arc<AtomicBool>,
    /// Set by the background checkpointer when it has copied the WAL: the next commit then
    /// truncates the WAL (`truncate_wal`), which a checkpoint running beside a steady stream of
    /// commits never can — without it a long session's WAL grew without bound (1.3 GB for a
    /// 9,900-object scene built call by call).
    backfilled: Arc<AtomicBool>,
    /// The SELECT list of events for this file's schema (see `event_columns`).
    select_columns: String,
    /// The acknowledgement file (`-seq`), once the log is open under its final name.
    acknowledged: Option<std::fs::File>,
    /// The log of record this file mirrors (cluster mode): every commit goes there first.
    replica: Option<Box<dyn super::Replica>>,
    /// Cluster mode: this file may be behind the log of record — a commit reached the record
    /// but not this file (a local write failed), or the record did not answer whether it took
    /// a commit, or refused it (another owner) — so it is no longer written; the registry
    /// rebuilds it from the record before the simulation is served again.
    stale: bool,
}

/// Copies the WAL into the main file on its own connection (PASSIVE: never blocks the
/// writer), then sets `backfilled`. Never creates a file: a log deleted meanwhile is simply
/// skipped.
fn checkpoint_in_background(path: PathBuf, busy: Arc<AtomicBool>, backfilled: Arc<AtomicBool>) {
    if busy.swap(true, Ordering::AcqRel) {
        return;
    }
    /// Clears the busy flag however the checkpointer ends (a panic included), so a log that
    /// waits for it never waits for ever.
    struct Done(Arc<AtomicBool>);
    impl Drop for Done {
        fn drop(&mut self) {
            self.0.store(false, Ordering::Release);
        }
    }
    let done = Done(busy.clone());
    let spawned = std::thread::Builder::new().name("checkpoint".into()).spawn(move || {
        let _done = done;
        let flags = rusqlite::OpenFlags::SQLITE_OPEN_READ_WRITE | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX;
        if let Ok(conn) = Connection::open_with_flags(&path, flags) {
            crate::crash_point!("checkpoint");
            match conn.query_row("PRAGMA wal_checkpoint(PASSIVE)", [], |_| Ok(())) {
                Ok(()) => backfilled.store(true, Ordering::Release),
                Err(e) => tracing::warn!("checkpoint of {} failed: {e}", path.display()),
            }
        }
    });
    if spawned.is_err() {
        busy.store(false, Ordering::Release);
    }
}

fn open_conn(path: &Path, sync: SyncMode) -> Result<Connection, StoreError> {
    let conn = Connection::open(path)?;
    // Snapshots are megabyte blobs: 64 KB pages cut their overflow chains 16-fold. Only
    // takes effect when the file is created (before WAL mode is set).
    conn.pragma_update(None, "page_size", 65536)?;
    conn.pragma_update(None, "journal_mode", "WAL")?;
    // Checkpoints copy the WAL into the main file; done automatically they land on whichever
    // commit crosses the threshold (a 100 ms stall after a few snapshots). `Log` runs them on
    // a background connection instead.
    conn.pragma_update(None, "wal_autocheckpoint", 0)?;
    let level = match sync {
        SyncMode::Normal => "NORMAL",
        SyncMode::Full => "FULL",
    };
    conn.pragma_update(None, "synchronous", level)?;
    conn.pragma_update(None, "foreign_keys", "ON")?;
    Ok(conn)
}

fn migrate(conn: &mut Connection) -> Result<(), StoreError> {
    let applied: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
    let applied = usize::try_from(applied).unwrap_or(usize::MAX);
    if applied > MIGRATIONS.len() {
        return Err(StoreError::Corrupt(format!(
            "schema version {applied} is newer than this server knows ({})",
            MIGRATIONS.len()
        )));
    }
    for (i, sql) in MIGRATIONS.iter().enumerate().skip(applied) {
        let tx = conn.transaction()?;
        tx.execute_batch(sql)?;
        tx.pragma_update(None, "user_version", (i + 1) as i64)?;
        tx.commit()?;
    }
    Ok(())
}

fn row_to_event(r: &rusqlite::Row) -> rusqlite::Result<Event> {
    let kind: String = r.get(1)?;
    // An unknown kind is a damaged or hostile file (the schema's CHECK forbids it): an error,
    // never silently read as some other kind.
    let kind = Kind::parse(&kind).ok_or_else(|| {
        rusqlite::Error::FromSqlConversionFailure(1, rusqlite::types::Type::Text, format!("unknown event kind {kind:?}").into())
    })?;
    Ok(Event {
        seq: r.get::<_, i64>(0)? as u64,
        kind,
        parent: r.get::<_, Option<i64>>(2)?.map(|p| p as u64),
        tool: r.get(3)?,
        arguments: r.get(4)?,
        command: r.get(5)?,
        version: r.get::<_, i64>(6)? as u32,
        ok: r.get::<_, i64>(7)? != 0,
        mutates: r.get::<_, i64>(8)? != 0,
        inherited: r.get::<_, i64>(9)? != 0,
        result: r.get(10)?,
        result_hash: r.get(11)?,
        state_hash: r.get(12)?,
        engine: r.get(13)?,
        summary: r.get(14)?,
    })
}

const EVENT_COLUMNS: &str = "seq, kind, parent, tool, arguments, command, version, ok, mutates, \
                             inherited, result, result_hash, state_hash, engine, summary";

/// `EVENT_COLUMNS` for a file of schema `version` (read-only opens do not migrate): a column
/// newer than the file is selected as NULL in its place.
fn event_columns(version: i64) -> String {
    let mut columns = EVENT_COLUMNS.to_string();
    if version < ENGINE_COLUMN_SINCE {
        columns = columns.replace(", engine", ", NULL AS engine");
    }
    if version < SUMMARY_COLUMN_SINCE {
        columns = columns.replace(", summary", ", NULL AS summary");
    }
    columns
}

fn insert_event(tx: &rusqlite::Transaction, e: &Event) -> Result<(), StoreError> {
    tx.prepare_cached(&format!(
        "INSERT INTO events ({EVENT_COLUMNS}) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)"
    ))?
    .execute(params![
        e.seq as i64,
        e.kind.as_str(),
        e.parent.map(|p| p as i64),
        e.tool,
        e.arguments,
        e.command,
        e.version as i64,
        e.ok as i64,
        e.mutates as i64,
        e.inherited as i64,
        e.result,
        e.result_hash,
        e.state_hash,
        e.engine,
        e.summary,
    ])?;
    Ok(())
}

/// Every snapshot `parent` holds on the inherited chain (a fork copies them), one at a time.
fn each_inherited_snapshot(
    (inherited, parent): (&[Event], Option<&dyn EventLog>),
    take: &mut dyn FnMut(u64, Vec<u8>, String) -> Result<(), StoreError>,
) -> Result<(), StoreError> {
    if let (Some(parent), Some(last)) = (parent, inherited.last()) {
        for seq in parent.chain_snapshot_seqs(last.seq)? {
            if let Some((bytes, hash)) = parent.snapshot_at(seq)? {
                take(seq, bytes, hash)?;
            }
        }
    }
    Ok(())
}

/// A snapshot to commit: (the seq of the event it is taken at, its bytes, its content hash).
pub type Snap<'a> = (u64, &'a [u8], &'a str);

impl Log {
    /// Creates a new log file (refusing to overwrite one) for simulation `sim_id`.
    pub fn create(path: &Path, sim_id: &str, sync: SyncMode) -> Result<Log, StoreError> {
        if path.exists() {
            return Err(StoreError::Corrupt(format!("{} already exists", path.display())));
        }
        let mut conn = open_conn(path, sync)?;
        migrate(&mut conn)?;
        conn.execute(
            "INSERT INTO meta (key, value) VALUES ('simulation_id', ?1), ('format', 'physics-mcp-log/1')",
            params![sim_id],
        )?;
        conn.execute("INSERT INTO head (id, head_seq) VALUES (1, 0)", [])?;
        let select_columns = event_columns(MIGRATIONS.len() as i64);
        Ok(Log {
            conn,
            path: path.to_path_buf(),
            last_seq: 0,
            head_seq: 0,
            pending: Vec::new(),
            commits_since_checkpoint: 0,
            checkpointing: Arc::default(),
            backfilled: Arc::default(),
            select_columns,
            acknowledged: None,
            replica: None,
            stale: false,
        })
    }

    /// Opens an existing log for writing. Refuses, without writing to it, a file that is not
    /// a log (empty, truncated, another database), fails SQLite's structural check, or ends
    /// before the last acknowledged commit (its WAL deleted or cut short).
    pub fn open(path: &Path, sync: SyncMode) -> Result<Log, StoreError> {
        if std::fs::metadata(path).map(|m| m.len()).unwrap_or(0) == 0 {
            return Err(StoreError::Corrupt("the file is empty".into()));
        }
        let mut conn = open_conn(path, sync)?;
        let version: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if version == 0 {
            return Err(StoreError::Corrupt("the file holds no physics-mcp log (schema version 0)".into()));
        }
        let check: String = conn.query_row("PRAGMA quick_check(1)", [], |r| r.get(0))?;
        if check != "ok" {
            return Err(StoreError::Corrupt(format!("SQLite's integrity check failed: {check}")));
        }
        migrate(&mut conn)?;
        let mut log = Self::from_existing(conn, path)?;
        if let Some(acked) = acknowledged_seq(path) {
            let last = log.last_state_seq()?;
            if last < acked {
                return Err(StoreError::Corrupt(format!(
                    "event {acked} was acknowledged but the log ends at event {last}: its write-ahead log (the -wal file) is missing or cut short, so acknowledged commits are lost"
                )));
            }
        }
        let seq_file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(companion(path, SEQ_SUFFIX))?;
        record_acknowledged(&seq_file, log.last_state_seq()?)?;
        log.acknowledged = Some(seq_file);
        Ok(log)
    }

    /// The seq of the last root, change or move event committed (0 if none).
    fn last_state_seq(&self) -> Result<u64, StoreError> {
        let seq: i64 = self.conn.query_row(
            "SELECT COALESCE(MAX(seq), 0) FROM events WHERE kind IN ('root', 'change', 'move')",
            [],
            |r| r.get(0),
        )?;
        Ok(seq as u64)
    }
    /// Commits buffered events and closes the file (its WAL is copied in and deleted). The
    /// log then sits on an empty in-memory database.
    fn close(&mut self) -> Result<(), StoreError> {
        self.flush()?;
        while self.checkpointing.load(Ordering::Acquire) {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        self.checkpoint()?;
        let empty = Connection::open_in_memory()?;
        let old = std::mem::replace(&mut self.conn, empty);
        old.close().map_err(|(_, e)| StoreError::Sql(e))
    }

    /// Closes a log written at `partial_path(final_path)` and renames it to `final_path` once
    /// its root has committed (the directory is synced under `--sync full`). Until then
    /// start-up never serves it and deletes it.
    pub fn publish(mut self, final_path: &Path, sync: SyncMode) -> Result<(), StoreError> {
        self.close()?;
        if final_path.exists() {
            return Err(StoreError::Corrupt(format!("{} already exists", final_path.display())));
        }
        crate::crash_point!("publish_before_rename");
        std::fs::rename(&self.path, final_path)?;
        // A partial log that was reopened (a sweep's variant) has an acknowledgement file of
        // its own; the published log starts its own, so the old one goes.
        if self.acknowledged.take().is_some() {
            let _ = std::fs::remove_file(companion(&self.path, SEQ_SUFFIX));
        }
        if sync == SyncMode::Full {
            if let Some(dir) = final_path.parent() {
                std::fs::File::open(dir).and_then(|d| d.sync_all())?;
            }
        }
        Ok(())
    }

    /// A `Log` over an opened existing file: reads where its head and last event are.
    fn from_existing(conn: Connection, path: &Path) -> Result<Log, StoreError> {
        let head_seq: i64 = conn
            .query_row("SELECT head_seq FROM head WHERE id = 1", [], |r| r.get(0))
            .optional()?
            .ok_or_else(|| StoreError::Corrupt("no head".into()))?;
        let last_seq: i64 =
            conn.query_row("SELECT COALESCE(MAX(seq), 0) FROM events", [], |r| r.get(0))?;
        let version: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
        let select_columns = event_columns(version);
        Ok(Log {
            conn,
            path: path.to_path_buf(),
            last_seq: last_seq as u64,
            head_seq: head_seq as u64,
            pending: Vec::new(),
            commits_since_checkpoint: 0,
            checkpointing: Arc::default(),
            backfilled: Arc::default(),
            select_columns,
            acknowledged: None,
            replica: None,
            stale: false,
        })
    }

    /// Opens a log for reading only (replay, history, diff): no migrations, no writes; a file
    /// of an older schema is read as it is.
    pub fn open_read_only(path: &Path) -> Result<Log, StoreError> {
        if !path.is_file() {
            return Err(StoreError::Corrupt(format!("{} is not a file", path.display())));
        }
        let conn = Connection::open_with_flags(path, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)?;
        let version: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if !(1..=MIGRATIONS.len() as i64).contains(&version) {
            return Err(StoreError::Corrupt(format!(
                "log schema version {version}, this build reads versions 1 to {}",
                MIGRATIONS.len()
            )));
        }
        Self::from_existing(conn, path)
    }

    /// The file this log lives in.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Makes this file a cache of a log of record (cluster mode): from now on every commit,
    /// buffered reads and blob goes to `replica` first.
    pub fn attach_replica(&mut self, replica: Box<dyn super::Replica>) {
        self.replica = Some(replica);
    }

    /// Commits the buffered events alone.
    fn write_pending(&mut self) -> Result<(), StoreError> {
        let tx = self.conn.transaction()?;
        for e in &self.pending {
            insert_event(&tx, e)?;
        }
        tx.commit()?;
        Ok(())
    }

    /// Nothing more is committed through a file that may be behind its log of record: the
    /// next append would be prepared against an end that may not be the record's.
    fn refuse_if_behind(&self) -> Result<(), StoreError> {
        if self.stale {
            return Err(StoreError::Cluster(
                "this node's copy of the log may be behind the cluster's; it is rebuilt on the next call".into(),
            ));
        }
        Ok(())
    }

    /// Whether this file fell behind the log of record it mirrors (see `stale`).
    pub fn is_stale(&self) -> bool {
        self.stale
    }

    /// After the log of record took a commit: a local write that fails leaves this file
    /// behind, not the commit unmade — it is acknowledged, and the file is rebuilt.
    fn behind_the_record(&mut self, failed: Result<(), StoreError>) -> Result<(), StoreError> {
        match failed {
            Err(e) if self.replica.is_some() => {
                tracing::warn!("{} fell behind the cluster's log ({e}); it will be rebuilt from there", self.path.display());
                self.stale = true;
                Ok(())
            }
            other => other,
        }
    }

    /// Writes one commit of another log as it is (events with their flags, head, snapshots):
    /// how a cache is rebuilt from the log of record, and how `export` writes a file.
    pub fn import_commit(&mut self, events: &[Event], head: u64, snapshots: &[Snap]) -> Result<(), StoreError> {
        self.commit((&[], None), events, head, snapshots)
    }

    /// Starts a forked log: the inherited chain (flagged `inherited`, original seqs), every
    /// snapshot `parent` holds on that chain (so any inherited point costs what it costs in the
    /// parent), and the fork's own root with its snapshot, all in one transaction (a failed
    /// fork leaves no half-written chain behind). Snapshots are copied one at a time.
    pub fn append_root_with_ancestry(
        &mut self,
        inherited: &[Event],
        parent: Option<&dyn EventLog>,
        root: Event,
        snapshot: (&[u8], &str),
    ) -> Result<(), StoreError> {
        let seq = root.seq;
        self.commit((inherited, parent), std::slice::from_ref(&root), seq, &[(seq, snapshot.0, snapshot.1)])
    }

    /// The SQLite transaction of one commit: inherited chain and its snapshots (a fork),
    /// buffered events, `events`, the head, `snapshots`.
    fn write_commit(
        &mut self,
        (inherited, parent): (&[Event], Option<&dyn EventLog>),
        events: &[Event],
        head: u64,
        snapshots: &[Snap],
    ) -> Result<(), StoreError> {
        let tx = self.conn.transaction()?;
        for e in inherited {
            let mut e = e.clone();
            e.inherited = true;
            insert_event(&tx, &e)?;
        }
        each_inherited_snapshot((inherited, parent), &mut |seq, bytes, hash| {
            tx.execute("INSERT INTO snapshots (seq, hash, bytes) VALUES (?1, ?2, ?3)", params![seq as i64, hash, bytes])?;
            Ok(())
        })?;
        for e in &self.pending {
            insert_event(&tx, e)?;
        }
        for event in events {
            insert_event(&tx, event)?;
        }
        tx.execute("UPDATE head SET head_seq = ?1 WHERE id = 1", params![head as i64])?;
        for (seq, bytes, hash) in snapshots {
            tx.execute(
                "INSERT OR REPLACE INTO snapshots (seq, hash, bytes) VALUES (?1, ?2, ?3)",
                params![*seq as i64, hash, bytes],
            )?;
            crate::crash_point!("snapshot_write");
        }
        tx.commit()?;
        Ok(())
    }

    fn commit(
        &mut self,
        (inherited, parent): (&[Event], Option<&dyn EventLog>),
        events: &[Event],
        head: u64,
        snapshots: &[Snap],
    ) -> Result<(), StoreError> {
        let Some(last) = events.last() else { return Ok(()) };
        self.refuse_if_behind()?;
        if let Some(replica) = self.replica.as_mut() {
            let mut all: Vec<(&Event, bool)> = inherited.iter().map(|e| (e, true)).collect();
            let mut copied: Vec<(u64, Vec<u8>, String)> = Vec::new();
            each_inherited_snapshot((inherited, parent), &mut |seq, bytes, hash| {
                copied.push((seq, bytes, hash));
                Ok(())
            })?;
            all.extend(self.pending.iter().chain(events).map(|e| (e, e.inherited)));
            let mut snaps: Vec<Snap> = copied.iter().map(|(s, b, h)| (*s, b.as_slice(), h.as_str())).collect();
            snaps.extend_from_slice(snapshots);
            replica.append(&all, head, &snaps).inspect_err(|_| self.stale = true)?;
        }
        let written = self.write_commit((inherited, parent), events, head, snapshots);
        self.behind_the_record(written)?;
        crate::crash_point!("after_commit");
        // The last root, change or move committed (a batch may hold reads, or only reads).
        let acked = events.iter().rev().find(|e| matches!(e.kind, Kind::Root | Kind::Change | Kind::Move));
        if let (Some(file), Some(acked)) = (&self.acknowledged, acked) {
            if let Err(e) = record_acknowledged(file, acked.seq) {
                tracing::warn!("could not record the acknowledged seq of {}: {e}", self.path.display());
            }
        }
        self.pending.clear();
        self.last_seq = last.seq;
        self.head_seq = head;
        self.commits_since_checkpoint += 1;
        self.truncate_wal();
        if !snapshots.is_empty() || self.commits_since_checkpoint >= CHECKPOINT_EVERY_COMMITS {
            self.commits_since_checkpoint = 0;
            checkpoint_in_background(self.path.clone(), self.checkpointing.clone(), self.backfilled.clone());
        }
        Ok(())
    }

    /// After a background checkpoint has copied the WAL, finishes it on the writer's own
    /// connection: copies the few commits made meanwhile and truncates the WAL to nothing
    /// (TRUNCATE; between commits, so no reader of this log holds it). Best effort: a busy or
    /// failed truncation leaves the WAL as it was, and the next background checkpoint tries
    /// again.
    fn truncate_wal(&mut self) {
        if self.checkpointing.load(Ordering::Acquire) || !self.backfilled.swap(false, Ordering::AcqRel) {
            return;
        }
        // Never wait for another reader of the file (a replay, a copy): skip instead.
        let waits = |ms| self.conn.busy_timeout(std::time::Duration::from_millis(ms));
        let done = waits(0).and_then(|()| self.conn.query_row("PRAGMA wal_checkpoint(TRUNCATE)", [], |_| Ok(())));
        if let Err(e) = done.and_then(|()| waits(DEFAULT_BUSY_MS)) {
            let _ = waits(DEFAULT_BUSY_MS);
            tracing::warn!("truncating the WAL of {} failed: {e}", self.path.display());
        }
    }

    /// Moves the WAL's contents into the main file (so `file_bytes` measures the log itself).
    pub fn checkpoint(&self) -> Result<(), StoreError> {
        // The background checkpointer may hold the WAL at this moment: retry briefly until
        // the WAL is really truncated, so sizes measured right after are the database's.
        for _ in 0..100 {
            let busy: i64 = self.conn.query_row("PRAGMA wal_checkpoint(TRUNCATE)", [], |r| r.get(0))?;
            if busy == 0 {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        Ok(())
    }

    /// Ends the log in its log of record, if it mirrors one (destroy_simulation in a cluster:
    /// the replica's fenced `destroyed` marker); a refusal or no answer marks this file behind,
    /// as a failed append does. Embedded, nothing to do.
    pub fn seal(&mut self) -> Result<(), StoreError> {
        match self.replica.as_mut() {
            Some(replica) => replica.seal().inspect_err(|_| self.stale = true),
            None => Ok(()),
        }
    }

    /// Closes the file before it is deleted (destroy_simulation): drops buffered events, waits
    /// for a background checkpoint still holding the file, and leaves the log on an empty
    /// in-memory database, so nothing done afterwards can reach or recreate the deleted files.
    pub fn close_for_deletion(&mut self) {
        self.pending.clear();
        self.replica = None;
        while self.checkpointing.load(Ordering::Acquire) {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        match Connection::open_in_memory() {
            Ok(empty) => drop(std::mem::replace(&mut self.conn, empty)),
            Err(e) => tracing::warn!("could not close {}: {e}", self.path.display()),
        }
    }

    /// Total bytes of the database file (for benchmarks and reports).
    pub fn file_bytes(&self) -> u64 {
        let wal = self.path.with_extension("sqlite-wal");
        std::fs::metadata(&self.path).map(|m| m.len()).unwrap_or(0)
            + std::fs::metadata(wal).map(|m| m.len()).unwrap_or(0)
    }
}

impl super::EventLog for Log {
    fn append(&mut self, events: &[Event], head: u64, snapshots: &[Snap]) -> Result<(), super::AppendError> {
        // One process owns this file (the data directory's lock): a conflict is a caller that
        // lost track of the log's end, never another writer.
        if let Some(first) = events.first() {
            if first.seq != self.last_seq + 1 {
                return Err(super::AppendError::Conflict { expected: first.seq - 1, actual: self.last_seq });
            }
        }
        self.commit((&[], None), events, head, snapshots).map_err(super::AppendError::Store)
    }

    /// The simulation id recorded in the file.
    fn simulation_id(&self) -> Result<String, StoreError> {
        Ok(self.conn.query_row(
            "SELECT value FROM meta WHERE key = 'simulation_id'",
            [],
            |r| r.get(0),
        )?)
    }

    /// The seq of the last event appended (committed or buffered).
    fn last_seq(&self) -> u64 {
        self.last_seq
    }

    /// The state-changing event the world reflects.
    fn head_seq(&self) -> u64 {
        self.head_seq
    }

    /// Stores a command's blob (URDF text, mesh) under its hash; storing it twice is a no-op.
    /// Written before the event that refers to it, so a committed event always finds it.
    fn put_blob(&mut self, hash: &str, bytes: &[u8]) -> Result<(), StoreError> {
        if let Some(replica) = self.replica.as_mut() {
            replica.put_blob(hash, bytes)?;
        }
        self.conn.execute(
            "INSERT OR IGNORE INTO blobs (hash, bytes) VALUES (?1, ?2)",
            params![hash, bytes],
        )?;
        Ok(())
    }

    /// Every blob stored, by hash.
    fn blobs(&self) -> Result<Vec<(String, Vec<u8>)>, StoreError> {
        let mut stmt = self.conn.prepare("SELECT hash, bytes FROM blobs ORDER BY hash")?;
        let rows = stmt.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))?.collect::<Result<_, _>>()?;
        Ok(rows)
    }

    /// The bytes stored under `hash`.
    fn get_blob(&self, hash: &str) -> Option<Vec<u8>> {
        self.conn
            .query_row("SELECT bytes FROM blobs WHERE hash = ?1", params![hash], |r| r.get(0))
            .ok()
    }

    /// Stores arguments inline, or as a blob when they are over 64 KB (returns the reference).
    /// If the blob cannot be written the arguments stay inline: the event is still recorded.
    fn store_arguments(&mut self, args_json: String) -> String {
        if args_json.len() <= INLINE_ARGS_MAX {
            return args_json;
        }
        let hash = blake3::hash(args_json.as_bytes()).to_hex().to_string();
        if let Some(replica) = self.replica.as_mut() {
            if let Err(e) = replica.put_blob(&hash, args_json.as_bytes()) {
                tracing::warn!("could not store large arguments as a blob in the cluster: {e}");
                return args_json;
            }
        }
        match self.conn.execute(
            "INSERT OR IGNORE INTO blobs (hash, bytes) VALUES (?1, ?2)",
            params![hash, args_json.as_bytes()],
        ) {
            Ok(_) => serde_json::json!({"blob": hash, "bytes": args_json.len()}).to_string(),
            Err(e) => {
                tracing::warn!("could not store large arguments as a blob: {e}");
                args_json
            }
        }
    }

    /// Every event in seq order (committed and buffered): for verification and redo stacks.
    fn all_events(&self) -> Result<Vec<Event>, StoreError> {
        self.events_since(0, usize::MAX / 2)
    }

    /// Buffers a read or refused event; committed with the next write or when many wait.
    fn append_lazy(&mut self, event: Event) -> Result<(), StoreError> {
        self.last_seq = event.seq;
        self.pending.push(event);
        if self.pending.len() >= LAZY_FLUSH_AT {
            self.flush()?;
        }
        Ok(())
    }

    /// Commits buffered events.
    fn flush(&mut self) -> Result<(), StoreError> {
        if self.pending.is_empty() {
            return Ok(());
        }
        self.refuse_if_behind()?;
        if let Some(replica) = self.replica.as_mut() {
            let pending: Vec<(&Event, bool)> = self.pending.iter().map(|e| (e, e.inherited)).collect();
            replica.append(&pending, self.head_seq, &[]).inspect_err(|_| self.stale = true)?;
        }
        let written = self.write_pending();
        self.behind_the_record(written)?;
        self.pending.clear();
        Ok(())
    }

    /// All events with seq > `since`, ascending, at most `limit`, buffered ones included.
    fn events_since(&self, since: u64, limit: usize) -> Result<Vec<Event>, StoreError> {
        let mut stmt = self.conn.prepare_cached(&format!(
            "SELECT {} FROM events WHERE seq > ?1 ORDER BY seq LIMIT ?2",
            self.select_columns
        ))?;
        let mut out: Vec<Event> = stmt
            .query_map(params![since as i64, limit as i64], row_to_event)?
            .collect::<Result<_, _>>()?;
        out.extend(self.pending.iter().filter(|e| e.seq > since).cloned());
        out.truncate(limit);
        Ok(out)
    }

    /// One event by seq (committed or buffered).
    fn event(&self, seq: u64) -> Result<Option<Event>, StoreError> {
        if let Some(e) = self.pending.iter().find(|e| e.seq == seq) {
            return Ok(Some(e.clone()));
        }
        Ok(self
            .conn
            .prepare_cached(&format!("SELECT {} FROM events WHERE seq = ?1", self.select_columns))?
            .query_row(params![seq as i64], row_to_event)
            .optional()?)
    }

    /// The chain of state-changing events from the root to `head` (inclusive), root first.
    fn chain_to(&self, head: u64) -> Result<Vec<Event>, StoreError> {
        let mut chain = Vec::new();
        let mut cur = Some(head);
        while let Some(seq) = cur {
            let e = self
                .event(seq)?
                .ok_or_else(|| StoreError::Corrupt(format!("event {seq} on the chain is missing")))?;
            if !e.kind.is_state_changing() {
                return Err(StoreError::Corrupt(format!(
                    "event {seq} on the chain is not state-changing"
                )));
            }
            if chain.len() as u64 > self.last_seq {
                return Err(StoreError::Corrupt("the chain has a cycle".into()));
            }
            cur = e.parent;
            chain.push(e);
        }
        chain.reverse();
        Ok(chain)
    }

    /// The chain from `head` back to (and including) the first event `stop` accepts, or to
    /// the root; newest first. Costs what it walks, not the whole history.
    fn chain_back(&self, head: u64, stop: &mut dyn FnMut(&Event) -> bool) -> Result<Vec<Event>, StoreError> {
        let mut out = Vec::new();
        let mut cur = Some(head);
        while let Some(seq) = cur {
            let e = self
                .event(seq)?
                .ok_or_else(|| StoreError::Corrupt(format!("event {seq} on the chain is missing")))?;
            if !e.kind.is_state_changing() || out.len() as u64 > self.last_seq {
                return Err(StoreError::Corrupt(format!("the chain is broken at event {seq}")));
            }
            cur = e.parent;
            let done = stop(&e);
            out.push(e);
            if done {
                break;
            }
        }
        Ok(out)
    }

    /// The head the log's last own root, change or move event left (a move's `to`): the
    /// stored head must equal it, since both are written in one transaction.
    fn head_by_events(&self) -> Result<Option<u64>, StoreError> {
        let last: Option<(i64, String, Option<String>)> = self
            .conn
            .prepare_cached(
                "SELECT seq, kind, command FROM events WHERE kind IN ('root', 'change', 'move') \
                 AND inherited = 0 ORDER BY seq DESC LIMIT 1",
            )?
            .query_row([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
            .optional()?;
        let Some((seq, kind, command)) = last else { return Ok(None) };
        if kind != "move" {
            return Ok(Some(seq as u64));
        }
        let to = command
            .as_deref()
            .and_then(|c| serde_json::from_str::<serde_json::Value>(c).ok())
            .and_then(|v| v["to"].as_u64())
            .ok_or_else(|| StoreError::Corrupt(format!("move {seq} does not decode")))?;
        Ok(Some(to))
    }

    /// This log's own root command (not an inherited one): it holds the gui flag.
    fn own_root_command(&self) -> Result<Option<String>, StoreError> {
        Ok(self
            .conn
            .prepare_cached("SELECT command FROM events WHERE kind = 'root' AND inherited = 0 ORDER BY seq DESC LIMIT 1")?
            .query_row([], |r| r.get(0))
            .optional()?
            .flatten())
    }

    /// The snapshot at `seq`, if one was taken: (bytes, recorded blake3).
    fn snapshot_at(&self, seq: u64) -> Result<Option<(Vec<u8>, String)>, StoreError> {
        Ok(self
            .conn
            .prepare_cached("SELECT bytes, hash FROM snapshots WHERE seq = ?1")?
            .query_row(params![seq as i64], |r| Ok((r.get(0)?, r.get(1)?)))
            .optional()?)
    }

    /// Seqs of the snapshots on the chain ending at `head`, newest first (one recursive query,
    /// not one per event).
    fn chain_snapshot_seqs(&self, head: u64) -> Result<Vec<u64>, StoreError> {
        let mut stmt = self.conn.prepare_cached(
            "WITH RECURSIVE chain(seq, parent) AS (
                 SELECT seq, parent FROM events WHERE seq = ?1
                 UNION ALL
                 SELECT e.seq, e.parent FROM events e JOIN chain c ON e.seq = c.parent
             )
             SELECT s.seq FROM snapshots s JOIN chain c ON s.seq = c.seq ORDER BY s.seq DESC",
        )?;
        let seqs = stmt
            .query_map(params![head as i64], |r| r.get::<_, i64>(0))?
            .map(|r| r.map(|s| s as u64))
            .collect::<Result<_, _>>()?;
        Ok(seqs)
    }

    /// Deletes snapshots (thinning); the events stay, so nothing is lost but re-simulation.
    fn delete_snapshots(&mut self, seqs: &[u64]) -> Result<(), StoreError> {
        if seqs.is_empty() {
            return Ok(());
        }
        let tx = self.conn.transaction()?;
        for s in seqs {
            tx.execute("DELETE FROM snapshots WHERE seq = ?1", params![*s as i64])?;
        }
        tx.commit()?;
        Ok(())
    }

    /// Seqs that have snapshots, ascending.
    fn snapshot_seqs(&self) -> Result<Vec<u64>, StoreError> {
        let mut stmt = self.conn.prepare_cached("SELECT seq FROM snapshots ORDER BY seq")?;
        let seqs = stmt
            .query_map([], |r| r.get::<_, i64>(0))?
            .map(|r| r.map(|s| s as u64))
            .collect::<Result<_, _>>()?;
        Ok(seqs)
    }
}

/// A log never outlives its background checkpointer: a fork or load drops its Log before
/// renaming `<id>.partial`, and a checkpointer still running would then open the renamed file
/// under its old name and leave a `.partial-wal` beside the published log.
impl Drop for Log {
    fn drop(&mut self) {
        let _ = self.flush();
        while self.checkpointing.load(Ordering::Acquire) {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
}

impl crate::command::BlobSource for Log {
    fn blob(&self, hash: &str) -> Option<Vec<u8>> {
        self.get_blob(hash)
    }
}
