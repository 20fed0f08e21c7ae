//! Parameters of batch.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;
use serde_json::Value;

/// One call of a batch or of a sweep's variant.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CallSpec {
    /// Tool name.
    pub tool: String,
    /// Its arguments.
    pub arguments: Option<serde_json::Map<String, Value>>,
}

/// batch parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Batch {
    /// Sim id.
    pub sim_id: Text,
    /// 1-10,000 calls, in order.
    pub calls: Vec<CallSpec>,
    /// full: whole results (default: ids, values).
    pub detail: Option<Text>,
}
