//! What the viewer page asks, answered the same way over HTTP (`GET /viewer/{id}/{kind}?…`)
//! and to the MCP App through the host (`resources/read` of `sim://{id}/viewer/{kind}?…`,
//! which is a look and not logged):
//!
//! - `timeline`: the head's chain with a time axis (`past::Timeline`);
//! - `poses` (`seq`, `step`: a past moment; `have`: the scene key the page holds): every
//!   part's pose now or then, and the scene itself when its key is not `have`;
//! - `clip` (`from_seq`, `to_seq`, `every`, `after_seq`, `after_step`, `have`): frames for
//!   playing an interval, by one re-simulation, resuming after where the last clip stopped;
//! - `object` (`id`): an object's summary and its height and speed over the chain, for the
//!   inspector;
//! - `frame`: the server-rendered PNG (`png.rs`).
//!
//! Never "busy": while a call holds the simulation, the present is the newest moment a
//! running step published, or else the last one a page was shown.
//!
//! Bounded (docs/guarantees.md "Isolation"): at most `ASKS_PER_SIMULATION` asks of one
//! simulation are answered at once (more are told "ask again" at once, so asks cannot hold
//! the blocking pool's threads); every re-simulation is held to `--max-work`, priced before it
//! runs, and stopped when nobody waits for the answer (`answer_text`'s `stop`); answers that
//! re-simulate, refusals included, are kept per (simulation, head), so asking again costs
//! nothing; and an object id the simulation never had is refused without re-simulating.

use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use axum::http::StatusCode;
use serde::Serialize;
use tokio_util::sync::CancellationToken;

use super::live::{self, Progress};
use super::moment::{Captured, Moment, Shown};
use super::png::{self, Failed, FrameQuery};
use super::recent::{Recent, SimulationCache};
use super::past::Past;
use super::{past, wire};
use crate::log::fold;
use crate::outputs::{ObjectSummary, ObjectTrack};
use crate::seeing::trajectory;
use crate::sim::{Registry, SharedSim, Sim};

/// How long an answer waits for a call holding the simulation before it says "ask again"
/// (202): past states and the timeline need the log, which the call holds.
const WAIT_FOR_LOCK: Duration = Duration::from_secs(3);
/// How long the present waits for a running step's first published moment.
const WAIT_FOR_PUBLISHED: Duration = Duration::from_millis(400);
/// Most bytes of frames one clip answer carries (at most half the reply budget: a resource
/// read's reply must stay under it; pages ask again from the last frame).
pub const CLIP_BUDGET: usize = 512 * 1024;

/// The present of a simulation as a page may see it.
pub enum Present<'a> {
    /// Nobody holds it: the world itself.
    Free(MutexGuard<'a, Sim>),
    /// A call holds it: the newest moment its stepping published, or the last one shown.
    Running(Arc<Progress>),
}

/// Asks of one simulation answered at once; more are told "ask again" (202) at once, so asks
/// waiting for a busy simulation (or re-simulating its past) hold at most this many of the
/// blocking pool's threads per simulation.
pub const ASKS_PER_SIMULATION: usize = 4;

/// The asks being answered, by simulation.
static ASKING: LazyLock<Mutex<BTreeMap<String, usize>>> = LazyLock::new(Default::default);

/// One ask's place among its simulation's `ASKS_PER_SIMULATION`, taken on the async side
/// before the ask goes to the blocking pool (so a refused ask takes no thread); given back
/// when dropped.
pub struct Asking(String);

impl Asking {
    /// A place for an ask of simulation `id`, or "ask again" (202) when all are taken.
    pub fn enter(id: &str) -> Result<Asking, Failed> {
        let mut asking = ASKING.lock().unwrap_or_else(|p| p.into_inner());
        let n = asking.entry(id.to_string()).or_default();
        if *n >= ASKS_PER_SIMULATION {
            return Err(ask_again());
        }
        *n += 1;
        Ok(Asking(id.to_string()))
    }
}

impl Drop for Asking {
    fn drop(&mut self) {
        let mut asking = ASKING.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = asking.get_mut(&self.0) {
            *n -= 1;
            if *n == 0 {
                asking.remove(&self.0);
            }
        }
    }
}

/// The last present each simulation's page was shown, by id: what a page gets while a call
/// that publishes nothing (a load, a batch) holds the simulation.
static SHOWN: Recent<String, Arc<Progress>> = Recent::new(64, 8 << 20);

