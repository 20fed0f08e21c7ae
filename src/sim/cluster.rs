//! What a registry does differently in a cluster (`serve --cluster`): a simulation joins the
//! cluster when it is published (lease, whole log uploaded, index entry, replica attached);
//! a call for a simulation this node does not hold takes it over when its lease has lapsed
//! (cache rebuilt from the subject, a takeover record fencing the old owner, the world
//! refolded); one this node stopped holding is dropped from memory. docs/cluster.md.

use std::sync::{Arc, Mutex};

use crate::cluster::lease::NotTaken;
use crate::cluster::replica::SimReplica;
use crate::cluster::{Cluster, IndexEntry};
use crate::log::EventLog;
use crate::sim::{lock_sim, remove_log_files, sim_not_found, Registry, SharedSim, Sim};
use crate::value::Refusal;

/// A simulation's place in a cluster: the cluster, the ownership it is served under, and its
/// index write under way (the next waits for it; a destroy waits for it before removing the
/// entry, so no write lands after).
pub(crate) struct Seat {
    cluster: Arc<Cluster>,
    /// The epoch of this node's ownership the simulation was taken (or made) under.
    epoch: u64,
    index_write: Option<tokio::task::JoinHandle<()>>,
}

/// The words of the refusal a call gets that waited for a simulation on a node that, by the
/// time the call ran, no longer served it (its lease ended while the call waited): nothing was
/// done or recorded, and routing sends the call again — to the simulation's owner now.
pub const MOVED: &str = "is no longer served by this node";

/// The "moved" sentence (see [`MOVED`]).
pub fn moved(id: &str) -> Refusal {
    format!("Simulation {id} {MOVED} (its lease ended while the call waited); nothing was done: call again")
}

/// The "owned elsewhere" sentence: what a call gets that reached a node while another node's
/// lease lived and the owner took none of its attempts (`mcp::routing` forwards calls to live
/// owners and waits out a dead one's lease first, so a client rarely sees it).
pub fn owned_elsewhere(id: &str, node: &str) -> Refusal {
    format!("Simulation {id} {OWNED_BY} {node}; send calls for it to that node (a node takes a simulation over only once its owner's lease lapses)")
}

/// The index entry a simulation's owner writes.
pub(crate) fn index_entry(sim: &Sim) -> IndexEntry {
    IndexEntry {
        name: sim.world().name().map(str::to_string),
        objects: sim.world().object_count(),
        simulation_time: sim.world().current_time(),
    }
}

impl Sim {
    /// In a cluster, rewrites this simulation's index entry after its head moved (a change,
    /// an undo or redo), so list_simulations on other nodes shows what it shows here.
    pub(crate) fn index_changed(&mut self) {
        let entry = index_entry(self);
        if let Some(seat) = &mut self.cluster {
            let after = seat.index_write.take();
            seat.index_write = seat.cluster.index_touch(self.world.simulation_id(), &entry, after);
        }
    }

    /// The lease check every call on a simulation makes once it holds the simulation's lock
    /// (`Sim::ensure_live` calls it, so reads, changes, forks, saves, sweeps and destroy all
    /// do): in a cluster, refused with [`moved`] unless this node still serves the simulation
    /// under the ownership it was taken under. A call that waited for the lock while this node
    /// was paused past its lease — and another node took over and wrote — can then neither
    /// answer from the stale state nor act on it. Embedded, nothing to check.
    ///
    /// Whoever waits for a busy simulation (the MCP layer's queue) calls this — through
    /// `ensure_live` — after the wait, never only before it.
    pub(crate) fn fenced(&self) -> Result<(), Refusal> {
        match &self.cluster {
            Some(seat) if !seat.cluster.serves(self.world.simulation_id(), seat.epoch) => Err(moved(self.world.simulation_id())),
            _ => Ok(()),
        }
    }

    /// Destroys this simulation in its cluster's log of record: the fenced `destroyed`
    /// marker, appended under the lock after the lease check; refused ([`moved`]) when another
    /// node wrote since. Returns what the removal needs. Embedded, nothing.
    pub(crate) fn seal(&mut self) -> Result<Option<Sealed>, Refusal> {
        self.fenced()?;
        let id = self.id().to_string();
        if self.cluster.is_none() {
            return Ok(None);
        }
        match self.log.seal() {
            Ok(()) => Ok(self.cluster.take().map(|seat| (seat.cluster, seat.index_write))),
            Err(crate::log::StoreError::Fenced(_)) => Err(moved(&id)),
            Err(e) => Err(format!("Simulation {id} could not be destroyed: {e}")),
        }
    }
}

/// What removing a sealed (destroyed) simulation from its cluster needs: the cluster, and the
/// index write still under way (awaited first, so none lands after the removal).
pub(crate) type Sealed = (Arc<Cluster>, Option<tokio::task::JoinHandle<()>>);

