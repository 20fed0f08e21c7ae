//! The MCP face of the server (rmcp): thin adapters from JSON arguments to `Command`s and
//! `Sim` calls, and from results to MCP tool results. No physics here.
//!
//! Every tool takes the raw argument object (so a wrong type is a clear `isError` result, not a
//! JSON-RPC failure, and the log keeps the arguments exactly as sent), parses it once into its
//! `params.rs` type — whose schema is the tool's input schema — and declares its output schema
//! from `outputs.rs`. Errors are one sentence
//! with `isError: true`; sim work runs on the blocking pool, one call at a time per simulation.
//!
//! A tool returns `Result<Json<T>, String>` spelled out: rmcp's `#[tool]` macro finds the
//! output schema by reading `Json<…>` in the written return type, so an alias for it would
//! silently drop the tool's `outputSchema`. Both schemas of every tool are then made plain
//! JSON Schema 2020-12 by `schema::plain` (input schemas by `schema::input`, also leaner; see
//! `tools`). Every reply passes the reply budget (`reply::fit`, in `call_tool`).

pub(crate) mod forwarded;
mod instructions;
mod logging;
pub(crate) mod progress;
mod prompts;
pub(crate) mod reply;
mod resources;
mod routing;
mod schema;
pub mod session_limit;
mod subscriptions;
mod tools;
pub mod transport;
mod viewer_relay;


use std::sync::{Arc, LazyLock};

use rmcp::handler::server::router::tool::ToolRouter;
use rmcp::handler::server::wrapper::Json;
use rmcp::handler::server::tool::ToolCallContext;
#[allow(deprecated)]
use rmcp::model::{LoggingLevel, SetLevelRequestParams, SubscribeRequestParams, UnsubscribeRequestParams};
use rmcp::model::{
    CallToolRequestParams, CallToolResponse, CallToolResult, SubscriptionFilter,
    ErrorData, GetPromptRequestParams, GetPromptResponse, Implementation, ListPromptsResult,
    ListResourceTemplatesResult, ListResourcesResult, PaginatedRequestParams, ReadResourceRequestParams,
    ReadResourceResponse, ServerCapabilities, ServerConfig,
};
use rmcp::service::{NotificationContext, RequestContext, SubscriptionContext};
use rmcp::{tool_handler, RoleServer, ServerHandler};
use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::json;

use crate::command::Command;
use crate::files::Reader;
use crate::params;
use crate::limits::Limits;
use crate::outputs::Outcome;
use crate::sim::{lock_sim, Registry, Sim};
use crate::value::{self, Args, Refusal};
use crate::world::StepControl;

/// A read's answer whose reply is built from it rather than being its recorded result (a
/// summary naming the file the answer went to, an image beside the structured content).
pub(crate) trait Replied: Serialize + Send + 'static {
    /// The reply as it is sent (and measured before the read is logged).
    fn reply(&self, tool: &str) -> CallToolResult;
}

/// What a tool's parameter type must be: parsed from the arguments, described by its schema.
pub(crate) trait Params: DeserializeOwned + JsonSchema + Send + 'static {}
impl<P: DeserializeOwned + JsonSchema + Send + 'static> Params for P {}

pub use resources::Sessions;

/// The MCP server: one instance per session, all sharing the registry.
#[derive(Clone)]
pub struct PhysicsServer {
    reg: Arc<Registry>,
    /// What every session of this server shares: peers for resource-list notifications and
    /// the resource subscriptions.
    sessions: Sessions,
    /// `http://host:port` of the web viewer (HTTP only; stdio has none).
    viewer_base: Option<Arc<str>>,
    /// This session's number (its `resources/subscribe` subscriptions are kept under it).
    session: u64,
    /// Drops the session's subscriptions when its last server clone goes, i.e. when rmcp
    /// drops the session's service because the session ended (DELETE, expiry, eviction).
    _session_end: Arc<subscriptions::SessionEnd>,
    /// This session's logging level (`logging/setLevel`).
    log: logging::SessionLog,
    /// Whether this server runs calls other nodes forwarded (it never forwards them again).
    forwarded: bool,
    tool_router: ToolRouter<PhysicsServer>,
}

