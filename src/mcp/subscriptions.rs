//! Resource subscriptions (docs/tools.md "Resources and prompts"): a client that subscribed to
//! `sim://{id}/…` hears `notifications/resources/updated` when that simulation's head moves —
//! any state-changing call, undo or redo, from any session.
//!
//! Two ways in, one hub: `resources/subscribe` / `unsubscribe` (sessions of revisions up to
//! 2025-11-25, kept per session) and `subscriptions/listen` (2026-07-28 clients, one stream per
//! request, ended by the client). The hub is shared by every session of one process.
//!
//! Notifications are paced per simulation: at most one per `MIN_GAP` (≤ 10 per second), and
//! a change that falls inside a gap is announced when the gap ends, so the last change is
//! always followed by one notification (trailing edge). A client stepping in a tight loop
//! costs its watchers a few messages per second, not one per call.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rmcp::model::{ResourceUpdatedNotificationParam, SubscriptionFilter};
use rmcp::service::SubscriptionSink;
use rmcp::{Peer, RoleServer};
use tokio::time::Instant;

/// The shortest time between two updates about one simulation (10 per second at most).
pub const MIN_GAP: Duration = Duration::from_millis(100);

/// Who is subscribed to what, and when each simulation last announced a change.
#[derive(Clone, Default)]
pub struct Subscriptions(Arc<Mutex<Hub>>);

#[derive(Default)]
struct Hub {
    /// `resources/subscribe` sessions: session number → its peer and the URIs it asked for.
    sessions: HashMap<u64, (Peer<RoleServer>, BTreeSet<String>)>,
    /// Open `subscriptions/listen` streams: a number → the stream's sink (its accepted URIs
    /// are in the sink's filter).
    listeners: HashMap<u64, SubscriptionSink>,
    next_listener: u64,
    /// Per simulation: when it last sent, and whether a trailing send is already scheduled.
    pace: HashMap<String, Pace>,
}

#[derive(Default)]
struct Pace {
    last: Option<Instant>,
    scheduled: bool,
}

/// The simulation a `sim://{id}/{part}` URI belongs to.
fn sim_of(uri: &str) -> Option<&str> {
    uri.strip_prefix("sim://")?.rsplit_once('/').map(|(id, _)| id)
}

impl Subscriptions {
    fn hub(&self) -> MutexGuard<'_, Hub> {
        self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// `resources/subscribe` from session `session` (its peer answers the notifications).
    pub fn subscribe(&self, session: u64, peer: Peer<RoleServer>, uri: String) {
        let mut hub = self.hub();
        hub.sessions.entry(session).or_insert_with(|| (peer, BTreeSet::new())).1.insert(uri);
    }

    /// `resources/unsubscribe`: the session hears nothing more about `uri`.
    pub fn unsubscribe(&self, session: u64, uri: &str) {
        let mut hub = self.hub();
        if let Some((_, uris)) = hub.sessions.get_mut(&session) {
            uris.remove(uri);
            if uris.is_empty() {
                hub.sessions.remove(&session);
            }
        }
    }

    /// Registers an open `subscriptions/listen` stream; the number is for `stop_listening`.
    pub fn listen(&self, sink: SubscriptionSink) -> u64 {
        let mut hub = self.hub();
        hub.next_listener += 1;
        let n = hub.next_listener;
        hub.listeners.insert(n, sink);
        n
    }

    /// Forgets a `subscriptions/listen` stream (the client cancelled it or went away).
    pub fn stop_listening(&self, n: u64) {
        self.hub().listeners.remove(&n);
    }

    /// The listen streams that asked for `notifications/resources/list_changed`.
    pub fn list_listeners(&self) -> Vec<SubscriptionSink> {
        self.hub()
            .listeners
            .values()
            .filter(|s| s.accepted().resources_list_changed == Some(true))
            .cloned()
            .collect()
    }

