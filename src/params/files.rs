//! Parameters of the workspace file tools: write_file, list_files.

use schemars::JsonSchema;
use serde::Deserialize;

use super::lenient::*;

/// write_file parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct WriteFile {
    /// Workspace-relative; folders are created.
    pub path: Text,
    /// Text (UTF-8), e.g. URDF or MJCF.
    pub content: Option<Text>,
    /// Bytes as base64 (e.g. STL), instead of content.
    pub content_base64: Option<Text>,
    /// Replace an existing file (default false).
    pub overwrite: Option<Bool>,
}

/// list_files parameters.
#[derive(Deserialize, JsonSchema, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct ListFiles {
    /// Workspace-relative folder or file (default all).
    pub path: Option<Text>,
}
