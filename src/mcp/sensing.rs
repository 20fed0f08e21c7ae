//! Sensing tools: rays, contacts, camera matrices and images.

use base64::Engine;
use rmcp::handler::server::common::{schema_for_output, schema_for_type};
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{CallToolResult, ContentBlock, JsonObject};
use rmcp::{tool, tool_router};

use super::lenient::int_or;
use super::params::{self, CollisionPair, ProjectionMatrix as ProjectionParams, RayTest, RayTestBatch, SimRef, ViewMatrix as ViewParams, ViewMatrixYawPitch};
use super::PhysicsServer;
use crate::outputs::{CameraImage, Contacts, ProjectionMatrix, RayBatch, RayHit, ViewMatrix};
use crate::reads;
use crate::sensing::camera;
use crate::value::Refusal;

fn view_matrix(p: ViewParams) -> Result<ViewMatrix, Refusal> {
    let (eye, target, up) = (p.camera_eye_position.0, p.camera_target_position.0, p.camera_up_vector.0);
    if let Some(why) = camera::view_problem(eye, target, up) {
        return Err(why.to_string());
    }
    Ok(ViewMatrix { view_matrix: camera::view_matrix(eye, target, up).to_vec() })
}

fn view_matrix_from_yaw_pitch(p: ViewMatrixYawPitch) -> Result<ViewMatrix, Refusal> {
    let (distance, yaw, pitch) = (p.distance.0, p.yaw.0, p.pitch.0);
    let up = int_or(p.up_axis_index, 2);
    if up != 1 && up != 2 {
        return Err(format!("up_axis_index must be 1 (y up) or 2 (z up); got {up}"));
    }
    if p.roll.is_some_and(|r| r.0 != 0.0) {
        return Err("roll must be 0 (compute_view_matrix_from_yaw_pitch has no roll)".into());
    }
    Ok(ViewMatrix { view_matrix: camera::view_matrix_from_yaw_pitch(p.target_position.0, distance, yaw, pitch, up as u8).to_vec() })
}

fn projection_matrix(p: ProjectionParams) -> Result<ProjectionMatrix, Refusal> {
    let fov = p.fov.0;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("fov must be in (0, 180) degrees; got {fov}"));
    }
    let aspect = p.aspect.0;
    if aspect <= 0.0 {
        return Err(format!("aspect must be > 0; got {aspect}"));
    }
    let near = p.near_plane.0;
    if near <= 0.0 {
        return Err(format!("near_plane must be > 0; got {near}"));
    }
    let far = p.far_plane.0;
    if far <= near {
        return Err(format!("far_plane must be greater than near_plane ({near}); got {far}"));
    }
    Ok(ProjectionMatrix { projection_matrix: camera::projection_matrix(fov, aspect, near, far).to_vec() })
}

#[tool_router(router = sensing_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// Cast one ray: the first object it enters between ray_from and ray_to (a shape that
    /// contains ray_from is not reported). Sees poses as they are now.
    #[tool(input_schema = schema_for_type::<params::RayTest>(), annotations(read_only_hint = true))]
    async fn ray_test(&self, args: JsonObject) -> Result<Json<RayHit>, String> {
        self.read("ray_test", args, |sim, p: RayTest| reads::ray_test(&sim.read_context(), &p)).await
    }

    /// Cast many rays at once (at most --max-rays); results in the order given.
    #[tool(input_schema = schema_for_type::<params::RayTestBatch>(), annotations(read_only_hint = true))]
    async fn ray_test_batch(&self, args: JsonObject) -> Result<Json<RayBatch>, String> {
        let max = self.reg.limits().max_rays;
        self.read_blocking("ray_test_batch", args, move |sim, p: RayTestBatch| {
            reads::ray_test_batch(&sim.read_context(), &p, max)
        })
        .await
    }

    /// Every contact point of the last step: objects and links, points on A and B, normal
    /// from B to A, distance (negative = penetration) and normal force.
    #[tool(input_schema = schema_for_type::<params::SimRef>(), annotations(read_only_hint = true))]
    async fn get_all_collisions(&self, args: JsonObject) -> Result<Json<Contacts>, String> {
        self.read("get_all_collisions", args, |sim, _: SimRef| reads::all_collisions(&sim.read_context())).await
    }

    /// The contact points of the last step between two objects (A = obj_a).
    #[tool(input_schema = schema_for_type::<params::CollisionPair>(), annotations(read_only_hint = true))]
    async fn get_collisions_for_pair(&self, args: JsonObject) -> Result<Json<Contacts>, String> {
        self.read("get_collisions_for_pair", args, |sim, p: CollisionPair| {
            reads::collisions_for_pair(&sim.read_context(), &p)
        })
        .await
    }

    /// A view matrix from eye, target and up (PyBullet's computeViewMatrix; 16 floats,
    /// column-major).
    #[tool(input_schema = schema_for_type::<params::ViewMatrix>(), annotations(read_only_hint = true))]
    async fn compute_view_matrix(&self, args: JsonObject) -> Result<Json<ViewMatrix>, String> {
        params::parse("compute_view_matrix", &args).and_then(view_matrix).map(Json)
    }

    /// A view matrix orbiting a target (PyBullet's computeViewMatrixFromYawPitchRoll, roll 0).
    #[tool(input_schema = schema_for_type::<params::ViewMatrixYawPitch>(), annotations(read_only_hint = true))]
    async fn compute_view_matrix_from_yaw_pitch(&self, args: JsonObject) -> Result<Json<ViewMatrix>, String> {
        params::parse("compute_view_matrix_from_yaw_pitch", &args).and_then(view_matrix_from_yaw_pitch).map(Json)
    }

    /// A perspective projection matrix (PyBullet's computeProjectionMatrixFOV).
    #[tool(input_schema = schema_for_type::<params::ProjectionMatrix>(), annotations(read_only_hint = true))]
    async fn compute_projection_matrix(&self, args: JsonObject) -> Result<Json<ProjectionMatrix>, String> {
        params::parse("compute_projection_matrix", &args).and_then(projection_matrix).map(Json)
    }

    /// Render the simulation on the CPU: a PNG image plus which objects are visible and the
    /// depth range; full depth (metres along the view axis) and segmentation (object id per
    /// pixel) arrays only when asked.
    #[tool(
        input_schema = schema_for_type::<params::CameraImage>(),
        output_schema = schema_for_output::<CameraImage>(),
        annotations(read_only_hint = true)
    )]
    async fn get_camera_image(&self, args: JsonObject) -> Result<CallToolResult, String> {
        let max = self.reg.limits().max_image_px;
        let Json(rendered) = self
            .read_blocking("get_camera_image", args, move |sim, p| {
                reads::camera_image(&sim.read_context(), &p, max)
            })
            .await?;
        let summary = serde_json::to_value(&rendered.summary)
            .map_err(|e| format!("Internal error: unexpected result shape: {e}"))?;
        let png = base64::engine::general_purpose::STANDARD.encode(&rendered.png);
        let mut result = CallToolResult::structured(summary);
        result.content.insert(0, ContentBlock::image(png, "image/png"));
        Ok(result)
    }
}
