//! What a simulation's subject in JetStream holds: one message per commit of its log (the
//! events, the head, the snapshots and blobs it needs, by content hash), or the claim of a
//! new owner that fences out the old one. The events are the SQLite log's rows field for
//! field, so a cache or an exported file is what an embedded server would have written.

use serde::{Deserialize, Serialize};

use crate::log::{Event, Kind};

/// One message on a simulation's subject.
#[derive(Serialize, Deserialize, Debug)]
#[serde(tag = "t", rename_all = "snake_case")]
pub enum Record {
    /// One commit, carried in the message itself.
    Commit(Commit),
    /// One commit too large for a message: its JSON is in the object store under this name.
    Stored {
        /// The object's name (`env/<blake3 of the JSON>`).
        object: String,
        /// Its size, for operators reading the stream.
        bytes: usize,
    },
    /// A node took the simulation over: any append prepared against an older end of the
    /// subject is refused from here on.
    Takeover {
        /// The node that took it.
        node: String,
        /// The revision of its ownership record.
        epoch: u64,
    },
    /// The simulation was destroyed (destroy_simulation on its owner): appended, fenced like
    /// any commit, before anything of it is removed, so a node that lost its lease can neither
    /// destroy it nor undo another node's acknowledged work; nothing may follow it. Readers
    /// (a takeover, `export`, a sweep's materialisation) find no simulation in a subject that
    /// holds it (docs/log-format.md "Cluster subjects").
    Destroyed {
        /// The node that destroyed it.
        node: String,
        /// The revision of its ownership record.
        epoch: u64,
    },
}

/// One all-or-nothing commit of a simulation's log.
#[derive(Serialize, Deserialize, Debug, Default)]
pub struct Commit {
    /// The events, in seq order (buffered reads included; inherited ones flagged).
    pub events: Vec<WireEvent>,
    /// The head after the commit.
    pub head: u64,
    /// Snapshots taken with it: (seq, content hash); the bytes are in the object store under
    /// `snap/<hash>`.
    pub snapshots: Vec<(u64, String)>,
    /// Blobs its events name, stored before it under `blob/<hash>`.
    pub blobs: Vec<String>,
}

/// An event row on the wire (`log::Event` field for field).
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct WireEvent {
    seq: u64,
    kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    parent: Option<u64>,
    tool: String,
    arguments: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    command: Option<String>,
    version: u32,
    ok: bool,
    mutates: bool,
    inherited: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    result: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    result_hash: Option<String>,
    state_hash: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    engine: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    summary: Option<String>,
}

impl From<&Event> for WireEvent {
    fn from(e: &Event) -> WireEvent {
        WireEvent::from((e, e.inherited))
    }
}

/// An event with whether it is recorded as inherited (a fork's copied chain).
impl From<(&Event, bool)> for WireEvent {
    fn from((e, inherited): (&Event, bool)) -> WireEvent {
        WireEvent {
            seq: e.seq,
            kind: e.kind.as_str().into(),
            parent: e.parent,
            tool: e.tool.clone(),
            arguments: e.arguments.clone(),
            command: e.command.clone(),
            version: e.version,
            ok: e.ok,
            mutates: e.mutates,
            inherited,
            result: e.result.clone(),
            result_hash: e.result_hash.clone(),
            state_hash: e.state_hash.clone(),
            engine: e.engine.clone(),
            summary: e.summary.clone(),
        }
    }
}

impl TryFrom<WireEvent> for Event {
    type Error = String;
    fn try_from(w: WireEvent) -> Result<Event, String> {
        Ok(Event {
            seq: w.seq,
            kind: Kind::parse(&w.kind).ok_or_else(|| format!("unknown event kind {:?}", w.kind))?,
            parent: w.parent,
            tool: w.tool,
            arguments: w.arguments,
            command: w.command,
            version: w.version,
            ok: w.ok,
            mutates: w.mutates,
            inherited: w.inherited,
            result: w.result,
            result_hash: w.result_hash,
            state_hash: w.state_hash,
            engine: w.engine,
            summary: w.summary,
        })
    }
}

/// The object-store name of a blob.
pub fn blob_object(hash: &str) -> String {
    format!("blob/{hash}")
}

/// The object-store name of a snapshot.
pub fn snapshot_object(hash: &str) -> String {
    format!("snap/{hash}")
}

/// The object-store name of a commit too large for one message.
pub fn commit_object(hash: &str) -> String {
    format!("env/{hash}")
}
