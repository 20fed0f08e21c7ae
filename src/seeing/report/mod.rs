//! `physics-mcp report FILE -o OUT.html` and `replay FILE --render OUT.gif`: a recorded
//! session told as pictures. Both re-simulate the head's chain once with the one core
//! (`fold::lend` on the read-only log, `fold::resimulate`) and observe it: scenes for the
//! animation and thumbnails, heights and speeds for the plots.
//!
//! - `page`  — the self-contained HTML page (everything inline; it requests nothing).
//! - `plots` — SVG line charts (height, speed, joint positions), written by hand.

mod page;
mod plots;

use crate::log::EventLog;
use std::collections::BTreeMap;
use std::path::Path;

use crate::log::fold::{self, At};
use crate::log::sqlite::Event;
use crate::seeing::animation::{self, Camera};
use crate::seeing::sensing::capture::Scene;
use crate::seeing::sensing::render;
use crate::seeing::style;
use crate::seeing::trajectory::{Request, Sampler};

pub use page::{html, Counts, RUNNING_NOTE};

/// At most this many thumbnails on a page (docs/tools.md).
pub const MAX_THUMBNAILS: usize = 200;
/// At most this many objects plotted (docs/tools.md).
pub const MAX_PLOTTED: usize = 10;
/// A report page's limit (docs/tools.md).
pub const MAX_PAGE_BYTES: usize = 10 * 1024 * 1024;
/// Thumbnail size.
pub const THUMB: (u32, u32) = (240, 180);
/// The animation's frame size on the page.
pub const MOVIE: (u32, u32) = (480, 360);

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
    /// The seqs of the head's chain: a change that is not on it was undone (or left behind by
    /// a change after an undo), and the page says so.
    pub chain: std::collections::BTreeSet<u64>,
    /// PNG thumbnails after chosen state-changing events (by seq); a thumbnail identical to
    /// the one before it is left out (see `same_picture`), as is an empty world's.
    pub thumbnails: BTreeMap<u64, Vec<u8>>,
    /// Events whose thumbnail was the same picture as an earlier event's (seq → that seq).
    pub same_picture: BTreeMap<u64, u64>,
    /// The run as a GIF.
    pub gif: Vec<u8>,
    /// Frames in it.
    pub frames: usize,
    /// Height and speed of the objects that moved most, then joint positions per robot.
    pub charts: Vec<plots::Chart>,
    /// Simulated time at the end.
    pub end_time: f64,
    /// State hash at the end.
    pub final_hash: String,
    /// "verified" or the first divergence, from a full replay of the log.
    pub verdict: String,
    /// The state events (root, change, move) the replay counted, when it verified.
    pub replayed_state_events: Option<u64>,
    /// Whether a server held the log's data directory when the report was made (it may
    /// still hold reads it has not written yet).
    pub server_running: bool,
}

