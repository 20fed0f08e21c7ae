//! Waiting for a busy simulation (docs/guarantees.md "Isolation"): one call at a time works on
//! a simulation, and the calls that arrive meanwhile wait in a bounded, first-come-first-served
//! queue of that simulation — as async tasks, not as blocking threads parked on its lock. So a
//! client that sends hundreds of calls at one busy simulation costs a few bytes each while they
//! wait, every call past `--max-waiting` is refused at once with a sentence saying who holds the
//! simulation and since when, and nothing it sends delays calls on other simulations.
//!
//! A refusal here never reached the simulation, so it is not recorded in its log; the server
//! log counts them (`physics_mcp::busy`).
//!
//! The queue is a turn to take, not the lock itself: the holder of a turn then takes the
//! simulation's lock, which only internal work (flushes, sweepers, a viewer's `try_lock`) holds
//! otherwise, and only briefly.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

use crate::value::Refusal;

/// Every simulation's queue, by id.
#[derive(Default)]
pub struct Queues {
    queues: Mutex<HashMap<String, Arc<Queue>>>,
    /// Calls refused because their simulation's queue was full, since the server started.
    refused: AtomicU64,
}

/// One simulation's queue: one turn, the calls waiting for it, and who holds it.
struct Queue {
    turn: Arc<Semaphore>,
    waiting: AtomicUsize,
    holder: Mutex<Option<(String, Instant)>>,
}

/// A call's turn on a simulation: held while the call works on it, given to the next waiting
/// call when dropped.
pub struct Turn {
    queue: Arc<Queue>,
    _permit: OwnedSemaphorePermit,
}

impl Drop for Turn {
    fn drop(&mut self) {
        *self.queue.holder.lock().unwrap_or_else(|p| p.into_inner()) = None;
    }
}

/// Counts a waiting call for as long as it waits (also when its client goes away meanwhile and
/// the wait is dropped).
struct Waiting<'a>(&'a AtomicUsize);

impl Drop for Waiting<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

impl Queue {
    fn new() -> Queue {
        Queue { turn: Arc::new(Semaphore::new(1)), waiting: AtomicUsize::new(0), holder: Mutex::new(None) }
    }

    fn taken(self: &Arc<Self>, permit: OwnedSemaphorePermit, tool: &str) -> Turn {
        *self.holder.lock().unwrap_or_else(|p| p.into_inner()) = Some((tool.to_string(), Instant::now()));
        Turn { queue: self.clone(), _permit: permit }
    }
}

impl Queues {
    fn queue(&self, id: &str) -> Arc<Queue> {
        let mut queues = self.queues.lock().unwrap_or_else(|p| p.into_inner());
        queues.entry(id.to_string()).or_insert_with(|| Arc::new(Queue::new())).clone()
    }

    /// `tool`'s turn on simulation `id`, waiting behind the calls before it; refused at once
    /// when `max_waiting` calls already wait.
    pub async fn turn(&self, id: &str, tool: &str, max_waiting: usize) -> Result<Turn, Refusal> {
        let queue = self.queue(id);
        if let Ok(permit) = queue.turn.clone().try_acquire_owned() {
            return Ok(queue.taken(permit, tool));
        }
        let before = queue.waiting.fetch_add(1, Ordering::Relaxed);
        let waiting = Waiting(&queue.waiting);
        if before >= max_waiting {
            drop(waiting);
            return Err(self.refuse(id, &queue, before, max_waiting));
        }
        let permit = queue.turn.clone().acquire_owned().await.map_err(|_| format!("Simulation {id} is gone"))?;
        drop(waiting);
        Ok(queue.taken(permit, tool))
    }

    /// `tool`'s turn on simulation `id` if nobody holds it or waits for it.
    pub fn try_turn(&self, id: &str, tool: &str) -> Option<Turn> {
        let queue = self.queue(id);
        let permit = queue.turn.clone().try_acquire_owned().ok()?;
        Some(queue.taken(permit, tool))
    }

    /// Drops a destroyed simulation's queue (calls still waiting on it keep theirs, then find
    /// the simulation gone).
    pub fn forget(&self, id: &str) {
        self.queues.lock().unwrap_or_else(|p| p.into_inner()).remove(id);
    }

    /// Calls refused because their simulation was too busy, since the start.
    pub fn refused(&self) -> u64 {
        self.refused.load(Ordering::Relaxed)
    }

    fn refuse(&self, id: &str, queue: &Queue, waiting: usize, max: usize) -> Refusal {
        let total = self.refused.fetch_add(1, Ordering::Relaxed) + 1;
        tracing::info!(target: "physics_mcp::busy", simulation = id, refused_total = total, "a call was refused: its simulation was busy");
        let holder = queue.holder.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let by = match holder {
            Some((tool, since)) => format!(" with {tool} since {} s", since.elapsed().as_secs()),
            None => String::new(),
        };
        format!("Simulation {id} is busy{by} and {waiting} calls are waiting for it (--max-waiting {max}); retry when it is done")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(flavor = "current_thread")]
    async fn calls_wait_in_order_and_past_the_bound_are_refused_at_once() {
        let queues = Arc::new(Queues::default());
        let first = queues.turn("s", "step_simulation", 2).await.unwrap();
        let (q1, q2) = (queues.clone(), queues.clone());
        let a = tokio::spawn(async move { q1.turn("s", "get_history", 2).await.map(|_| ()) });
        let b = tokio::spawn(async move { q2.turn("s", "get_history", 2).await.map(|_| ()) });
        tokio::task::yield_now().await;
        let refused = queues.turn("s", "get_history", 2).await.err().expect("a third waiter is refused");
        assert!(refused.starts_with("Simulation s is busy with step_simulation since 0 s and 2 calls are waiting"), "{refused}");
        assert_eq!(queues.refused(), 1);
        // Another simulation is not held up at all.
        assert!(queues.try_turn("t", "get_object_state").is_some());
        drop(first);
        a.await.unwrap().unwrap();
        b.await.unwrap().unwrap();
        assert!(queues.try_turn("s", "get_object_state").is_some(), "the queue empties");
    }

    #[tokio::test(flavor = "current_thread")]
    async fn a_wait_given_up_frees_its_place() {
        let queues = Queues::default();
        let _held = queues.turn("s", "step_simulation", 1).await.unwrap();
        let gave_up = tokio::time::timeout(std::time::Duration::from_millis(10), queues.turn("s", "get_history", 1)).await;
        assert!(gave_up.is_err(), "it waited");
        let again = tokio::time::timeout(std::time::Duration::from_millis(10), queues.turn("s", "get_history", 1)).await;
        assert!(again.is_err(), "its place was free again, so this one waits instead of being refused");
    }
}
