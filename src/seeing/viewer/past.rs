//! The viewer's timeline: the head's chain as a list of events, and the picture of any past
//! state on it — after event `seq`, or after `step` steps inside step event `seq` — re-simulated
//! by the one core (`fold::lend` under the lock, `fold::resimulate` without it) and cached as
//! a captured scene, so scrubbing back and forth or turning the camera costs a render only.

use std::sync::Arc;

use serde::Serialize;

use crate::command::Command;
use crate::log::fold::{self, At};
use crate::seeing::sensing::capture::Scene;
use crate::sim::Sim;
use crate::seeing::viewer::recent::{Recent, SimulationCache};
use crate::seeing::viewer::moment::Captured;
use crate::seeing::viewer::wire;

/// Past states and timelines kept, each cache at most this many…
const CACHED: usize = 64;
/// …and this many bytes (a timeline is about 80 bytes an event; a past state its parts'
/// poses and the meshes it holds).
const CACHED_BYTES: usize = 16 << 20;

/// One state-changing event of the head's chain, as the timeline shows it.
#[derive(Serialize, Debug, Clone)]
pub struct Mark {
    /// The event.
    pub seq: u64,
    /// Simulated time after it (s): the page's time axis.
    pub time: f64,
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
#[derive(Serialize, Debug, Clone)]
pub struct Timeline {
    /// The simulation.
    pub simulation_id: String,
    /// Its head.
    pub head_seq: u64,
    /// Oldest first.
    pub events: Vec<Mark>,
    /// The first enable_debug_visualization event on the chain: contacts are drawn from there on.
    pub debug_since: Option<u64>,
    /// The clock after the head, to extend the timeline by the events after it.
    #[serde(skip)]
    clock: Clock,
}

impl Timeline {
    /// Whether the state after event `seq` shows contacts (enable_debug_visualization was
    /// called at or before it).
    pub fn contacts_asked(&self, seq: u64) -> bool {
        self.debug_since.is_some_and(|d| d <= seq)
    }
}

/// Simulated time along a chain, as `World::current_time` keeps it: the timestep as given and
/// the time and step count when it was given.
#[derive(Clone, Debug)]
struct Clock {
    dt: f64,
    time_at: f64,
    steps_at: u64,
    steps: u64,
}

impl Clock {
    fn now(&self) -> f64 {
        self.time_at + self.steps.saturating_sub(self.steps_at) as f64 * self.dt
    }

