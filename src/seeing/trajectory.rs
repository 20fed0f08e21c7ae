//! Trajectories (docs/tools.md "Seeing time"): the pose sampler — an observer of the re-simulation
//! core (`fold::resimulate`) and of live stepping — its bounds, and its files (CSV, JSONL; the
//! MCAP export rides along the same sampling, `seeing::foxglove`).
//! get_trajectory, step_simulation's `sample_every` and `replay --trajectory` all sample
//! here, with the same reads as get_object_state / get_joint_state, so a sample is bit for
//! bit what those tools said at that step.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::log::fold::{self, FoldError, Interval, Lent, Moment};
use crate::seeing::measure::{Meter, Spec};
use crate::outputs::{ObjectTrack, Trajectory};
use crate::value::Refusal;
use crate::world::World;

/// Most samples × objects one trajectory holds (docs/tools.md "Seeing time").
pub const MAX_CELLS: u64 = 1_000_000;
/// Samples the default `every` aims at.
pub const TARGET_SAMPLES: u64 = 100;
/// Upper bound of a sampled number's JSON bytes (an f32's shortest decimal, sign, exponent
/// and separator), for refusing before stepping.
const NUMBER_BYTES: u64 = 24;

/// the documented default `every`: about `TARGET_SAMPLES` samples over `steps` steps.
pub fn default_every(steps: u64) -> u64 {
    steps.div_ceil(TARGET_SAMPLES).max(1)
}

/// Samples an upper bound on how many samples `steps` steps give at `every`: the first
/// state, every `every`-th step, the last state.
pub fn max_samples(steps: u64, every: u64) -> u64 {
    2 + steps / every.max(1)
}

/// What to sample.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// Steps between samples (None: `default_every`).
    pub every: Option<u64>,
    /// Objects to sample (None: every object that exists at some sample).
    pub object_ids: Option<Vec<u32>>,
    /// Also velocities (linear, angular, joint).
    pub include_velocities: bool,
}

/// Refuses a request that is over `MAX_CELLS` before any work, when the objects are known.
pub fn check_cells(samples: u64, objects: u64, every_name: &str) -> Result<(), Refusal> {
    if samples.saturating_mul(objects) > MAX_CELLS {
        return Err(format!(
            "too many samples: {samples} samples × {objects} objects is over {MAX_CELLS}; give a larger {every_name} or fewer objects"
        ));
    }
    Ok(())
}

/// The documented upper size, in bytes, of `samples` samples of `numbers_per_sample` numbers
/// (checked against the reply budget before stepping: a step cannot be refused once taken).
pub fn reply_bound(samples: u64, numbers_per_sample: u64) -> u64 {
    samples.saturating_mul(numbers_per_sample.saturating_mul(NUMBER_BYTES) + 40)
}

/// Numbers one sample of object `id` holds in `world` (base pose, velocities, joints).
pub fn numbers_per_object(world: &World, id: u32, velocities: bool) -> u64 {
    let joints = world.robot(id).map_or(0, |_| world.link_count(id)) as u64;
    if velocities {
        13 + 2 * joints
    } else {
        7 + joints
    }
}

/// Accumulates samples into a `Trajectory` (the observer's state).
pub struct Sampler {
    ids: Option<Vec<u32>>,
    velocities: bool,
    out: Trajectory,
    tracks: BTreeMap<u32, ObjectTrack>,
    cells: u64,
    overflow: bool,
}

fn pad<T: Clone>(n: usize) -> Vec<Option<T>> {
    vec![None; n]
}

impl Sampler {
    /// An empty sampler for `interval` at `every`.
    pub fn new(interval: Interval, every: u64, req: &Request) -> Sampler {
        Sampler {
            ids: req.object_ids.clone(),
            velocities: req.include_velocities,
            out: Trajectory {
                from_seq: interval.from_seq,
                to_seq: interval.to_seq,
                every,
                samples: 0,
                times: vec![],
                steps: vec![],
                seqs: vec![],
                objects: vec![],
                output_path: None,
                unmoved: vec![],
                measures: None,
            },
            tracks: BTreeMap::new(),
            cells: 0,
            overflow: false,
        }
    }

