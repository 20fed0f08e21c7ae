//! Parameters of run_sweep.

use schemars::JsonSchema;
use serde::Deserialize;

use super::batch::CallSpec;
use super::lenient::*;

/// What run_sweep reports of each variant.
#[derive(Deserialize, JsonSchema, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct Observe {
    /// Default all.
    pub object_ids: Option<Vec<ObjectId>>,
    /// Default false.
    pub include_velocities: Option<Bool>,
    /// Also sample poses every N steps.
    pub every: Option<Int<u64>>,
    /// Per-step answers.
    pub measure: Option<super::trajectory::Measures>,
    /// Sample columns.
    pub fields: Option<Vec<Text>>,
}

/// run_sweep parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// Sim id.
    pub sim_id: Text,
    /// 1-256 call lists, one fork each.
    pub variants: Vec<Vec<CallSpec>>,
    /// Steps after the calls.
    pub steps: Int<u64>,
    /// What to report (default all).
    pub observe: Option<Observe>,
    /// Keep the forks.
    pub keep: Option<Bool>,
    /// full: unmoved objects too.
    pub detail: Option<Text>,
    /// Order the variants (docs/tools.md).
    pub rank_by: Option<RankBy>,
}

/// How run_sweep ranks its variants.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct RankBy {
    /// observe.measure index,
    pub measure: Option<Int<u32>>,
    /// or object_id
    pub object_id: Option<ObjectId>,
    /// and displacement/peak_speed/final_z.
    pub metric: Option<Text>,
}
