//! Simulation management tools: create, list, destroy, step, set_timestep, info.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{JsonObject, ProgressNotificationParam, RequestMetaObject};
use rmcp::{tool, tool_router, Peer, RoleServer};
use tokio_util::sync::CancellationToken;

use super::{params, PhysicsServer};
use crate::command::Command;
use crate::outputs::{Created, Message, SimulationInfo, SimulationList, Stepped, TimestepSet};
use crate::reads;
use crate::value::{self, arg, Args, Refusal};

pub(super) fn decide_step(a: &Args) -> Result<Command, Refusal> {
    let steps = value::integer_or(a, "steps", 1)?;
    let steps = u64::try_from(steps)
        .ok()
        .filter(|s| *s > 0)
        .ok_or_else(|| format!("steps must be an integer >= 1; got {steps}"))?;
    Ok(Command::StepSimulation { steps })
}

fn decide_timestep(a: &Args) -> Result<Command, Refusal> {
    let v = value::required(a, "timestep", "a number of seconds > 0")?;
    let (timestep, given) = value::positive_given("timestep", v)?;
    Ok(Command::SetTimestep { timestep, timestep_given: Some(given) })
}

#[tool_router(router = simulation_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Create a new, empty physics simulation (no implicit ground: add a static box or
    /// load plane.urdf). Returns its id.
    #[tool(input_schema = schema_for_type::<params::CreateSimulation>())]
    async fn create_simulation(&self, args: JsonObject) -> Result<Json<Created>, String> {
        let gravity = match arg(&args, "gravity") {
            Some(g) => value::gravity("gravity", g)?,
            None => [0.0, 0.0, -9.81],
        };
        let gui = value::bool_or(&args, "gui", false)?;
        let simulation_id = uuid::Uuid::new_v4().to_string();
        let root = Command::CreateSimulation {
            simulation_id,
            gravity,
            gui,
        };
        let reg = self.reg.clone();
        let out = tokio::task::spawn_blocking(move || reg.create(root, &args))
            .await
            .map_err(|_| "Internal error: the simulation was not created".to_string())??;
        let mut created: Created = serde_json::from_value(out).map_err(|e| format!("Internal error: {e}"))?;
        created.viewer_url = self.viewer_url(&created.simulation_id);
        self.simulations_changed(Ok(Json(created)))
    }

    /// List the live simulations with their object counts and simulated time.
    #[tool(
        input_schema = schema_for_type::<params::NoParams>(),
        annotations(read_only_hint = true)
    )]
    async fn list_simulations(&self, _args: JsonObject) -> Result<Json<SimulationList>, String> {
        let reg = self.reg.clone();
        tokio::task::spawn_blocking(move || reg.list())
            .await
            .map(Json)
            .map_err(|_| "Internal error: could not list simulations".to_string())
    }

    /// Destroy a simulation and delete its log (this cannot be undone).
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(destructive_hint = true)
    )]
    async fn destroy_simulation(&self, args: JsonObject) -> Result<Json<Message>, String> {
        let id = value::string(&args, "sim_id")?;
        let reg = self.reg.clone();
        let out = tokio::task::spawn_blocking(move || reg.destroy(&id))
            .await
            .map_err(|_| "Internal error: the simulation was not destroyed".to_string())?
            .map(Json);
        self.simulations_changed(out)
    }

    /// Advance the simulation by `steps` fixed timesteps (default 1). Long runs send MCP
    /// progress notifications when the request has a progress token, and can be cancelled:
    /// the steps already taken stay applied and are what the log records.
    #[tool(input_schema = schema_for_type::<params::Step>())]
    async fn step_simulation(
        &self,
        args: JsonObject,
        meta: RequestMetaObject,
        peer: Peer<RoleServer>,
        ct: CancellationToken,
    ) -> Result<Json<Stepped>, String> {
        let total = value::integer_or(&args, "steps", 1).unwrap_or(1).max(1) as u64;
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<u64>();
        let forward = meta.get_progress_token().map(|token| {
            tokio::spawn(async move {
                while let Some(done) = rx.recv().await {
                    let note = ProgressNotificationParam::new(token.clone(), done as f64)
                        .with_total(total as f64);
                    let _ = peer.notify_progress(note).await;
                }
            })
        });
        let every = (total / 100).max(1);
        let mut last_sent = 0;
        let control = move |done| {
            if done - last_sent >= every {
                last_sent = done;
                let _ = tx.send(done);
            }
            !ct.is_cancelled()
        };
        let out = match super::time::step_sampling(&args) {
            Ok(None) => self.change_with("step_simulation", args, decide_step, control).await,
            _ => self.sampled_step(args, control).await,
        };
        if let Some(f) = forward {
            let _ = f.await;
        }
        out
    }

    /// Set the simulation's fixed timestep in seconds (PyBullet's default is 1/240).
    #[tool(input_schema = schema_for_type::<params::SetTimestep>())]
    async fn set_timestep(&self, args: JsonObject) -> Result<Json<TimestepSet>, String> {
        self.change("set_timestep", args, decide_timestep).await
    }

    /// Summarise a simulation: gravity, timestep, time, steps, objects, constraints, the
    /// head of its event log and its state hash.
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_simulation_info(&self, args: JsonObject) -> Result<Json<SimulationInfo>, String> {
        self.read("get_simulation_info", args, |sim, a| {
            reads::simulation_info(&sim.read_context(), a)
        })
        .await
    }
}