/// Gathers the story of a log: a full replay for the verdict, then one re-simulation of the
/// head's chain for the pictures and plots. `progress(steps done, steps in all)`.
pub fn gather(path: &Path, mut progress: impl FnMut(u64, u64) + Send) -> Result<Story, String> {
    let server_running = crate::log::data_dir::held_by_server(path);
    let (verdict, replayed_state_events) = match crate::log::replay::replay(path, None, |_, _| {}) {
        Ok(s) => (
            format!("verified: {} events replayed, {} state hashes, {} reads and {} snapshots checked", s.events, s.state_events, s.reads_checked, s.snapshots_checked),
            Some(s.state_events),
        ),
        Err(e) => (format!("NOT verified: {e}"), None),
    };
    let (log, lent) = crate::log::replay::open_interval(path, None, None)?;
    let events = log.all_events().map_err(|e| e.to_string())?;
    let steps = lent.interval_steps();
    let every = animation::default_every(steps);
    let changes: Vec<u64> = lent.chain.iter().map(|(e, _)| e.seq).filter(|s| *s >= lent.interval.from_seq).collect();
    let thumb_every = changes.len().div_ceil(MAX_THUMBNAILS).max(1);
    let thumb_seqs: std::collections::BTreeSet<u64> = changes.iter().copied().step_by(thumb_every).collect();

    let mut effectors = Effectors::default();
    let mut shots: Vec<animation::Shot> = Vec::new();
    let mut thumbs: Vec<(u64, Scene)> = Vec::new();
    let mut time_at = BTreeMap::new();
    let mut time_of_hash = BTreeMap::new();
    // The plots sample as get_trajectory does (same reads, same sample points).
    let request = Request { every: Some(every), object_ids: None, include_velocities: true };
    let mut sampler = Sampler::new(lent.interval, every, &request);
    let mut described: BTreeMap<u32, Described> = BTreeMap::new();
    let (mut end_time, mut final_hash) = (0.0, String::new());
    fold::resimulate(&lent, every, &mut |w, m| {
        if m.at == At::Step {
            progress(m.steps, steps);
        }
        if m.sample {
            animation::Shot::record(&mut shots, w, m);
            // Over get_trajectory's cell bound the sampler says so at `finish`; the
            // re-simulation goes on for the pictures.
            sampler.sample(w, m.seq);
            effectors.record(w);
            for (id, o) in w.objects() {
                described.entry(id).or_insert_with(|| describe(id, o));
            }
        }
        if m.at != At::Step {
            let (t, hash) = (w.current_time(), w.state_hash());
            time_at.insert(m.seq, t);
            time_of_hash.insert(hash.clone(), t);
            (end_time, final_hash) = (t, hash);
            // An empty world is a blank picture: no thumbnail.
            if thumb_seqs.contains(&m.seq) && w.objects().next().is_some() {
                thumbs.push((m.seq, Scene::capture(w)));
            }
        }
        true
    })
    .map_err(|e| format!("the chain could not be re-simulated: {e}"))?;
    progress(steps, steps);

    let (gif, frames) = movie(&shots)?;
    let scenes: Vec<&Scene> = shots.iter().map(|s| &s.scene).collect();
    let (thumbnails, same_picture) = distinct(thumbnails(&thumbs, &scenes)?);
    let charts = match sampler.finish("every") {
        Ok(mut trajectory) => {
            effectors.substitute(&mut trajectory, &mut described);
            charts(&trajectory, &described)
        }
        Err(_) => Vec::new(),
    };
    Ok(Story {
        simulation_id: lent.id.clone(),
        events,
        time_at,
        time_of_hash,
        chain: lent.chain.iter().map(|(e, _)| e.seq).collect(),
        thumbnails,
        same_picture,
        frames,
        gif,
        charts,
        end_time,
        final_hash,
        verdict,
        replayed_state_events,
        server_running,
    })
}

/// What the plots call an object, and the colours the scene draws it and its links in.
struct Described {
    /// `#3 box`, `#5 iiwa14`.
    label: String,
    /// Its colour as `style::object_*` takes it.
    color: Option<[f32; 4]>,
    /// A robot's movable joints.
    joints: Vec<JointLabel>,
    /// Whether its movable joints are all prismatic / all rotational (the y axis's unit).
    units: &'static str,
}

/// A movable joint: its index, legend label and its link's colour.
type JointLabel = (usize, String, Option<[f32; 4]>);

fn describe(id: u32, o: &crate::world::Object) -> Described {
    use crate::command::Shape;
    match o.kind.robot() {
        None => {
            let shape = match &o.kind {
                crate::world::ObjectKind::Primitive { shape: Shape::Box { .. } } => "box",
                crate::world::ObjectKind::Primitive { shape: Shape::Sphere { .. } } => "sphere",
                crate::world::ObjectKind::Primitive { shape: Shape::Cylinder { .. } } => "cylinder",
                crate::world::ObjectKind::Primitive { shape: Shape::Capsule { .. } } => "capsule",
                _ => "object",
            };
            Described { label: format!("#{id} {shape}"), color: o.color, joints: Vec::new(), units: "" }
        }
        Some(robot) => {
            // The base is drawn in the object's colour; a robot given none shows its links'.
            let color = o.color.or_else(|| robot.links.iter().find_map(|l| l.color));
            let joints: Vec<_> = robot
                .movable()
                .into_iter()
                .map(|i| {
                    let l = &robot.links[i];
                    (i, format!("{} ({})", l.joint.name, l.name), l.color.or(o.color))
                })
                .collect();
            let prismatic = robot.movable().iter().filter(|i| robot.links[**i].joint.kind.name() == "prismatic").count();
            let units = match prismatic {
                0 => "joint position (rad)",
                n if n == joints.len() => "joint position (m)",
                _ => "joint position (rad or m)",
            };
            Described { label: format!("#{id} {}", robot.name), color, joints, units }
        }
    }
}

