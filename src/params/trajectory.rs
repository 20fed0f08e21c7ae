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
    /// full: exact, unmoved objects too.
    pub detail: Option<Text>,
    /// Decimals (default 4).
    pub precision: Option<Int<u32>>,
}