fn remember_shown(id: &str, p: Arc<Progress>) {
    let bytes = p.seen.bytes();
    SHOWN.put(id.to_string(), p, bytes);
}

fn last_shown(id: &str) -> Option<Arc<Progress>> {
    SHOWN.get(&id.to_string())
}

/// "Ask again": a call has held the simulation for longer than a page should wait.
fn ask_again() -> Failed {
    (StatusCode::ACCEPTED, "a call is running on this simulation; ask again".to_string())
}

/// Nobody waits for the answer any more (`answer_text`'s `stop`): never remembered.
fn stopped() -> Failed {
    (StatusCode::SERVICE_UNAVAILABLE, fold::CANCELLED.to_string())
}

/// Whether the ask being answered on this thread was given up by its asker.
fn given_up() -> bool {
    fold::current_bounds().stopped()
}

/// The simulation's lock, waiting up to `WAIT_FOR_LOCK` for a call in flight (and no longer
/// than the asker waits).
pub fn lock_within(sim: &SharedSim) -> Result<MutexGuard<'_, Sim>, Failed> {
    let start = Instant::now();
    loop {
        if let Ok(guard) = sim.try_lock() {
            return Ok(guard);
        }
        if given_up() {
            return Err(stopped());
        }
        if start.elapsed() >= WAIT_FOR_LOCK {
            return Err(ask_again());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The present of `sim` without waiting behind a long call.
pub fn present<'a>(sim: &'a SharedSim, id: &str) -> Result<Present<'a>, Failed> {
    let start = Instant::now();
    loop {
        if let Ok(guard) = sim.try_lock() {
            return Ok(Present::Free(guard));
        }
        if let Some(p) = live::latest_waiting(id, WAIT_FOR_PUBLISHED, || sim.try_lock().is_ok()) {
            return Ok(Present::Running(p));
        }
        if sim.try_lock().is_err() {
            if let Some(p) = last_shown(id) {
                return Ok(Present::Running(p));
            }
        }
        if given_up() {
            return Err(stopped());
        }
        if start.elapsed() >= WAIT_FOR_LOCK {
            return Err(ask_again());
        }
    }
}

/// One moment for the page: every part's pose, and the scene when the page lacks it.
#[derive(Serialize, Debug)]
pub struct PoseFrame {
    /// The scene's key.
    pub key: String,
    /// Whether the recorded camera is the initial one (pages frame the scene themselves then).
    pub camera_is_initial: bool,
    /// `wire::poses`.
    pub poses: String,
    /// What the moment says about itself.
    #[serde(flatten)]
    pub shown: Shown,
    /// The scene, when the page's `have` is not its key.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scene: Option<wire::SceneJson>,
}

/// What a page asked, parsed (its `Debug` form, free of parameters the viewer does not read,
/// is what answers are remembered by).
#[derive(Debug)]
enum Ask {
    Timeline,
    Poses { seq: Option<u64>, step: Option<u64>, have: Option<String> },
    Clip { from: u64, to: Option<u64>, every: u64, after: Option<(u64, Option<u64>)>, have: Option<String> },
    Object { id: u32 },
    Frame(FrameQuery),
}

type Query = BTreeMap<String, String>;

fn number<T: std::str::FromStr>(q: &Query, name: &str) -> Result<Option<T>, Failed> {
    q.get(name)
        .map(|v| v.parse::<T>().map_err(|_| (StatusCode::BAD_REQUEST, format!("{name} must be a number; got {v:?}"))))
        .transpose()
}

