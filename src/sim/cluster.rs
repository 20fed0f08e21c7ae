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
use crate::sim::{remove_log_files, sim_not_found, Registry, SharedSim, Sim};
use crate::value::Refusal;

/// The "owned elsewhere" sentence: what a call gets that reached a node while another node's
/// lease lived and the owner took none of its attempts (`mcp::routing` forwards calls to live
/// owners and waits out a dead one's lease first, so a client rarely sees it).
pub fn owned_elsewhere(id: &str, node: &str) -> Refusal {
    format!("Simulation {id} is owned by node {node}; send calls for it to that node (a node takes a simulation over only once its owner's lease lapses)")
}

/// The index entry a simulation's owner writes.
pub(crate) fn index_entry(sim: &Sim) -> IndexEntry {
    IndexEntry {
        name: sim.world().name().map(str::to_string),
        objects: sim.world().object_count(),
        simulation_time: sim.world().current_time(),
    }
}

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
            let epoch = cluster.acquire(&id).map_err(|e| match e {
                NotTaken::Owned(_) => format!("a simulation with id {id} already exists in the cluster"),
                NotTaken::Failed(why) => format!("the cluster could not record simulation {id}: {why}"),
            })?;
            let seq = cluster.upload(&id, &sim.log, epoch).inspect_err(|_| cluster.release(&id))?;
            cluster.index_put(&id, &index_entry(&sim)).inspect_err(|_| {
                let _ = cluster.forget(&id);
            })?;
            Ok::<_, Refusal>((seq, epoch))
        })();
        match joined {
            Ok((seq, epoch)) => {
                sim.log.attach_replica(Box::new(SimReplica::new(cluster.clone(), &id, seq, epoch)));
                sim.cluster = Some(cluster);
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
        if let Some(sim) = self.held_sim(cluster, id) {
            return Ok(sim);
        }
        let _one_at_a_time = self.takeovers.lock().unwrap_or_else(|p| p.into_inner());
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
        tracing::warn!("simulation {id} dropped from memory: {}", if stale { "its cache fell behind the cluster's log" } else { "this node's lease on it ended" });
        self.evict(id);
        None
    }

    /// Takes `id` over: lease, cache rebuilt from the subject, a takeover record written at
    /// the subject's end (so an earlier owner's next append is refused), the world refolded
    /// and checked. A node of another engine build than the simulation's roots declines.
    fn take_over(&self, cluster: &Arc<Cluster>, id: &str) -> Result<Sim, Refusal> {
        let started = std::time::Instant::now();
        let epoch = cluster.acquire(id).map_err(|e| match e {
            NotTaken::Owned(node) => owned_elsewhere(id, &node),
            NotTaken::Failed(why) => format!("The cluster could not give this node simulation {id}: {why}"),
        })?;
        let built = (|| {
            let path = self.path_for(id);
            remove_log_files(&path);
            let seen = cluster.materialize(id, &path, self.config().sync).inspect_err(|_| remove_log_files(&path))?;
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
            sim.cluster = Some(cluster.clone());
            cluster.index_touch(id, &index_entry(&sim));
            Ok(sim)
        })();
        match &built {
            Ok(_) => tracing::info!("took over simulation {id} in {:?}", started.elapsed()),
            Err(_) => cluster.release(id),
        }
        built
    }

    /// Held by destroy_simulation in a cluster, so no call takes the simulation over between
    /// its leaving memory and leaving the cluster.
    pub(crate) fn no_takeovers(&self) -> Option<std::sync::MutexGuard<'_, ()>> {
        self.cluster.as_ref().map(|_| self.takeovers.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// Removes a simulation from the cluster (destroy_simulation on its owner).
    pub(crate) fn forget_in_cluster(&self, id: &str) -> Result<(), Refusal> {
        match &self.cluster {
            Some(cluster) => cluster.forget(id).map_err(|e| format!("Simulation {id} could not be removed from the cluster: {e}")),
            None => Ok(()),
        }
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
        .find(|b| b != crate::engine::ENGINE_BUILD)
}