    /// Simulation `id`'s head moved: tell its subscribers now, or when the current gap ends
    /// if one was told less than `MIN_GAP` ago. Must run inside the tokio runtime.
    pub fn head_moved(&self, id: &str) {
        let now = Instant::now();
        let wait = {
            let mut hub = self.hub();
            let watched = hub.sessions.values().any(|(_, uris)| uris.iter().any(|u| sim_of(u) == Some(id)))
                || hub.listeners.values().any(|s| accepted_uris(s.accepted()).any(|u| sim_of(u) == Some(id)));
            if !watched {
                return;
            }
            let pace = hub.pace.entry(id.to_string()).or_default();
            if pace.scheduled {
                return; // the scheduled send will announce this change too
            }
            match pace.last {
                Some(last) if now < last + MIN_GAP => {
                    pace.scheduled = true;
                    Some(last + MIN_GAP)
                }
                _ => {
                    pace.last = Some(now);
                    None
                }
            }
        };
        match wait {
            None => self.send(id),
            Some(at) => {
                let me = self.clone();
                let id = id.to_string();
                tokio::spawn(async move {
                    tokio::time::sleep_until(at).await;
                    {
                        let mut hub = me.hub();
                        let pace = hub.pace.entry(id.clone()).or_default();
                        pace.scheduled = false;
                        pace.last = Some(Instant::now());
                    }
                    me.send(&id);
                });
            }
        }
    }

    /// Sends `notifications/resources/updated` for every subscribed URI of simulation `id`,
    /// in the background: a slow or gone client never holds up a tool's reply.
    fn send(&self, id: &str) {
        let (peers, sinks) = {
            let mut hub = self.hub();
            hub.sessions.retain(|_, (p, _)| !p.is_transport_closed());
            let peers: Vec<(Peer<RoleServer>, Vec<String>)> = hub
                .sessions
                .values()
                .map(|(p, uris)| (p.clone(), uris.iter().filter(|u| sim_of(u) == Some(id)).cloned().collect::<Vec<_>>()))
                .filter(|(_, uris)| !uris.is_empty())
                .collect();
            let sinks: Vec<(SubscriptionSink, Vec<String>)> = hub
                .listeners
                .values()
                .map(|s| (s.clone(), accepted_uris(s.accepted()).filter(|u| sim_of(u) == Some(id)).cloned().collect::<Vec<_>>()))
                .filter(|(_, uris)| !uris.is_empty())
                .collect();
            (peers, sinks)
        };
        for (peer, uris) in peers {
            tokio::spawn(async move {
                for uri in uris {
                    if let Err(e) = peer.notify_resource_updated(ResourceUpdatedNotificationParam::new(uri)).await {
                        tracing::debug!("resource update not delivered: {e}");
                    }
                }
            });
        }
        for (sink, uris) in sinks {
            tokio::spawn(async move {
                for uri in uris {
                    if let Err(e) = sink.notify_resource_updated(uri).await {
                        tracing::debug!("resource update not delivered on a listen stream: {e}");
                    }
                }
            });
        }
    }
}

/// The resource URIs a listen stream was accepted for.
fn accepted_uris(filter: &SubscriptionFilter) -> impl Iterator<Item = &String> {
    filter.resource_subscriptions.iter().flatten()
}

/// What `subscriptions/listen` accepts of a request: resource-list changes, and updates of
/// any URI, like `resources/subscribe` (only `sim://{id}/{part}` ones ever change; ids are
/// never reused, so watching a simulation not made yet is harmless).
pub fn accepted_filter(requested: &SubscriptionFilter) -> SubscriptionFilter {
    let mut accepted = SubscriptionFilter::builder();
    if requested.resources_list_changed == Some(true) {
        accepted = accepted.resources_list_changed();
    }
    let uris: Vec<String> = requested
        .resource_subscriptions
        .iter()
        .flatten()
        .cloned()
        .collect();
    if !uris.is_empty() {
        accepted = accepted.resource_subscriptions(uris);
    }
    accepted.build()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_name_their_simulation() {
        assert_eq!(sim_of("sim://abc-1/info"), Some("abc-1"));
        assert_eq!(sim_of("sim://abc-1/history"), Some("abc-1"));
        assert_eq!(sim_of("file:///x"), None);
    }

    #[test]
    fn listen_accepts_uris_and_list_changes_only() {
        let req = SubscriptionFilter::builder()
            .resources_list_changed()
            .tools_list_changed()
            .resource_subscriptions(["sim://a/info", "file:///etc/passwd"])
            .build();
        let got = accepted_filter(&req);
        assert_eq!(got.resources_list_changed, Some(true));
        assert_eq!(got.tools_list_changed, None);
        assert_eq!(got.resource_subscriptions.map(|u| u.len()), Some(2));
    }
}