fn parse(kind: &str, query: &str) -> Result<Ask, Failed> {
    let q: Query = form_urlencoded::parse(query.as_bytes()).into_owned().collect();
    let have = q.get("have").cloned();
    Ok(match kind {
        "timeline" => Ask::Timeline,
        "poses" => {
            let (seq, step) = (number(&q, "seq")?, number(&q, "step")?);
            if seq.is_none() && step.is_some() {
                return Err((StatusCode::BAD_REQUEST, "step needs seq (the step event it is inside)".to_string()));
            }
            Ask::Poses { seq, step, have }
        }
        "clip" => Ask::Clip {
            from: number(&q, "from_seq")?.ok_or_else(|| (StatusCode::BAD_REQUEST, "from_seq is required".to_string()))?,
            to: number(&q, "to_seq")?,
            every: number(&q, "every")?.unwrap_or(1),
            after: match (number(&q, "after_seq")?, number(&q, "after_step")?) {
                (Some(seq), step) => Some((seq, step)),
                (None, None) => None,
                (None, Some(_)) => return Err((StatusCode::BAD_REQUEST, "after_step needs after_seq".to_string())),
            },
            have,
        },
        "object" => Ask::Object { id: number(&q, "id")?.ok_or_else(|| (StatusCode::BAD_REQUEST, "id is required".to_string()))? },
        "frame" => Ask::Frame(FrameQuery {
            w: number(&q, "w")?,
            h: number(&q, "h")?,
            distance: number(&q, "distance")?,
            yaw: number(&q, "yaw")?,
            pitch: number(&q, "pitch")?,
            tx: number(&q, "tx")?,
            ty: number(&q, "ty")?,
            tz: number(&q, "tz")?,
            seq: number(&q, "seq")?,
            step: number(&q, "step")?,
        }),
        other => return Err((StatusCode::NOT_FOUND, format!("the viewer has no {other:?}; it answers timeline, poses, clip, object and frame"))),
    })
}

fn pose_frame(m: &Moment, have: Option<&str>) -> PoseFrame {
    let scene = &m.seen.scene;
    let key = wire::key(scene);
    PoseFrame {
        scene: (have != Some(key.as_str())).then(|| wire::scene(scene)),
        key,
        camera_is_initial: scene.camera.camera_is_initial(),
        poses: wire::poses(scene),
        shown: Shown::of(m),
    }
}

/// A moment the viewer answers about, held while it is answered: a past state, the present
/// as captured, or a running step's published (or the last shown) moment.
pub enum Held {
    /// After event `seq` (`step` steps into it).
    Past {
        /// The state re-simulated (or cached).
        past: Arc<Past>,
        /// The event.
        seq: u64,
        /// Steps into it.
        step: Option<u64>,
    },
    /// The present.
    Present {
        /// As captured (not running: `done` and `total` are 0).
        now: Arc<Progress>,
        /// Its state hash.
        state_hash: String,
    },
    /// While a call holds the simulation.
    Running(Arc<Progress>),
}

impl Held {
    /// The moment as answers describe it.
    pub fn moment(&self) -> Moment<'_> {
        match self {
            Held::Past { past, seq, step } => Moment { seen: &past.seen, state_hash: &past.state_hash, seq: Some(*seq), step: *step, progress: None },
            Held::Present { now, state_hash } => Moment { seen: &now.seen, state_hash, seq: None, step: None, progress: None },
            Held::Running(p) => {
                let running = (p.total > 0).then_some([p.done, p.total]);
                Moment { seen: &p.seen, state_hash: "", seq: None, step: None, progress: running }
            }
        }
    }
}

/// The present of world `w` (state hash `state_hash`), held; also what is shown while a later
/// call holds the simulation.
pub fn present_of(w: &crate::world::World, state_hash: &str, contacts_asked: bool) -> Held {
    let now = Arc::new(Progress { seen: Captured::of(w, contacts_asked), done: 0, total: 0 });
    Held::Present { now, state_hash: state_hash.to_string() }
}

/// The frame of world `w` as it is — the whole server cost of a live frame
/// (`benches/viewer.rs` measures it against the PNG frame).
pub fn world_frame(w: &crate::world::World, state_hash: &str, contacts_asked: bool, have: Option<&str>) -> PoseFrame {
    pose_frame(&present_of(w, state_hash, contacts_asked).moment(), have)
}

/// The moment a page asked of simulation `id`: after `seq` (`step` steps into it), else now.
pub fn held(sim: &SharedSim, id: &str, seq: Option<u64>, step: Option<u64>) -> Result<Held, Failed> {
    let bad = |e: String| (StatusCode::BAD_REQUEST, e);
    if let Some(seq) = seq {
        let req = past::request(&*lock_within(sim)?, seq, step).map_err(bad)?;
        return Ok(Held::Past { past: past::resolve(req).map_err(bad)?, seq, step });
    }
    match present(sim, id)? {
        Present::Free(guard) => {
            let held = present_of(guard.world(), guard.state_hash(), past::contacts_asked_now(&guard));
            drop(guard);
            if let Held::Present { now, .. } = &held {
                remember_shown(id, now.clone());
            }
            Ok(held)
        }
        Present::Running(p) => Ok(Held::Running(p)),
    }
}