/// Where each fixed-base robot's end effector (its last link, PyBullet's usual choice) is at
/// every sample: a fixed base stays put, so its height and speed say nothing; the plots show
/// the end effector's instead.
#[derive(Default)]
struct Effectors {
    /// Samples recorded so far.
    samples: usize,
    /// Per robot: its end-effector link, and where it was at each sample it existed in.
    tracks: BTreeMap<u32, (i32, Vec<EffectorAt>)>,
}

/// (sample index, link frame position, centre-of-mass velocity).
type EffectorAt = (usize, [f64; 3], [f64; 3]);

impl Effectors {
    /// Records the sample the trajectory sampler just took.
    fn record(&mut self, w: &crate::world::World) {
        for (id, o) in w.objects() {
            let Some(robot) = o.kind.robot().filter(|r| r.fixed_base && !r.links.is_empty()) else { continue };
            let link = (robot.links.len() - 1) as i32;
            if let Some(s) = w.link_state(id, link) {
                self.tracks.entry(id).or_insert_with(|| (link, Vec::new())).1.push((self.samples, s.link_world_position, s.linear_velocity));
            }
        }
        self.samples += 1;
    }

    /// Puts each fixed-base robot's end effector in place of its base in `t`, and says so in
    /// its label. Left as it is when the samples do not line up (they always should).
    fn substitute(&self, t: &mut crate::outputs::Trajectory, described: &mut BTreeMap<u32, Described>) {
        if self.samples != t.samples {
            return;
        }
        for o in &mut t.objects {
            let Some((link, track)) = self.tracks.get(&o.object_id) else { continue };
            let mut positions = vec![None; t.samples];
            let mut velocities = vec![None; t.samples];
            for (i, p, v) in track {
                positions[*i] = Some(*p);
                velocities[*i] = Some(*v);
            }
            o.positions = positions;
            o.linear_velocities = Some(velocities);
            if let Some(d) = described.get_mut(&o.object_id) {
                d.label = format!("{} end effector (link {link})", d.label);
            }
        }
    }
}

/// Sum of |Δ| between consecutive samples where both exist.
fn path_length<T: Copy>(values: &[Option<T>], dist: impl Fn(T, T) -> f64) -> f64 {
    values.windows(2).filter_map(|w| Some(dist(w[0]?, w[1]?))).sum()
}

/// Things that moved less than this (m or rad over the run) count as still.
const STILL: f64 = 1e-9;

