//! Persistence tools: save_simulation, load_simulation.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{JsonObject, ProgressNotificationParam, RequestMetaObject};
use rmcp::{tool, tool_router, Peer, RoleServer};

use crate::mcp::PhysicsServer;
use crate::params;
use crate::outputs::{Loaded, Saved};

#[tool_router(router = persistence_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Save with full history to a workspace JSON file.
    #[tool(input_schema = schema_for_type::<params::Save>())]
    async fn save_simulation(&self, args: JsonObject) -> Result<Json<Saved>, String> {
        let reg = self.reg.clone();
        self.with_sim("save_simulation", args, move |sim, a, _| sim.save(a, &reg)).await.map(Json)
    }

    /// Load a saved JSON file (ours or the PyBullet server's) as a new simulation.
    #[tool(input_schema = schema_for_type::<params::Load>())]
    async fn load_simulation(
        &self,
        args: JsonObject,
        meta: RequestMetaObject,
        peer: Peer<RoleServer>,
    ) -> Result<Json<Loaded>, String> {
        let new_id = uuid::Uuid::new_v4().to_string();
        let reg = self.reg.clone();
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(u64, u64)>();
        let forward = meta.get_progress_token().map(|token| {
            tokio::spawn(async move {
                while let Some((done, total)) = rx.recv().await {
                    let note = ProgressNotificationParam::new(token.clone(), done as f64).with_total(total as f64);
                    let _ = peer.notify_progress(note).await;
                }
            })
        });
        let out = tokio::task::spawn_blocking(move || {
            let mut last = 0;
            reg.load(&args, new_id, &mut |done, total| {
                if done == total || done - last >= (total / 100).max(1) {
                    last = done;
                    let _ = tx.send((done, total));
                }
            })
        })
        .await
        .map_err(|_| "Internal error: nothing was loaded".to_string())?;
        if let Some(f) = forward {
            let _ = f.await;
        }
        let out = out.map(|mut loaded| {
            loaded.viewer_url = self.viewer_url(&loaded.simulation_id);
            Json(loaded)
        });
        self.simulations_changed(out)
    }
}