    /// The re-simulation observer: samples at the documented sample points.
    pub fn observe(&mut self, w: &World, m: &Moment) -> bool {
        !m.sample || self.sample(w, m.seq)
    }

    /// Takes one sample of `w`, which is at event `seq`. False once over `MAX_CELLS`.
    pub fn sample(&mut self, w: &World, seq: u64) -> bool {
        let i = self.out.samples;
        let ids: Vec<u32> = match &self.ids {
            Some(ids) => ids.clone(),
            None => w.objects().map(|(id, _)| id).collect(),
        };
        for id in ids {
            let velocities = self.velocities;
            let t = self.tracks.entry(id).or_insert_with(|| ObjectTrack {
                object_id: id,
                positions: pad(i),
                x: None,
                y: None,
                z: None,
                orientations: pad(i),
                linear_velocities: velocities.then(|| pad(i)),
                angular_velocities: velocities.then(|| pad(i)),
                joint_positions: None,
                joint_velocities: None,
            });
            if t.positions.len() > i {
                continue; // listed twice
            }
            let s = w.object_state(id);
            t.positions.push(s.as_ref().map(|s| s.position));
            t.orientations.push(s.as_ref().map(|s| s.orientation));
            if let (Some(lv), Some(av)) = (&mut t.linear_velocities, &mut t.angular_velocities) {
                lv.push(s.as_ref().map(|s| s.linear_velocity));
                av.push(s.as_ref().map(|s| s.angular_velocity));
            }
            if w.robot(id).is_some() {
                let joints: Vec<_> = (0..w.link_count(id)).filter_map(|j| w.joint_state(id, j)).collect();
                t.joint_positions.get_or_insert_with(|| pad(i)).push(Some(joints.iter().map(|j| j.joint_position.scalar()).collect()));
                if velocities {
                    t.joint_velocities.get_or_insert_with(|| pad(i)).push(Some(joints.iter().map(|j| j.joint_velocity.scalar()).collect()));
                }
            }
        }
        for t in self.tracks.values_mut() {
            for col in [&mut t.joint_positions, &mut t.joint_velocities].into_iter().flatten() {
                if col.len() == i {
                    col.push(None);
                }
            }
            if t.positions.len() == i {
                t.positions.push(None);
                t.orientations.push(None);
                for col in [&mut t.linear_velocities, &mut t.angular_velocities].into_iter().flatten() {
                    col.push(None);
                }
            }
        }
        self.out.samples += 1;
        self.out.times.push(w.current_time());
        self.out.steps.push(w.steps());
        self.out.seqs.push(seq);
        self.cells += self.tracks.len() as u64;
        self.overflow = self.cells > MAX_CELLS;
        !self.overflow
    }

    /// The trajectory, or why it cannot be given (too many samples; a requested object
    /// that exists at no sample).
    pub fn finish(mut self, every_name: &str) -> Result<Trajectory, Refusal> {
        if self.overflow {
            return Err(format!(
                "too many samples: samples × objects is over {MAX_CELLS}; give a larger {every_name} or fewer object_ids"
            ));
        }
        let order: Vec<u32> = match &self.ids {
            Some(ids) => ids.clone(),
            None => self.tracks.keys().copied().collect(),
        };
        for id in order {
            if let Some(t) = self.tracks.remove(&id) {
                if self.ids.is_some() && t.positions.iter().all(Option::is_none) {
                    return Err(format!("object_ids: object {id} does not exist at any sample of the interval"));
                }
                self.out.objects.push(t);
            }
        }
        Ok(self.out)
    }
}

/// Re-simulates `lent` and samples it (get_trajectory, `replay --trajectory`).
pub fn sample_interval(lent: &Lent, req: &Request) -> Result<Trajectory, Refusal> {
    sample_interval_with(lent, req, &mut |_, _| true)
}

