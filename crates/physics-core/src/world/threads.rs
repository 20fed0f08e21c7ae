//! Multi-threaded stepping, compiled only with the `threads` feature (rapier's `parallel`):
//! an evaluation of SPEC "Scale: … threads", not part of the default build. The pool is the
//! caller's (the core starts no threads of its own) and is not part of the world's state: a
//! snapshot does not carry it (rapier skips the pipeline when serialising), so whoever restores
//! a world must hand it the pool again — without one, rapier steps on whatever rayon pool the
//! calling thread is in.

use std::sync::Arc;

use rapier3d::rayon::ThreadPool;

use super::World;

impl World {
    /// Steps on `pool` from now on (`None`: on the calling thread's rayon pool). Changes no
    /// state and no hash — if rapier's parallel step is as deterministic as it claims.
    pub fn set_thread_pool(&mut self, pool: Option<Arc<ThreadPool>>) {
        self.physics.set_thread_pool(pool);
    }

    /// The size of the pool set with `set_thread_pool`, if one is: what a test asserts after
    /// a restore.
    pub fn num_threads(&self) -> Option<usize> {
        self.physics.num_threads()
    }
}
