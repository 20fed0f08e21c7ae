//! list_models: the built-in models load_urdf and load_mjcf find by name (`files::library`),
//! with what a load of each builds. The same list is the `models://builtin` resource.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::mcp::PhysicsServer;
use crate::outputs::Models;
use crate::params::{self, ListModels};

/// The URI of the built-in model list as a resource.
pub(crate) const MODELS_URI: &str = "models://builtin";

#[tool_router(router = models_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Built-in models to load by name (no file needed): name, format, joints, dofs, mass, base, licence.
    #[tool(input_schema = schema_for_type::<params::ListModels>(), annotations(read_only_hint = true))]
    async fn list_models(&self, args: JsonObject) -> Result<Json<Models>, String> {
        tokio::task::spawn_blocking(move || {
            let p: ListModels = params::parse("list_models", &args)?;
            crate::files::library::matching(p.filter.as_ref().map(|t| t.0.as_str())).map(|models| Models { models })
        })
        .await
        .map_err(|_| "Internal error: the models could not be listed".to_string())?
        .map(Json)
    }
}