/// `sample_interval` with another observer riding along the same re-simulation (the MCAP
/// export), called after the sampler at every moment; either returning false stops it.
pub fn sample_interval_with(lent: &Lent, req: &Request, also: fold::Observer) -> Result<Trajectory, Refusal> {
    let every = req.every.unwrap_or_else(|| default_every(lent.interval_steps()));
    if let Some(ids) = &req.object_ids {
        check_cells(max_samples(lent.interval_steps(), every), ids.len() as u64, "every")?;
    }
    let mut sampler = Sampler::new(lent.interval, every, req);
    fold::resimulate(lent, every, &mut |w, m| sampler.observe(w, m) && also(w, m)).map_err(resim_error)?;
    sampler.finish("every")
}

/// get_trajectory with `measure`: the measures taken at every step of the same
/// re-simulation that samples (`fold::resimulate_each`), rounded to `decimals` unless exact;
/// with `samples` false (neither `every` nor `object_ids` asked) the trajectory holds the
/// measures and no samples.
pub fn sample_and_measure(lent: &Lent, req: &Request, specs: Vec<Spec>, samples: bool, (decimals, fields): (Option<u32>, Option<&[String]>)) -> Result<Trajectory, Refusal> {
    let every = req.every.unwrap_or_else(|| default_every(lent.interval_steps()));
    if let (true, Some(ids)) = (samples, &req.object_ids) {
        check_cells(max_samples(lent.interval_steps(), every), ids.len() as u64, "every")?;
    }
    let mut sampler = Sampler::new(lent.interval, every, req);
    let mut meter = Meter::new(specs);
    fold::resimulate_each(lent, every, &mut |w, m| {
        meter.see(w);
        !samples || sampler.observe(w, m)
    })
    .map_err(resim_error)?;
    meter.unseen("measure")?;
    let mut t = sampler.finish("every")?;
    if let Some(f) = fields {
        select(&mut t, f);
    }
    if let Some(d) = decimals {
        compact(&mut t, Some(d));
    }
    t.measures = Some(meter.finish(decimals));
    Ok(t)
}

/// A re-simulation that failed: the log does not fold to what it recorded.
pub fn resim_error(e: FoldError) -> Refusal {
    e.explained("The interval could not be re-simulated")
}

fn num(out: &mut String, x: Option<f64>) {
    if let Some(x) = x {
        let _ = write!(out, "{x}");
    }
}

fn nums(out: &mut String, xs: &[f64]) {
    for (k, x) in xs.iter().enumerate() {
        if k > 0 {
            out.push(';');
        }
        let _ = write!(out, "{x}");
    }
}

/// The header of `to_csv`.
pub const CSV_HEADER: &str = "sample,time,step,seq,object_id,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,joint_positions,joint_velocities";

/// One row per sample and object: numbers as the JSON result writes them (shortest decimals,
/// so parsing gives the same f64, and the same f32); a missing value is an empty field; joint
/// values are `;`-separated in one field.
pub fn to_csv(t: &Trajectory) -> String {
    let mut out = String::with_capacity(64 + t.samples * t.objects.len() * 120);
    out.push_str(CSV_HEADER);
    out.push('\n');
    for i in 0..t.samples {
        for o in &t.objects {
            let _ = write!(out, "{i},{},{},{},{}", t.times[i], t.steps[i], t.seqs[i], o.object_id);
            let p = o.positions[i].map(|a| a.to_vec()).unwrap_or_default();
            let q = o.orientations[i].map(|a| a.to_vec()).unwrap_or_default();
            let col = |c: &Option<Vec<Option<[f64; 3]>>>| c.as_ref().and_then(|c| c[i]).map(|a| a.to_vec()).unwrap_or_default();
            let (lv, av) = (col(&o.linear_velocities), col(&o.angular_velocities));
            for (vals, n) in [(&p, 3), (&q, 4), (&lv, 3), (&av, 3)] {
                for k in 0..n {
                    out.push(',');
                    num(&mut out, vals.get(k).copied());
                }
            }
            for c in [&o.joint_positions, &o.joint_velocities] {
                out.push(',');
                if let Some(v) = c.as_ref().and_then(|c| c[i].as_ref()) {
                    nums(&mut out, v);
                }
            }
            out.push('\n');
        }
    }
    out
}

