//! Moving logs between a subject and SQLite: publishing a commit (fenced, retried through
//! leader elections), a whole SQLite log into an empty subject (a simulation joining the
//! cluster, `import`), and a subject back into a SQLite file (a takeover's cache, `export`).

use std::path::Path;
use std::time::Instant;

use async_nats::jetstream::context::PublishErrorKind;
use async_nats::jetstream::message::PublishMessage;
use async_nats::jetstream::stream::LastRawMessageErrorKind;

use super::record::{blob_object, commit_object, snapshot_object, Commit, Record, WireEvent};
use super::{Cluster, APPEND_PATIENCE, INLINE_COMMIT_MAX};

/// The words a read of a subject that holds no simulation fails with (never made, or
/// destroyed): callers answer "not found".
pub const NO_LOG: &str = "the cluster holds no log for simulation";

/// How long a read of one subject's end, or of one object, may take.
const SUBJECT_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

/// How long a read of a whole subject may go without a message before it asks whether the
/// subject still reaches the end it set out for.
const MESSAGE_WAIT: std::time::Duration = std::time::Duration::from_secs(3);

/// The most a whole subject's read may take (a log of 10,000 events reads in well under a
/// second; a loaded machine and a large log get ample room).
const READ_WHOLE_WAIT: std::time::Duration = std::time::Duration::from_secs(300);
use crate::log::whole::{as_one_commit, write_log, CommitParts};
use crate::log::{Event, EventLog, StoreError, SyncMode};

impl Cluster {
    /// Stores `bytes` under `name` in the object store unless an object of that name exists
    /// (names are content hashes, so it holds the same bytes).
    pub fn put_object(&self, name: &str, bytes: &[u8]) -> Result<(), String> {
        let (store, name, bytes) = (self.objects.clone(), name.to_string(), bytes.to_vec());
        self.run_for(READ_WHOLE_WAIT, async move {
            if store.info(&name).await.is_ok_and(|i| !i.deleted) {
                return Ok(());
            }
            super::patiently(|| {
                let mut reader = bytes.as_slice();
                let (store, name) = (&store, &name);
                async move { store.put(name.as_str(), &mut reader).await.map(|_| ()) }
            })
            .await
            .map_err(|e| format!("storing {name}: {e}"))
        })?
    }

    /// The bytes of an object.
    pub fn get_object(&self, name: &str) -> Result<Vec<u8>, String> {
        let (store, name) = (self.objects.clone(), name.to_string());
        self.run_for(READ_WHOLE_WAIT, async move {
            use tokio::io::AsyncReadExt;
            super::patiently(|| async {
                let mut object = store.get(&name).await.map_err(|e| format!("reading {name}: {e}"))?;
                let mut bytes = Vec::new();
                object
                    .read_to_end(&mut bytes)
                    .await
                    .map_err(|e| format!("reading {name}: {e}"))?;
                Ok::<_, String>(bytes)
            })
            .await
        })?
    }

    /// Publishes a commit on `subject` if the subject still ends at `expected`; returns its
    /// sequence. Retried (same message id, so a commit that landed is not written twice) while
    /// the cluster is unreachable or electing, up to [`APPEND_PATIENCE`]; a stale expectation
    /// is [`StoreError::Fenced`].
    pub fn publish_commit(
        &self,
        subject: &str,
        commit: Commit,
        expected: u64,
        msg_id: &str,
    ) -> Result<u64, StoreError> {
        let json = serde_json::to_vec(&Record::Commit(commit))
        .map_err(|e| StoreError::Cluster(e.to_string()))?;
        let payload = if json.len() > INLINE_COMMIT_MAX {
            let object = commit_object(&crate::digest::content_hash(&json));
            self.put_object(&object, &json).map_err(StoreError::Cluster)?;
            serde_json::to_vec(&Record::Stored {
                object,
                bytes: json.len(),
            })
            .map_err(|e| StoreError::Cluster(e.to_string()))?
        } else {
            json
        };
        // Only a retry of these very bytes is a duplicate: another commit prepared at the same
        // end (after an append whose outcome was unknown) must meet the sequence check instead.
        let msg_id = format!("{msg_id}.{}", &crate::digest::content_hash(&payload)[..16]);
        self.publish_fenced(subject, payload, expected, &msg_id)
    }

