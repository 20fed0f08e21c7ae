//! MCP resources (docs/tools.md "Resources and prompts"): every simulation as three readable URIs —
//! `sim://{id}/info` (get_simulation_info's answer), `sim://{id}/history` (its events as JSON
//! lines) and `sim://{id}/image` (a PNG from the viewer camera) — and the session list that
//! lets a simulation created or destroyed in one session tell every session its resource list
//! changed; beside them, the viewer app and `models://builtin` (list_models' answer).
//!
//! Reading a resource is a look, not a tool call: it is not recorded in the simulation's log
//! (the README says so), and it never changes the world.

use std::sync::{Arc, Mutex};

use base64::Engine;
use rmcp::model::{ErrorData, ListResourceTemplatesResult, ListResourcesResult, ReadResourceResult, Resource,
                  ResourceContents, ResourceTemplate};
use rmcp::{Peer, RoleServer};
use serde_json::{json, Value};

use super::subscriptions::Subscriptions;
use super::tools::models::MODELS_URI;
use super::PhysicsServer;
use crate::seeing::viewer;
use crate::sim::reads;
use crate::sim::{lock_sim, Sim};
use crate::sim::timeline::HISTORY_MAX_LIMIT;
use crate::value::Refusal;

/// Newest events `sim://{id}/history` lists (older ones: get_history with `since_seq`, or the
/// `history` CLI on the log file).
pub const HISTORY_RESOURCE_EVENTS: u64 = 10_000;

/// The viewer-camera image size of `sim://{id}/image` (get_camera_image's default view).
const IMAGE_SIZE: (u32, u32) = (320, 240);

/// What a `sim://` URI names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Info,
    History,
    Image,
}

impl Part {
    const ALL: [Part; 3] = [Part::Info, Part::History, Part::Image];

    fn name(self) -> &'static str {
        match self {
            Part::Info => "info",
            Part::History => "history",
            Part::Image => "image",
        }
    }

    fn mime(self) -> &'static str {
        match self {
            Part::Info => "application/json",
            Part::History => "application/x-ndjson",
            Part::Image => "image/png",
        }
    }

    fn description(self) -> &'static str {
        match self {
            Part::Info => "The simulation's gravity, timestep, time, objects, constraints and state hash (as get_simulation_info).",
            Part::History => "The simulation's event log, one JSON event per line (as get_history's compact events; the newest 10,000 that fit the reply budget).",
            Part::Image => "A 320x240 PNG of the simulation from its viewer camera (set_camera).",
        }
    }
}

/// The simulation a `sim://` resource URI names (for routing a read to its owner).
pub(super) fn sim_of_uri(uri: &str) -> Option<String> {
    viewer_read(uri).map(|(id, _, _)| id.to_string()).or_else(|| parse(uri).ok().map(|(id, _)| id.to_string()))
}

/// Splits `sim://{id}/viewer/{kind}?{query}`: what the viewer app reads through its host
/// (`seeing::viewer::ask`), the same answers the viewer page gets over HTTP.
fn viewer_read(uri: &str) -> Option<(&str, &str, &str)> {
    let (id, rest) = uri.strip_prefix("sim://")?.split_once("/viewer/")?;
    let (kind, query) = rest.split_once('?').unwrap_or((rest, ""));
    Some((id, kind, query))
}

/// Splits `sim://{id}/{part}`.
fn parse(uri: &str) -> Result<(&str, Part), String> {
    let rest = uri
        .strip_prefix("sim://")
        .ok_or_else(|| format!("Unknown resource {uri}: resources are sim://{{sim_id}}/info, /history or /image"))?;
    let (id, part) = rest
        .rsplit_once('/')
        .ok_or_else(|| format!("Unknown resource {uri}: resources are sim://{{sim_id}}/info, /history or /image"))?;
    let part = Part::ALL
        .into_iter()
        .find(|p| p.name() == part)
        .ok_or_else(|| format!("Unknown resource {uri}: the part must be info, history or image"))?;
    Ok((id, part))
}

