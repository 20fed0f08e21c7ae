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
//!
//! Bounded (docs/guarantees.md "Isolation"): a session holds at most `MAX_PER_SESSION` URIs of
//! at most `MAX_URI_BYTES` each, and `MAX_LISTENS_PER_SESSION` listen streams; everything a
//! session subscribed is dropped when the session ends (`drop_session`, from the session's
//! server); and the subscriptions are indexed by simulation, so a change looks up its own
//! watchers instead of scanning everyone's.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rmcp::model::{ResourceUpdatedNotificationParam, SubscriptionFilter};
use rmcp::service::SubscriptionSink;
use rmcp::{Peer, RoleServer};
use tokio::time::Instant;

/// The shortest time between two updates about one simulation (10 per second at most).
pub const MIN_GAP: Duration = Duration::from_millis(100);

/// Most URIs one session may subscribe to (`resources/subscribe`), and accepted on one listen
/// stream.
pub const MAX_PER_SESSION: usize = 64;

/// Longest URI a subscription may name, in bytes (a `sim://` URI is about 50).
pub const MAX_URI_BYTES: usize = 512;

/// Most `subscriptions/listen` streams one session may hold open at once.
pub const MAX_LISTENS_PER_SESSION: usize = 4;

/// Who is subscribed to what, and when each simulation last announced a change.
#[derive(Clone, Default)]
pub struct Subscriptions(Arc<Mutex<Hub>>);

#[derive(Default)]
struct Hub {
    /// `resources/subscribe` sessions: session number → its peer and the URIs it asked for.
    sessions: HashMap<u64, (Peer<RoleServer>, BTreeSet<String>)>,
    /// Open `subscriptions/listen` streams: a number → its session and the stream's sink (its
    /// accepted URIs are in the sink's filter).
    listeners: HashMap<u64, (u64, SubscriptionSink)>,
    next_listener: u64,
    /// Who watches each simulation (by id): what a change looks up.
    watchers: HashMap<String, Watchers>,
    /// Per simulation: when it last sent, and whether a trailing send is already scheduled.
    pace: HashMap<String, Pace>,
}

/// The sessions and listen streams with a URI of one simulation.
#[derive(Default)]
struct Watchers {
    sessions: BTreeSet<u64>,
    listeners: BTreeSet<u64>,
}

impl Hub {
    fn watch(&mut self, uri: &str, session: Option<u64>, listener: Option<u64>) {
        let Some(sim) = sim_of(uri) else { return };
        let w = self.watchers.entry(sim.to_string()).or_default();
        w.sessions.extend(session);
        w.listeners.extend(listener);
    }

    /// Forgets that `session` (or `listener`) watches `sim`; a simulation nobody watches any
    /// more leaves the index (and its pacing, unless a send is scheduled).
    fn unwatch(&mut self, sim: &str, session: Option<u64>, listener: Option<u64>) {
        let Some(w) = self.watchers.get_mut(sim) else { return };
        if let Some(s) = session {
            w.sessions.remove(&s);
        }
        if let Some(l) = listener {
            w.listeners.remove(&l);
        }
        if w.sessions.is_empty() && w.listeners.is_empty() {
            self.watchers.remove(sim);
            if self.pace.get(sim).is_some_and(|p| !p.scheduled) {
                self.pace.remove(sim);
            }
        }
    }

    /// Forgets session `n`'s `resources/subscribe` URIs.
    fn drop_subscriber(&mut self, n: u64) {
        if let Some((_, uris)) = self.sessions.remove(&n) {
            for sim in uris.iter().filter_map(|u| sim_of(u)).collect::<BTreeSet<_>>() {
                self.unwatch(sim, Some(n), None);
            }
        }
    }

    /// Forgets listen stream `n`.
    fn drop_listener(&mut self, n: u64) {
        if let Some((_, sink)) = self.listeners.remove(&n) {
            for sim in accepted_uris(sink.accepted()).filter_map(|u| sim_of(u)).collect::<BTreeSet<_>>() {
                self.unwatch(sim, None, Some(n));
            }
        }
    }
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

    /// `resources/subscribe` from session `session` (its peer answers the notifications);
    /// refused, in one sentence naming `uri`, past `MAX_URI_BYTES` or `MAX_PER_SESSION`.
    pub fn subscribe(&self, session: u64, peer: Peer<RoleServer>, uri: String) -> Result<(), String> {
        if uri.len() > MAX_URI_BYTES {
            return Err(format!("uri is {} bytes; a subscribed URI may have at most {MAX_URI_BYTES} (sim://{{sim_id}}/info, /history or /image)", uri.len()));
        }
        let mut hub = self.hub();
        let uris = &mut hub.sessions.entry(session).or_insert_with(|| (peer, BTreeSet::new())).1;
        if !uris.contains(&uri) && uris.len() >= MAX_PER_SESSION {
            return Err(format!("uri: this session already holds {MAX_PER_SESSION} subscriptions, the most one may; unsubscribe from one first"));
        }
        if uris.insert(uri.clone()) {
            hub.watch(&uri, Some(session), None);
        }
        Ok(())
    }

    /// `resources/unsubscribe`: the session hears nothing more about `uri`.
    pub fn unsubscribe(&self, session: u64, uri: &str) {
        let mut hub = self.hub();
        let Some((_, uris)) = hub.sessions.get_mut(&session) else { return };
        if !uris.remove(uri) {
            return;
        }
        let (still, empty) = (sim_of(uri).is_some_and(|sim| uris.iter().any(|u| sim_of(u) == Some(sim))), uris.is_empty());
        if empty {
            hub.sessions.remove(&session);
        }
        if let (Some(sim), false) = (sim_of(uri), still) {
            hub.unwatch(sim, Some(session), None);
        }
    }

