//! The MCP surface: protocol revisions and stateless requests, the `call` client, sessions and
//! their bound, broken clients, subscriptions and resources, output schemas, the context cost
//! of tools/list, progress and cancellation, and the one parameter model.

#[path = "../common/mod.rs"]
mod common;

mod broken_clients;
mod cli_call;
mod context_cost;
mod mcp_app;
mod output_schemas;
mod next_steps;
mod params;
mod resources;
mod revisions;
mod session_limit;
mod step_progress;
mod subscriptions;