/// The contents of one part of one simulation.
/// The newest of `lines` (oldest first) whose text, as the reply carries it (a JSON string,
/// escaped), fits `budget` bytes with room for the envelope: a resource read is held to the
/// reply budget like a tool call, dropping the oldest events (get_history pages further back).
fn newest_that_fit(lines: &[String], budget: usize) -> String {
    let room = budget.saturating_sub(1024);
    let (mut used, mut first) = (0usize, lines.len());
    for (i, line) in lines.iter().enumerate().rev() {
        // Escaped inside the reply's JSON string, plus the escaped newline.
        let cost = serde_json::to_string(line).map_or(usize::MAX, |q| q.len()).saturating_sub(2).saturating_add(2);
        if used.saturating_add(cost) > room {
            break;
        }
        used += cost;
        first = i;
    }
    let mut text = String::with_capacity(used);
    for line in &lines[first..] {
        text.push_str(line);
        text.push('\n');
    }
    text
}

fn contents(sim: &Sim, part: Part, uri: &str, max_px: usize, budget: usize) -> Result<ResourceContents, Refusal> {
    sim.ensure_live()?;
    let cx = sim.read_context();
    let text = |v: Value| ResourceContents::text(v.to_string(), uri).with_mime_type(part.mime());
    match part {
        Part::Info => {
            let info = reads::simulation_info(&cx)?;
            Ok(text(serde_json::to_value(info).map_err(|e| format!("Internal error: {e}"))?))
        }
        Part::History => {
            let mut since = sim.log().last_seq().saturating_sub(HISTORY_RESOURCE_EVENTS);
            let mut lines: Vec<String> = Vec::new();
            loop {
                let page = sim.history(since, HISTORY_MAX_LIMIT, false)?;
                let Some(last) = page.events.last().map(|e| e.seq) else { break };
                for e in &page.events {
                    lines.push(serde_json::to_string(e).map_err(|e| format!("Internal error: {e}"))?);
                }
                since = last;
            }
            Ok(ResourceContents::text(newest_that_fit(&lines, budget), uri).with_mime_type(part.mime()))
        }
        Part::Image => {
            let (w, h) = IMAGE_SIZE;
            let args = json!({"sim_id": cx.world.simulation_id(), "width": w, "height": h});
            let p = crate::params::parse("sim://image", args.as_object().unwrap_or(&Default::default()))?;
            let rendered = reads::camera_image(&cx, &p, max_px)?;
            let png = base64::engine::general_purpose::STANDARD.encode(&rendered.png);
            Ok(ResourceContents::blob(png, uri).with_mime_type(part.mime()))
        }
    }
}

impl PhysicsServer {
    /// resources/list: three per simulation, by simulation id.
    pub(super) fn resource_list(&self) -> ListResourcesResult {
        let resources: Vec<Resource> = self
            .reg
            .list()
            .simulations
            .iter()
            .flat_map(|s| {
                Part::ALL.into_iter().map(move |p| {
                    Resource::new(format!("sim://{}/{}", s.simulation_id, p.name()), format!("{} {}", s.simulation_id, p.name()))
                        .with_description(p.description())
                        .with_mime_type(p.mime())
                })
            })
            .collect();
        let app = Resource::new(viewer::app::APP_URI, "viewer")
            .with_description("The simulation viewer as an MCP App (3D, timeline, inspector).")
            .with_mime_type(viewer::app::APP_MIME);
        let models = Resource::new(MODELS_URI, "built-in models")
            .with_description("The built-in models load_urdf and load_mjcf take by name (as list_models).")
            .with_mime_type("application/json");
        let resources = [app, models].into_iter().chain(resources).collect();
        // Simulations come and go: a client must not serve this list from a cache.
        ListResourcesResult::with_all_items(resources).with_ttl_ms(0)
    }

