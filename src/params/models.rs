//! Parameters of list_models.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// list_models parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ListModels {
    /// Text in name, format, description or licence (any case).
    pub filter: Option<Text>,
}
