//! Who serves a simulation: a lease per *node* and an ownership record per *simulation*.
//!
//! - `NS_nodes`: one entry per live node (key: its name; value: a token naming this run of it,
//!   its *incarnation*), renewed by compare-and-set every quarter of the lease and expired by the
//!   NATS servers (the bucket's `max_age` is the lease) when its node stops renewing. One
//!   renewal per node, however many simulations it holds: idle simulations cost nothing.
//! - `NS_owners`: one entry per owned simulation (key: its id; value: the owning node and its
//!   incarnation), written when a simulation joins the cluster and changed only by a takeover —
//!   by compare-and-set, and only once the recorded incarnation's node lease is gone. Its
//!   revision is the ownership's *epoch* (takeover records and message ids name it).
//!
//! A node serves a simulation while it holds its record and its own node lease is current. It
//! stops a fifth of the lease before its last renewal could expire, measured from when that
//! renewal was *sent*, so a node that was paused or cut off stops before anyone else can start;
//! a node lease that lapsed locally (a late renewal on a loaded machine) is renewed by
//! compare-and-set before anything is served, which succeeds only if the entry never expired
//! (so no other node can have taken anything). A node whose entry expired has lost every
//! simulation at once: it forgets them all and joins again under a new incarnation. Every
//! decision that lets a node take a simulation is read from the buckets' stream leaders, never
//! from a replica that may lag (`leader_entry`). Appends are fenced besides (`replica`).

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use async_nats::jetstream::kv;
use serde::{Deserialize, Serialize};

use super::Cluster;

/// This process's entry in `NS_nodes`.
pub(super) struct NodeLease {
    /// The token naming this run of the node (the entry's value).
    token: String,
    /// The entry's latest revision (what the next renewal must find).
    revision: u64,
    /// Until when this node may serve what it holds.
    valid_until: Instant,
}

/// An ownership record in `NS_owners`: which run of which node owns a simulation.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Eq)]
pub struct Owner {
    /// The node's name (where calls for the simulation go).
    pub node: String,
    /// The node's incarnation when it took the simulation (the token of its node lease then).
    pub token: String,
}

/// What this node holds: its lease and the simulations it owns, by id, with their epochs.
#[derive(Default)]
pub(super) struct Holdings {
    node: Option<NodeLease>,
    sims: HashMap<String, u64>,
}

/// Why a lease was not taken.
#[derive(Debug)]
pub enum NotTaken {
    /// Another live node owns the simulation (its name).
    Owned(String),
    /// The cluster failed, or this node is not in it right now.
    Failed(String),
}

/// A key's last value and revision as the stream leader has it (None: no such key, or
/// deleted). Direct gets may be answered by a replica that lags; this never is.
pub(crate) async fn leader_entry(store: &kv::Store, key: &str) -> Result<Option<(bytes::Bytes, u64)>, String> {
    use async_nats::jetstream::stream::LastRawMessageErrorKind;
    let subject = format!("{}{key}", store.prefix);
    let got = super::patiently_unless(|| async {
        match store.stream.get_last_raw_message_by_subject(&subject).await {
            Ok(m) => Ok(Some(m)),
            Err(e) if e.kind() == LastRawMessageErrorKind::NoMessageFound => Ok(None),
            Err(e) if e.kind() == LastRawMessageErrorKind::InvalidSubject => Err(super::Failure::permanent(e)),
            Err(e) => Err(super::Failure::passing(e)),
        }
    })
    .await
    .map_err(|e| e.to_string())?;
    let Some(m) = got else { return Ok(None) };
    let removed = m.headers.get("KV-Operation").is_some_and(|op| matches!(op.as_str(), "DEL" | "PURGE"))
        || m.headers.get("Nats-Marker-Reason").is_some();
    Ok((!removed).then_some((m.payload, m.sequence)))
}

impl Cluster {
    /// The margin before a lease's expiry at which its holder stops serving.
    fn margin(&self) -> Duration {
        self.config.lease / 5
    }

    /// How long a renewal sent at `sent` lets this node serve.
    fn valid_from(&self, sent: Instant) -> Instant {
        sent + self.config.lease - self.margin()
    }

