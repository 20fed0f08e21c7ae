//! `physics-mcp report FILE -o OUT.html` and `replay FILE --render OUT.gif`: a recorded
//! session told as pictures. Both re-simulate the head's chain once with the one core
//! (`fold::lend` on the read-only log, `fold::resimulate`) and observe it: scenes for the
//! animation and thumbnails, heights and speeds for the plots.
//!
//! - `page`  — the self-contained HTML page (everything inline; it requests nothing).
//! - `plots` — SVG line plots with `plotters` (its SVG backend, no system fonts).

mod page;
mod plots;

use crate::log::EventLog;
use std::collections::BTreeMap;
use std::path::Path;

use crate::seeing::animation::{self, Camera};
use crate::log::fold::{self, At};
use crate::seeing::sensing::render;
use crate::seeing::sensing::capture::Scene;
use crate::log::sqlite::Event;

pub use page::html;

/// At most this many thumbnails on a page (docs/tools.md).
pub const MAX_THUMBNAILS: usize = 200;
/// At most this many objects plotted (docs/tools.md).
pub const MAX_PLOTTED: usize = 10;
/// A report page's limit (docs/tools.md).
pub const MAX_PAGE_BYTES: usize = 10 * 1024 * 1024;
/// Thumbnail size.
const THUMB: (u32, u32) = (160, 120);
/// The animation's frame size on the page.
const MOVIE: (u32, u32) = (320, 240);

/// Which part of a log's chain to look at (CLI flags); defaults: the head's whole chain.
#[derive(Clone, Copy, Debug, Default)]
pub struct Span {
    /// First event (its resulting state is the first frame).
    pub from: Option<u64>,
    /// Last event.
    pub to: Option<u64>,
}

/// `replay FILE --render OUT.gif`: the span as a looping GIF (30 fps); `progress(steps
/// done, steps in all)` is told as the re-simulation goes. Returns the animation.
pub fn render_gif(path: &Path, span: Span, every: Option<u64>, size: (u32, u32), mut progress: impl FnMut(u64, u64) + Send) -> Result<animation::Animation, String> {
    let lent = crate::log::replay::lend_interval(path, span.from, span.to)?;
    let steps = lent.interval_steps();
    let every = every.unwrap_or_else(|| animation::default_every(steps));
    let cam = Camera::sized(size.0, size.1);
    animation::check_size(animation::sample_count(&lent, every), every, &cam, usize::MAX)?;
    progress(0, steps);
    let anim = animation::animate_with(&lent, every, &cam, animation::Pacing::default(), &mut |done| progress(done, steps))?;
    progress(steps, steps);
    Ok(anim)
}

/// One object's course over the run, for the plots.
#[derive(Debug, Clone, Default)]
pub struct Course {
    /// The object.
    pub object_id: u32,
    /// (time s, height m) at each sample where it existed.
    pub height: Vec<(f64, f64)>,
    /// (time s, speed m/s).
    pub speed: Vec<(f64, f64)>,
}

/// What the page shows, gathered in one re-simulation.
pub struct Story {
    /// The log's simulation id.
    pub simulation_id: String,
    /// Every event of the log, in seq order.
    pub events: Vec<Event>,
    /// Simulated time after each state-changing event of the chain (by seq), and of the
    /// states read and refused events saw (by state hash).
    pub time_at: BTreeMap<u64, f64>,
    /// Simulated time by state hash.
    pub time_of_hash: BTreeMap<String, f64>,
    /// PNG thumbnails after chosen state-changing events (by seq).
    pub thumbnails: BTreeMap<u64, Vec<u8>>,
    /// The run as a GIF.
    pub gif: Vec<u8>,
    /// Frames in it.
    pub frames: usize,
    /// The plotted objects' courses.
    pub courses: Vec<Course>,
    /// Simulated time at the end.
    pub end_time: f64,
    /// State hash at the end.
    pub final_hash: String,
    /// "verified" or the first divergence, from a full replay of the log.
    pub verdict: String,
}