    /// resources/templates/list: the three URI shapes.
    pub(super) fn resource_templates() -> ListResourceTemplatesResult {
        let templates = Part::ALL
            .into_iter()
            .map(|p| {
                ResourceTemplate::new(format!("sim://{{sim_id}}/{}", p.name()), format!("simulation {}", p.name()))
                    .with_description(p.description())
                    .with_mime_type(p.mime())
            })
            .collect();
        ListResourceTemplatesResult::with_all_items(templates)
    }

    /// resources/read, on the blocking pool (it waits for a call in flight on the simulation).
    /// A viewer read stops waiting and re-simulating once `stop` is cancelled (the client
    /// cancelled the read or its session ended).
    pub(super) async fn read_sim_resource(&self, uri: String, stop: tokio_util::sync::CancellationToken) -> Result<ReadResourceResult, ErrorData> {
        if uri == viewer::app::APP_URI {
            let html = ResourceContents::text(viewer::app::app_html(), &uri).with_mime_type(viewer::app::APP_MIME);
            return Ok(ReadResourceResult::new(vec![html.with_meta(viewer::app::resource_meta())]));
        }
        if uri == MODELS_URI {
            let listed = tokio::task::spawn_blocking(|| crate::files::library::matching(None))
                .await
                .map_err(|_| ErrorData::internal_error("Internal error: the models could not be listed", None))?
                .map_err(|why| ErrorData::internal_error(why, None))?;
            let text = serde_json::to_string(&crate::outputs::Models { models: listed }).map_err(|e| ErrorData::internal_error(format!("Internal error: {e}"), None))?;
            return Ok(ReadResourceResult::new(vec![ResourceContents::text(text, &uri).with_mime_type("application/json")]));
        }
        if let Some((id, kind, query)) = viewer_read(&uri) {
            let (reg, budget) = (self.reg.clone(), self.reg.limits().max_reply_bytes);
            let (id, kind, query) = (id.to_string(), kind.to_string(), query.to_string());
            let answered = match viewer::ask::Asking::enter(&id) {
                Ok(asking) => tokio::task::spawn_blocking(move || {
                    let _asking = asking;
                    viewer::ask::answer_text(&reg, &id, &kind, &query, &stop)
                })
                .await
                .map_err(|_| ErrorData::internal_error("Internal error: the viewer could not answer", None))?,
                Err(busy) => Err(busy),
            };
            let text = match answered {
                Ok(text) => text,
                // "Ask again" (a call holds the simulation): JSON null, which the app asks again on.
                Err((status, _)) if status == axum::http::StatusCode::ACCEPTED => "null".to_string(),
                Err((status, why)) if status == axum::http::StatusCode::NOT_FOUND => {
                    return Err(ErrorData::resource_not_found(why, Some(json!({"uri": uri}))))
                }
                Err((_, why)) => return Err(ErrorData::invalid_params(why, Some(json!({"uri": uri})))),
            };
            // As the reply carries it: a JSON string, escaped.
            let carried = serde_json::to_string(&text).map_or(usize::MAX, |q| q.len());
            if carried > budget.saturating_sub(1024) {
                return Err(ErrorData::invalid_params(format!("{uri} is {carried} bytes, over the reply budget; open the viewer page instead"), None));
            }
            return Ok(ReadResourceResult::new(vec![ResourceContents::text(text, &uri).with_mime_type("application/json")]).with_ttl_ms(0));
        }
        let not_found = |why: String| ErrorData::resource_not_found(why, Some(json!({"uri": uri})));
        let (id, part) = parse(&uri).map_err(not_found)?;
        let sim = self.sim(id).await.map_err(not_found)?;
        let (max_px, budget) = (self.reg.limits().max_image_px, self.reg.limits().max_reply_bytes);
        let at = uri.clone();
        let turn = self.turn(id, "resources/read").await.map_err(|why| ErrorData::internal_error(why, Some(json!({"uri": uri}))))?;
        let read = tokio::task::spawn_blocking(move || {
            let _turn = turn;
            contents(&lock_sim(&sim), part, &at, max_px, budget)
        })
            .await
            .map_err(|_| ErrorData::internal_error("Internal error: the resource could not be read", None))?;
        // Live state: never fresh for longer than this reply.
        read.map(|c| ReadResourceResult::new(vec![c]).with_ttl_ms(0))
            .map_err(|why| ErrorData::internal_error(why, Some(json!({"uri": uri}))))
    }
}