/// The words an "owned elsewhere" refusal holds (routing retries a call refused so in the
/// instant a dead owner's lease lapses: replicas expire it one by one).
pub const OWNED_BY: &str = "is owned by node";

impl Registry {
    /// Gives a complete simulation its final name and, in a cluster, makes it the cluster's:
    /// lease taken (refused if the id exists), whole log published, index entry written,
    /// later commits sent to its subject first. On failure nothing of it is left.
    pub(crate) fn publish_sim(&self, sim: Sim) -> Result<Sim, Refusal> {
        let path = self.path_for(sim.id());
        let mut sim = sim.publish(&path)?;
        let Some(cluster) = self.cluster.clone() else { return Ok(sim) };
        let id = sim.id().to_string();
        let joined = (|| {
            let epoch = cluster.acquire(&id, true).map_err(|e| match e {
                NotTaken::Owned(_) => format!("a simulation with id {id} already exists in the cluster"),
                NotTaken::Failed(why) => format!("the cluster could not record simulation {id}: {why}"),
            })?;
            let seq = cluster.upload(&id, &sim.log, epoch).inspect_err(|_| cluster.release(&id))?;
            cluster.index_put(&id, &index_entry(&sim)).inspect_err(|_| {
                // The subject holds the whole log: ended as a destroy ends it, so no node
                // takes up a simulation whose creation was refused.
                let _ = cluster.publish_destroyed(&id, seq, epoch);
                cluster.remove(&id, None);
            })?;
            Ok::<_, Refusal>((seq, epoch))
        })();
        match joined {
            Ok((seq, epoch)) => {
                sim.log.attach_replica(Box::new(SimReplica::new(cluster.clone(), &id, seq, epoch)));
                sim.cluster = Some(Seat { cluster, epoch, index_write: None });
                Ok(sim)
            }
            Err(why) => {
                sim.delete();
                Err(why)
            }
        }
    }

    /// `get` in a cluster: a simulation this node holds, or one it takes over now.
    pub(crate) fn get_in_cluster(&self, cluster: &Arc<Cluster>, id: &str) -> Result<SharedSim, Refusal> {
        // An id that cannot name a simulation names none: answered before the cluster is asked.
        if !crate::cluster::valid_id(id) {
            return Err(sim_not_found(id));
        }
        if let Some(sim) = self.held_sim(cluster, id) {
            return Ok(sim);
        }
        // One takeover of this simulation at a time; other simulations' calls go on.
        let lock = cluster.one_at_a_time(id);
        let _one_at_a_time = lock.hold();
        if let Some(sim) = self.held_sim(cluster, id) {
            return Ok(sim);
        }
        if cluster.index_get(id).map_err(|e| format!("The cluster could not be asked for simulation {id}: {e}"))?.is_none() {
            return Err(sim_not_found(id));
        }
        let sim = self.take_over(cluster, id)?;
        let shared: SharedSim = Arc::new(Mutex::new(sim));
        self.insert(id, shared.clone());
        Ok(shared)
    }

    /// The simulation if this node holds it and its lease; one whose lease it lost is dropped
    /// from memory (its cache file stays until the next takeover rewrites it).
    fn held_sim(&self, cluster: &Cluster, id: &str) -> Option<SharedSim> {
        let sim = self.lookup(id)?;
        // A cache that fell behind its log of record (a local write failed after the cluster
        // took the commit) is rebuilt: dropped here, taken over again below.
        let stale = sim.try_lock().is_ok_and(|s| s.log.is_stale());
        if cluster.owns(id) && !stale {
            return Some(sim);
        }
        if stale {
            cluster.forget_held(id);
        }
        tracing::warn!("simulation {id} dropped from memory: {}", if stale { "its cache fell behind the cluster's log" } else { "this node's lease on it ended" });
        self.evict(id);
        None
    }

