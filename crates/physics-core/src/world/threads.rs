//! Which threads step a world (docs/tools.md "Scale"; rapier's `parallel` feature). Results
//! and hashes do not depend on it: rapier 0.36's parallel step is bit-identical for any thread
//! count, which `tests/physics/threads.rs` checks against hashes recorded by the single-threaded build
//! for every `replays/` log and three scenes, restore included. So no snapshot, event or hash
//! carries it.
//!
//! The server names a thread count once, at start (`--threads N`). A step command then runs on
//! a pool of N threads that belongs to the thread asking for the step (built on its first step,
//! gone with it), not to the world and not to the process:
//! - not to the world, because rapier keeps a world's pool in a field its serialisation skips:
//!   a restored world (recovery, undo, fork, load, replay) would step elsewhere until handed it
//!   again; here there is nothing to hand back;
//! - not one pool for the process, because rapier's step waits, outside rayon, for a task it
//!   spawned on its own pool: two steps on one N-thread pool from N callers each hold a worker
//!   while their tasks queue behind them, and never finish. One pool per calling thread runs
//!   one step at a time, so a spare worker is always there (with one thread rapier runs that
//!   task inline). A calling thread that is itself a worker of another rayon pool may, while
//!   it waits for its step, start another job that steps too: that step gets a second pool.
//!
//! Simulations on different threads (sessions, run_sweep's variants) step side by side as
//! before; each step gets N threads.

use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::Arc;

use rapier3d::rayon::{ThreadPool, ThreadPoolBuilder};

use super::World;

/// Threads per step; 1 unless the server says otherwise. Never "none": without a pool of ours
/// rapier would run its parallel parts on whatever rayon pool the calling thread is in — the
/// global one, for a step called from a `rayon::scope` or `par_iter` (animations re-simulate
/// inside one) — and two such steps can hold both of its workers in that `recv`.
static STEP_THREADS: AtomicUsize = AtomicUsize::new(1);

thread_local! {
    /// This thread's stepping pools, built on first use (see the module doc): one per step in
    /// progress on this thread's stack. Usually one; more when this thread is a worker of
    /// another rayon pool, which, while it waits for its step, may start another job that
    /// steps too — a second step on the same pool would be the hang the module doc describes.
    static POOLS: RefCell<Vec<Arc<ThreadPool>>> = const { RefCell::new(Vec::new()) };
    /// Steps in progress on this thread's stack.
    static DEPTH: Cell<usize> = const { Cell::new(0) };
}

/// Every step from now on runs on `n` threads (at least 1). Pools already built with another
/// count are replaced on their thread's next step.
pub fn set_step_threads(n: usize) {
    STEP_THREADS.store(n.max(1), Relaxed);
}

/// The count named by [`set_step_threads`].
pub fn step_threads() -> usize {
    STEP_THREADS.load(Relaxed)
}

/// The calling thread's stepping pool for a step at `depth` (steps already in progress on its
/// stack), built (threads named `physics-step-<i>`) on first use or when the count changed;
/// `None` if the threads cannot be started (the step then runs on the calling thread: never
/// different, only slower).
fn stepping_pool(depth: usize) -> Option<Arc<ThreadPool>> {
    let n = step_threads();
    POOLS.with(|pools| {
        let mut pools = pools.borrow_mut();
        if pools.get(depth).is_none_or(|p| p.current_num_threads() != n) {
            let built = ThreadPoolBuilder::new().num_threads(n).thread_name(|i| format!("physics-step-{i}")).build().ok()?;
            pools.truncate(depth);
            pools.push(Arc::new(built));
        }
        pools.get(depth).cloned()
    })
}

/// Marks a step in progress on this thread until dropped (also when the step panics).
struct InProgress(usize);

impl InProgress {
    fn enter() -> InProgress {
        let depth = DEPTH.get();
        DEPTH.set(depth + 1);
        InProgress(depth)
    }
}

impl Drop for InProgress {
    fn drop(&mut self) {
        DEPTH.set(self.0);
    }
}

impl World {
    /// Steps on `pool` from now on instead of the calling thread's stepping pool (`None`: back
    /// to that): for tests that compare thread counts side by side. Changes no state and no
    /// hash, and is not kept by a snapshot or a copy. The pool must serve one step at a time
    /// (two worlds stepped at once on one pool can hang, see the module doc).
    pub fn set_thread_pool(&mut self, pool: Option<Arc<ThreadPool>>) {
        self.physics.set_thread_pool(pool);
    }

    /// How many threads this world's steps run on: its own pool's size, else the `--threads`
    /// count.
    pub fn num_threads(&self) -> usize {
        self.physics.num_threads().unwrap_or_else(step_threads)
    }

    /// Runs `work` (a whole step command) inside this world's pool, or the calling thread's
    /// stepping pool: one hand-over per command instead of one per simulated step, which on a
    /// one-body world would cost more than the step itself. Inside, rapier finds itself in its
    /// pool and does not hand over again.
    pub(super) fn in_pool<R: Send>(&mut self, work: impl FnOnce(&mut World) -> R + Send) -> R {
        if let Some(pool) = self.physics.thread_pool() {
            return pool.install(|| work(self));
        }
        let step = InProgress::enter();
        match stepping_pool(step.0) {
            Some(pool) => pool.install(|| work(self)),
            None => work(self),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::Command;

    /// A world restored from a snapshot steps on the calling thread's pool of `--threads`
    /// threads, with nothing handed back; a world's own pool wins over it.
    #[test]
    fn restored_worlds_step_on_the_step_threads() {
        set_step_threads(3);
        let root = Command::CreateSimulation { simulation_id: "t".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) };
        let (mut w, _) = World::create(&root).unwrap();
        w.apply(&Command::step(3), &mut |_| true);
        let mut r = World::restore("t", false, &w.snapshot()).unwrap();
        let mut seen = Vec::new();
        let step = Command::step(2);
        r.apply_observed(&step, &mut |_| true, &mut |_| {
            seen.push((rapier3d::rayon::current_num_threads(), std::thread::current().name().map(String::from)))
        });
        assert_eq!(r.num_threads(), 3);
        assert!(seen.iter().all(|(n, name)| *n == 3 && name.as_deref().is_some_and(|s| s.starts_with("physics-step-"))), "{seen:?}");
        r.set_thread_pool(Some(Arc::new(ThreadPoolBuilder::new().num_threads(2).build().unwrap())));
        assert_eq!(r.num_threads(), 2);
        set_step_threads(1);
    }
}