impl PhysicsServer {
    /// A session's server over `reg` with every tool routed; `sessions` is shared by all
    /// sessions of one process so each hears when simulations come and go.
    pub fn new(reg: Arc<Registry>, sessions: Sessions) -> Self {
        static NEXT_SESSION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        let session = NEXT_SESSION.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let _session_end = Arc::new(subscriptions::SessionEnd::new(session, sessions.subscriptions().clone()));
        Self {
            reg,
            sessions,
            viewer_base: None,
            session,
            _session_end,
            log: logging::SessionLog::default(),
            forwarded: false,
            tool_router: Self::tools(),
        }
    }

    /// The server that runs calls forwarded from other nodes (`forwarded`): it runs them here
    /// whatever the lease says (the owner checked it), and its log lines at `warning` and
    /// above (a snapshot stall) travel back to the caller, who passes them to its client at
    /// that client's level (refusals the caller logs itself, from the answer).
    fn for_forwarded_calls(&self) -> Self {
        let log = logging::SessionLog::default();
        #[allow(deprecated)]
        log.set(LoggingLevel::Warning);
        Self { forwarded: true, log, ..self.clone() }
    }

    /// Every tool, with plain input and output schemas. Built once per process: a session
    /// gets a cheap clone (the schemas are shared `Arc`s).
    fn tools() -> ToolRouter<PhysicsServer> {
        static TOOLS: LazyLock<ToolRouter<PhysicsServer>> = LazyLock::new(|| {
            let mut router = PhysicsServer::simulation_router()
                + PhysicsServer::object_router()
                + PhysicsServer::timeline_router()
                + PhysicsServer::persistence_router()
                + PhysicsServer::robot_router()
                + PhysicsServer::constraint_router()
                + PhysicsServer::sensing_router()
                + PhysicsServer::viewer_router()
                + PhysicsServer::animation_router()
                + PhysicsServer::time_router()
                + PhysicsServer::mjcf_router()
                + PhysicsServer::batch_router()
                + PhysicsServer::sweep_router()
                + PhysicsServer::files_router()
                + PhysicsServer::models_router()
                + PhysicsServer::dynamics_router();
            for route in router.map.values_mut() {
                let tool = &mut route.attr;
                tool.input_schema = Arc::new(schema::input(&tool.input_schema));
                tool.output_schema = tool.output_schema.as_deref().map(|s| Arc::new(schema::plain(s)));
            }
            router
        });
        TOOLS.clone()
    }

    /// Every tool's name (a batch tells an unknown tool from one it cannot hold).
    pub(crate) fn tool_names() -> impl Iterator<Item = String> {
        Self::tools().map.keys().map(|k| k.to_string()).collect::<Vec<_>>().into_iter()
    }

    /// The same server with the web viewer at `base` (`viewer_url` in results when gui is on).
    pub fn with_viewer(mut self, base: Arc<str>) -> Self {
        self.viewer_base = Some(base);
        self
    }

    /// Where simulation `id`'s viewer page is, when this server has a viewer and the
    /// simulation was made with `gui = true`.
    fn viewer_url(&self, id: &str) -> Option<String> {
        let base = self.viewer_base.as_ref()?;
        let gui = self.reg.get_local(id).is_some() && self.reg.gui_of(id);
        gui.then(|| format!("{base}/viewer/{id}"))
    }

    /// Passes a tool's result through, telling every session the resource list changed when
    /// it succeeded (the tools that create or destroy simulations).
    fn simulations_changed<T>(&self, r: Result<Json<T>, String>) -> Result<Json<T>, String> {
        if r.is_ok() {
            self.sessions.resource_list_changed();
        }
        r
    }

    /// The registry behind this server.
    pub fn registry(&self) -> &Arc<Registry> {
        &self.reg
    }