/// Gathers the story of a log: a full replay for the verdict, then one re-simulation of the
/// head's chain for the pictures and plots. `progress(steps done, steps in all)`.
pub fn gather(path: &Path, mut progress: impl FnMut(u64, u64) + Send) -> Result<Story, String> {
    let verdict = match crate::log::replay::replay(path, None, |_, _| {}) {
        Ok(s) => format!("verified: {} events replayed, {} state hashes, {} reads and {} snapshots checked", s.events, s.state_events, s.reads_checked, s.snapshots_checked),
        Err(e) => format!("NOT verified: {e}"),
    };
    let (log, lent) = crate::log::replay::open_interval(path, None, None)?;
    let events = log.all_events().map_err(|e| e.to_string())?;
    let steps = lent.interval_steps();
    let every = animation::default_every(steps);
    let changes: Vec<u64> = lent.chain.iter().map(|(e, _)| e.seq).filter(|s| *s >= lent.interval.from_seq).collect();
    let thumb_every = changes.len().div_ceil(MAX_THUMBNAILS).max(1);
    let thumb_seqs: std::collections::BTreeSet<u64> = changes.iter().copied().step_by(thumb_every).collect();

    let mut shots: Vec<animation::Shot> = Vec::new();
    let mut thumbs: Vec<(u64, Scene)> = Vec::new();
    let mut time_at = BTreeMap::new();
    let mut time_of_hash = BTreeMap::new();
    let mut courses: BTreeMap<u32, Course> = BTreeMap::new();
    let (mut end_time, mut final_hash) = (0.0, String::new());
    fold::resimulate(&lent, every, &mut |w, m| {
        if m.at == At::Step {
            progress(m.steps, steps);
        }
        if m.sample {
            if !shots.is_empty() || w.object_count() > 0 {
                shots.push(animation::Shot { scene: Scene::capture(w), seq: m.seq, steps: m.steps });
            }
            let t = w.current_time();
            for (id, _) in w.objects() {
                if let Some(s) = w.object_state(id) {
                    let c = courses.entry(id).or_insert_with(|| Course { object_id: id, ..Course::default() });
                    c.height.push((t, s.position[2]));
                    c.speed.push((t, s.linear_velocity.iter().map(|v| v * v).sum::<f64>().sqrt()));
                }
            }
        }
        if m.at != At::Step {
            let (t, hash) = (w.current_time(), w.state_hash());
            time_at.insert(m.seq, t);
            time_of_hash.insert(hash.clone(), t);
            (end_time, final_hash) = (t, hash);
            if thumb_seqs.contains(&m.seq) {
                thumbs.push((m.seq, Scene::capture(w)));
            }
        }
        true
    })
    .map_err(|e| format!("the chain could not be re-simulated: {e}"))?;
    progress(steps, steps);

    let movie = animation::animate_shots(&shots, &Camera::sized(MOVIE.0, MOVIE.1), animation::Pacing::default())?;
    let scenes: Vec<&Scene> = shots.iter().map(|s| &s.scene).collect();
    let thumbnails = thumbnails(&thumbs, &scenes)?;
    // Objects that move, lowest ids first (else the first objects, still as they are).
    let moves = |c: &Course| c.speed.iter().any(|(_, v)| *v > 1e-9) || c.height.windows(2).any(|w| w[0].1 != w[1].1);
    let (moving, still): (Vec<Course>, Vec<Course>) = courses.into_values().partition(moves);
    let courses = if moving.is_empty() { still } else { moving }.into_iter().take(MAX_PLOTTED).collect();
    Ok(Story {
        simulation_id: lent.id.clone(),
        events,
        time_at,
        time_of_hash,
        thumbnails,
        frames: movie.frames,
        gif: movie.gif,
        courses,
        end_time,
        final_hash,
        verdict,
    })
}

/// Renders the chosen thumbnails as PNGs on all cores, all with the camera of the run's
/// animation (`run`: its scenes).
fn thumbnails(thumbs: &[(u64, Scene)], run: &[&Scene]) -> Result<BTreeMap<u64, Vec<u8>>, String> {
    use rayon::prelude::*;
    let cam = Camera::sized(THUMB.0, THUMB.1);
    let (view, proj, _) = cam.fix(run);
    thumbs
        .par_iter()
        .filter(|(_, s)| !s.parts.is_empty())
        .map(|(seq, s)| {
            let png = render::render_scene(s, THUMB.0, THUMB.1, &view, &proj).png()?;
            Ok((*seq, png))
        })
        .collect()
}
