//! The measures an agent may ask for (docs/tools.md "Measures"): what each asks, checked for
//! sense. They live in the core because step_simulation's are part of its command
//! (`Command::StepSimulation::measure`) from event version `RECORDED_SINCE`, so a fold
//! re-derives the answers its recorded result holds; the server's `seeing::measure::Meter`
//! computes them.

use serde::{Deserialize, Serialize};

use crate::value::Refusal;

/// The event version from which step_simulation's `measure` is part of its command and its
/// answers part of its recorded result (before it they were in the reply only).
pub const RECORDED_SINCE: u32 = 8;

/// The most measures one call may ask for.
pub const MAX_MEASURES: usize = 64;

/// One measure asked for.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// The object of an object measure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_id: Option<u32>,
    /// The two objects of first_contact.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pair: Option<[u32; 2]>,
    /// What to measure.
    pub what: What,
    /// The condition of `first` (exactly one of its fields).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub when: Option<When>,
}

/// The kinds of measure.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum What {
    /// Highest base height (z) and when it was first reached.
    PeakHeight,
    /// Lowest base height and when it was first reached.
    LowestHeight,
    /// The first moment `when` holds, and the quantity then.
    First,
    /// Path length of the base position, summed over every step.
    Travel,
    /// Tilt at the end: the angle between the object's z axis and the world's, in degrees.
    FinalTilt,
    /// When the object settled: the start of the last stretch, lasting to the end, in which its
    /// speed stayed below `when.speed_below` (an object at rest from the start settled then).
    Settled,
    /// The first moment the pair touches (a contact point at or inside zero distance, or
    /// pushing).
    FirstContact,
}

impl What {
    /// The name the schema uses.
    pub fn name(self) -> &'static str {
        match self {
            What::PeakHeight => "peak_height",
            What::LowestHeight => "lowest_height",
            What::First => "first",
            What::Travel => "travel",
            What::FinalTilt => "final_tilt",
            What::Settled => "settled",
            What::FirstContact => "first_contact",
        }
    }
}

/// A condition on one object (`first`).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct When {
    /// Base height below this (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_below: Option<f64>,
    /// Base height above this (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub height_above: Option<f64>,
    /// Tilt above this many degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tilt_above: Option<f64>,
    /// Speed of the base below this (m/s): settled.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_below: Option<f64>,
}

impl When {
    /// Every condition by name, given or not.
    fn all(&self) -> [(&'static str, Option<f64>); 4] {
        [("height_below", self.height_below), ("height_above", self.height_above), ("tilt_above", self.tilt_above), ("speed_below", self.speed_below)]
    }

    /// The conditions given: (name, threshold).
    pub fn only(&self) -> Vec<(&'static str, f64)> {
        self.all().into_iter().filter_map(|(n, v)| v.map(|v| (n, v))).collect()
    }

    /// The first condition given (the one `Spec::check` allows), without building a list: read
    /// after every step.
    pub fn condition(&self) -> Option<(&'static str, f64)> {
        self.all().into_iter().find_map(|(n, v)| v.map(|v| (n, v)))
    }
}

/// Reads `measure`'s JSON: a list of specs, each checked for sense (not for the objects'
/// existence, which depends on when): a one-sentence refusal naming `param[i]`.
pub fn parse(param: &str, v: &serde_json::Value) -> Result<Vec<Spec>, Refusal> {
    let list = v.as_array().ok_or_else(|| format!("{param} must be a list of measures like {{\"object_id\": 1, \"what\": \"peak_height\"}}; see docs/tools.md Measures"))?;
    if list.len() > MAX_MEASURES {
        return Err(format!("{param} holds {} measures; at most {MAX_MEASURES}", list.len()));
    }
    let specs = list
        .iter()
        .enumerate()
        .map(|(i, item)| {
            serde_json::from_value(item.clone()).map_err(|e| {
                format!("{param}[{i}]: {e}; give object_id and what (peak_height, lowest_height, first, settled, travel, final_tilt) or pair and what first_contact")
            })
        })
        .collect::<Result<Vec<Spec>, Refusal>>()?;
    check_values(param, &specs)?;
    Ok(specs)
}

/// Whether `specs` make sense, whatever the world (a call's, or a command read from a log):
/// at most `MAX_MEASURES`, each `Spec::check`ed; a refusal naming `param[i]`.
pub fn check_values(param: &str, specs: &[Spec]) -> Result<(), Refusal> {
    if specs.len() > MAX_MEASURES {
        return Err(format!("{param} holds {} measures; at most {MAX_MEASURES}", specs.len()));
    }
    for (i, spec) in specs.iter().enumerate() {
        spec.check().map_err(|why| format!("{param}[{i}]: {why}"))?;
    }
    Ok(())
}

impl Spec {
    /// Whether the spec makes sense: an object measure names one object, first_contact a pair
    /// of two different objects, `first` exactly one finite condition.
    pub fn check(&self) -> Result<(), Refusal> {
        match (self.what, self.object_id, self.pair) {
            (What::FirstContact, _, None) => return Err("first_contact needs pair: [a, b]".into()),
            (What::FirstContact, Some(_), _) => return Err("first_contact takes pair, not object_id".into()),
            (What::FirstContact, None, Some([a, b])) if a == b => return Err(format!("pair must name two different objects; got [{a}, {b}]")),
            (What::FirstContact, None, Some(_)) => {}
            (w, None, _) => return Err(format!("{} needs object_id", w.name())),
            (w, Some(_), Some(_)) => return Err(format!("{} takes object_id, not pair", w.name())),
            (_, Some(_), None) => {}
        }
        match (self.what, &self.when) {
            (What::First, None) => Err("first needs when: {height_below | height_above | tilt_above | speed_below: number}".into()),
            (What::First, Some(when)) => match when.only()[..] {
                [(name, v)] if !v.is_finite() => Err(format!("when.{name} must be a finite number; got {v}")),
                [_] => Ok(()),
                _ => Err("when must hold exactly one of height_below, height_above, tilt_above, speed_below".into()),
            },
            (What::Settled, Some(When { speed_below: Some(v), height_below: None, height_above: None, tilt_above: None })) if v.is_finite() => Ok(()),
            (What::Settled, _) => Err("settled needs when: {speed_below: number} (and nothing else)".into()),
            (w, Some(_)) => Err(format!("when is only for what: first or settled, not {}", w.name())),
            (_, None) => Ok(()),
        }
    }

