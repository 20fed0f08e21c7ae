//! render_animation: a looping GIF of any interval of a simulation's chain (docs/tools.md "Seeing
//! time"). Thin: the interval is lent by the log (`fold::lend`) under the simulation's lock,
//! re-simulated and rendered without it (`animation::animate`), and the call is then recorded
//! as a read (or a refusal). The live simulation is never changed.

use rmcp::handler::server::common::{schema_for_output, schema_for_type};
use rmcp::model::{CallToolResult, ContentBlock, JsonObject, Resource};
use rmcp::{tool, tool_router};
use schemars::JsonSchema;
use serde::Serialize;
use tokio_util::sync::CancellationToken;

use crate::outputs::CameraUsed;
use crate::params::lenient::{int_or, Int, Positive, Text};
use crate::seeing::framing;
use crate::seeing::overlay::Overlay;
use crate::params::{self, RenderAnimation};
use crate::mcp::PhysicsServer;
use crate::seeing::animation::{self, Camera, Pacing};
use crate::sim::budget;
use crate::command::Command;
use crate::log::fold::{Interval, Lent};
use crate::value::{Args, Refusal};
use crate::files::{write, Sandbox};

const TOOL: &str = "render_animation";

/// What render_animation returns beside the GIF.
#[derive(Serialize, JsonSchema, Debug)]
pub struct AnimationSummary {
    /// Frames in the GIF.
    pub frames: usize,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// The most frames per second shown, as asked (samples closer in playback are skipped).
    pub fps: u32,
    /// Playback speed (1: real time).
    pub speed: f64,
    /// Playing time of one loop (s): the simulated time shown / speed.
    pub duration_s: f64,
    /// Simulated time from the first frame to the last (s).
    pub simulated_s: f64,
    /// The camera every frame was taken with.
    pub camera: CameraUsed,
    /// Size of the GIF file in bytes.
    pub bytes: usize,
    /// The interval's first event.
    pub from_seq: u64,
    /// The interval's last event.
    pub to_seq: u64,
    /// Steps between frames.
    pub every: u64,
    /// Steps simulated over the interval.
    pub steps: u64,
    /// Where the GIF was written (with output_path).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output_path: Option<String>,
}

/// What the call asks for besides the interval.
struct Asked {
    every: Option<u64>,
    cam: Camera,
    pacing: Pacing,
    output: Option<(String, std::path::PathBuf)>,
}

/// An optional seq or count: an integer ≥ 0.
fn opt_u64(v: Option<Int<u64>>, name: &str) -> Result<Option<u64>, Refusal> {
    v.map(|n| u64::try_from(n.get()).map_err(|_| format!("{name} must be an integer >= 0; got {}", n.get()))).transpose()
}

/// `every` when given: an integer ≥ 1.
fn every(v: Option<Int<u64>>) -> Result<Option<u64>, Refusal> {
    v.map(|n| {
        u64::try_from(n.get())
            .ok()
            .filter(|n| *n >= 1)
            .ok_or_else(|| format!("every must be an integer >= 1 (steps between frames); got {}", n.get()))
    })
    .transpose()
}

/// A frame side: an integer ≥ 1 (default `default`).
fn side(v: Option<Int<u32>>, name: &str, default: u32) -> Result<u32, Refusal> {
    let v = int_or(v, i64::from(default));
    u32::try_from(v).ok().filter(|v| *v >= 1).ok_or_else(|| format!("{name} must be an integer >= 1; got {v}"))
}

/// The speed: from 0.01 to 100 (default 1).
fn speed(v: Option<Positive>) -> Result<f64, Refusal> {
    let s = v.map_or(1.0, |s| f64::from(s.0));
    if !(0.01..=100.0).contains(&s) {
        return Err(format!("speed must be a number from 0.01 to 100 (1 plays at real time); got {s}"));
    }
    Ok(s)
}

fn fps(v: Option<Int<u32>>) -> Result<u32, Refusal> {
    let v = int_or(v, 30);
    u32::try_from(v).ok().filter(|v| (1..=50).contains(v)).ok_or_else(|| format!("fps must be an integer from 1 to 50; got {v}"))
}

/// The .gif file `output_path` names: new, inside the workspace.
fn output(user: Option<Text>, sandbox: &Sandbox) -> Result<Option<(String, std::path::PathBuf)>, Refusal> {
    let Some(Text(user)) = user else { return Ok(None) };
    if !user.to_ascii_lowercase().ends_with(".gif") {
        return Err(format!("output_path must end in .gif; got {user}"));
    }
    let path = write::new_output(sandbox, "output_path", &user)?;
    Ok(Some((user, path)))
}

