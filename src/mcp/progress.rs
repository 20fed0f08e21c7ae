//! Progress notifications and cancellation for long calls (step_simulation, batch,
//! run_sweep): one `Watch` per request hands out step controls that report steps done (about
//! 100 notifications per call, when the client sent a progress token) and stop the steps
//! once the client cancels.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use rmcp::model::{ProgressNotificationParam, RequestMetaObject};
use rmcp::{Peer, RoleServer};
use tokio::sync::mpsc::UnboundedSender;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

/// A request's progress reporter and cancellation token.
pub(crate) struct Watch {
    tx: Option<UnboundedSender<u64>>,
    ct: CancellationToken,
    every: u64,
    forward: Option<JoinHandle<()>>,
}

impl Watch {
    /// Watches a request expected to take `total` steps.
    pub(crate) fn new(meta: &RequestMetaObject, peer: Peer<RoleServer>, ct: CancellationToken, total: u64) -> Watch {
        let every = (total / 100).max(1);
        let Some(token) = meta.get_progress_token() else {
            return Watch { tx: None, ct, every, forward: None };
        };
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<u64>();
        let forward = tokio::spawn(async move {
            while let Some(done) = rx.recv().await {
                let note = ProgressNotificationParam::new(token.clone(), done as f64).with_total(total as f64);
                let _ = peer.notify_progress(note).await;
            }
        });
        Watch { tx: Some(tx), ct, every, forward: Some(forward) }
    }

    /// A step control for one runner: reports the steps it is given as done, and returns
    /// false (stop) once the request is cancelled or the server is shutting down.
    pub(crate) fn control(&self) -> impl FnMut(u64) -> bool + Send + 'static {
        let (tx, ct, every) = (self.tx.clone(), self.ct.clone(), self.every);
        let mut last_sent = 0;
        move |done| {
            if let Some(tx) = &tx {
                if done.saturating_sub(last_sent) >= every {
                    last_sent = done;
                    let _ = tx.send(done);
                }
            }
            // A shutdown stops a step exactly as a client's cancellation does.
            !ct.is_cancelled() && !crate::shutdown::requested()
        }
    }

    /// A step control for one of several runners working side by side: their steps add up
    /// in `done`, which is what is reported.
    pub(crate) fn shared_control(&self, done: Arc<AtomicU64>) -> impl FnMut(u64) -> bool + Send + 'static {
        let mut report = self.control();
        let mut mine = 0;
        move |now| {
            // Each step command counts from zero again.
            if now < mine {
                mine = 0;
            }
            let delta = now - mine;
            mine = now;
            report(done.fetch_add(delta, Ordering::Relaxed) + delta)
        }
    }

    /// Waits until every notification sent has gone out (before the reply).
    pub(crate) async fn finish(mut self) {
        self.tx.take();
        if let Some(f) = self.forward.take() {
            let _ = f.await;
        }
    }
}
