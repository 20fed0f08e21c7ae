//! Measures (docs/tools.md "Measures"): answers computed over an interval at every step — how
//! high, how low, when a condition first held, how far, how tilted at the end, when two objects
//! first touched — so an agent reads one number instead of scanning samples. One `Meter`
//! serves all three tools that ask: step_simulation and run_sweep feed it the world after every
//! step as they step, get_trajectory from the one re-simulation (`fold::resimulate_each`).
//! Every quantity is read as the read tools report it (get_object_state's position and
//! velocity, get_collisions_for_pair's contacts), so an answer can be checked with them. What
//! a measure asks (`Spec`) is the core's (`physics_core::measure`): step_simulation's are part
//! of its command, and the fold measures them (`fold::apply`).

use std::collections::BTreeMap;

pub use crate::measure::{check_objects, parse, tilt_degrees, Spec, What, When, MAX_MEASURES, RECORDED_SINCE};
use crate::outputs::Measured;
use crate::value::Refusal;
use crate::world::World;

/// What one spec has found so far.
#[derive(Clone, Copy, Debug, Default)]
struct Found {
    /// The value (height, quantity, path length, tilt).
    value: Option<f64>,
    /// When it was found.
    time: Option<f64>,
    /// The last position seen (travel).
    last: Option<[f64; 3]>,
    /// Whether its objects existed in some state seen.
    seen: bool,
}

/// Accumulates the answers to some specs over states seen in order (the observer's state).
pub struct Meter {
    specs: Vec<Spec>,
    found: Vec<Found>,
}

impl Meter {
    /// A meter for `specs`, nothing seen yet.
    pub fn new(specs: Vec<Spec>) -> Meter {
        let found = vec![Found::default(); specs.len()];
        Meter { specs, found }
    }

    /// Whether there is nothing to measure (the observer can be left out).
    pub fn is_empty(&self) -> bool {
        self.specs.is_empty()
    }

    /// Sees one state: the interval's first, the state after every step, and after any other
    /// change. An object that does not exist in this state is skipped.
    pub fn see(&mut self, w: &World) {
        let time = w.current_time();
        for (spec, f) in self.specs.iter().zip(&mut self.found) {
            if matches!(spec.what, What::First | What::FirstContact) && f.time.is_some() {
                continue;
            }
            f.seen |= spec.objects().all(|id| w.has_object(id));
            if let (What::FirstContact, Some([a, b])) = (spec.what, spec.pair) {
                let touching = crate::seeing::sensing::contacts::contacts(w, Some((a, b)))
                    .iter()
                    .any(|c| c.contact_distance <= 0.0 || c.normal_force > 0.0);
                if touching {
                    f.time = Some(time);
                }
                continue;
            }
            let Some(s) = spec.object_id.and_then(|id| w.object_state(id)) else { continue };
            let z = s.position[2];
            match spec.what {
                What::PeakHeight if f.value.is_none_or(|v| z > v) => (f.value, f.time) = (Some(z), Some(time)),
                What::LowestHeight if f.value.is_none_or(|v| z < v) => (f.value, f.time) = (Some(z), Some(time)),
                What::Travel => {
                    let step = f.last.map_or(0.0, |p| (0..3).map(|k| (s.position[k] - p[k]).powi(2)).sum::<f64>().sqrt());
                    f.value = Some(f.value.unwrap_or(0.0) + step);
                    f.last = Some(s.position);
                }
                What::FinalTilt => (f.value, f.time) = (Some(tilt_degrees(s.orientation)), Some(time)),
                What::Settled => {
                    let speed = s.linear_velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
                    let below = spec.when.as_ref().and_then(|w| w.speed_below).is_some_and(|limit| speed < limit);
                    // The value is the speed in the last state seen; the time, when the last
                    // stretch below the limit began (none while it is above).
                    f.value = below.then_some(speed);
                    f.time = if below { f.time.or(Some(time)) } else { None };
                }
                What::First => {
                    let Some((name, limit)) = spec.when.as_ref().and_then(When::condition) else { continue };
                    let speed = || s.linear_velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
                    let (quantity, holds) = match name {
                        "height_below" => (z, z < limit),
                        "height_above" => (z, z > limit),
                        "tilt_above" => {
                            let t = tilt_degrees(s.orientation);
                            (t, t > limit)
                        }
                        _ => {
                            let v = speed();
                            (v, v < limit)
                        }
                    };
                    if holds {
                        (f.value, f.time) = (Some(quantity), Some(time));
                    }
                }
                _ => {}
            }
        }
    }

    /// Why the answers cannot be given: a spec whose objects never existed together in any
    /// state seen (a refusal naming `param[i]`, as for get_trajectory's object_ids).
    pub fn unseen(&self, param: &str) -> Result<(), Refusal> {
        match self.found.iter().position(|f| !f.seen) {
            Some(i) => Err(format!("{param}[{i}]: {} not exist at any step of the interval", match self.specs[i].pair {
                Some([a, b]) => format!("objects {a} and {b} do"),
                None => format!("object {} does", self.specs[i].object_id.unwrap_or_default()),
            })),
            None => Ok(()),
        }
    }

    /// The answers, in the order asked; with `decimals`, values and times rounded to that many
    /// decimals (the compact form), else exact.
    pub fn finish(self, decimals: Option<u32>) -> Vec<Measured> {
        let mut out: Vec<Measured> = self.specs
            .into_iter()
            .zip(self.found)
            .map(|(spec, f)| Measured {
                object_id: spec.object_id,
                pair: spec.pair,
                what: spec.what.name().to_string(),
                when: spec.when.map(|w| w.only().into_iter().map(|(n, v)| (n.to_string(), v)).collect::<BTreeMap<_, _>>()),
                value: f.value,
                time: f.time,
            })
            .collect();
        if let Some(d) = decimals {
            out.iter_mut().for_each(|m| round(m, d));
        }
        out
    }
}

/// Rounds an answer's value and time to `decimals` decimals (the compact form).
pub fn round(m: &mut Measured, decimals: u32) {
    let scale = 10f64.powi(decimals as i32);
    for x in [&mut m.value, &mut m.time].into_iter().flatten() {
        *x = (*x * scale).round() / scale;
    }
}

/// The number a ranking compares for a measure's answer: a moment's time (earlier is better,
/// so negated), else its value; None when it never held (ranked last).
pub fn rank_key(m: &Measured) -> Option<f64> {
    if [What::First, What::FirstContact, What::Settled].iter().any(|w| m.what == w.name()) {
        m.time.map(|t| -t)
    } else {
        m.value
    }
}
