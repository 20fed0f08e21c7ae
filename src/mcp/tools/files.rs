//! Workspace file tools: write_file (a client's own URDF, MJCF or mesh, to load in the next
//! call — the one way a client of a remote server gets a file there) and list_files. Thin
//! adapters over the files layer; no simulation is involved, so nothing is logged.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::mcp::PhysicsServer;
use crate::outputs::{FileWritten, Files};
use crate::params::{self, ListFiles, WriteFile};

#[tool_router(router = files_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Write a workspace file (URDF, MJCF, mesh) to load next; at most 3 MB
    /// (--max-write-bytes); new unless overwrite.
    #[tool(input_schema = schema_for_type::<params::WriteFile>())]
    async fn write_file(&self, args: JsonObject) -> Result<Json<FileWritten>, String> {
        let (sandbox, max) = (self.reg.sandbox().clone(), self.reg.limits().max_write_bytes);
        tokio::task::spawn_blocking(move || {
            let p: WriteFile = params::parse("write_file", &args)?;
            crate::files::write::write_file(&sandbox, &p, max)
        })
        .await
        .map_err(|_| "Internal error: nothing was written".to_string())?
        .map(Json)
    }

    /// List workspace files and folders under path, recursively (links not followed; 256 at most).
    #[tool(input_schema = schema_for_type::<params::ListFiles>(), annotations(read_only_hint = true))]
    async fn list_files(&self, args: JsonObject) -> Result<Json<Files>, String> {
        let sandbox = self.reg.sandbox().clone();
        tokio::task::spawn_blocking(move || {
            let p: ListFiles = params::parse("list_files", &args)?;
            crate::files::listing::list(&sandbox, p.path.as_ref().map(|t| t.0.as_str()))
        })
        .await
        .map_err(|_| "Internal error: nothing was listed".to_string())?
        .map(Json)
    }
}