    /// Publishes one record fenced by `expected`, retrying what may be transient.
    pub(crate) fn publish_fenced(
        &self,
        subject: &str,
        payload: Vec<u8>,
        expected: u64,
        msg_id: &str,
    ) -> Result<u64, StoreError> {
        let (js, subject, msg_id) = (self.js.clone(), subject.to_string(), msg_id.to_string());
        self.run(async move {
            let started = Instant::now();
            let mut last_error = String::new();
            while started.elapsed() < APPEND_PATIENCE {
                let message = PublishMessage::build()
                    .payload(payload.clone().into())
                    .message_id(&msg_id)
                    .expected_last_subject_sequence(expected);
                let acked = match js.send_publish(subject.clone(), message).await {
                    Ok(pending) => pending.await,
                    Err(e) => Err(e),
                };
                match acked {
                    Ok(ack) => return Ok(ack.sequence),
                    Err(e) if e.kind() == PublishErrorKind::WrongLastSequence => {
                        return Err(StoreError::Fenced(format!("another node wrote to {subject} first")));
                    }
                    Err(e) if e.kind() == PublishErrorKind::MaxPayloadExceeded => {
                        return Err(StoreError::Cluster(e.to_string()));
                    }
                    Err(e) => {
                        last_error = e.to_string();
                        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
                    }
                }
            }
            Err(StoreError::Cluster(format!(
                "no acknowledgement within {APPEND_PATIENCE:?} ({last_error}); whether the call was recorded is known once the cluster answers again: get_history tells"
            )))
        })
    }

    /// The sequence of the last message on a simulation's subject (0: none).
    pub fn last_sequence(&self, id: &str) -> Result<u64, String> {
        if !super::valid_id(id) {
            return Ok(0);
        }
        let (stream, subject) = self.subject(id);
        let js = self.js.clone();
        self.run_for(SUBJECT_WAIT, async move { last_on(&js, &stream, &subject).await })?
    }

    /// Every commit on a simulation's subject in order, and the subject's last sequence; None
    /// when the subject holds no simulation (never made, purged, or ending in a `destroyed`
    /// marker). Every wait has a deadline: a subject purged while it is read (a destroy) ends
    /// the read instead of waiting for messages that are gone.
    pub fn read_commits(&self, id: &str) -> Result<Option<(Vec<Commit>, u64)>, String> {
        let (records, last) = self.raw_records_to_end(id)?;
        if last == 0 {
            return Ok(None);
        }
        let mut commits = Vec::new();
        for bytes in records {
            match serde_json::from_slice::<Record>(&bytes)
                .map_err(|e| format!("a record of {id} does not decode: {e}"))?
            {
                Record::Commit(c) => commits.push(c),
                Record::Stored { object, .. } => {
                    let json = self.get_object(&object)?;
                    match serde_json::from_slice::<Record>(&json)
                        .map_err(|e| format!("{object} does not decode: {e}"))?
                    {
                        Record::Commit(c) => commits.push(c),
                        _ => return Err(format!("{object} is not a commit")),
                    }
                }
                Record::Takeover { .. } => {}
                Record::Destroyed { .. } => return Ok(None),
            }
        }
        if commits.is_empty() {
            return Ok(None);
        }
        Ok(Some((commits, last)))
    }

    /// Every message payload on `id`'s subject (empty: none).
    pub(crate) fn raw_records(&self, id: &str) -> Result<Vec<Vec<u8>>, String> {
        self.raw_records_to_end(id).map(|(records, _)| records)
    }

    /// Every message payload on `id`'s subject and the subject's last sequence (0: no
    /// message). A read cut short (the subject was purged under it) is asked again.
    fn raw_records_to_end(&self, id: &str) -> Result<(Vec<Vec<u8>>, u64), String> {
        for _ in 0..3 {
            let last = self.last_sequence(id)?;
            if last == 0 {
                return Ok((Vec::new(), 0));
            }
            if let Some(records) = self.records_up_to(id, last)? {
                return Ok((records, last));
            }
        }
        Err(format!("simulation {id}'s log kept changing while it was read"))
    }

    /// The payloads of `id`'s subject up to stream sequence `last` (as its end was seen a
    /// moment ago); None when the subject no longer reaches `last` — it was purged while it was
    /// read (a destroy). Never waits for messages that are gone.
    pub fn records_up_to(&self, id: &str, last: u64) -> Result<Option<Vec<Vec<u8>>>, String> {
        let (stream, subject) = self.subject(id);
        let js = self.js.clone();
        self.run_for(READ_WHOLE_WAIT, async move { read_subject(&js, &stream, &subject, last).await })?
    }

    /// Writes a simulation's log from its subject into a new SQLite file at `path`; returns
    /// the subject's last sequence (what the next append must follow). A subject that holds
    /// no simulation is [`NO_LOG`].
    pub fn materialize(&self, id: &str, path: &Path, sync: SyncMode) -> Result<u64, String> {
        let Some((commits, last)) = self.read_commits(id)? else {
            return Err(format!("{NO_LOG} {id}"));
        };
        let mut parts = Vec::new();
        for commit in commits {
            let mut blobs = Vec::new();
            for hash in &commit.blobs {
                blobs.push((hash.clone(), self.get_object(&blob_object(hash))?));
            }
            let mut snapshots = Vec::new();
            for (seq, hash) in &commit.snapshots {
                let bytes = self.get_object(&snapshot_object(hash))?;
                if crate::digest::content_hash(&bytes) != *hash {
                    return Err(format!("snapshot {hash} of {id} does not match its hash"));
                }
                snapshots.push((*seq, bytes, hash.clone()));
            }
            let events = commit.events.into_iter().map(Event::try_from).collect::<Result<_, _>>()?;
            parts.push(CommitParts { events, head: commit.head, snapshots, blobs });
        }
        write_log(path, id, sync, parts).map_err(|e| e.to_string())?;
        Ok(last)
    }