/// One JSON object per line and sample: {sample, time, step, seq, objects: [{object_id,
/// position, orientation, …}]} (null where an object does not exist).
pub fn to_jsonl(t: &Trajectory) -> String {
    let mut out = String::new();
    for i in 0..t.samples {
        let objects: Vec<serde_json::Value> = t
            .objects
            .iter()
            .map(|o| {
                let mut m = serde_json::json!({
                    "object_id": o.object_id,
                    "position": o.positions[i],
                    "orientation": o.orientations[i],
                });
                let extra = [
                    ("linear_velocity", o.linear_velocities.as_ref().map(|c| serde_json::json!(c[i]))),
                    ("angular_velocity", o.angular_velocities.as_ref().map(|c| serde_json::json!(c[i]))),
                    ("joint_positions", o.joint_positions.as_ref().map(|c| serde_json::json!(c[i]))),
                    ("joint_velocities", o.joint_velocities.as_ref().map(|c| serde_json::json!(c[i]))),
                ];
                for (k, v) in extra {
                    if let Some(v) = v {
                        m[k] = v;
                    }
                }
                m
            })
            .collect();
        let line = serde_json::json!({"sample": i, "time": t.times[i], "step": t.steps[i], "seq": t.seqs[i], "objects": objects});
        out.push_str(&line.to_string());
        out.push('\n');
    }
    out
}

/// The forms a trajectory file takes, told by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileForm {
    /// `.csv`: one row per sample and object (`to_csv`).
    Csv,
    /// `.jsonl`: one JSON object per sample (`to_jsonl`).
    Jsonl,
    /// `.mcap`: Foxglove messages on simulated time (`seeing::foxglove`; get_trajectory's
    /// output_path only — the command line has `replay --mcap`).
    Mcap,
}

/// The form `path` asks for among `allowed`, or a one-sentence refusal naming `param`.
pub fn file_form(path: &str, param: &str, allowed: &[FileForm]) -> Result<FileForm, Refusal> {
    let form = match std::path::Path::new(path).extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("csv") => Some(FileForm::Csv),
        Some("jsonl") => Some(FileForm::Jsonl),
        Some("mcap") => Some(FileForm::Mcap),
        _ => None,
    };
    form.filter(|f| allowed.contains(f)).ok_or_else(|| {
        let names: Vec<&str> = allowed.iter().map(|f| match f {
            FileForm::Csv => ".csv",
            FileForm::Jsonl => ".jsonl",
            FileForm::Mcap => ".mcap",
        }).collect();
        let (last, rest) = names.split_last().unwrap_or((&"", &[]));
        let listed = if rest.is_empty() { last.to_string() } else { format!("{} or {last}", rest.join(", ")) };
        format!("{param} must end in {listed}; got {path}")
    })
}

/// The table file of `t` in form `form` (.csv or .jsonl; an MCAP is written while sampling,
/// by `seeing::foxglove::export`).
pub fn file_bytes(t: &Trajectory, form: FileForm) -> Vec<u8> {
    if form == FileForm::Jsonl { to_jsonl(t) } else { to_csv(t) }.into_bytes()
}

/// The decimals every compact series of samples is rounded to unless `precision` says
/// otherwise (get_trajectory, step_simulation's samples, run_sweep's).
pub const DEFAULT_DECIMALS: u32 = 4;

