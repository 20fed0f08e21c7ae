//! One owner per simulation: a lease is an entry in the `pmcp_leases` bucket, whose entries
//! the server expires after the lease time unless renewed. Taken by `create` (refused while
//! another node's entry lives), renewed by compare-and-set on its revision every quarter of
//! the lease. The holder stops serving a simulation a fifth of the lease before its last
//! renewal could expire (measured from when the renewal was *sent*, so a node that was
//! paused or cut off stops before anyone else can start); appends are fenced besides
//! (`replica`), so a write it had already begun cannot land after a takeover.

use std::sync::Arc;
use std::time::{Duration, Instant};

use async_nats::jetstream::kv;

use super::Cluster;

/// A lease this node holds.
pub struct Held {
    /// The revision the lease was taken at: names this ownership (takeover records, message
    /// ids), unchanged by renewals.
    pub epoch: u64,
    /// The entry's latest revision (what the next renewal must find).
    revision: u64,
    /// Until when this node may serve the simulation.
    valid_until: Instant,
}

/// Why a lease was not taken.
#[derive(Debug)]
pub enum NotTaken {
    /// Another node's lease lives (its name).
    Owned(String),
    /// The cluster failed.
    Failed(String),
}

impl Cluster {
    /// The margin before a lease's expiry at which its holder stops serving.
    fn margin(&self) -> Duration {
        self.config.lease / 5
    }

    /// Takes the lease on `id` for this node (or confirms it holds it); returns its epoch.
    pub fn acquire(&self, id: &str) -> Result<u64, NotTaken> {
        if let Some(epoch) = self
            .held_epoch(id)
            .or_else(|| if self.reclaim(id) { self.held_epoch(id) } else { None })
        {
            return Ok(epoch);
        }
        let leases = self.leases.clone();
        let (key, node) = (id.to_string(), self.config.node.clone());
        let sent = Instant::now();
        let taken = self.run(async move {
            let started = Instant::now();
            loop {
                match leases.create(&key, node.clone().into()).await {
                    Ok(revision) => return Ok(revision),
                    Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => {
                        let entry = leases.entry(&key).await.ok().flatten();
                        let owner = entry.as_ref().map(|e| String::from_utf8_lossy(&e.value).into_owned());
                        return match (entry, owner) {
                            // An earlier run of this node (names are unique among live nodes):
                            // taken back at once, by compare-and-set on what it left.
                            (Some(entry), Some(owner)) if owner == node => leases
                                .update(&key, node.into(), entry.revision)
                                .await
                                .map_err(|e| NotTaken::Failed(e.to_string())),
                            (_, owner) => Err(NotTaken::Owned(owner.unwrap_or_else(|| "unknown".into()))),
                        };
                    }
                    // A bucket not ready or a leader being elected: tried again for a while.
                    Err(e) if started.elapsed() < super::PATIENCE => {
                        tracing::debug!("taking the lease on {key}: {e}; retrying");
                        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
                    }
                    Err(e) => return Err(NotTaken::Failed(e.to_string())),
                }
            }
        })?;
        let valid_until = sent + self.config.lease - self.margin();
        self.held.lock().unwrap_or_else(|p| p.into_inner()).insert(
            id.to_string(),
            Held {
                epoch: taken,
                revision: taken,
                valid_until,
            },
        );
        Ok(taken)
    }

    /// The epoch of the lease this node holds on `id`, while it may still serve it.
    pub fn held_epoch(&self, id: &str) -> Option<u64> {
        let held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        held.get(id).filter(|h| Instant::now() < h.valid_until).map(|h| h.epoch)
    }

    /// Whether this node may serve `id` now: its lease is current, or was let lapse locally
    /// (a renewal came late: a loaded machine, a paused process) but is still this node's in
    /// the bucket, which a compare-and-set renewal proves before anything is served.
    pub fn owns(&self, id: &str) -> bool {
        self.held_epoch(id).is_some() || self.reclaim(id)
    }

    /// Renews a lease this node let lapse locally, if the bucket still holds this node's
    /// revision of it (no other node took it since); otherwise forgets it.
    fn reclaim(&self, id: &str) -> bool {
        let Some(revision) = self
            .held
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get(id)
            .map(|h| h.revision)
        else {
            return false;
        };
        let (leases, key, node) = (self.leases.clone(), id.to_string(), self.config.node.clone());
        let sent = Instant::now();
        let renewed = self.run(async move { leases.update(&key, node.into(), revision).await });
        let mut held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        match renewed {
            Ok(next) => match held.get_mut(id) {
                Some(h) if h.revision == revision => {
                    h.revision = next;
                    h.valid_until = sent + self.config.lease - self.margin();
                    true
                }
                _ => false,
            },
            Err(_) => {
                // Lost, unless the renewer renewed it meanwhile.
                if held.get(id).is_some_and(|h| h.revision == revision) {
                    held.remove(id);
                    return false;
                }
                held.get(id).is_some_and(|h| Instant::now() < h.valid_until)
            }
        }
    }

    /// Gives up the lease on `id` (destroy, shutdown): another node may take it at once.
    pub fn release(&self, id: &str) {
        let Some(held) = self.held.lock().unwrap_or_else(|p| p.into_inner()).remove(id) else {
            return;
        };
        let leases = self.leases.clone();
        let key = id.to_string();
        self.run(async move {
            let _ = leases.delete_expect_revision(&key, Some(held.revision)).await;
        });
    }

    /// Gives up every lease (graceful shutdown).
    pub fn release_all(&self) {
        let ids: Vec<String> = self
            .held
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .keys()
            .cloned()
            .collect();
        for id in ids {
            self.release(&id);
        }
    }
}

/// Renews every held lease each quarter of the lease time, by compare-and-set: a lease whose
/// entry changed (another node took it after it expired) is dropped, and the node stops
/// serving that simulation.
pub fn start_renewing(cluster: &Arc<Cluster>) {
    let weak = Arc::downgrade(cluster);
    let every = cluster.config.lease / 4;
    let Some(rt) = cluster.rt.as_ref() else { return };
    rt.spawn(async move {
        loop {
            tokio::time::sleep(every).await;
            let Some(cluster) = weak.upgrade() else { return };
            let due: Vec<(String, u64)> = {
                let held = cluster.held.lock().unwrap_or_else(|p| p.into_inner());
                held.iter().map(|(k, h)| (k.clone(), h.revision)).collect()
            };
            // All at once: a node holding thousands of simulations renews them in one round
            // trip's time, not one after another.
            let sent = Instant::now();
            let renewals = due.into_iter().map(|(id, revision)| {
                let (leases, node) = (cluster.leases.clone(), cluster.config.node.clone());
                async move {
                    let renewed = leases.update(&id, node.into(), revision).await;
                    (id, revision, renewed)
                }
            });
            for (id, revision, renewed) in futures_util::future::join_all(renewals).await {
                let mut held = cluster.held.lock().unwrap_or_else(|p| p.into_inner());
                match renewed {
                    Ok(next) => {
                        if let Some(h) = held.get_mut(&id) {
                            h.revision = next;
                            h.valid_until = sent + cluster.config.lease - cluster.margin();
                        }
                    }
                    // Lost, unless this process renewed it meanwhile (`reclaim`).
                    Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => {
                        if held.get(&id).is_some_and(|h| h.revision == revision) {
                            tracing::warn!("lost the lease on simulation {id}: another node holds it");
                            held.remove(&id);
                        }
                    }
                    // A transient failure: the lease still runs out on time if it persists.
                    Err(e) => tracing::warn!("could not renew the lease on simulation {id}: {e}"),
                }
            }
        }
    });
}
