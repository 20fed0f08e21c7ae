//! Visualization tools: enable_debug_visualization and set_camera. There is no web viewer yet;
//! both are recorded state (hashed, undone, saved) and set_camera is the default camera of
//! get_camera_image.

use rmcp::handler::server::common::schema_for_type;
use rmcp::handler::server::wrapper::Json;
use rmcp::model::JsonObject;
use rmcp::{tool, tool_router};

use crate::params::{self, DebugVisualization, SetCamera};
use crate::mcp::PhysicsServer;
use crate::command::Command;
use crate::outputs::Message;
use crate::value::Refusal;

pub(super) fn decide_debug(p: DebugVisualization) -> Result<Command, Refusal> {
    Ok(Command::SetDebugVisualization {
        show_contacts: p.show_contacts.is_none_or(|b| b.0),
        show_frames: p.show_frames.is_some_and(|b| b.0),
    })
}

pub(super) fn decide_camera(p: SetCamera) -> Result<Command, Refusal> {
    Ok(Command::SetCamera {
        distance: p.distance.0,
        yaw: p.yaw.0,
        pitch: p.pitch.0,
        target: p.target.0,
    })
}

#[tool_router(router = viewer_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// What the viewer draws besides bodies.
    #[tool(input_schema = schema_for_type::<params::DebugVisualization>())]
    async fn enable_debug_visualization(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("enable_debug_visualization", args, decide_debug).await
    }

    /// Place the viewer camera, every picture's default.
    #[tool(input_schema = schema_for_type::<params::SetCamera>())]
    async fn set_camera(&self, args: JsonObject) -> Result<Json<Message>, String> {
        self.change("set_camera", args, decide_camera).await
    }
}
