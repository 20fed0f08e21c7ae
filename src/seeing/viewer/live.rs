//! Live progress of a long step: while step_simulation holds a simulation's lock, the stepping
//! loop publishes a copy of what the camera would see (`Scene::capture`: poses and shape
//! handles) about every 100 ms of wall time, through the step observer hook of
//! `World::apply_observed`, which only ever sees a shared borrow — so publishing never
//! changes a result or a hash. The viewer renders the latest copy instead of waiting.
//!
//! Slots live in a process-wide table by simulation id (ids are UUIDs, unique across
//! registries), so the viewer reaches them without the simulation's lock.
//!
//! Capturing costs (the scene and its contacts), so a step publishes only while a viewer has
//! asked for the simulation within the last [`WATCHED_FOR`]: the first request of a watcher
//! finds nothing yet, and the frames follow from the next publication on.

use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex};
use std::time::{Duration, Instant};

use crate::seeing::viewer::moment::Captured;
use crate::world::World;

/// How often a running step publishes (wall time): 10 pictures a second to choose from.
pub const PUBLISH_EVERY: Duration = Duration::from_millis(100);

/// One published moment of a running step.
pub struct Progress {
    /// The world then.
    pub seen: Captured,
    /// Steps this call has taken so far.
    pub done: u64,
    /// Steps this call asked for.
    pub total: u64,
}

/// How long a viewer's request keeps a running step publishing.
pub const WATCHED_FOR: Duration = Duration::from_secs(3);

type Slot = Arc<Mutex<Option<Arc<Progress>>>>;

static SLOTS: LazyLock<Mutex<BTreeMap<String, Slot>>> = LazyLock::new(Default::default);

/// When a viewer last asked for each simulation's live progress.
static WATCHED: LazyLock<Mutex<BTreeMap<String, Instant>>> = LazyLock::new(Default::default);

/// Whether a viewer asked for simulation `id` within [`WATCHED_FOR`].
pub fn watched(id: &str) -> bool {
    let table = WATCHED.lock().unwrap_or_else(|p| p.into_inner());
    table.get(id).is_some_and(|t| t.elapsed() < WATCHED_FOR)
}

fn slot(id: &str) -> Slot {
    let mut table = SLOTS.lock().unwrap_or_else(|p| p.into_inner());
    table.entry(id.to_string()).or_default().clone()
}

/// The latest moment a running step of simulation `id` published; None when no step runs.
pub fn latest(id: &str) -> Option<Arc<Progress>> {
    {
        let mut watched = WATCHED.lock().unwrap_or_else(|p| p.into_inner());
        watched.retain(|_, t| t.elapsed() < WATCHED_FOR);
        watched.insert(id.to_string(), Instant::now());
    }
    let table = SLOTS.lock().unwrap_or_else(|p| p.into_inner());
    let slot = table.get(id)?.clone();
    drop(table);
    let guard = slot.lock().unwrap_or_else(|p| p.into_inner());
    guard.clone()
}

/// The latest published moment of simulation `id`, waiting up to `wait` for the first one
/// after a viewer starts watching (a step publishes within `PUBLISH_EVERY` of being
/// watched); None when `free` says the simulation is free again, or nothing came.
pub fn latest_waiting(id: &str, wait: Duration, free: impl Fn() -> bool) -> Option<Arc<Progress>> {
    let start = Instant::now();
    loop {
        if let Some(p) = latest(id) {
            return Some(p);
        }
        if free() || start.elapsed() >= wait {
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Publishes a running step's progress; clears it when dropped (the step is over).
pub struct Publisher {
    id: String,
    contacts: bool,
    slot: Slot,
    last: Instant,
    done: u64,
    total: u64,
}

impl Publisher {
    /// A publisher for a step of `total` steps on simulation `id`; `contacts`: whether its
    /// frames show contacts (`past::contacts_asked_now`).
    pub fn new(id: &str, total: u64, contacts: bool) -> Publisher {
        Publisher { id: id.to_string(), contacts, slot: slot(id), last: Instant::now(), done: 0, total }
    }

    /// The step observer: called after every step with the world (read-only).
    pub fn observe(&mut self, w: &World) {
        self.done += 1;
        if self.last.elapsed() < PUBLISH_EVERY {
            return;
        }
        self.last = Instant::now();
        if !watched(&self.id) {
            return;
        }
        let progress = Progress { seen: Captured::of(w, self.contacts), done: self.done, total: self.total };
        *self.slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(Arc::new(progress));
    }
}

impl Drop for Publisher {
    fn drop(&mut self) {
        *self.slot.lock().unwrap_or_else(|p| p.into_inner()) = None;
        let mut table = SLOTS.lock().unwrap_or_else(|p| p.into_inner());
        table.remove(&self.id);
    }
}