    /// Registers an open `subscriptions/listen` stream of session `session`; the number is for
    /// `stop_listening`. Refused past `MAX_LISTENS_PER_SESSION` open streams.
    pub fn listen(&self, session: u64, sink: SubscriptionSink) -> Result<u64, String> {
        let mut hub = self.hub();
        if hub.listeners.values().filter(|(s, _)| *s == session).count() >= MAX_LISTENS_PER_SESSION {
            return Err(format!("this session already holds {MAX_LISTENS_PER_SESSION} open listen streams, the most one may; cancel one first"));
        }
        hub.next_listener += 1;
        let n = hub.next_listener;
        for uri in accepted_uris(sink.accepted()) {
            hub.watch(uri, None, Some(n));
        }
        hub.listeners.insert(n, (session, sink));
        Ok(n)
    }

    /// Forgets a `subscriptions/listen` stream (the client cancelled it or went away).
    pub fn stop_listening(&self, n: u64) {
        self.hub().drop_listener(n);
    }

    /// Forgets everything session `session` subscribed (the session ended).
    pub fn drop_session(&self, session: u64) {
        let mut hub = self.hub();
        let uris = hub.sessions.get(&session).map_or(0, |(_, uris)| uris.len());
        hub.drop_subscriber(session);
        let streams: Vec<u64> = hub.listeners.iter().filter(|(_, (s, _))| *s == session).map(|(n, _)| *n).collect();
        for n in &streams {
            hub.drop_listener(*n);
        }
        if uris > 0 || !streams.is_empty() {
            tracing::info!(session, uris, streams = streams.len(), "session ended: its subscriptions dropped");
        }
    }

    /// URIs subscribed and listen streams open, over every session (for tests and the log).
    pub fn held(&self) -> (usize, usize) {
        let hub = self.hub();
        (hub.sessions.values().map(|(_, uris)| uris.len()).sum(), hub.listeners.len())
    }

    /// The listen streams that asked for `notifications/resources/list_changed`.
    pub fn list_listeners(&self) -> Vec<SubscriptionSink> {
        self.hub()
            .listeners
            .values()
            .filter(|(_, s)| s.accepted().resources_list_changed == Some(true))
            .map(|(_, s)| s.clone())
            .collect()
    }

    /// Simulation `id`'s head moved: tell its subscribers now, or when the current gap ends
    /// if one was told less than `MIN_GAP` ago. Must run inside the tokio runtime.
    pub fn head_moved(&self, id: &str) {
        let now = Instant::now();
        let wait = {
            let mut hub = self.hub();
            if !hub.watchers.contains_key(id) {
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
            let Some(w) = hub.watchers.get(id) else { return };
            let (sessions, listeners) = (w.sessions.clone(), w.listeners.clone());
            let mut peers: Vec<(Peer<RoleServer>, Vec<String>)> = Vec::new();
            for n in sessions {
                let entry = hub.sessions.get(&n).map(|(p, uris)| (p.clone(), uris.iter().filter(|u| sim_of(u) == Some(id)).cloned().collect()));
                let Some((p, uris)) = entry else { continue };
                if p.is_transport_closed() {
                    hub.drop_subscriber(n);
                    continue;
                }
                peers.push((p, uris));
            }
            let sinks: Vec<(SubscriptionSink, Vec<String>)> = listeners
                .iter()
                .filter_map(|n| hub.listeners.get(n))
                .map(|(_, s)| (s.clone(), accepted_uris(s.accepted()).filter(|u| sim_of(u) == Some(id)).cloned().collect()))
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

/// Held by every clone of a session's server: when the last goes (rmcp dropped the session's
/// service), the session's subscriptions and listen streams go with it.
pub struct SessionEnd {
    session: u64,
    subscriptions: Subscriptions,
}

impl SessionEnd {
    /// The end of session `session`, whose subscriptions live in `subscriptions`.
    pub fn new(session: u64, subscriptions: Subscriptions) -> SessionEnd {
        SessionEnd { session, subscriptions }
    }
}

impl Drop for SessionEnd {
    fn drop(&mut self) {
        self.subscriptions.drop_session(self.session);
    }
}

/// The resource URIs a listen stream was accepted for.
fn accepted_uris(filter: &SubscriptionFilter) -> impl Iterator<Item = &String> {
    filter.resource_subscriptions.iter().flatten()
}

/// What `subscriptions/listen` accepts of a request: resource-list changes, and updates of
/// any URI, like `resources/subscribe` (only `sim://{id}/{part}` ones ever change; ids are
/// never reused, so watching a simulation not made yet is harmless) — the first
/// `MAX_PER_SESSION` of at most `MAX_URI_BYTES` (the accepted filter tells the client which).
pub fn accepted_filter(requested: &SubscriptionFilter) -> SubscriptionFilter {
    let mut accepted = SubscriptionFilter::builder();
    if requested.resources_list_changed == Some(true) {
        accepted = accepted.resources_list_changed();
    }
    let uris: Vec<String> = requested
        .resource_subscriptions
        .iter()
        .flatten()
        .filter(|u| u.len() <= MAX_URI_BYTES)
        .take(MAX_PER_SESSION)
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
        // Only URIs that fit, and at most a session's worth.
        let long = format!("sim://{}/info", "x".repeat(MAX_URI_BYTES));
        let many: Vec<String> = (0..MAX_PER_SESSION + 10).map(|i| format!("sim://s{i}/info")).chain([long]).collect();
        let got = accepted_filter(&SubscriptionFilter::builder().resource_subscriptions(many).build());
        assert_eq!(got.resource_subscriptions.map(|u| u.len()), Some(MAX_PER_SESSION));
    }
}
