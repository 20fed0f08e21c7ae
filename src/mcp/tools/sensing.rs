//! Sensing tools: rays, contacts, camera matrices and images; ray batches and images can go
//! to files (`output_path`) when they would not fit the reply budget.

use rmcp::handler::server::common::{schema_for_output, schema_for_type};
use rmcp::handler::server::wrapper::Json;
use rmcp::model::{CallToolResult, JsonObject};
use rmcp::{tool, tool_router};
use serde::Serialize;

use crate::params::lenient::int_or;
use crate::params::{self, CollisionPair, ProjectionMatrix as ProjectionParams, RayTest, RayTestBatch, SimRef, ViewMatrix as ViewParams, ViewMatrixYawPitch};
use crate::sim::budget;
use crate::mcp::{PhysicsServer, Replied};
use crate::files::npy;
use crate::outputs::{CameraImage, Contacts, ProjectionMatrix, RayBatch, RayHit, ViewMatrix};
use crate::sim::reads;
use crate::seeing::sensing::camera;
use crate::value::Refusal;
use crate::files::{write, Sandbox};

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
    /// First object hit from ray_from to ray_to (shapes containing ray_from skipped).
    #[tool(input_schema = schema_for_type::<params::RayTest>(), annotations(read_only_hint = true))]
    async fn ray_test(&self, args: JsonObject) -> Result<Json<RayHit>, String> {
        self.read("ray_test", args, |sim, p: RayTest| reads::ray_test(&sim.read_context(), &p)).await
    }

    /// Cast many rays; results in order. Over ~4,000 rays, give output_path.
    #[tool(
        input_schema = schema_for_type::<params::RayTestBatch>(),
        output_schema = schema_for_output::<RayBatch>(),
        annotations(read_only_hint = true)
    )]
    async fn ray_test_batch(&self, args: JsonObject) -> Result<CallToolResult, String> {
        let (max, budget) = (self.reg.limits().max_rays, self.reg.limits().max_reply_bytes);
        let sandbox = self.reg.sandbox().clone();
        self.read_blocking_replied("ray_test_batch", args, move |sim, p: RayTestBatch| {
            ray_batch_to(&sim.read_context(), &p, max, budget, &sandbox)
        })
        .await
    }

    /// Contact points of the last step (normal B to A; distance < 0: penetration).
    #[tool(input_schema = schema_for_type::<params::SimRef>(), annotations(read_only_hint = true))]
    async fn get_all_collisions(&self, args: JsonObject) -> Result<Json<Contacts>, String> {
        self.read("get_all_collisions", args, |sim, _: SimRef| reads::all_collisions(&sim.read_context())).await
    }

    /// Contact points of the last step between obj_a and obj_b.
    #[tool(input_schema = schema_for_type::<params::CollisionPair>(), annotations(read_only_hint = true))]
    async fn get_collisions_for_pair(&self, args: JsonObject) -> Result<Json<Contacts>, String> {
        self.read("get_collisions_for_pair", args, |sim, p: CollisionPair| {
            reads::collisions_for_pair(&sim.read_context(), &p)
        })
        .await
    }

    /// View matrix from eye, target and up.
    #[tool(input_schema = schema_for_type::<params::ViewMatrix>(), annotations(read_only_hint = true))]
    async fn compute_view_matrix(&self, args: JsonObject) -> Result<Json<ViewMatrix>, String> {
        params::parse("compute_view_matrix", &args).and_then(view_matrix).map(Json)
    }

    /// View matrix orbiting a target (roll 0).
    #[tool(input_schema = schema_for_type::<params::ViewMatrixYawPitch>(), annotations(read_only_hint = true))]
    async fn compute_view_matrix_from_yaw_pitch(&self, args: JsonObject) -> Result<Json<ViewMatrix>, String> {
        params::parse("compute_view_matrix_from_yaw_pitch", &args).and_then(view_matrix_from_yaw_pitch).map(Json)
    }

    /// Perspective projection matrix.
    #[tool(input_schema = schema_for_type::<params::ProjectionMatrix>(), annotations(read_only_hint = true))]
    async fn compute_projection_matrix(&self, args: JsonObject) -> Result<Json<ProjectionMatrix>, String> {
        params::parse("compute_projection_matrix", &args).and_then(projection_matrix).map(Json)
    }

    /// Render a PNG; also the visible objects and depth range.
    #[tool(
        input_schema = schema_for_type::<params::CameraImage>(),
        output_schema = schema_for_output::<CameraImage>(),
        annotations(read_only_hint = true)
    )]
    async fn get_camera_image(&self, args: JsonObject) -> Result<CallToolResult, String> {
        let (max, budget) = (self.reg.limits().max_image_px, self.reg.limits().max_reply_bytes);
        let sandbox = self.reg.sandbox().clone();
        self.read_blocking_replied("get_camera_image", args, move |sim, p| camera_image_to(&sim.read_context(), &p, max, budget, &sandbox))
            .await
    }
}