/// The charts: height and speed of the objects that moved most (by path length; the first
/// objects when none moved), then one joint-position chart per robot whose joints moved.
fn charts(t: &crate::outputs::Trajectory, described: &BTreeMap<u32, Described>) -> Vec<plots::Chart> {
    let rgb = |id: u32, color: Option<[f32; 4]>| style::object_bytes(id, color);
    let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
    let mut ranked: Vec<(f64, &crate::outputs::ObjectTrack)> = t.objects.iter().map(|o| (path_length(&o.positions, dist), o)).collect();
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.object_id.cmp(&b.1.object_id)));
    let moved = ranked.iter().take_while(|(p, _)| *p > STILL).count();
    let chosen: Vec<&crate::outputs::ObjectTrack> = if moved > 0 {
        ranked.iter().take(moved.min(MAX_PLOTTED)).map(|(_, o)| *o).collect()
    } else {
        t.objects.iter().take(MAX_PLOTTED).collect()
    };
    let at = |i: usize, v: Option<f64>| v.map(|v| (t.times[i], v));
    let line = |o: &crate::outputs::ObjectTrack, value: &dyn Fn(usize) -> Option<f64>| {
        let d = described.get(&o.object_id);
        plots::Line {
            object_id: o.object_id,
            joint: None,
            label: d.map_or_else(|| format!("#{}", o.object_id), |d| d.label.clone()),
            rgb: rgb(o.object_id, d.and_then(|d| d.color)),
            points: (0..t.samples).map(|i| at(i, value(i))).collect(),
        }
    };
    let mut out = Vec::new();
    if !chosen.is_empty() {
        let height = chosen.iter().map(|o| line(o, &|i| o.positions[i].map(|p| p[2]))).collect();
        let speed = chosen
            .iter()
            .map(|o| line(o, &|i| o.linear_velocities.as_ref().and_then(|v| v[i]).map(|v| v.iter().map(|x| x * x).sum::<f64>().sqrt())))
            .collect();
        out.push(plots::Chart { id: "plot-height".into(), title: "Height over time".into(), unit: "height z (m)".into(), lines: height });
        out.push(plots::Chart { id: "plot-speed".into(), title: "Speed over time".into(), unit: "speed (m/s)".into(), lines: speed });
    }
    for o in &t.objects {
        let (Some(d), Some(q)) = (described.get(&o.object_id), &o.joint_positions) else { continue };
        if out.len() >= 2 + MAX_PLOTTED {
            break;
        }
        let value = |i: usize, j: usize| q[i].as_ref().and_then(|v| v.get(j).copied());
        let mut joints: Vec<(f64, &JointLabel)> = d
            .joints
            .iter()
            .map(|jd| (path_length(&(0..t.samples).map(|i| value(i, jd.0)).collect::<Vec<_>>(), |a, b| (a - b).abs()), jd))
            .filter(|(p, _)| *p > STILL)
            .collect();
        if joints.is_empty() {
            continue;
        }
        joints.sort_by(|a, b| b.0.total_cmp(&a.0));
        joints.truncate(MAX_PLOTTED);
        joints.sort_by_key(|(_, jd)| jd.0);
        let lines = joints
            .into_iter()
            .map(|(_, (j, label, color))| plots::Line {
                object_id: o.object_id,
                joint: Some(*j),
                label: format!("joint {j}: {label}"),
                rgb: rgb(o.object_id, *color),
                points: (0..t.samples).map(|i| at(i, value(i, *j))).collect(),
            })
            .collect();
        out.push(plots::Chart {
            id: format!("plot-joints-{}", o.object_id),
            title: format!("Joint positions of {}", d.label),
            unit: d.units.into(),
            lines,
        });
    }
    out
}

/// Keeps the first of each run of identical consecutive thumbnails; the others point at it.
fn distinct(thumbs: BTreeMap<u64, Vec<u8>>) -> (BTreeMap<u64, Vec<u8>>, BTreeMap<u64, u64>) {
    let (mut kept, mut same) = (BTreeMap::new(), BTreeMap::new());
    let mut last: Option<(u64, Vec<u8>)> = None;
    for (seq, png) in thumbs {
        match &last {
            Some((first, prev)) if *prev == png => {
                same.insert(seq, *first);
            }
            _ => {
                kept.insert(seq, png.clone());
                last = Some((seq, png));
            }
        }
    }
    (kept, same)
}

/// The run as a GIF (every call into the animation module for the page is here and in
/// `thumbnails`).
fn movie(shots: &[animation::Shot]) -> Result<(Vec<u8>, usize), String> {
    if shots.is_empty() {
        return Ok((Vec::new(), 0));
    }
    let movie = animation::animate_shots(shots, &scene_wide(MOVIE), animation::Pacing::default())?;
    Ok((movie.gif, movie.frames))
}

/// The report's one camera, for the movie and every thumbnail: framing everything but the
/// ground over the whole run, so the scene is seen being built and nothing moving little is
/// blown up to fill the picture.
fn scene_wide((width, height): (u32, u32)) -> Camera {
    Camera { asked: crate::seeing::framing::Asked { whole_scene: true, ..Default::default() }, ..Camera::sized(width, height) }
}

/// Renders the chosen thumbnails as PNGs on all cores, all with the camera of the run's
/// animation (`run`: its scenes), so they compare with one another and with the movie.
fn thumbnails(thumbs: &[(u64, Scene)], run: &[&Scene]) -> Result<BTreeMap<u64, Vec<u8>>, String> {
    use rayon::prelude::*;
    let (view, proj, _) = scene_wide(THUMB).fix(run);
    thumbs
        .par_iter()
        .map(|(seq, s)| {
            let png = render::render_scene(s, THUMB.0, THUMB.1, &view, &proj).png()?;
            Ok((*seq, png))
        })
        .collect()
}
