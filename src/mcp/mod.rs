//! The MCP face of the server (rmcp): thin adapters from JSON arguments to `Command`s and
//! `Sim` calls, and from results to MCP tool results. No physics here.
//!
//! Every tool takes the raw argument object (so a wrong type is a clear `isError` result, not a
//! JSON-RPC failure, and the log keeps the arguments exactly as sent) and declares its input
//! schema from `params.rs` and its output schema from `outputs.rs`. Errors are one sentence
//! with `isError: true`; sim work runs on the blocking pool, one call at a time per simulation.

mod constraints;
mod objects;
mod params;
mod persistence;
mod robots;
mod sensing;
mod simulations;
mod timeline;
mod viewer;
pub mod transport;

use std::sync::Arc;

use rmcp::handler::server::router::tool::ToolRouter;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{Implementation, ServerCapabilities, ServerConfig};
use rmcp::{tool_handler, ServerHandler};
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::command::Command;
use crate::limits::Limits;
use crate::sim::{lock_sim, Registry, Sim};
use crate::value::{self, Args, Refusal};
use crate::world::StepControl;

/// Result type of every tool: structured output, or one sentence with `isError: true`.
pub type ToolResult<T> = Result<Json<T>, String>;

/// The MCP server: one instance per session, all sharing the registry.
#[derive(Clone)]
pub struct PhysicsServer {
    reg: Arc<Registry>,
    tool_router: ToolRouter<PhysicsServer>,
}

impl PhysicsServer {
    /// A server over `reg` with every tool routed.
    pub fn new(reg: Arc<Registry>) -> Self {
        Self {
            reg,
            tool_router: Self::simulation_router()
                + Self::object_router()
                + Self::timeline_router()
                + Self::persistence_router()
                + Self::robot_router()
                + Self::constraint_router()
                + Self::sensing_router()
                + Self::viewer_router(),
        }
    }

    /// The registry behind this server.
    pub fn registry(&self) -> &Arc<Registry> {
        &self.reg
    }

    /// Runs `f` on the simulation named by `sim_id`, on the blocking pool, holding its lock.
    async fn with_sim<T: Send + 'static>(
        &self,
        args: Args,
        f: impl FnOnce(&mut Sim, &Args, &Limits) -> Result<T, Refusal> + Send + 'static,
    ) -> Result<T, String> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.reg.get(&id)?;
        let reg = self.reg.clone();
        tokio::task::spawn_blocking(move || {
            let mut guard = lock_sim(&sim);
            f(&mut guard, &args, reg.limits())
        })
        .await
        .map_err(|_| "Internal error: the call failed and changed nothing".to_string())?
    }

    /// A state-changing call whose steps may be watched (progress) or stopped (cancel).
    async fn change_with<T: DeserializeOwned>(
        &self,
        tool: &'static str,
        args: Args,
        decide: impl FnOnce(&Args) -> Result<Command, Refusal> + Send + 'static,
        mut control: impl FnMut(u64) -> bool + Send + 'static,
    ) -> ToolResult<T> {
        let out = self
            .with_sim(args, move |sim, a, limits| {
                let ctl: StepControl = &mut control;
                #[allow(clippy::disallowed_methods)] // timing for the debug log; never enters the world
                let started = std::time::Instant::now();
                let out = sim.change(tool, a, decide(a), limits, ctl);
                // The in-process cost of the call, for measuring what MCP adds (benches/physics.rs).
                tracing::debug!(target: "physics_mcp::timing", tool, sim_change_ms = started.elapsed().as_secs_f64() * 1e3);
                out
            })
            .await?;
        serde_json::from_value(out)
            .map(Json)
            .map_err(|e| format!("Internal error: unexpected result shape: {e}"))
    }

    /// A state-changing call.
    async fn change<T: DeserializeOwned>(
        &self,
        tool: &'static str,
        args: Args,
        decide: impl FnOnce(&Args) -> Result<Command, Refusal> + Send + 'static,
    ) -> ToolResult<T> {
        self.change_with(tool, args, decide, |_| true).await
    }

    /// A read-only call that may take long (history pages, verification): always on the
    /// blocking pool.
    async fn read_blocking<T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&Sim, &Args) -> Result<T, Refusal> + Send + 'static,
    ) -> ToolResult<T> {
        self.with_sim(args, move |sim, a, _| sim.read(tool, a, |s| f(s, a)))
            .await
            .map(Json)
    }

    /// A read-only call on a simulation; recorded as a read event. Reads take microseconds,
    /// so when the simulation is idle they run right here instead of on the blocking pool;
    /// when a long call holds it, they wait on the pool like everything else.
    async fn read<T: Serialize + Send + 'static>(
        &self,
        tool: &'static str,
        args: Args,
        f: impl FnOnce(&Sim, &Args) -> Result<T, Refusal> + Send + 'static,
    ) -> ToolResult<T> {
        let id = value::string(&args, "sim_id")?;
        let sim = self.reg.get(&id)?;
        if let Ok(mut guard) = sim.try_lock() {
            return guard.read(tool, &args, |s| f(s, &args)).map(Json);
        }
        self.read_blocking(tool, args, f).await
    }
}

#[tool_handler(router = self.tool_router)]
impl ServerHandler for PhysicsServer {
    fn get_info(&self) -> ServerConfig {
        ServerConfig::new(ServerCapabilities::builder().enable_tools().build())
            .with_server_info(Implementation::new("physics-mcp", env!("CARGO_PKG_VERSION")))
            .with_instructions(
                "Deterministic rigid-body physics (rapier3d), z-up, SI units, quaternions \
                 [x, y, z, w]. Create a simulation, add bodies (mass 0 = static; there is no \
                 implicit ground), step it, read states. Every call is recorded in the \
                 simulation's event log.",
            )
    }
}