/// A ray batch as computed and recorded (the full results: what replay recomputes and
/// hashes), and the file they went to when output_path was given.
#[derive(Serialize)]
struct RaysOut {
    #[serde(flatten)]
    batch: RayBatch,
    #[serde(skip)]
    file: Option<String>,
}

impl Replied for RaysOut {
    /// The full batch, or with output_path a summary naming the file.
    fn reply(&self, tool: &str) -> CallToolResult {
        let structured = match &self.file {
            None => serde_json::to_value(&self.batch),
            Some(path) => {
                let hits = self.batch.results.iter().filter(|h| h.hit).count() as u64;
                let rays = Some(self.batch.results.len() as u64);
                serde_json::to_value(RayBatch { rays, hits: Some(hits), output_path: Some(path.clone()), results: Vec::new() })
            }
        };
        budget::reply(tool, structured.unwrap_or_default(), &[])
    }
}

/// ray_test_batch: refused before casting when the rays could not fit the reply budget
/// (`budget::RAY_BYTES_MAX` each) and no output_path is given; with one, the full results
/// are written there as JSON (never over an existing file).
fn ray_batch_to(cx: &reads::ReadContext, p: &RayTestBatch, max: usize, budget: usize, sandbox: &Sandbox) -> Result<RaysOut, Refusal> {
    let target = p.output_path.as_ref().map(|t| output_target(sandbox, &t.0, ".json")).transpose()?;
    let n = p.rays_from.0.len();
    if target.is_none() && n <= max && n == p.rays_to.0.len() {
        budget::check_bound("ray_test_batch", n as u64, budget::RAY_BYTES_MAX, budget)?;
    }
    let batch = reads::ray_test_batch(cx, p, max)?;
    let file = match target {
        Some(target) => {
            let bytes = serde_json::to_vec(&batch).map_err(|e| format!("Internal error: {e}"))?;
            write::create_new(sandbox, &target, "output_path", &sandbox.shown(&target), &bytes)?;
            Some(sandbox.shown(&target))
        }
        None => None,
    };
    Ok(RaysOut { batch, file })
}

/// The files get_camera_image wrote with output_path: (png, depth, segmentation).
type CameraFiles = (String, Option<String>, Option<String>);

/// A rendered image as recorded (the full structured result: what replay recomputes and
/// hashes), and the files it went to when output_path was given.
#[derive(Serialize)]
struct CameraOut {
    #[serde(flatten)]
    rendered: reads::Rendered,
    #[serde(skip)]
    files: Option<CameraFiles>,
}

