//! Time-machine tools: undo, redo, get_history, fork_simulation, verify_simulation.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use super::lenient::{int_or, Int};
use super::params::{self, Count, Fork, HistoryPage, SimRef};
use super::PhysicsServer;
use crate::outputs::{Forked, History, Redone, Undone, Verified};
use crate::timeline::HISTORY_MAX_LIMIT;
use crate::value::Refusal;

/// `count` for undo/redo: an integer ≥ 1 (range against what is available is the sim's check).
fn count(p: Count) -> Result<u64, Refusal> {
    let n = int_or(p.count, 1);
    u64::try_from(n)
        .ok()
        .filter(|n| *n >= 1)
        .ok_or_else(|| format!("count must be an integer >= 1; got {n}"))
}

/// An event seq parameter: an integer ≥ 0.
fn seq(name: &str, v: Option<Int<u64>>) -> Result<Option<u64>, Refusal> {
    v.map(|n| u64::try_from(n.get()).map_err(|_| format!("{name} must be an event seq (integer >= 0); got {}", n.get())))
        .transpose()
}

#[tool_router(router = timeline_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Undo the last `count` state-changing calls (default 1): the world returns exactly to
    /// the state before them (ids, time and all). Read-only calls are skipped. Redo reverses
    /// it until a new state-changing call starts a new branch.
    #[tool(input_schema = schema_for_type::<params::Count>())]
    async fn undo(&self, args: JsonObject) -> Result<Json<Undone>, String> {
        self.with_sim(args, |sim, a, _| match params::parse("undo", a).and_then(count) {
            Ok(n) => sim.undo(a, n),
            Err(why) => Err(sim.refuse("undo", a, why)),
        })
        .await
        .map(Json)
    }

    /// Redo the `count` most recently undone calls (default 1), bit for bit.
    #[tool(input_schema = schema_for_type::<params::Count>())]
    async fn redo(&self, args: JsonObject) -> Result<Json<Redone>, String> {
        self.with_sim(args, |sim, a, _| match params::parse("redo", a).and_then(count) {
            Ok(n) => sim.redo(a, n),
            Err(why) => Err(sim.refuse("redo", a, why)),
        })
        .await
        .map(Json)
    }

    /// Page through the simulation's event log: every call on it (reads and refusals too),
    /// with arguments, kind, parent and state hash. Returns events with seq > since_seq.
    #[tool(
        input_schema = schema_for_type::<params::HistoryPage>(),
        annotations(read_only_hint = true)
    )]
    async fn get_history(&self, args: JsonObject) -> Result<Json<History>, String> {
        self.read_blocking("get_history", args, |sim, p: HistoryPage| {
            let since = seq("since_seq", p.since_seq)?.unwrap_or(0);
            let limit = int_or(p.limit, 50);
            if !(1..=HISTORY_MAX_LIMIT as i64).contains(&limit) {
                return Err(format!("limit must be an integer from 1 to {HISTORY_MAX_LIMIT}; got {limit}"));
            }
            sim.history(since, limit as usize)
        })
        .await
    }

    /// Fork a simulation at one of its state-changing events (default: now) into a new,
    /// independent simulation that inherits its history and evolves bit for bit alike.
    #[tool(input_schema = schema_for_type::<params::Fork>())]
    async fn fork_simulation(&self, args: JsonObject) -> Result<Json<Forked>, String> {
        let p: Fork = params::parse("fork_simulation", &args)?;
        let (parent, at) = (p.sim_id.0, seq("at_seq", p.at_seq)?);
        let new_id = uuid::Uuid::new_v4().to_string();
        let reg = self.reg.clone();
        let out = tokio::task::spawn_blocking(move || reg.fork(&parent, at, new_id, &args))
            .await
            .map_err(|_| "Internal error: the fork was not created".to_string())?
            .map(|mut forked| {
                forked.viewer_url = self.viewer_url(&forked.simulation_id);
                Json(forked)
            });
        self.simulations_changed(out)
    }

    /// Refold the simulation's history in a fresh world and check every recorded state hash
    /// and snapshot; reports the first divergence, if any.
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(read_only_hint = true)
    )]
    async fn verify_simulation(&self, args: JsonObject) -> Result<Json<Verified>, String> {
        self.read_blocking("verify_simulation", args, |sim, _: SimRef| sim.verify()).await
    }
}
