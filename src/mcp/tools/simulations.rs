//! Simulation management tools: create, list, destroy, step, set_timestep, info.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{JsonObject, RequestMetaObject};
use rmcp::{tool, tool_router, Peer, RoleServer};
use tokio_util::sync::CancellationToken;

use crate::params::lenient::int_or;
use crate::params::{self, CreateSimulation, NoParams, SetTimestep, SimRef, Step};
use crate::mcp::PhysicsServer;
use crate::command::Command;
use crate::outputs::{Created, Message, SimulationInfo, SimulationList, Stepped, TimestepSet};
use crate::sim::reads;
use crate::value::Refusal;

pub(super) fn decide_step(p: &Step) -> Result<Command, Refusal> {
    let steps = int_or(p.steps, 1);
    let steps = u64::try_from(steps)
        .ok()
        .filter(|s| *s > 0)
        .ok_or_else(|| format!("steps must be an integer >= 1; got {steps}"))?;
    // An empty list asks nothing: the step is a plain one.
    let measure = p.measure.as_ref().map(|m| m.0.clone()).filter(|m| !m.is_empty());
    Ok(Command::StepSimulation { steps, measure })
}

pub(super) fn decide_timestep(p: SetTimestep) -> Result<Command, Refusal> {
    let (timestep, given) = p.timestep.0;
    Ok(Command::SetTimestep { timestep, timestep_given: Some(given) })
}

#[tool_router(router = simulation_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Create an empty simulation (no ground: add a static box or plane.urdf).
    #[tool(input_schema = schema_for_type::<params::CreateSimulation>())]
    async fn create_simulation(&self, args: JsonObject) -> Result<Json<Created>, String> {
        let p: CreateSimulation = params::parse("create_simulation", &args)?;
        let gravity = p.gravity.map_or([0.0, 0.0, -9.81], |g| g.0);
        let gui = p.gui.is_some_and(|g| g.0);
        let name = params::lenient::label(p.name)?;
        let simulation_id = uuid::Uuid::new_v4().to_string();
        let root = Command::CreateSimulation {
            simulation_id,
            gravity,
            gui,
            name,
            engine_rule: Some(crate::engine::ENGINE_RULE),
        };
        let reg = self.reg.clone();
        let out = tokio::task::spawn_blocking(move || reg.create(root, &args))
            .await
            .map_err(|_| "Internal error: the simulation was not created".to_string())??;
        let mut created = Created::try_from(out)
            .map_err(|_| "Internal error: create_simulation gave a result of an unexpected kind".to_string())?;
        created.viewer_url = self.viewer_url(&created.simulation_id);
        self.simulations_changed(Ok(Json(created)))
    }

    /// Live simulations.
    #[tool(
        input_schema = schema_for_type::<params::NoParams>(),
        annotations(read_only_hint = true)
    )]
    async fn list_simulations(&self, args: JsonObject) -> Result<Json<SimulationList>, String> {
        let _: NoParams = params::parse("list_simulations", &args)?;
        let reg = self.reg.clone();
        tokio::task::spawn_blocking(move || reg.list())
            .await
            .map(Json)
            .map_err(|_| "Internal error: could not list simulations".to_string())
    }

    /// Destroy a simulation and delete its log (cannot be undone).
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(destructive_hint = true)
    )]
    async fn destroy_simulation(&self, args: JsonObject) -> Result<Json<Message>, String> {
        let id = params::parse::<SimRef>("destroy_simulation", &args)?.sim_id.0;
        let reg = self.reg.clone();
        self.sim(&id).await?;
        let turn = self.turn(&id, "destroy_simulation").await?;
        let out = tokio::task::spawn_blocking(move || {
            let _turn = turn;
            reg.destroy(&id)
        })
            .await
            .map_err(|_| "Internal error: the simulation was not destroyed".to_string())?
            .map(Json);
        self.simulations_changed(out)
    }

    /// Advance by steps timesteps; measures, samples: docs/tools.md.
    #[tool(input_schema = schema_for_type::<params::Step>())]
    async fn step_simulation(
        &self,
        args: JsonObject,
        meta: RequestMetaObject,
        peer: Peer<RoleServer>,
        ct: CancellationToken,
    ) -> Result<Json<Stepped>, String> {
        // For progress only: a refusal of the arguments is the step's own (below).
        let total = params::parse::<Step>("step_simulation", &args).map_or(1, |p| int_or(p.steps, 1).max(1) as u64);
        let watch = crate::mcp::progress::Watch::new(&meta, peer, ct, total);
        let control = watch.control();
        let sampling = params::parse::<Step>("step_simulation", &args).map(|p| super::trajectory::step_sampling(&p));
        let out = match sampling {
            Ok(Ok(None)) => self.change_with("step_simulation", args, |p: Step, _| decide_step(&p), control).await,
            _ => self.sampled_step(args, control).await,
        };
        watch.finish().await;
        out
    }

    /// Set the fixed timestep.
    #[tool(input_schema = schema_for_type::<params::SetTimestep>())]
    async fn set_timestep(&self, args: JsonObject) -> Result<Json<TimestepSet>, String> {
        self.change("set_timestep", args, decide_timestep).await
    }

    /// Gravity, timestep, time, steps, objects, constraints, head, state hash.
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(read_only_hint = true)
    )]
    async fn get_simulation_info(&self, args: JsonObject) -> Result<Json<SimulationInfo>, String> {
        self.read("get_simulation_info", args, |sim, _: SimRef| reads::simulation_info(&sim.read_context()))
        .await
    }
}