/// What every session of one server shares: the live sessions' peers (for resource-list
/// notifications) and the resource subscriptions — and, in a cluster, the other nodes, told
/// of every change here so their subscribers hear it too (`forwarded::hear`).
#[derive(Clone, Default)]
pub struct Sessions {
    peers: Arc<Mutex<Vec<Peer<RoleServer>>>>,
    subscriptions: Subscriptions,
    cluster: Option<Arc<crate::cluster::Cluster>>,
}

impl Sessions {
    /// The sessions of a server whose registry may be a cluster node's.
    pub fn of(reg: &crate::sim::Registry) -> Sessions {
        Sessions { cluster: reg.cluster().cloned(), ..Sessions::default() }
    }

    /// A simulation's head moved here: this node's subscribers hear it (paced), and so do
    /// the other nodes'.
    pub fn head_moved(&self, id: &str) {
        self.subscriptions.head_moved(id);
        self.tell("moved", id);
    }

    /// Tells the other nodes of a change here (in the background).
    fn tell(&self, what: &'static str, payload: &str) {
        if let Some(cluster) = self.cluster.clone() {
            let payload = payload.to_string();
            tokio::spawn(async move { cluster.tell(what, payload).await });
        }
    }

    /// Remembers a session once its client has initialized.
    pub fn join(&self, peer: Peer<RoleServer>) {
        if let Ok(mut peers) = self.peers.lock() {
            peers.retain(|p| !p.is_transport_closed());
            peers.push(peer);
        }
    }

    /// The subscriptions of every session.
    pub fn subscriptions(&self) -> &Subscriptions {
        &self.subscriptions
    }

    /// A simulation came or went here: every session on every node hears it.
    pub fn resource_list_changed(&self) {
        self.notify_list_changed();
        self.tell("listed", "");
    }

    /// Tells every live session here (and every `subscriptions/listen` stream that asked)
    /// that the resource list changed. Sent in the background: a slow or gone client never
    /// holds up the tool's reply.
    pub fn notify_list_changed(&self) {
        let peers: Vec<Peer<RoleServer>> = match self.peers.lock() {
            Ok(mut peers) => {
                peers.retain(|p| !p.is_transport_closed());
                peers.clone()
            }
            Err(_) => return,
        };
        for peer in peers {
            tokio::spawn(async move {
                if let Err(e) = peer.notify_resource_list_changed().await {
                    tracing::debug!("resource list notification not delivered: {e}");
                }
            });
        }
        for sink in self.subscriptions.list_listeners() {
            tokio::spawn(async move {
                if let Err(e) = sink.notify_resource_list_changed().await {
                    tracing::debug!("resource list notification not delivered on a listen stream: {e}");
                }
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_parse_or_say_what_is_expected() {
        assert_eq!(parse("sim://abc-1/info"), Ok(("abc-1", Part::Info)));
        assert_eq!(parse("sim://abc-1/history"), Ok(("abc-1", Part::History)));
        assert_eq!(parse("sim://abc-1/image"), Ok(("abc-1", Part::Image)));
        assert!(parse("sim://abc-1/video").unwrap_err().contains("info, history or image"));
        assert!(parse("file:///etc/passwd").unwrap_err().contains("sim://"));
        assert!(parse("sim://abc").is_err());
    }
}
