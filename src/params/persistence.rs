//! Parameters of save_simulation, load_simulation.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// save_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Save {
    /// Sim id.
    pub sim_id: Text,
    /// Workspace-relative .json path.
    pub file_path: Text,
    /// Replace a non-save file (default false).
    pub overwrite: Option<Bool>,
}

/// load_simulation parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// Workspace-relative saved file.
    pub file_path: Text,
    /// Web viewer (default false).
    pub gui: Option<Bool>,
    /// A label.
    pub name: Option<Text>,
}