    /// Appends the `destroyed` marker to `id`'s subject if it still ends at `expected` (this
    /// owner's view of it): the point at which destroy_simulation is decided.
    pub fn publish_destroyed(&self, id: &str, expected: u64, epoch: u64) -> Result<u64, StoreError> {
        let record = Record::Destroyed { node: self.config.node.clone(), epoch };
        let payload = serde_json::to_vec(&record).map_err(|e| StoreError::Cluster(e.to_string()))?;
        let subject = self.subject(id).1;
        self.publish_fenced(&subject, payload, expected, &format!("{id}.{expected}.{}.{epoch}.destroyed", self.config.node))
    }

    /// Publishes a whole log as the first commit of an empty subject (refused if the subject
    /// has anything: ids are unique in the cluster); returns its sequence.
    pub fn upload(&self, id: &str, log: &dyn EventLog, epoch: u64) -> Result<u64, String> {
        let whole = as_one_commit(log).map_err(|e| e.to_string())?;
        for (hash, bytes) in &whole.blobs {
            self.put_object(&blob_object(hash), bytes)?;
        }
        for (_, bytes, hash) in &whole.snapshots {
            self.put_object(&snapshot_object(hash), bytes)?;
        }
        let commit = Commit {
            events: whole.events.iter().map(WireEvent::from).collect(),
            head: whole.head,
            snapshots: whole.snapshots.iter().map(|(seq, _, hash)| (*seq, hash.clone())).collect(),
            blobs: whole.blobs.iter().map(|(hash, _)| hash.clone()).collect(),
        };
        let subject = self.subject(id).1;
        let msg_id = format!("{id}.0.{}.{epoch}", self.config.node);
        self.publish_commit(&subject, commit, 0, &msg_id).map_err(|e| match e {
            StoreError::Fenced(_) => format!("a simulation with id {id} already exists in the cluster"),
            e => e.to_string(),
        })
    }

    /// Records that this node took `id` over at the subject's sequence `seen`, fencing out any
    /// append an earlier owner prepared; returns the new last sequence.
    pub fn claim(&self, id: &str, seen: u64, epoch: u64) -> Result<u64, StoreError> {
        let record = Record::Takeover {
            node: self.config.node.clone(),
            epoch,
        };
        let payload = serde_json::to_vec(&record).map_err(|e| StoreError::Cluster(e.to_string()))?;
        let subject = self.subject(id).1;
        self.publish_fenced(
            &subject,
            payload,
            seen,
            &format!("{id}.{seen}.{}.{epoch}.claim", self.config.node),
        )
    }
}

/// The last sequence of `subject` in `stream` (0: no message), retried while it may pass.
async fn last_on(js: &async_nats::jetstream::Context, stream: &str, subject: &str) -> Result<u64, String> {
    super::patiently(|| async {
        let stream = js.get_stream_no_info(stream).await.map_err(|e| e.to_string())?;
        match stream.get_last_raw_message_by_subject(subject).await {
            Ok(m) => Ok(m.sequence),
            Err(e) if e.kind() == LastRawMessageErrorKind::NoMessageFound => Ok(0),
            Err(e) => Err(e.to_string()),
        }
    })
    .await
}

/// The payloads of a subject's messages up to stream sequence `last`, by an ordered consumer
/// (one pass, not a request per message). None: the subject ended before `last` (it was
/// purged while read), seen from the consumer's count of what is left, or from a wait of
/// [`MESSAGE_WAIT`] with no message after which the subject no longer reaches `last`.
async fn read_subject(
    js: &async_nats::jetstream::Context,
    stream: &str,
    subject: &str,
    last: u64,
) -> Result<Option<Vec<Vec<u8>>>, String> {
    use async_nats::jetstream::consumer::{pull, DeliverPolicy};
    use futures_util::StreamExt;
    let js_stream = js.get_stream_no_info(stream).await.map_err(|e| e.to_string())?;
    let consumer = js_stream
        .create_consumer(pull::OrderedConfig {
            filter_subject: subject.to_string(),
            deliver_policy: DeliverPolicy::All,
            ..Default::default()
        })
        .await
        .map_err(|e| e.to_string())?;
    let mut messages = consumer.messages().await.map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    loop {
        let m = match tokio::time::timeout(MESSAGE_WAIT, messages.next()).await {
            Ok(Some(m)) => m.map_err(|e| e.to_string())?,
            Ok(None) => return Err(format!("the cluster stopped sending {subject}")),
            Err(_) => {
                if last_on(js, stream, subject).await? < last {
                    return Ok(None);
                }
                continue;
            }
        };
        let info = m.info().map_err(|e| e.to_string())?;
        let (seq, pending) = (info.stream_sequence, info.pending);
        out.push(m.payload.to_vec());
        if seq >= last {
            return Ok(Some(out));
        }
        if pending == 0 && last_on(js, stream, subject).await? < last {
            return Ok(None);
        }
    }
}
