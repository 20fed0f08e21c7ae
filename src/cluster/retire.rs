//! What is left of a destroyed simulation, removed. destroy_simulation is decided by a fenced
//! `destroyed` marker on the simulation's subject (`replica`); only after it is acknowledged
//! does the owner remove the rest — its index entry (after its index writes still under way,
//! so none lands after the removal), its subject, the commit envelopes only its subject named,
//! its ownership record. Every step has a deadline; a step that fails is left for the next node
//! that finds the marker (`finish_removal`), since the marker alone already makes every node
//! answer "not found".
//!
//! Snapshots and blobs stay in the object store: they are named by content and shared — a
//! fork copies its parent's snapshots, two loads of one model share its blob — so no single
//! simulation's destruction may delete them.

use std::time::Duration;

use super::record::Record;
use super::Cluster;

/// How long each removal step may take.
const STEP_WAIT: Duration = Duration::from_secs(30);

impl Cluster {
    /// Removes what is left of `id` after its `destroyed` marker was acknowledged: waits for
    /// `index_write` (its last index write), then deletes its index entry, purges its subject,
    /// deletes its commit envelopes and gives up its ownership record. Returns the steps that
    /// failed (each logged); the destroy stands either way.
    pub fn remove(&self, id: &str, index_write: Option<tokio::task::JoinHandle<()>>) -> Vec<String> {
        if let Some(write) = index_write {
            let _ = self.run_for(STEP_WAIT, write);
        }
        let failed = self.finish_removal(id);
        self.release(id);
        failed
    }

    /// Removes the index entry, the subject and the commit envelopes of `id`, whose subject
    /// ends in (or has lost to a purge) its `destroyed` marker. Returns the steps that failed.
    pub fn finish_removal(&self, id: &str) -> Vec<String> {
        let mut failed = Vec::new();
        let envelopes = self.envelopes(id).unwrap_or_else(|e| {
            failed.push(format!("listing its commit envelopes: {e}"));
            Vec::new()
        });
        let index = self.index.clone();
        let key = id.to_string();
        let deleted = self.run_for(STEP_WAIT, async move { super::patiently(|| index.delete(&key)).await.map_err(|e| e.to_string()) });
        if let Err(e) = deleted.and_then(|r| r) {
            failed.push(format!("deleting its index entry: {e}"));
        }
        let (js, (stream, subject)) = (self.js.clone(), self.subject(id));
        let purged = self.run_for(STEP_WAIT, async move {
            super::patiently(|| async {
                let stream = js.get_stream_no_info(&stream).await.map_err(|e| e.to_string())?;
                stream.purge().filter(subject.clone()).await.map(|_| ()).map_err(|e| e.to_string())
            })
            .await
        });
        if let Err(e) = purged.and_then(|r| r) {
            failed.push(format!("purging its subject: {e}"));
        }
        let objects = self.objects.clone();
        let removed = self.run_for(STEP_WAIT, async move {
            for name in envelopes {
                if let Err(e) = objects.delete(&name).await {
                    tracing::debug!("deleting {name}: {e}");
                }
            }
        });
        if let Err(e) = removed {
            failed.push(format!("deleting its commit envelopes: {e}"));
        }
        for step in &failed {
            tracing::warn!("destroyed simulation {id}: {step} failed; the next node that finds its marker finishes it");
        }
        failed
    }

    /// The commit envelopes (`env/…` objects) `id`'s subject names.
    fn envelopes(&self, id: &str) -> Result<Vec<String>, String> {
        let records = self.raw_records(id)?;
        Ok(records
            .iter()
            .filter_map(|bytes| match serde_json::from_slice::<Record>(bytes) {
                Ok(Record::Stored { object, .. }) => Some(object),
                _ => None,
            })
            .collect())
    }

    /// Whether `id`'s subject ends in a `destroyed` marker (its removal was not finished).
    pub fn ends_destroyed(&self, id: &str) -> bool {
        let (stream, subject) = self.subject(id);
        let js = self.js.clone();
        let last = self.run_for(STEP_WAIT, async move {
            let stream = js.get_stream_no_info(&stream).await.map_err(|e| e.to_string())?;
            stream.get_last_raw_message_by_subject(&subject).await.map_err(|e| e.to_string())
        });
        matches!(last, Ok(Ok(m)) if matches!(serde_json::from_slice::<Record>(&m.payload), Ok(Record::Destroyed { .. })))
    }
}