    /// The objects this spec reads.
    pub fn objects(&self) -> impl Iterator<Item = u32> {
        self.object_id.into_iter().chain(self.pair.into_iter().flatten())
    }
}

/// The first spec naming an object that `exists` says is missing: a refusal naming `param[i]`.
pub fn check_objects(param: &str, specs: &[Spec], exists: impl Fn(u32) -> bool) -> Result<(), Refusal> {
    for (i, s) in specs.iter().enumerate() {
        if let Some(id) = s.objects().find(|id| !exists(*id)) {
            return Err(format!("{param}[{i}]: object {id} does not exist"));
        }
    }
    Ok(())
}

/// Tilt of orientation `q` ([x, y, z, w]) in degrees: the angle between the body's z axis and
/// the world's (0 upright, 90 on its side, 180 upside down).
pub fn tilt_degrees(q: [f64; 4]) -> f64 {
    let [x, y, z, w] = q;
    let n = x * x + y * y + z * z + w * w;
    // The z component of the rotated z axis, for a quaternion of any length.
    let cos = if n > 0.0 { 1.0 - 2.0 * (x * x + y * y) / n } else { 1.0 };
    cos.clamp(-1.0, 1.0).acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn tilt_is_the_angle_of_the_z_axis() {
        assert!(tilt_degrees([0.0, 0.0, 0.0, 1.0]).abs() < 1e-12);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((tilt_degrees([h, 0.0, 0.0, h]) - 90.0).abs() < 1e-9);
        assert!((tilt_degrees([0.0, 0.0, h, h])).abs() < 1e-9, "a turn about z is no tilt");
        assert!((tilt_degrees([1.0, 0.0, 0.0, 0.0]) - 180.0).abs() < 1e-9);
    }

    #[test]
    fn specs_that_make_no_sense_are_refused_naming_the_entry() {
        let bad = [
            (json!([{"what": "peak_height"}]), "measure[0]: peak_height needs object_id"),
            (json!([{"object_id": 1, "what": "first"}]), "measure[0]: first needs when"),
            (json!([{"object_id": 1, "what": "first", "when": {"speed_below": 1, "tilt_above": 3}}]), "exactly one"),
            (json!([{"object_id": 1, "what": "first_contact"}]), "first_contact needs pair"),
            (json!([{"pair": [2, 2], "what": "first_contact"}]), "two different objects"),
            (json!([{"object_id": 1, "what": "travel", "when": {"speed_below": 1}}]), "when is only for what: first or settled"),
            (json!([{"object_id": 1, "what": "settled", "when": {"tilt_above": 1}}]), "settled needs when: {speed_below"),
            (json!([{"object_id": 1, "what": "highest"}]), "measure[0]: unknown variant `highest`"),
            (json!({"object_id": 1}), "must be a list"),
        ];
        for (v, said) in bad {
            let why = parse("measure", &v).unwrap_err();
            assert!(why.contains(said), "{v}: {why}");
        }
        let ok = parse("measure", &json!([{"object_id": 1, "what": "first", "when": {"speed_below": 0.01}}, {"pair": [1, 2], "what": "first_contact"}])).unwrap();
        assert_eq!(ok.len(), 2);
    }
}