/// The inspector's answer: what the object is (in the present world) and its track over the
/// head's chain (about 100 samples, with velocities).
#[derive(Serialize, Debug)]
pub struct Inspected {
    /// The object.
    pub object_id: u32,
    /// Its summary now (None: it is gone since).
    pub summary: Option<ObjectSummary>,
    /// Sample times (s).
    pub times: Vec<f64>,
    /// Its samples.
    pub track: Option<ObjectTrack>,
}

/// Inspections lately answered, by (simulation, head, object): a second click on an object is
/// not a second re-simulation of the whole chain.
static INSPECTED: Recent<(String, u64, u32), Arc<Inspected>> = Recent::new(16, 4 << 20);

fn object(sim: &SharedSim, id: u32) -> Result<Arc<Inspected>, Failed> {
    let bad = |e: String| (StatusCode::BAD_REQUEST, e);
    let (key, summary, lent) = {
        let guard = lock_within(sim)?;
        let key = (guard.id().to_string(), guard.log().head_seq(), id);
        if let Some(done) = INSPECTED.get(&key) {
            return Ok(done);
        }
        // Ids are given in order and never reused: one at or past the next is no object's.
        let next = guard.world().next_object_id();
        if id >= next {
            return Err(bad(format!("id: simulation {} never had an object {id} (the ids it gave so far are below {next})", guard.id())));
        }
        let summary = guard.world().object_summaries().into_iter().find(|s| s.object_id == id);
        let root = past::timeline(&guard).map_err(bad)?.events.first().map(|e| e.seq);
        (key, summary, fold::lend(guard.log(), guard.id(), root, None).map_err(bad)?)
    };
    let req = trajectory::Request { every: None, object_ids: Some(vec![id]), include_velocities: true };
    let t = trajectory::sample_interval(&lent, &req).map_err(|e| (StatusCode::BAD_REQUEST, e.replace("object_ids", "id")))?;
    let done = Arc::new(Inspected { object_id: id, summary, times: t.times, track: t.objects.into_iter().find(|o| o.object_id == id) });
    // About what it costs as JSON (the samples' numbers).
    let bytes = serde_json::to_string(&*done).map_or(0, |j| j.len());
    INSPECTED.put(key, done.clone(), bytes);
    Ok(done)
}

fn clip(sim: &SharedSim, from: u64, to: Option<u64>, every: u64, after: Option<(u64, Option<u64>)>, have: Option<String>, budget: usize) -> Result<past::Clip, Failed> {
    let bad = |e: String| (StatusCode::BAD_REQUEST, e);
    let req = past::clip_request(&*lock_within(sim)?, from, to, every, after, have).map_err(bad)?;
    past::clip(req, budget).map_err(bad)
}

/// Answers of re-simulating asks lately refused, by (simulation, head, ask): asking again what
/// was refused at this head is refused again without re-pricing or re-simulating anything.
static REFUSED: Recent<(String, u64, String), Failed> = Recent::new(1024, 1 << 20);

/// Clips lately answered, by (simulation, head, ask).
static CLIPS: Recent<(String, u64, String), Arc<String>> = Recent::new(16, 8 << 20);

/// Every cache of the viewer whose entries belong to a simulation, named — this module's
/// answers and `past`'s states: what `forget` empties and `kept_of` counts (one list, so no
/// cache can be left out of either).
fn caches() -> impl Iterator<Item = (&'static str, &'static dyn SimulationCache)> {
    let answers: [(&'static str, &'static dyn SimulationCache); 4] = [("shown", &SHOWN), ("inspected", &INSPECTED), ("refused", &REFUSED), ("clips", &CLIPS)];
    answers.into_iter().chain(past::caches())
}

/// Drops what the viewer keeps of simulation `id` (it was destroyed).
pub fn forget(id: &str) {
    for (_, cache) in caches() {
        cache.forget_simulation(id);
    }
}

/// How many cached answers the viewer keeps of simulation `id`, by cache: none once it is
/// destroyed (`forget`), which a test checks directly — the caches' byte bounds would hide a
/// forgotten `forget` from any measure of the process's memory.
pub fn kept_of(id: &str) -> Vec<(&'static str, usize)> {
    caches().map(|(name, cache)| (name, cache.count_simulation(id))).collect()
}