    /// Runs `f` on the simulation named by `sim_id`, on the blocking pool, holding its lock,
    /// once it is `tool`'s turn on it (`sim::queue`: waiting is bounded per simulation and
    /// parks no thread).
    ///
    /// Every call that can move a simulation's head (state-changing tools, undo, redo,
    /// sampled steps) runs through here, so this is the one place that tells the resource
    /// subscribers: when the head moved, `Subscriptions::head_moved` paces the notifications.
    async fn with_sim<T: Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&mut Sim, &Args, &Limits) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<T, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.sim(&id).await?;
        self.locked(tool, &id, sim, args, f).await
    }

    /// `with_sim` whose `prepare` runs first, on the blocking pool and before the call waits
    /// for its turn: parsing the arguments and reading the files they name (a call waiting on
    /// a slow or large file holds no simulation), then `f` under the lock with what `prepare`
    /// made.
    async fn with_sim_prepared<X: Send + 'static, T: Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        prepare: impl FnOnce(&Args) -> X + Send + 'static,
        f: impl FnOnce(&mut Sim, &Args, &Limits, X) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<T, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.sim(&id).await?;
        let (args, prepared) = tokio::task::spawn_blocking(move || {
            let prepared = prepare(&args);
            (args, prepared)
        })
        .await
        .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?;
        self.locked(tool, &id, sim, args, move |s, a, limits| f(s, a, limits, prepared)).await
    }

    /// `tool`'s turn on simulation `id` (which must exist: queues are made for the
    /// simulations callers found), waiting behind the calls before it (`sim::queue`).
    pub(crate) async fn turn(&self, id: &str, tool: &'static str) -> Result<crate::sim::queue::Turn, String> {
        self.reg.queues().turn(id, tool, self.reg.limits().max_waiting).await
    }

    /// `f` on `sim` under its lock on the blocking pool, once `tool` has its turn; tells the
    /// subscribers when the head moved and keeps the simulation's listing up to date.
    async fn locked<T: Send + 'static>(
        &self,
        tool: &'static str,
        id: &str,
        sim: crate::sim::SharedSim,
        args: Args,
        f: impl FnOnce(&mut Sim, &Args, &Limits) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<T, String> {
        let turn = self.turn(id, tool).await?;
        let reg = self.reg.clone();
        let (out, moved) = tokio::task::spawn_blocking(move || {
            let _turn = turn;
            let mut guard = lock_sim(&sim);
            // Cluster mode: the lease is checked again now that the call has waited (a node
            // paused meanwhile may have lost it); the refusal names the new owner, so routing
            // resends the call there. Nothing ran, nothing is logged.
            if let Err(moved) = guard.fenced() {
                return (Err(moved), false);
            }
            let before = (guard.log().head_seq(), guard.state_hash().to_string());
            let out = f(&mut guard, &args, reg.limits());
            let moved = guard.log().head_seq() != before.0 || guard.state_hash() != before.1;
            if moved {
                reg.listed(&guard);
            }
            (out, moved)
        })
        .await
        .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?;
        if moved {
            self.sessions.head_moved(id);
        }
        out
    }

    /// A state-changing call whose steps may be watched (progress) or stopped (cancel): the
    /// arguments are parsed as `P` and `decide` makes the command — reading through a
    /// request's `Reader` the files it names — before the simulation is locked; a refusal
    /// of either is recorded like any other.
    async fn change_with<P: Params, T: TryFrom<Outcome>>(
        &self,
        tool: &'static str,
        args: Args,
        decide: impl FnOnce(P, &mut Reader) -> Result<Command, Refusal> + Send + 'static,
        mut control: impl FnMut(u64) -> bool + Send + 'static,
    ) -> Result<Json<T>, String> {
        let sandbox = self.reg.sandbox().clone();
        let prepare = move |a: &Args| {
            let mut reader = Reader::new(&sandbox);
            params::parse::<P>(tool, a).and_then(|p| decide(p, &mut reader)).and_then(Command::ready)
        };
        let out = self
            .with_sim_prepared(tool, args, prepare, move |sim, a, limits, decided| {
                let ctl: StepControl = &mut control;
                let started = std::time::Instant::now();
                // A running step shows its progress in the viewer (read-only copies of the
                // poses about every 100 ms; results and hashes are untouched).
                let total = match &decided {
                    Ok(Command::StepSimulation { steps, .. }) => *steps,
                    _ => 0,
                };
                // Whether its frames show contacts: read off the chain only while a viewer watches.
                let contacts = crate::seeing::viewer::live::watched(sim.id()) && crate::seeing::viewer::past::contacts_asked_now(sim);
                let mut live = crate::seeing::viewer::live::Publisher::new(sim.id(), total, contacts);
                let out = sim.change_observed(tool, a, decided, limits, ctl, &mut |w| live.observe(w));
                // The in-process cost of the call, for measuring what MCP adds (benches/physics.rs).
                tracing::debug!(target: "physics_mcp::timing", tool, sim_change_ms = started.elapsed().as_secs_f64() * 1e3);
                out
            })
            .await?;
        T::try_from(out)
            .map(Json)
            .map_err(|_| format!("Internal error: {tool} gave a result of an unexpected kind"))
    }

    /// A state-changing call.
    async fn change<P: Params, T: TryFrom<Outcome>>(
        &self,
        tool: &'static str,
        args: Args,
        decide: impl FnOnce(P) -> Result<Command, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        self.change_with(tool, args, move |p, _| decide(p), |_| true).await
    }

    /// A state-changing call whose command is made from files the arguments name.
    async fn change_reading<P: Params, T: TryFrom<Outcome>>(
        &self,
        tool: &'static str,
        args: Args,
        decide: impl FnOnce(P, &mut Reader) -> Result<Command, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        self.change_with(tool, args, decide, |_| true).await
    }

    /// A read-only call that may take long (history pages, verification): always on the
    /// blocking pool. The arguments are parsed as `P`; a refusal is recorded.
    async fn read_blocking<P: Params, T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&Sim, P) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        let budget = self.reg.limits().max_reply_bytes;
        self.with_sim(tool, args, move |sim, a, _| sim.read_within(tool, a, budget, |s| f(s, params::parse::<P>(tool, a)?)))
            .await
            .map(Json)
    }

    /// `read_blocking` of a read whose reply is built from its answer (`Replied`): measured
    /// as it will be sent before the read is logged, then sent as measured.
    async fn read_blocking_replied<P: Params, T: Replied>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&Sim, P) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<CallToolResult, String> {
        let budget = self.reg.limits().max_reply_bytes;
        let measure = move |t: &T, _: &str| crate::sim::budget::bytes_of(&t.reply(tool));
        let out = self
            .with_sim(tool, args, move |sim, a, _| sim.read_replying(tool, a, budget, |s| f(s, params::parse::<P>(tool, a)?), measure))
            .await?;
        Ok(out.reply(tool))
    }

    /// The simulation `id`: in a cluster, found (or taken over) on the blocking pool, since
    /// that may wait on the cluster; embedded, here.
    pub(crate) async fn sim(&self, id: &str) -> Result<crate::sim::SharedSim, String> {
        if !self.reg.in_cluster() {
            return self.reg.get(id);
        }
        let (reg, id) = (self.reg.clone(), id.to_string());
        tokio::task::spawn_blocking(move || reg.get(&id))
            .await
            .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?
    }

    /// A read-only call on a simulation; recorded as a read event. Reads take microseconds,
    /// so when the simulation is idle they run right here instead of on the blocking pool;
    /// when a long call holds it, they wait on the pool like everything else.
    async fn read<P: Params, T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&Sim, P) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<Json<T>, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.sim(&id).await?;
        // In a cluster a read's buffered events are published when many wait: never on the
        // async worker. Only when nobody holds or waits for the simulation: a read does not
        // jump the queue.
        if !self.reg.in_cluster() {
            if let Some(turn) = self.reg.queues().try_turn(&id, tool) {
                if let Ok(mut guard) = sim.try_lock() {
                    let budget = self.reg.limits().max_reply_bytes;
                    let out = guard.read_within(tool, &args, budget, |s| f(s, params::parse::<P>(tool, &args)?)).map(Json);
                    drop(guard);
                    drop(turn);
                    return out;
                }
            }
        }
        self.read_blocking(tool, args, f).await
    }
}

