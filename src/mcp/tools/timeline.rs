//! Time-machine tools: undo, redo, get_history, fork_simulation, verify_simulation.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::lenient::{int_or, Int};
use crate::params::{self, Count, Fork, HistoryPage, SimRef};
use crate::mcp::PhysicsServer;
use crate::outputs::{Forked, History, Redone, Undone, Verified};
use crate::sim::timeline::HISTORY_MAX_LIMIT;
use crate::value::Refusal;

/// `count` for undo/redo: an integer ≥ 1 (range against what is available is the sim's check).
fn count(p: Count) -> Result<u64, Refusal> {
    let n = int_or(p.count, 1);
    u64::try_from(n)
        .ok()
        .filter(|n| *n >= 1)
        .ok_or_else(|| format!("count must be an integer >= 1; got {n}"))
}

/// A history page that fits the reply budget: the most events, in order, whose reply (as
/// `reply::fit` will send it) fits, with `truncated` set when some were left for the next page.
/// Each event is small — arguments over 64 KB are shown as a blob reference — so at least one
/// always fits the default budget; if not, the reply check refuses it with a sentence.
fn within_budget(mut h: History, budget: usize) -> History {
    let n = h.events.len();
    let events: Vec<serde_json::Value> = h.events.iter().map(|e| serde_json::to_value(e).unwrap_or_default()).collect();
    let fits = |k: usize| {
        let mut page = serde_json::to_value(History { events: Vec::new(), head_seq: h.head_seq, last_seq: h.last_seq, truncated: k < n })
            .unwrap_or_default();
        page["events"] = serde_json::Value::Array(events[..k].to_vec());
        crate::sim::budget::reply_bytes("get_history", page) <= budget
    };
    if n == 0 || fits(n) {
        return h;
    }
    // The largest k in [1, n) that fits (fitting is monotone in k): binary search.
    let (mut lo, mut hi) = (1, n - 1);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    h.events.truncate(lo);
    h.truncated = true;
    h
}

/// An event seq parameter: an integer ≥ 0.
fn seq(name: &str, v: Option<Int<u64>>) -> Result<Option<u64>, Refusal> {
    v.map(|n| u64::try_from(n.get()).map_err(|_| format!("{name} must be an event seq (integer >= 0); got {}", n.get())))
        .transpose()
}

#[tool_router(router = timeline_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Undo the last count state-changing calls exactly (ids too); reads skipped.
    #[tool(input_schema = schema_for_type::<params::Count>())]
    async fn undo(&self, args: JsonObject) -> Result<Json<Undone>, String> {
        self.with_sim("undo", args, |sim, a, limits| match params::parse("undo", a).and_then(count) {
            Ok(n) => sim.undo_within(a, n, limits.max_reply_bytes),
            Err(why) => Err(sim.refuse("undo", a, why)),
        })
        .await
        .map(Json)
    }

    /// Redo the count most recently undone calls.
    #[tool(input_schema = schema_for_type::<params::Count>())]
    async fn redo(&self, args: JsonObject) -> Result<Json<Redone>, String> {
        self.with_sim("redo", args, |sim, a, limits| match params::parse("redo", a).and_then(count) {
            Ok(n) => sim.redo_within(a, n, limits.max_reply_bytes),
            Err(why) => Err(sim.refuse("redo", a, why)),
        })
        .await
        .map(Json)
    }

    /// All calls, reads and refusals too, paged.
    #[tool(
        input_schema = schema_for_type::<params::HistoryPage>(),
        annotations(read_only_hint = true)
    )]
    async fn get_history(&self, args: JsonObject) -> Result<Json<History>, String> {
        let budget = self.reg.limits().max_reply_bytes;
        self.read_blocking("get_history", args, move |sim, p: HistoryPage| {
            let since = seq("since_seq", p.since_seq)?.unwrap_or(0);
            let limit = int_or(p.limit, 50);
            if !(1..=HISTORY_MAX_LIMIT as i64).contains(&limit) {
                return Err(format!("limit must be an integer from 1 to {HISTORY_MAX_LIMIT}; got {limit}"));
            }
            let full = crate::params::lenient::full_detail(p.detail.as_ref())?;
            sim.history(since, limit as usize, full).map(|h| within_budget(h, budget))
        })
        .await
    }

    /// New simulation from an event (default: now), inheriting its history.
    #[tool(input_schema = schema_for_type::<params::Fork>())]
    async fn fork_simulation(&self, args: JsonObject) -> Result<Json<Forked>, String> {
        let p: Fork = params::parse("fork_simulation", &args)?;
        let (parent, at, name) = (p.sim_id.0, seq("at_seq", p.at_seq)?, crate::params::lenient::label(p.name)?);
        let new_id = uuid::Uuid::new_v4().to_string();
        let reg = self.reg.clone();
        self.sim(&parent).await?;
        let turn = self.turn(&parent, "fork_simulation").await?;
        let out = tokio::task::spawn_blocking(move || {
            let _turn = turn;
            reg.fork(&parent, at, (new_id, name), &args)
        })
            .await
            .map_err(|_| "Internal error: the fork was not created".to_string())?
            .map(|mut forked| {
                forked.viewer_url = self.viewer_url(&forked.simulation_id);
                Json(forked)
            });
        self.simulations_changed(out)
    }

    /// Refold the history, checking every hash; reports the first divergence.
    #[tool(
        input_schema = schema_for_type::<params::SimRef>(),
        annotations(read_only_hint = true)
    )]
    async fn verify_simulation(&self, args: JsonObject) -> Result<Json<Verified>, String> {
        self.read_blocking("verify_simulation", args, |sim, _: SimRef| sim.verify()).await
    }
}