    fn holdings(&self) -> std::sync::MutexGuard<'_, Holdings> {
        self.held.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Joins the cluster as a node: its entry in `NS_nodes` under a new incarnation. An entry
    /// of the same name left by an earlier run (names are unique among live nodes) is taken
    /// over at once, which frees every simulation that run held.
    ///
    /// One join at a time, and none over a lease another caller has just got: after a lost
    /// lease the renewer and a takeover both join, and two racing joins gave the node two
    /// incarnations — ownership records written under the first while the node's entry held
    /// the second. Other nodes then saw the records' incarnation dead and took over
    /// simulations this node still served: a read answered from its memory after another
    /// node's acknowledged change (the fault schedule's stale read, seed 7027981827904121657).
    pub(super) fn join(&self) -> Result<(), String> {
        let _one = self.joining.lock().unwrap_or_else(|p| p.into_inner());
        if self.holdings().node.is_some() {
            return Ok(());
        }
        let (nodes, name) = (self.nodes.clone(), self.config.node.clone());
        let token = uuid::Uuid::new_v4().simple().to_string();
        let value: bytes::Bytes = token.clone().into();
        let sent = Instant::now();
        let revision = self.run_for(super::PATIENCE + Duration::from_secs(5), async move {
            super::patiently(|| async {
                match nodes.create(&name, value.clone()).await {
                    Ok(r) => Ok(r),
                    Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => {
                        let (_, revision) = leader_entry(&nodes, &name).await?.unwrap_or_default();
                        nodes.update(&name, value.clone(), revision).await.map_err(|e| e.to_string())
                    }
                    Err(e) => Err(e.to_string()),
                }
            })
            .await
        })??;
        let mut h = self.holdings();
        // Whatever was held belonged to an earlier incarnation, dead to every other node now.
        h.sims.clear();
        h.node = Some(NodeLease { token, revision, valid_until: self.valid_from(sent) });
        Ok(())
    }

    /// This node's incarnation while its lease is current.
    fn current_token(&self) -> Option<String> {
        let h = self.holdings();
        h.node.as_ref().filter(|n| Instant::now() < n.valid_until).map(|n| n.token.clone())
    }

    /// This node's incarnation, renewing a lease that lapsed locally first (by compare-and-set:
    /// only if its entry never expired). None: this node holds nothing now.
    fn live_token(&self) -> Option<String> {
        if let Some(token) = self.current_token() {
            return Some(token);
        }
        let (token, revision) = {
            let h = self.holdings();
            let n = h.node.as_ref()?;
            (n.token.clone(), n.revision)
        };
        let (nodes, name, value) = (self.nodes.clone(), self.config.node.clone(), token.clone());
        let sent = Instant::now();
        let renewed = self.run_for(Duration::from_secs(10), async move { nodes.update(&name, value.into(), revision).await });
        match renewed {
            Ok(Ok(next)) => {
                self.renewed(&token, revision, next, sent);
                Some(token)
            }
            Ok(Err(e)) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => {
                self.lost(&token);
                None
            }
            // The cluster did not answer: nothing is served until it does.
            _ => None,
        }
    }

    /// A renewal of incarnation `token` from `revision` to `next`, sent at `sent`, succeeded.
    fn renewed(&self, token: &str, revision: u64, next: u64, sent: Instant) {
        let valid_until = self.valid_from(sent);
        let mut h = self.holdings();
        if let Some(n) = h.node.as_mut().filter(|n| n.token == token && n.revision == revision) {
            n.revision = next;
            n.valid_until = n.valid_until.max(valid_until);
        }
    }

    /// Incarnation `token`'s entry is gone (it expired, or another run of this name took it):
    /// every simulation it held is another node's to take. Forgets them all.
    fn lost(&self, token: &str) {
        let mut h = self.holdings();
        if h.node.as_ref().is_some_and(|n| n.token == token) {
            let n = h.sims.len();
            h.node = None;
            h.sims.clear();
            tracing::warn!("this node's lease lapsed: the {n} simulations it held are dropped (other nodes may take them over)");
        }
    }