// rmcp marks MCP logging and resources/subscribe deprecated (SEP-2577, 2026-07-28); clients
// of 2025-11-25 and before still use them, so this server keeps serving them.
#[allow(deprecated)]
#[tool_handler(router = self.tool_router)]
impl ServerHandler for PhysicsServer {
    fn get_info(&self) -> ServerConfig {
        // MCP Apps (SEP-1865): the viewer app, for hosts that show apps.
        let ui = serde_json::Map::from_iter([("mimeTypes".to_string(), json!([crate::seeing::viewer::app::APP_MIME]))]);
        let extensions = std::collections::BTreeMap::from([(crate::seeing::viewer::app::UI_EXTENSION.to_string(), ui)]);
        let capabilities = ServerCapabilities::builder()
            .enable_extensions_with(extensions)
            .enable_logging()
            .enable_tools()
            .enable_resources()
            .enable_resources_list_changed()
            .enable_resources_subscribe()
            .enable_prompts()
            .build();
        ServerConfig::new(capabilities)
            .with_server_info(Implementation::new("physics-mcp", env!("CARGO_PKG_VERSION")))
            .with_instructions(instructions::INSTRUCTIONS)
    }

    /// tools/list: the tools, and for a client that announced MCP Apps
    /// (`io.modelcontextprotocol/ui`) the viewer app linked from the tools worth looking at.
    /// Other clients get exactly the list they always had.
    async fn list_tools(
        &self,
        _request: Option<PaginatedRequestParams>,
        cx: RequestContext<RoleServer>,
    ) -> Result<rmcp::model::ListToolsResult, ErrorData> {
        use crate::seeing::viewer::app;
        let supports_cache_hints = cx.protocol_version().is_some_and(|v| v >= rmcp::model::ProtocolVersion::V_2026_07_28);
        let shows_apps = cx
            .peer
            .peer_info()
            .and_then(|info| info.capabilities.extensions.as_ref().map(|e| e.contains_key(app::UI_EXTENSION)))
            .unwrap_or(false);
        let mut tools = self.tool_router.list_all();
        if shows_apps {
            for tool in tools.iter_mut().filter(|t| app::LINKED_TOOLS.contains(&t.name.as_ref())) {
                tool.meta = Some(app::tool_meta());
            }
        }
        Ok(rmcp::model::ListToolsResult {
            result_type: Some(rmcp::model::ResultType::COMPLETE),
            tools,
            meta: None,
            next_cursor: None,
            ttl_ms: supports_cache_hints.then_some(0),
            // The list depends on what this client announced.
            cache_scope: supports_cache_hints.then_some(rmcp::model::CacheScope::Private),
        })
    }

