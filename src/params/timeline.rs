//! Parameters of undo, redo, get_history, fork_simulation.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// undo / redo parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Count {
    /// Sim id.
    pub sim_id: Text,
    /// Default 1.
    pub count: Option<Int<u64>>,
}

/// get_history parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct HistoryPage {
    /// Sim id.
    pub sim_id: Text,
    /// After seq (default 0).
    pub since_seq: Option<Int<u64>>,
    /// 1-1000 (default 50).
    pub limit: Option<Int<u64>>,
    /// full: as logged.
    pub detail: Option<Text>,
}

/// fork_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Fork {
    /// Sim id.
    pub sim_id: Text,
    /// Default: the head.
    pub at_seq: Option<Int<u64>>,
    /// A label.
    pub name: Option<Text>,
}
