//! Parameters of get_trajectory.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// get_trajectory parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct GetTrajectory {
    /// Sim id.
    pub sim_id: Text,
    /// Default: before the last step.
    pub from_seq: Option<Int<u64>>,
    /// Default: the head.
    pub to_seq: Option<Int<u64>>,
    /// Default: ~100 samples.
    pub every: Option<Int<u64>>,
    /// Default all.
    pub object_ids: Option<Vec<ObjectId>>,
    /// Default false.
    pub include_velocities: Option<Bool>,
    /// New .csv/.jsonl/.mcap
    pub output_path: Option<Text>,
    /// full: exact.
    pub detail: Option<Text>,
    /// Decimals (default 4).
    pub precision: Option<Int<u32>>,
    /// Per-step answers.
    pub measure: Option<Measures>,
    /// Sample columns.
    pub fields: Option<Vec<Text>>,
}

/// `measure` (get_trajectory, step_simulation, run_sweep's observe): a list of measures, read
/// by `measure::parse` (each checked, a refusal naming `measure[i]`); its schema is a
/// plain list of objects, the forms told in docs/tools.md "Measures" (tools/list stays lean).
#[derive(Debug, Clone, PartialEq)]
pub struct Measures(pub Vec<crate::measure::Spec>);

impl<'de> serde::Deserialize<'de> for Measures {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let v = serde_json::Value::deserialize(d)?;
        crate::measure::parse(FIELD, &v).map(Measures).map_err(D::Error::custom)
    }
}

impl JsonSchema for Measures {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "Measures".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({"type": "array", "items": {"type": "object"}})
    }
}