    /// Takes `id` over: lease, cache rebuilt from the subject, a takeover record written at
    /// the subject's end (so an earlier owner's next append is refused), the world refolded
    /// and checked. A node of another engine build than the simulation's roots declines.
    fn take_over(&self, cluster: &Arc<Cluster>, id: &str) -> Result<Sim, Refusal> {
        let started = std::time::Instant::now();
        let epoch = cluster.acquire(id, false).map_err(|e| match e {
            NotTaken::Owned(node) => owned_elsewhere(id, &node),
            NotTaken::Failed(why) => format!("The cluster could not give this node simulation {id}: {why}"),
        })?;
        let built = (|| {
            let path = self.path_for(id);
            remove_log_files(&path);
            let seen = cluster.materialize(id, &path, self.config().sync).map_err(|e| {
                remove_log_files(&path);
                if e.starts_with(crate::cluster::transfer::NO_LOG) {
                    // Destroyed (its marker is there, or its subject was purged) and not yet
                    // removed everywhere: this node finishes the removal.
                    cluster.finish_removal(id);
                    sim_not_found(id)
                } else {
                    e
                }
            })?;
            let refuse = |why: String| {
                remove_log_files(&path);
                why
            };
            let mut sim = Sim::recover(&path, self.config().sync).map_err(|e| refuse(format!("Simulation {id} could not be taken over: {e}")))?;
            if let Some(other) = foreign_engine(&sim) {
                drop(sim);
                return Err(refuse(format!(
                    "Simulation {id} was recorded by engine build {other} and this node runs {}; it does not take it over (results would fork)",
                    crate::engine::ENGINE_BUILD
                )));
            }
            let last = cluster.claim(id, seen, epoch).map_err(|e| refuse(format!("Simulation {id} could not be taken over: {e}")))?;
            sim.log.attach_replica(Box::new(SimReplica::new(cluster.clone(), id, last, epoch)));
            let index_write = cluster.index_touch(id, &index_entry(&sim), None);
            sim.cluster = Some(Seat { cluster: cluster.clone(), epoch, index_write });
            Ok(sim)
        })();
        match &built {
            Ok(_) => tracing::info!("took over simulation {id} in {:?}", started.elapsed()),
            Err(_) => cluster.release(id),
        }
        built
    }

    /// destroy_simulation on a cluster node: the simulation is taken (or taken over) here,
    /// then — holding its takeover lock, so no call takes it over meanwhile, and its own lock,
    /// after the lease check — destroyed by its fenced `destroyed` marker; only then are its
    /// files, index entry, subject and ownership removed. A node that lost the lease while the
    /// call waited refuses with [`moved`] (routing sends the call to the owner) and undoes
    /// nothing.
    pub(crate) fn destroy_in_cluster(&self, cluster: &Arc<Cluster>, id: &str) -> Result<(), Refusal> {
        self.get_in_cluster(cluster, id)?;
        let lock = cluster.one_at_a_time(id);
        let _one_at_a_time = lock.hold();
        let sim = self.lookup(id).ok_or_else(|| sim_not_found(id))?;
        let (path, sealed) = {
            let mut guard = lock_sim(&sim);
            let sealed = match guard.seal() {
                Ok(sealed) => sealed,
                Err(why) => {
                    // Not this node's any more (or unknown): dropped from memory, taken over
                    // again from the cluster by the next call.
                    drop(guard);
                    self.evict(id);
                    return Err(why);
                }
            };
            guard.mark_destroyed();
            (guard.log.path().to_path_buf(), sealed)
        };
        self.evict(id);
        remove_log_files(&path);
        if let Some((cluster, index_write)) = sealed {
            cluster.remove(id, index_write);
        }
        Ok(())
    }

    /// How many simulations the cluster holds (for --max-sims, counted per cluster).
    pub(crate) fn cluster_count(&self) -> Result<Option<usize>, Refusal> {
        let Some(cluster) = self.cluster.as_ref() else { return Ok(None) };
        let all = cluster.index_all().map_err(|e| format!("The cluster could not count its simulations (--max-sims): {e}"))?;
        Ok(Some(all.len()))
    }

    /// The cluster's simulations this node does not hold, from the index.
    pub(crate) fn listed_elsewhere(&self, here: &[String]) -> Vec<(String, IndexEntry)> {
        let Some(cluster) = &self.cluster else { return Vec::new() };
        match cluster.index_all() {
            Ok(all) => all.into_iter().filter(|(id, _)| !here.contains(id)).collect(),
            Err(e) => {
                tracing::warn!("could not list the cluster's simulations: {e}");
                Vec::new()
            }
        }
    }

    /// Gives up every lease (graceful shutdown, after the flush): the simulations can be taken
    /// over at once instead of after the lease time.
    pub fn leave_cluster(&self) {
        if let Some(cluster) = &self.cluster {
            cluster.release_all();
        }
    }
}

/// The engine build of a root of `sim`'s own log that is not this binary's, if any.
fn foreign_engine(sim: &Sim) -> Option<String> {
    let events = sim.log.all_events().ok()?;
    events
        .iter()
        .filter(|e| e.kind == crate::log::Kind::Root && !e.inherited)
        .filter_map(|e| e.engine.clone())
        // As embedded replay reads them (`engine::differences`): the vendored rapier
        // `<release>+pmcp.<N>` reads logs of its release, so an imported log of the release
        // is taken over; any other difference would fork results.
        .find(|b| !crate::engine::differences(b, crate::engine::ENGINE_BUILD).is_empty())
}