    async fn on_initialized(&self, cx: NotificationContext<RoleServer>) {
        self.sessions.join(cx.peer);
    }

    /// Every tool call, through the router, then the reply budget (`reply::fit`); a refused
    /// call's sentence (the budget's own included) also goes to the session's log at `info`,
    /// and a snapshot stall of the simulation called at `warning`.
    /// One place sees every result as it goes out, so no tool can send a reply a client would
    /// drop or forget to log a refusal.
    async fn call_tool(
        &self,
        request: CallToolRequestParams,
        cx: RequestContext<RoleServer>,
    ) -> Result<CallToolResponse, ErrorData> {
        let peer = cx.peer.clone();
        let tool = request.name.clone();
        let sim_id = request.arguments.as_ref().and_then(|a| a.get("sim_id")).and_then(|v| v.as_str()).map(str::to_owned);
        let read_only = self.tool_router.map.get(tool.as_ref()).and_then(|r| r.attr.annotations.as_ref()).and_then(|a| a.read_only_hint) == Some(true);
        // Only a cluster node routes (embedded, the call runs here untouched).
        let answered = match sim_id.as_deref().filter(|_| self.routes()) {
            Some(id) => self.routed_call(id, request, cx).await?,
            None => self.tool_router.call(ToolCallContext::new(self, request, cx)).await?,
        };
        let response = match answered {
            CallToolResponse::Complete(r) => CallToolResponse::Complete(reply::fit(&tool, r, self.reg.limits().max_reply_bytes, read_only)),
            other => other,
        };
        if let CallToolResponse::Complete(result) = &response {
            if result.is_error == Some(true) {
                let why: Vec<&str> = result.content.iter().filter_map(|c| c.as_text().map(|t| t.text.as_str())).collect();
                self.log.send(&peer, LoggingLevel::Info, json!({"tool": tool, "refused": why.join(" ")}));
            }
        }
        if let Some(sim) = sim_id.as_deref().and_then(|id| self.reg.get_local(id)) {
            // A busy simulation keeps its stalls for a later call.
            let stalls = sim.try_lock().map(|mut s| s.take_stalls()).unwrap_or_default();
            for stall in stalls {
                self.log.send(&peer, LoggingLevel::Warning, json!({"tool": tool, "stall": stall}));
            }
        }
        Ok(response)
    }