/// What a model reads by default: with `precision` every number is rounded to that many
/// decimals (times too), and then objects whose every shown sample is the same go from
/// `objects` to `unmoved` (a 100-sample track of a static ground is ~5 KB of the same
/// numbers; a box at rest that jitters by less than the shown precision is at rest to a model).
pub fn compact(t: &mut Trajectory, precision: Option<u32>) {
    fn same<T: PartialEq>(v: &[T]) -> bool {
        v.windows(2).all(|w| w[0] == w[1])
    }
    if let Some(p) = precision {
        let scale = 10f64.powi(p as i32);
        let r = |x: &mut f64| *x = (*x * scale).round() / scale;
        t.times.iter_mut().for_each(r);
        for o in &mut t.objects {
            o.positions.iter_mut().flatten().flatten().for_each(r);
            o.orientations.iter_mut().flatten().flatten().for_each(r);
            for v in [&mut o.x, &mut o.y, &mut o.z].into_iter().flatten() {
                v.iter_mut().flatten().for_each(r);
            }
            for v in [&mut o.linear_velocities, &mut o.angular_velocities].into_iter().flatten() {
                v.iter_mut().flatten().flatten().for_each(r);
            }
            for v in [&mut o.joint_positions, &mut o.joint_velocities].into_iter().flatten() {
                v.iter_mut().flatten().flatten().for_each(r);
            }
        }
    }
    let still = |o: &ObjectTrack| {
        same(&o.positions)
            && same(&o.orientations)
            && [&o.x, &o.y, &o.z].into_iter().all(|c| c.as_deref().is_none_or(same))
            && o.linear_velocities.as_deref().is_none_or(same)
            && o.angular_velocities.as_deref().is_none_or(same)
            && o.joint_positions.as_deref().is_none_or(same)
            && o.joint_velocities.as_deref().is_none_or(same)
    };
    let (unmoved, moved): (Vec<ObjectTrack>, Vec<ObjectTrack>) = std::mem::take(&mut t.objects).into_iter().partition(|o| t.samples > 1 && still(o));
    t.unmoved = unmoved.iter().map(|o| o.object_id).collect();
    t.objects = moved;
}

/// The columns `fields` may name (docs/tools.md "Trajectories").
pub const FIELDS: &[&str] = &["positions", "x", "y", "z", "orientations", "linear_velocities", "angular_velocities", "joint_positions", "joint_velocities"];

/// Reads `fields` (named `param`): the columns to keep, each one of `FIELDS`.
pub fn parse_fields(param: &str, names: &[String]) -> Result<Vec<String>, Refusal> {
    if names.is_empty() {
        return Err(format!("{param} must name at least one of {}", FIELDS.join(", ")));
    }
    for n in names {
        if !FIELDS.contains(&n.as_str()) {
            return Err(format!("{param}: unknown field {n:?}; the fields are {}", FIELDS.join(", ")));
        }
    }
    Ok(names.to_vec())
}

/// Keeps only the columns `fields` names in every track (before `compact`, so `unmoved` is
/// judged on what is shown): "x", "y", "z" become columns of their own in place of
/// `positions`, so "only the heights" costs one number a sample.
pub fn select(t: &mut Trajectory, fields: &[String]) {
    let has = |f: &str| fields.iter().any(|n| n == f);
    for o in &mut t.objects {
        for (k, col) in [(0, &mut o.x), (1, &mut o.y), (2, &mut o.z)] {
            if has(["x", "y", "z"][k]) {
                *col = Some(o.positions.iter().map(|p| p.map(|p| p[k])).collect());
            }
        }
        if !has("positions") {
            o.positions.clear();
        }
        if !has("orientations") {
            o.orientations.clear();
        }
        for (name, col) in [("linear_velocities", &mut o.linear_velocities), ("angular_velocities", &mut o.angular_velocities)] {
            if !has(name) {
                *col = None;
            }
        }
        for (name, col) in [("joint_positions", &mut o.joint_positions), ("joint_velocities", &mut o.joint_velocities)] {
            if !has(name) {
                *col = None;
            }
        }
    }
}

/// The summary a reply carries when the table went to a file.
pub fn summary(mut t: Trajectory, shown_path: String) -> Trajectory {
    (t.times, t.steps, t.seqs, t.objects) = (vec![], vec![], vec![], vec![]);
    t.output_path = Some(shown_path);
    t
}