    /// Moves the clock over one event; an event that recorded its time (results from event
    /// version 3 on, and a load's, whose world came from a file) sets it.
    fn pass(&mut self, cmd: Option<&Command>, result: Option<&str>) -> f64 {
        match cmd {
            Some(Command::StepSimulation { steps, .. }) => self.steps += steps,
            Some(Command::SetTimestep { timestep, timestep_given }) => {
                let now = self.now();
                (self.dt, self.time_at, self.steps_at) = (timestep_given.unwrap_or_else(|| crate::value::r32(*timestep)), now, self.steps);
            }
            _ => {}
        }
        let recorded = result.and_then(|r| serde_json::from_str::<serde_json::Value>(r).ok()).and_then(|v| {
            v.get("time").or_else(|| v.get("current_time")).and_then(serde_json::Value::as_f64)
        });
        if let Some(t) = recorded.filter(|t| t.is_finite()) {
            (self.time_at, self.steps_at) = (t, self.steps);
        }
        self.now()
    }
}

/// The timeline of `sim` (read from its log; no physics): `before`, the timeline at an
/// earlier head, extended by the events after it when that head is still on the chain, else
/// read from the root — so a watched simulation does not re-read its whole chain per call.
fn read_timeline(sim: &Sim, before: Option<&Timeline>) -> Result<Timeline, String> {
    let read = |e: crate::log::StoreError| format!("the log could not be read: {e}");
    let head = sim.log().head_seq();
    let (mut t, newer) = match before {
        Some(b) => {
            let mut back = sim.log().chain_back(head, &mut |e| e.seq <= b.head_seq).map_err(read)?;
            if back.last().is_some_and(|e| e.seq == b.head_seq) {
                back.pop();
                back.reverse();
                (Timeline { head_seq: head, ..b.clone() }, back)
            } else {
                (Timeline::empty(sim.id(), head), sim.log().chain_to(head).map_err(read)?)
            }
        }
        None => (Timeline::empty(sim.id(), head), sim.log().chain_to(head).map_err(read)?),
    };
    for e in &newer {
        let cmd = fold::decode(e, sim.log()).ok().flatten();
        let steps = match cmd {
            Some(Command::StepSimulation { steps, .. }) => steps,
            _ => 0,
        };
        if matches!(cmd, Some(Command::SetDebugVisualization { .. })) && t.debug_since.is_none() {
            t.debug_since = Some(e.seq);
        }
        let time = t.clock.pass(cmd.as_ref(), e.result.as_deref());
        t.events.push(Mark { seq: e.seq, time, tool: e.tool.clone(), steps, total_steps: t.clock.steps, inherited: e.inherited });
    }
    Ok(t)
}

impl Timeline {
    fn empty(id: &str, head: u64) -> Timeline {
        Timeline {
            simulation_id: id.to_string(),
            head_seq: head,
            events: Vec::new(),
            debug_since: None,
            clock: Clock { dt: 1.0 / 240.0, time_at: 0.0, steps_at: 0, steps: 0 },
        }
    }
}

/// The latest timeline read of recently watched simulations, by id: re-read only when the
/// head moved, and what a page is answered while a call holds the simulation.
static TIMELINES: Recent<String, Arc<Timeline>> = Recent::new(CACHED, CACHED_BYTES);

/// The timeline of `sim` at its head (cached until the head moves).
pub fn timeline(sim: &Sim) -> Result<Arc<Timeline>, String> {
    let head = sim.log().head_seq();
    if let Some(t) = last_timeline(sim.id()).filter(|t| t.head_seq == head) {
        return Ok(t);
    }
    let t = Arc::new(read_timeline(sim, last_timeline(sim.id()).as_deref())?);
    TIMELINES.put(sim.id().to_string(), t.clone(), t.bytes());
    Ok(t)
}

impl Timeline {
    /// Bytes it holds (for `TIMELINES`' budget).
    fn bytes(&self) -> usize {
        self.events.iter().map(|m| std::mem::size_of::<Mark>() + m.tool.len()).sum::<usize>() + self.simulation_id.len()
    }
}

/// This module's caches of simulations' states, named (`ask::caches` lists them with the
/// viewer's others, for `forget` and `kept_of`).
pub fn caches() -> [(&'static str, &'static dyn SimulationCache); 2] {
    [("timelines", &TIMELINES), ("past moments", &CACHE)]
}

/// The timeline last read of simulation `id`, without its lock.
pub fn last_timeline(id: &str) -> Option<Arc<Timeline>> {
    TIMELINES.get(&id.to_string())
}

/// Whether `sim`'s present shows contacts (see `Overlays::of`).
pub fn contacts_asked_now(sim: &Sim) -> bool {
    timeline(sim).is_ok_and(|t| t.contacts_asked(t.head_seq))
}

/// A past state, ready to render.
pub struct Past {
    /// The world then.
    pub seen: Captured,
    /// Its state hash.
    pub state_hash: String,
}

type Key = (String, u64, Option<u64>);

/// Recently re-simulated states.
static CACHE: Recent<Key, Arc<Past>> = Recent::new(CACHED, CACHED_BYTES);

fn cached(key: &Key) -> Option<Arc<Past>> {
    CACHE.get(key)
}

fn remember(key: Key, past: Arc<Past>) {
    let bytes = past.seen.bytes() + past.state_hash.len();
    CACHE.put(key, past, bytes);
}

/// What to lend for the state after `seq` (and `step` steps into it), decided under the lock.
pub struct Request {
    key: Key,
    lent: Option<fold::Lent>,
    /// The state itself when it was cached (held here, so it cannot leave the cache meanwhile).
    found: Option<Arc<Past>>,
    step: Option<u64>,
    contacts: bool,
}

/// Looks `seq` (and `step`) up on `sim`'s chain and lends what re-simulating it needs; a cached
/// state lends nothing. Refuses a seq off the chain, or a step outside a step event's steps.
pub fn request(sim: &Sim, seq: u64, step: Option<u64>) -> Result<Request, String> {
    let key = (sim.id().to_string(), seq, step);
    if let Some(found) = cached(&key) {
        return Ok(Request { key, lent: None, found: Some(found), step, contacts: false });
    }
    let contacts = timeline(sim)?.contacts_asked(seq);
    let lent = match step {
        None => fold::lend(sim.log(), sim.id(), Some(seq), Some(seq))?,
        Some(k) => {
            let e = sim.log().event(seq).map_err(|e| e.to_string())?.ok_or_else(|| format!("seq {seq} is not an event of this simulation"))?;
            let steps = match fold::decode(&e, sim.log()) {
                Ok(Some(Command::StepSimulation { steps, .. })) => steps,
                _ => return Err(format!("step is only meaningful inside a step_simulation event; seq {seq} is {}", e.tool)),
            };
            if k == 0 || k > steps {
                return Err(format!("step must be from 1 to {steps} (the steps event {seq} took); got {k}"));
            }
            let parent = e.parent.ok_or_else(|| format!("seq {seq} has no parent"))?;
            // Re-simulated (and priced) only as far as step k.
            fold::Lent { until_step: Some(k), ..fold::lend(sim.log(), sim.id(), Some(parent), Some(seq))? }
        }
    };
    Ok(Request { key, lent: Some(lent), found: None, step, contacts })
}

/// Re-simulates a request (no lock held) or takes it from the cache.
pub fn resolve(req: Request) -> Result<Arc<Past>, String> {
    let contacts = req.contacts;
    if let Some(found) = req.found {
        return Ok(found);
    }
    let Some(lent) = req.lent else { return Err("nothing to re-simulate".to_string()) };
    let (seq, step) = (req.key.1, req.step);
    let mut found: Option<Past> = None;
    fold::resimulate(&lent, step.unwrap_or(1), &mut |w, m| {
        let here = match step {
            None => m.at == At::Start,
            Some(k) => m.at == At::Step && m.seq == seq && m.step_in_event == k,
        };
        if here {
            found = Some(Past { seen: Captured::of(w, contacts), state_hash: w.state_hash() });
        }
        !here
    })
    .map_err(|e| e.explained("the state could not be re-simulated"))?;
    let past = Arc::new(found.ok_or_else(|| format!("seq {seq} step {step:?} was not reached"))?);
    remember(req.key, past.clone());
    Ok(past)
}

/// One moment of a clip: where it is and every part's pose then.
#[derive(Serialize, Debug)]
pub struct ClipFrame {
    /// The scene's key (`wire::key`).
    pub key: String,
    /// The event the moment is in (or after).
    pub seq: u64,
    /// Steps into event `seq` (None: after it).
    pub step: Option<u64>,
    /// Simulated time (s).
    pub time: f64,
    /// Steps since creation.
    pub steps: u64,
    /// `wire::poses`.
    pub poses: String,
}

/// Frames of an interval for playing it: every `every`-th step from the state after `from`
/// to the state after `to`, by one re-simulation.
#[derive(Serialize, Debug)]
pub struct Clip {
    /// The frames, oldest first.
    pub frames: Vec<ClipFrame>,
    /// The scenes the frames' keys name, except `have`.
    pub scenes: Vec<wire::SceneJson>,
    /// Whether the frames reach `to` (false: the byte budget ended the clip; ask again from
    /// the last frame).
    pub complete: bool,
}

/// What a clip re-simulates, lent under the lock.
pub struct ClipRequest {
    lent: fold::Lent,
    every: u64,
    after: Option<(u64, u64)>,
    have: Option<String>,
}

/// A moment's place on a chain, for resuming a clip after it: seqs rise along a chain, and
/// inside an event its steps come before its end.
fn place(seq: u64, step: Option<u64>) -> (u64, u64) {
    (seq, step.unwrap_or(u64::MAX))
}

/// Lends `from..to` of `sim`'s chain for a clip sampled every `every` steps, leaving out
/// moments up to the one after `after` = (seq, step in it; None: its end) — where the last
/// clip stopped.
pub fn clip_request(sim: &Sim, from: u64, to: Option<u64>, every: u64, after: Option<(u64, Option<u64>)>, have: Option<String>) -> Result<ClipRequest, String> {
    let lent = fold::lend(sim.log(), sim.id(), Some(from), to)?;
    Ok(ClipRequest { lent, every: every.max(1), after: after.map(|(seq, step)| place(seq, step)), have })
}

/// Re-simulates a clip (no lock held) until it reaches its end or `budget` bytes of frames.
pub fn clip(req: ClipRequest, budget: usize) -> Result<Clip, String> {
    let mut out = Clip { frames: Vec::new(), scenes: Vec::new(), complete: true };
    let (mut used, mut last_key) = (0usize, req.have.clone());
    fold::resimulate(&req.lent, req.every, &mut |w, m| {
        let step = (m.at == At::Step).then_some(m.step_in_event);
        if !m.sample || req.after.is_some_and(|a| place(m.seq, step) <= a) {
            return true;
        }
        let scene = Scene::capture(w);
        let key = wire::key(&scene);
        if last_key.as_deref() != Some(key.as_str()) {
            let s = wire::scene(&scene);
            used += serde_json::to_string(&s).map_or(0, |t| t.len());
            out.scenes.push(s);
            last_key = Some(key.clone());
        }
        let frame = ClipFrame { key, seq: m.seq, step, time: w.current_time(), steps: w.steps(), poses: wire::poses(&scene) };
        used += frame.poses.len() + 120;
        out.frames.push(frame);
        if used > budget && !m.last {
            out.complete = false;
            return false;
        }
        true
    })
    .map_err(|e| e.explained("the interval could not be re-simulated"))?;
    Ok(out)
}
