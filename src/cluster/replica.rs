//! The hook that makes a simulation's SQLite log a cache of its subject: every commit is
//! published first, with the subject sequence it expects to follow, under this node's lease.
//! Another owner's takeover record (or anything it wrote) makes the expectation stale, so
//! the append is refused and nothing reaches the SQLite file or the client as acknowledged.

use std::sync::Arc;

use super::record::{blob_object, snapshot_object, Commit, WireEvent};
use super::Cluster;
use crate::log::{Event, Replica, Snap, StoreError};

/// The log of record of one simulation this node owns.
pub struct SimReplica {
    cluster: Arc<Cluster>,
    id: String,
    subject: String,
    /// The subject's last sequence this node wrote or read: the next append must follow it.
    expected: u64,
    /// The lease this node writes under.
    epoch: u64,
    /// Blobs stored since the last commit (the commit names them).
    blobs: Vec<String>,
}

impl SimReplica {
    /// The replica of `id`, whose subject this node last saw end at `expected`, written under
    /// the lease of `epoch`.
    pub fn new(cluster: Arc<Cluster>, id: &str, expected: u64, epoch: u64) -> SimReplica {
        let subject = cluster.subject(id).1;
        SimReplica {
            cluster,
            id: id.into(),
            subject,
            expected,
            epoch,
            blobs: Vec::new(),
        }
    }

    /// Refuses to write once this node may no longer serve the simulation.
    fn check_lease(&self) -> Result<(), StoreError> {
        if self.cluster.serves(&self.id, self.epoch) {
            Ok(())
        } else {
            Err(StoreError::Fenced(format!(
                "this node's lease on simulation {} ran out",
                self.id
            )))
        }
    }
}

impl Replica for SimReplica {
    fn put_blob(&mut self, hash: &str, bytes: &[u8]) -> Result<(), StoreError> {
        self.check_lease()?;
        self.cluster
            .put_object(&blob_object(hash), bytes)
            .map_err(StoreError::Cluster)?;
        self.blobs.push(hash.to_string());
        Ok(())
    }

    fn append(&mut self, events: &[(&Event, bool)], head: u64, snapshots: &[Snap]) -> Result<(), StoreError> {
        self.check_lease()?;
        for (_, bytes, hash) in snapshots {
            self.cluster
                .put_object(&snapshot_object(hash), bytes)
                .map_err(StoreError::Cluster)?;
        }
        let commit = Commit {
            events: events.iter().map(|&e| WireEvent::from(e)).collect(),
            head,
            snapshots: snapshots
                .iter()
                .map(|(seq, _, hash)| (*seq, hash.to_string()))
                .collect(),
            blobs: std::mem::take(&mut self.blobs),
        };
        let blobs = commit.blobs.clone();
        let msg_id = format!(
            "{}.{}.{}.{}",
            self.id,
            self.expected,
            self.cluster.config().node,
            self.epoch
        );
        match self
            .cluster
            .publish_commit(&self.subject, commit, self.expected, &msg_id)
        {
            Ok(seq) => {
                self.expected = seq;
                Ok(())
            }
            Err(e) => {
                self.blobs = blobs;
                Err(e)
            }
        }
    }

    fn seal(&mut self) -> Result<(), StoreError> {
        self.check_lease()?;
        let seq = self.cluster.publish_destroyed(&self.id, self.expected, self.epoch)?;
        self.expected = seq;
        Ok(())
    }
}