/// `answer` of an ask that re-simulates (a past moment, a clip, an inspection), refused again
/// at once when it was refused at the simulation's current head; a refusal is remembered
/// unless the asker gave up (a stopped answer says nothing about the ask).
fn remembered(sim: &SharedSim, id: &str, ask: &str, answer: impl FnOnce(u64) -> Result<String, Failed>) -> Result<String, Failed> {
    let head = lock_within(sim)?.log().head_seq();
    let key = (id.to_string(), head, ask.to_string());
    if let Some(refused) = REFUSED.get(&key) {
        return Err(refused);
    }
    let out = answer(head);
    if let Err((StatusCode::BAD_REQUEST, why)) = &out {
        if !given_up() {
            let bytes = why.len() + key.0.len() + key.2.len();
            REFUSED.put(key, (StatusCode::BAD_REQUEST, why.clone()), bytes);
        }
    }
    out
}

fn timeline(sim: &SharedSim, id: &str) -> Result<Arc<past::Timeline>, Failed> {
    if let Ok(guard) = sim.try_lock() {
        return past::timeline(&guard).map_err(|e| (StatusCode::INTERNAL_SERVER_ERROR, e));
    }
    if let Some(t) = past::last_timeline(id) {
        return Ok(t);
    }
    past::timeline(&*lock_within(sim)?).map_err(|e| (StatusCode::INTERNAL_SERVER_ERROR, e))
}

/// Answers `kind?query` for simulation `id` as JSON text (blocking: run it off the async
/// threads, holding the ask's place, `Asking::enter`). `stop` is cancelled when nobody waits
/// for the answer any more (the page went away, the app's read was cancelled): the ask then
/// stops waiting and re-simulating.
pub fn answer_text(reg: &Registry, id: &str, kind: &str, query: &str, stop: &CancellationToken) -> Result<String, Failed> {
    let ask = parse(kind, query)?;
    let sim = reg.get(id).map_err(|why| (StatusCode::NOT_FOUND, why))?;
    let bounds = fold::Bounds { stop: Some(stop.clone()), max_work: Some(reg.limits().max_work) };
    let out = fold::bounded(bounds, || answer(reg, sim, id, ask));
    // An ask re-simulates without the simulation's lock, so it can cache its answer after
    // `destroy` emptied the caches of this simulation. destroy unlists the simulation before it
    // forgets it, and this looks after caching: one of the two forgets comes last.
    if reg.get_local(id).is_none() {
        forget(id);
    }
    out
}

fn answer(reg: &Registry, sim: SharedSim, id: &str, ask: Ask) -> Result<String, Failed> {
    let text = |v: Result<String, serde_json::Error>| v.map_err(|e| (StatusCode::INTERNAL_SERVER_ERROR, format!("Internal error: {e}")));
    let asked = format!("{ask:?}");
    match ask {
        Ask::Timeline => text(serde_json::to_string(&*timeline(&sim, id)?)),
        Ask::Poses { seq: None, step, have } => text(serde_json::to_string(&pose_frame(&held(&sim, id, None, step)?.moment(), have.as_deref()))),
        Ask::Poses { seq, step, have } => remembered(&sim, id, &asked, |_| {
            text(serde_json::to_string(&pose_frame(&held(&sim, id, seq, step)?.moment(), have.as_deref())))
        }),
        // Half the reply budget: a clip's last frame and scenes may go past its budget.
        Ask::Clip { from, to, every, after, have } => remembered(&sim, id, &asked, |head| {
            let key = (id.to_string(), head, asked.clone());
            if let Some(done) = CLIPS.get(&key) {
                return Ok(String::clone(&done));
            }
            let budget = CLIP_BUDGET.min(reg.limits().max_reply_bytes / 2);
            let done = text(serde_json::to_string(&clip(&sim, from, to, every, after, have, budget)?))?;
            let bytes = done.len() + key.2.len();
            // Where a test destroys the simulation under a finished clip (answer_text's forget).
            crate::hold_point!("viewer_clip_put");
            CLIPS.put(key, Arc::new(done.clone()), bytes);
            Ok(done)
        }),
        Ask::Object { id: object_id } => remembered(&sim, id, &asked, |_| text(serde_json::to_string(&*object(&sim, object_id)?))),
        Ask::Frame(q) if q.seq.is_none() => text(serde_json::to_string(&png::answer(sim, id, &q, reg.limits().max_image_px)?)),
        Ask::Frame(q) => {
            let max_px = reg.limits().max_image_px;
            remembered(&sim.clone(), id, &asked, move |_| text(serde_json::to_string(&png::answer(sim, id, &q, max_px)?)))
        }
    }
}
