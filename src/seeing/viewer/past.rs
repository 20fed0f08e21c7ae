//! The viewer's timeline: the head's chain as a list of events, and the picture of any past
//! state on it — after event `seq`, or after `step` steps inside step event `seq` — re-simulated
//! by the one core (`fold::lend` under the lock, `fold::resimulate` without it) and cached as
//! a captured scene, so scrubbing back and forth or turning the camera costs a render only.

use std::collections::VecDeque;
use std::sync::{Arc, LazyLock, Mutex};

use serde::Serialize;

use crate::command::Command;
use crate::log::fold::{self, At};
use crate::seeing::sensing::capture::Scene;
use crate::sim::Sim;
use crate::seeing::viewer::Overlays;

/// Past states kept rendered-ready (scenes are small: poses and shape handles).
const CACHED: usize = 64;

/// One state-changing event of the head's chain, as the timeline shows it.
#[derive(Serialize, Debug, Clone)]
pub struct Mark {
    /// The event.
    pub seq: u64,
    /// Its tool.
    pub tool: String,
    /// Steps it took (step events), else 0.
    pub steps: u64,
    /// Steps since the simulation's creation after it.
    pub total_steps: u64,
    /// Whether it was inherited from a fork's or a load's parent.
    pub inherited: bool,
}

/// The timeline of `sim`: every state-changing event from its root to its head.
#[derive(Serialize, Debug)]
pub struct Timeline {
    /// The simulation.
    pub simulation_id: String,
    /// Its head.
    pub head_seq: u64,
    /// Oldest first.
    pub events: Vec<Mark>,
}

/// The timeline of `sim` (read from its log; no physics).
pub fn timeline(sim: &Sim) -> Result<Timeline, String> {
    let chain = sim.log().chain_to(sim.log().head_seq()).map_err(|e| format!("the log could not be read: {e}"))?;
    let mut total = 0;
    let events = chain
        .iter()
        .map(|e| {
            let steps = match fold::decode(e, sim.log()) {
                Ok(Some(Command::StepSimulation { steps })) => steps,
                _ => 0,
            };
            total += steps;
            Mark { seq: e.seq, tool: e.tool.clone(), steps, total_steps: total, inherited: e.inherited }
        })
        .collect();
    Ok(Timeline { simulation_id: sim.id().to_string(), head_seq: sim.log().head_seq(), events })
}

/// A past state, ready to render.
pub struct Past {
    /// What the camera sees.
    pub scene: Scene,
    /// Steps since creation.
    pub steps: u64,
    /// Simulated time (s).
    pub time: f64,
    /// Objects.
    pub objects: usize,
    /// Its state hash.
    pub state_hash: String,
    /// Contacts and body frames then, as its recorded viewer settings asked.
    pub overlays: Overlays,
}

type Key = (String, u64, Option<u64>);

/// Recently re-simulated states, oldest first.
type Cache = VecDeque<(Key, Arc<Past>)>;

static CACHE: LazyLock<Mutex<Cache>> = LazyLock::new(Default::default);

fn cached(key: &Key) -> Option<Arc<Past>> {
    let cache = CACHE.lock().unwrap_or_else(|p| p.into_inner());
    cache.iter().find(|(k, _)| k == key).map(|(_, p)| p.clone())
}

fn remember(key: Key, past: Arc<Past>) {
    let mut cache = CACHE.lock().unwrap_or_else(|p| p.into_inner());
    if cache.len() >= CACHED {
        cache.pop_front();
    }
    cache.push_back((key, past));
}

/// What to lend for the state after `seq` (and `step` steps into it), decided under the lock.
pub struct Request {
    key: Key,
    lent: Option<fold::Lent>,
    step: Option<u64>,
}

/// Looks `seq` (and `step`) up on `sim`'s chain and lends what re-simulating it needs; a cached
/// state lends nothing. Refuses a seq off the chain, or a step outside a step event's steps.
pub fn request(sim: &Sim, seq: u64, step: Option<u64>) -> Result<Request, String> {
    let key = (sim.id().to_string(), seq, step);
    if cached(&key).is_some() {
        return Ok(Request { key, lent: None, step });
    }
    let lent = match step {
        None => fold::lend(sim.log(), sim.id(), Some(seq), Some(seq))?,
        Some(k) => {
            let e = sim.log().event(seq).map_err(|e| e.to_string())?.ok_or_else(|| format!("seq {seq} is not an event of this simulation"))?;
            let steps = match fold::decode(&e, sim.log()) {
                Ok(Some(Command::StepSimulation { steps })) => steps,
                _ => return Err(format!("step is only meaningful inside a step_simulation event; seq {seq} is {}", e.tool)),
            };
            if k == 0 || k > steps {
                return Err(format!("step must be from 1 to {steps} (the steps event {seq} took); got {k}"));
            }
            let parent = e.parent.ok_or_else(|| format!("seq {seq} has no parent"))?;
            fold::lend(sim.log(), sim.id(), Some(parent), Some(seq))?
        }
    };
    Ok(Request { key, lent: Some(lent), step })
}

/// Re-simulates a request (no lock held) or takes it from the cache.
pub fn resolve(req: Request) -> Result<Arc<Past>, String> {
    let Some(lent) = req.lent else {
        return cached(&req.key).ok_or_else(|| "the state left the cache; ask again".to_string());
    };
    let (seq, step) = (req.key.1, req.step);
    let mut found: Option<Past> = None;
    fold::resimulate(&lent, step.unwrap_or(1), &mut |w, m| {
        let here = match step {
            None => m.at == At::Start,
            Some(k) => m.at == At::Step && m.seq == seq && m.step_in_event == k,
        };
        if here {
            found = Some(Past {
                scene: Scene::capture(w),
                steps: w.steps(),
                time: w.current_time(),
                objects: w.objects().count(),
                state_hash: w.state_hash(),
                overlays: Overlays::of(w),
            });
        }
        !here
    })
    .map_err(|e| format!("the state could not be re-simulated: {e}"))?;
    let past = Arc::new(found.ok_or_else(|| format!("seq {seq} step {step:?} was not reached"))?);
    remember(req.key, past.clone());
    Ok(past)
}