/// Parses the call: the interval asked for and the rest.
fn parse(a: &Args, sandbox: &Sandbox) -> Result<(super::trajectory::Asked, Asked), Refusal> {
    let p: RenderAnimation = params::parse(TOOL, a)?;
    let interval = (opt_u64(p.from_seq, "from_seq")?, opt_u64(p.to_seq, "to_seq")?);
    let terms = p.camera.unwrap_or_default();
    let asked = framing::Asked { view: p.view_matrix.map(|m| m.0), distance: terms.distance, yaw: terms.yaw, pitch: terms.pitch, target: terms.target, whole_scene: false };
    asked.check()?;
    let cam = Camera {
        width: side(p.width, "width", 320)?,
        height: side(p.height, "height", 240)?,
        asked,
        projection: p.projection_matrix.map(|m| m.0),
        overlay: p.overlay.map_or(Ok(Overlay::Time), |Text(o)| Overlay::parse(&o))?,
    };
    let pacing = Pacing { fps: fps(p.fps)?, speed: speed(p.speed)? };
    Ok((interval, Asked { every: every(p.every)?, cam, pacing, output: output(p.output_path, sandbox)? }))
}

/// Why an interval without steps is refused (it would be one still frame lasting 0 s), and what
/// to ask instead: a fork's own chain starts at its fork point, so its default interval is
/// empty until it steps; the steps it inherited are reached by their seqs.
fn nothing_to_animate(lent: &Lent) -> Refusal {
    let Interval { from_seq, to_seq } = lent.interval;
    let forked = lent.chain.iter().find_map(|(e, c)| match c {
        Command::ForkSimulation { parent_id, at_seq, .. } if e.seq == from_seq => Some((parent_id, at_seq)),
        _ => None,
    });
    match forked {
        Some((parent, at)) => format!(
            "Nothing to animate: simulation {} has not stepped since it was forked from {parent} (from_seq {from_seq} to to_seq {to_seq} holds no steps); step_simulation first, or give to_seq={at} to animate the last step it inherited",
            lent.id
        ),
        None => format!(
            "Nothing to animate: from_seq {from_seq} to to_seq {to_seq} holds no steps; step_simulation first, or give a from_seq before a step (get_history lists them)"
        ),
    }
}

/// Checks the size, renders the interval and writes or inlines the GIF (no lock held).
fn run(asked: Asked, lent: &Lent, max_px: usize, sandbox: &Sandbox) -> Result<(AnimationSummary, Option<Vec<u8>>), Refusal> {
    if lent.interval_steps() == 0 {
        return Err(nothing_to_animate(lent));
    }
    let every = asked.every.unwrap_or_else(|| animation::default_every(lent.interval_steps()));
    animation::check_size(animation::sample_count(lent, every), every, &asked.cam, max_px)?;
    let anim = animation::animate(lent, every, &asked.cam, asked.pacing)?;
    let summary = AnimationSummary {
        frames: anim.frames,
        width: asked.cam.width,
        height: asked.cam.height,
        fps: asked.pacing.fps,
        speed: asked.pacing.speed,
        duration_s: anim.duration_s,
        simulated_s: anim.simulated_s,
        camera: anim.camera,
        bytes: anim.gif.len(),
        from_seq: lent.interval.from_seq,
        to_seq: lent.interval.to_seq,
        every,
        steps: lent.interval_steps(),
        output_path: asked.output.as_ref().map(|(_, path)| sandbox.shown(path)),
    };
    if let Some((user, path)) = &asked.output {
        write::create_new(sandbox, path, "output_path", user, &anim.gif)?;
        return Ok((summary, None));
    }
    // Inline, the GIF is held to the reply budget (after base64) where the read is logged.
    Ok((summary, Some(anim.gif)))
}

/// The reply: the GIF inline, or a link to the file it went to; measured as sent.
fn reply(summary: &AnimationSummary, gif: Option<&[u8]>, workspace: &std::path::Path) -> CallToolResult {
    let structured = serde_json::to_value(summary).unwrap_or_default();
    let images: Vec<budget::Image> = gif.into_iter().map(|bytes| budget::Image { bytes, mime: "image/gif" }).collect();
    let mut result = budget::reply(TOOL, structured, &images);
    if let (None, Some(user)) = (gif, &summary.output_path) {
        let path = workspace.join(user);
        let link = Resource::new(format!("file://{}", path.display()), user.clone())
            .with_mime_type("image/gif")
            .with_size(summary.bytes as u64);
        result.content.push(ContentBlock::resource_link(link));
    }
    result
}

#[tool_router(router = animation_router, vis = "pub(crate)")]
impl PhysicsServer {
    /// GIF of a past interval, re-simulated from the log.
    #[tool(
        input_schema = schema_for_type::<params::RenderAnimation>(),
        output_schema = schema_for_output::<AnimationSummary>(),
        annotations(read_only_hint = true)
    )]
    async fn render_animation(&self, args: JsonObject, ct: CancellationToken) -> Result<CallToolResult, String> {
        let (max_px, sandbox) = (self.reg.limits().max_image_px, self.reg.sandbox().clone());
        let workspace = sandbox.workspace.clone();
        let measure = move |s: &AnimationSummary, gif: &Option<Vec<u8>>| budget::bytes_of(&reply(s, gif.as_deref(), &workspace));
        let for_parse = sandbox.clone();
        let parse = move |a: &Args| parse(a, &for_parse);
        let (summary, gif) = self.look_back_with(TOOL, args, ct, parse, move |asked, lent| run(asked, lent, max_px, &sandbox), measure).await?;
        Ok(reply(&summary, gif.as_deref(), &self.reg.sandbox().workspace))
    }
}