impl Replied for CameraOut {
    /// The PNG inline beside the full result, or with output_path the summary with the files'
    /// paths instead of the arrays.
    fn reply(&self, tool: &str) -> CallToolResult {
        let mut s = self.rendered.summary.clone();
        let mut images = Vec::new();
        match &self.files {
            Some((png, depth, seg)) => {
                (s.depth, s.segmentation) = (None, None);
                (s.png_path, s.depth_path, s.segmentation_path) = (Some(png.clone()), depth.clone(), seg.clone());
            }
            None => images.push(budget::Image { bytes: &self.rendered.png, mime: "image/png" }),
        }
        budget::reply(tool, serde_json::to_value(s).unwrap_or_default(), &images)
    }
}

/// get_camera_image: refused before rendering when the requested depth and segmentation
/// arrays could not fit the reply budget and no output_path is given; with one, the PNG and
/// the arrays (`.npy`) are written beside each other, none over an existing file.
fn camera_image_to(cx: &reads::ReadContext, p: &params::CameraImage, max_px: usize, budget: usize, sandbox: &Sandbox) -> Result<CameraOut, Refusal> {
    let depth = p.include_depth.as_ref().is_some_and(|b| b.0);
    let seg = p.include_segmentation.as_ref().is_some_and(|b| b.0);
    let targets = match &p.output_path {
        Some(t) => {
            let png = output_target(sandbox, &t.0, ".png")?;
            let stem = &t.0[..t.0.len() - ".png".len()];
            let depth = depth.then(|| output_target(sandbox, &format!("{stem}.depth.npy"), ".npy")).transpose()?;
            let seg = seg.then(|| output_target(sandbox, &format!("{stem}.seg.npy"), ".npy")).transpose()?;
            Some((png, depth, seg))
        }
        None => {
            let px = (p.width.get().max(0) as u64).saturating_mul(p.height.get().max(0) as u64);
            let per_px = usize::from(depth) * budget::DEPTH_BYTES_MAX + usize::from(seg) * budget::SEGMENT_BYTES_MAX;
            if px <= max_px as u64 {
                budget::check_bound("get_camera_image", px, per_px, budget)?;
            }
            None
        }
    };
    let rendered = reads::camera_image(cx, p, max_px)?;
    let Some((png, depth_at, seg_at)) = targets else {
        return Ok(CameraOut { rendered, files: None });
    };
    let (w, h) = (rendered.summary.width as usize, rendered.summary.height as usize);
    let show = |p: &std::path::Path| sandbox.shown(p);
    let depth = match (&depth_at, &rendered.summary.depth) {
        (Some(at), Some(d)) => Some((at, npy::encode(h, w, &d.iter().map(|v| *v as f32).collect::<Vec<f32>>()))),
        _ => None,
    };
    let seg = match (&seg_at, &rendered.summary.segmentation) {
        (Some(at), Some(s)) => Some((at, npy::encode(h, w, &s.iter().map(|v| i32::try_from(*v).unwrap_or(i32::MAX)).collect::<Vec<i32>>()))),
        _ => None,
    };
    // The arrays first and the PNG last, all or none: a PNG present means its arrays are too.
    let mut files: Vec<(&std::path::Path, &[u8])> = Vec::new();
    files.extend(depth.iter().map(|(at, bytes)| (at.as_path(), bytes.as_slice())));
    files.extend(seg.iter().map(|(at, bytes)| (at.as_path(), bytes.as_slice())));
    files.push((png.as_path(), rendered.png.as_slice()));
    write::create_new_all(sandbox, "output_path", &files)?;
    let (depth_file, seg_file) = (depth.map(|(at, _)| show(at)), seg.map(|(at, _)| show(at)));
    Ok(CameraOut { rendered, files: Some((show(&png), depth_file, seg_file)) })
}

/// A new output file in the workspace for parameter output_path, which must end in `ext`.
fn output_target(sandbox: &Sandbox, user: &str, ext: &str) -> Result<std::path::PathBuf, Refusal> {
    if !user.to_ascii_lowercase().ends_with(ext) || user.len() <= ext.len() {
        return Err(format!("output_path must name a {ext} file; got {user}"));
    }
    write::new_output(sandbox, "output_path", user)
}