    /// Takes simulation `id` for this node — a new one (`fresh`: refused if any record exists)
    /// or one whose owner is gone (its record names an incarnation whose node lease expired) —
    /// and returns the epoch of this ownership.
    pub fn acquire(&self, id: &str, fresh: bool) -> Result<u64, NotTaken> {
        if self.holdings().node.is_none() {
            // Lost earlier (a long pause): joins again under a new incarnation.
            self.join().map_err(NotTaken::Failed)?;
        }
        let Some(token) = self.live_token() else {
            return Err(NotTaken::Failed("this node's lease on the cluster lapsed and could not be renewed yet".into()));
        };
        let (owners, nodes) = (self.owners.clone(), self.nodes.clone());
        let mine = Owner { node: self.config.node.clone(), token: token.clone() };
        let key = id.to_string();
        let taken = self.run_for(super::PATIENCE + Duration::from_secs(5), async move {
            let value: bytes::Bytes = serde_json::to_vec(&mine).unwrap_or_default().into();
            let started = Instant::now();
            loop {
                let attempt = async {
                    match leader_entry(&owners, &key).await.map_err(NotTaken::Failed)? {
                        None => match owners.create(&key, value.clone()).await {
                            Ok(r) => Ok(Some(r)),
                            Err(e) if e.kind() == kv::CreateErrorKind::AlreadyExists => Ok(None),
                            Err(e) => Err(NotTaken::Failed(e.to_string())),
                        },
                        Some(_) if fresh => Err(NotTaken::Owned(String::new())),
                        Some((bytes, revision)) => {
                            let owner: Option<Owner> = serde_json::from_slice(&bytes).ok();
                            if owner.as_ref() == Some(&mine) {
                                return Ok(Some(revision));
                            }
                            if let Some(o) = owner.filter(|o| o.node != mine.node || o.token != mine.token) {
                                if alive(&nodes, &o).await.map_err(NotTaken::Failed)? {
                                    return Err(NotTaken::Owned(o.node));
                                }
                            }
                            match owners.update(&key, value.clone(), revision).await {
                                Ok(r) => Ok(Some(r)),
                                // Another node took it first: read again.
                                Err(e) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => Ok(None),
                                Err(e) => Err(NotTaken::Failed(e.to_string())),
                            }
                        }
                    }
                };
                match attempt.await {
                    Ok(Some(epoch)) => return Ok(epoch),
                    Ok(None) => {}
                    Err(NotTaken::Failed(e)) if started.elapsed() < super::PATIENCE => {
                        tracing::debug!("taking simulation {key}: {e}; retrying");
                    }
                    Err(e) => return Err(e),
                }
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        })
        .map_err(NotTaken::Failed)??;
        let mut h = self.holdings();
        // The node lease must still be the one the record names.
        if h.node.as_ref().is_none_or(|n| n.token != token) {
            return Err(NotTaken::Failed("this node's lease on the cluster lapsed while it took the simulation".into()));
        }
        h.sims.insert(id.to_string(), taken);
        Ok(taken)
    }

    /// The epoch of this node's ownership of `id`, while it may still serve it.
    pub fn held_epoch(&self, id: &str) -> Option<u64> {
        let h = self.holdings();
        let current = h.node.as_ref().is_some_and(|n| Instant::now() < n.valid_until);
        h.sims.get(id).copied().filter(|_| current)
    }

    /// Whether this node may serve `id` now: it owns it and its node lease is current — or was
    /// let lapse locally but never expired, which a compare-and-set renewal proves first.
    pub fn owns(&self, id: &str) -> bool {
        self.held_epoch(id).is_some() || (self.holdings().sims.contains_key(id) && self.live_token().is_some() && self.held_epoch(id).is_some())
    }

    /// Whether this node may still serve `id` under `epoch` (the ownership a simulation in
    /// memory was taken under): the check every call makes once it holds the simulation.
    pub fn serves(&self, id: &str, epoch: u64) -> bool {
        self.owns(id) && self.held_epoch(id) == Some(epoch)
    }

    /// Gives up simulation `id` (destroy): its record is deleted if it is still this
    /// ownership's, so nobody waits for this node's lease to take a new simulation of that id.
    pub fn release(&self, id: &str) {
        let Some(epoch) = self.holdings().sims.remove(id) else { return };
        let (owners, key) = (self.owners.clone(), id.to_string());
        let _ = self.run_for(Duration::from_secs(10), async move { owners.delete_expect_revision(&key, Some(epoch)).await });
    }

    /// Forgets simulation `id` here without touching its record (it was found moved).
    pub fn forget_held(&self, id: &str) {
        self.holdings().sims.remove(id);
    }

    /// Gives up everything (graceful shutdown): the node's entry is deleted, so every
    /// simulation it held can be taken over at once instead of after the lease time.
    pub fn release_all(&self) {
        let node = {
            let mut h = self.holdings();
            h.sims.clear();
            h.node.take()
        };
        let Some(node) = node else { return };
        let (nodes, name) = (self.nodes.clone(), self.config.node.clone());
        let _ = self.run_for(Duration::from_secs(5), async move { nodes.delete_expect_revision(&name, Some(node.revision)).await });
    }

    /// Who owns `id` now: the node its record names while that node's incarnation lives; None
    /// when nobody does (never taken since an `import`, or its owner's lease expired).
    pub async fn lease_holder(self: &Arc<Self>, id: &str) -> Result<Option<String>, String> {
        let (owners, nodes, key) = (self.owners.clone(), self.nodes.clone(), id.to_string());
        self.spawn(async move {
            let Some((bytes, _)) = leader_entry(&owners, &key).await? else { return Ok(None) };
            let Ok(owner) = serde_json::from_slice::<Owner>(&bytes) else { return Ok(None) };
            Ok(alive(&nodes, &owner).await?.then_some(owner.node))
        })
        .await?
    }

    /// Whether the node named `node` is in the cluster now (its lease lives), by its name
    /// alone (a sweeping node, whose work items name it).
    pub async fn node_alive(self: &Arc<Self>, node: &str, token: &str) -> Result<bool, String> {
        let nodes = self.nodes.clone();
        let owner = Owner { node: node.to_string(), token: token.to_string() };
        self.spawn(async move { alive(&nodes, &owner).await }).await?
    }

    /// This node's incarnation (for work items other nodes check it by), if current.
    pub fn incarnation(&self) -> Option<String> {
        self.live_token()
    }
}

/// Whether `owner`'s incarnation still holds its node lease (read from the leader).
async fn alive(nodes: &kv::Store, owner: &Owner) -> Result<bool, String> {
    Ok(leader_entry(nodes, &owner.node).await?.is_some_and(|(token, _)| token.as_ref() == owner.token.as_bytes()))
}

/// Renews this node's lease each quarter of the lease time, by compare-and-set: an entry that
/// changed or expired means every simulation it held may be another node's now — they are all
/// dropped, and the node joins again under a new incarnation.
pub fn start_renewing(cluster: &Arc<Cluster>) {
    let weak = Arc::downgrade(cluster);
    let every = cluster.config.lease / 4;
    let Some(rt) = cluster.rt.as_ref() else { return };
    rt.spawn(async move {
        loop {
            tokio::time::sleep(every).await;
            let Some(cluster) = weak.upgrade() else { return };
            let due = cluster.holdings().node.as_ref().map(|n| (n.token.clone(), n.revision));
            let Some((token, revision)) = due else {
                // Lost earlier: join again (nothing is held until then).
                let c = cluster.clone();
                if let Err(e) = tokio::task::spawn_blocking(move || c.join()).await.unwrap_or_else(|e| Err(e.to_string())) {
                    tracing::warn!("this node could not join the cluster again: {e}");
                }
                continue;
            };
            let (nodes, name) = (cluster.nodes.clone(), cluster.config.node.clone());
            let sent = Instant::now();
            match tokio::time::timeout(every, nodes.update(&name, token.clone().into(), revision)).await {
                Ok(Ok(next)) => cluster.renewed(&token, revision, next, sent),
                Ok(Err(e)) if e.kind() == kv::UpdateErrorKind::WrongLastRevision => cluster.lost(&token),
                // A transient failure: the lease still runs out on time if it persists.
                Ok(Err(e)) => tracing::warn!("could not renew this node's lease: {e}"),
                Err(_) => tracing::warn!("could not renew this node's lease: no answer within {every:?}"),
            }
        }
    });
}