    /// logging/setLevel: this session hears messages at `level` and above; the simulations
    /// skipped as damaged at start are told now (no session existed then).
    async fn set_level(&self, request: SetLevelRequestParams, cx: RequestContext<RoleServer>) -> Result<(), ErrorData> {
        self.log.set(request.level);
        for (id, why) in self.reg.damaged_at_start() {
            self.log.send(
                &cx.peer,
                LoggingLevel::Warning,
                json!({"simulation_id": id, "skipped_at_start": why}),
            );
        }
        Ok(())
    }

    /// resources/subscribe (sessions before 2026-07-28): updates of a `sim://` URI. Any URI
    /// is accepted — one naming no simulation (yet) just never changes, as the protocol's
    /// conformance suite expects of an unknown URI — within the session's bounds
    /// (`subscriptions::MAX_PER_SESSION`, `MAX_URI_BYTES`).
    async fn subscribe(&self, request: SubscribeRequestParams, cx: RequestContext<RoleServer>) -> Result<(), ErrorData> {
        self.sessions
            .subscriptions()
            .subscribe(self.session, cx.peer, request.uri)
            .map_err(|why| ErrorData::invalid_params(why, None))
    }

    /// resources/unsubscribe: no more updates of that URI for this session (unknown URIs
    /// are fine: the session is then simply not subscribed).
    async fn unsubscribe(&self, request: UnsubscribeRequestParams, _cx: RequestContext<RoleServer>) -> Result<(), ErrorData> {
        self.sessions.subscriptions().unsubscribe(self.session, &request.uri);
        Ok(())
    }

    /// subscriptions/listen (2026-07-28): list changes and `sim://` URI updates.
    fn accepted_subscription_filter(&self, requested: &SubscriptionFilter) -> Option<SubscriptionFilter> {
        Some(subscriptions::accepted_filter(requested))
    }

    /// Holds one listen stream open until the client cancels it, delivering its updates.
    async fn listen(&self, cx: SubscriptionContext) -> Result<(), ErrorData> {
        let subs = self.sessions.subscriptions();
        let n = subs.listen(self.session, cx.sink().clone()).map_err(|why| ErrorData::invalid_params(why, None))?;
        cx.cancelled().await;
        subs.stop_listening(n);
        Ok(())
    }

    async fn list_resources(
        &self,
        _request: Option<PaginatedRequestParams>,
        _cx: RequestContext<RoleServer>,
    ) -> Result<ListResourcesResult, ErrorData> {
        let me = self.clone();
        tokio::task::spawn_blocking(move || me.resource_list())
            .await
            .map_err(|_| ErrorData::internal_error("Internal error: could not list resources", None))
    }

    async fn list_resource_templates(
        &self,
        _request: Option<PaginatedRequestParams>,
        _cx: RequestContext<RoleServer>,
    ) -> Result<ListResourceTemplatesResult, ErrorData> {
        Ok(Self::resource_templates())
    }

    async fn read_resource(
        &self,
        request: ReadResourceRequestParams,
        _cx: RequestContext<RoleServer>,
    ) -> Result<ReadResourceResponse, ErrorData> {
        if let Some(id) = resources::sim_of_uri(&request.uri).filter(|_| self.routes()) {
            let params = serde_json::to_value(&request).unwrap_or_default();
            let out = routing::Outgoing { sim: &id, method: "resources/read", params, peer: None, ct: _cx.ct.clone() };
            match self.route(out).await {
                routing::Routed::Here => {}
                routing::Routed::Answered(answer) => {
                    return answer.and_then(|v| {
                        serde_json::from_value::<rmcp::model::ReadResourceResult>(v)
                            .map(Into::into)
                            .map_err(|e| ErrorData::internal_error(format!("Internal error: the owner's answer could not be read: {e}"), None))
                    });
                }
                routing::Routed::Lost(why) => return Err(ErrorData::internal_error(why, Some(json!({"uri": request.uri})))),
            }
        }
        self.read_sim_resource(request.uri, _cx.ct.clone()).await.map(Into::into)
    }

    async fn list_prompts(
        &self,
        _request: Option<PaginatedRequestParams>,
        _cx: RequestContext<RoleServer>,
    ) -> Result<ListPromptsResult, ErrorData> {
        Ok(prompts::list())
    }

    async fn get_prompt(
        &self,
        request: GetPromptRequestParams,
        _cx: RequestContext<RoleServer>,
    ) -> Result<GetPromptResponse, ErrorData> {
        prompts::get(&request.name, request.arguments.as_ref()).map(Into::into)
    }
}
