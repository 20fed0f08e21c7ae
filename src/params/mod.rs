//! Tool parameters: the types each tool's arguments are parsed as, whose JSON Schemas (their
//! `///` comments become the descriptions) are the tools' input schemas — one model, so the
//! schema a client reads is exactly what the server accepts.
//!
//! `parse` reads a call's raw argument object into one of these types: an unknown parameter
//! is refused (naming the closest known one), a missing required one is refused with its
//! description, and a value is read by the lenient types of `lenient.rs`; every refusal is one
//! sentence naming the parameter. The raw arguments are still what the log records.
//!
//! One file per tool family, named as its adapter in `mcp/tools/` is (`objects.rs` holds
//! add_box's `AddBox`, `trajectory.rs` get_trajectory's `GetTrajectory`, …); these types are
//! also the log's argument schema: replay re-parses a recorded read's arguments with them.

pub mod lenient;
mod simulations;
mod objects;
mod timeline;
mod persistence;
mod robots;
mod constraints;
mod sensing;
mod viewer;
mod trajectory;
mod animation;
mod mjcf;
mod batch;
mod sweep;
mod files;
mod models;
mod dynamics;

pub use simulations::*;
pub use objects::*;
pub use timeline::*;
pub use persistence::*;
pub use robots::*;
pub use constraints::*;
pub use sensing::*;
pub use viewer::*;
pub use trajectory::*;
pub use animation::*;
pub use mjcf::*;
pub use batch::*;
pub use sweep::*;
pub use files::*;
pub use models::*;
pub use dynamics::*;

use std::any::TypeId;
use std::collections::BTreeMap;
use std::sync::{Arc, LazyLock, Mutex};

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde_json::Value;

use self::lenient::FIELD;
use crate::value::{Args, Refusal};

/// Parses a call's arguments as `P` (see the module docs); `tool` names the call in errors.
pub fn parse<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args) -> Result<P, Refusal> {
    parse_with(tool, args, true)
}

/// `parse` for arguments recorded by an earlier release, which ignored unknown parameters:
/// those are dropped instead of refused, so an old log's reads replay as they were answered.
pub fn parse_recorded<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args) -> Result<P, Refusal> {
    parse_with(tool, args, false)
}

fn parse_with<P: DeserializeOwned + JsonSchema + 'static>(tool: &str, args: &Args, strict: bool) -> Result<P, Refusal> {
    let schema = schema_of::<P>();
    let known: Vec<&str> = schema
        .get("properties")
        .and_then(Value::as_object)
        .map(|p| p.keys().map(String::as_str).collect())
        .unwrap_or_default();
    let mut kept = Args::new();
    for (name, v) in args {
        if known.contains(&name.as_str()) {
            kept.insert(name.clone(), v.clone());
        } else if strict {
            return Err(unknown_parameter(tool, name, &known));
        }
    }
    let required = schema.get("required").and_then(Value::as_array).into_iter().flatten();
    for name in required.filter_map(Value::as_str) {
        if kept.get(name).is_none_or(Value::is_null) {
            let about = schema["properties"][name]["description"].as_str().unwrap_or("see the tool's input schema");
            let about = about.trim_end_matches('.').replace('\n', " ");
            return Err(format!("{name} is required: {about}"));
        }
    }
    serde_path_to_error::deserialize(Value::Object(kept)).map_err(|e| {
        let path = e.path().to_string();
        let why = e.into_inner().to_string();
        if why.contains(FIELD) {
            why.replace(FIELD, &path)
        } else {
            format!("{path}: {why}")
        }
    })
}

/// The JSON Schema of `P` as a JSON object (computed once per type).
pub fn schema_of<P: JsonSchema + 'static>() -> Arc<Value> {
    static SCHEMAS: LazyLock<Mutex<BTreeMap<TypeId, Arc<Value>>>> = LazyLock::new(Default::default);
    let mut schemas = SCHEMAS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    schemas
        .entry(TypeId::of::<P>())
        .or_insert_with(|| Arc::new(schemars::schema_for!(P).to_value()))
        .clone()
}

/// The refusal of an unknown parameter: its name (shortened when long), the closest known one
/// (edit distance ≤ 2) and the known ones.
///
/// Names are at most a few dozen characters, and the edit distance of two names is at least
/// the difference of their lengths, so a name more than 2 characters longer or shorter than a
/// known one is not compared with it at all: a 4 MB name costs a length check per known
/// parameter, not a 4 MB × n distance table on the server's async thread.
fn unknown_parameter(tool: &str, name: &str, known: &[&str]) -> Refusal {
    let shown = shown_name(name);
    if known.is_empty() {
        return format!("Unknown parameter `{shown}` for {tool}: it takes no parameters");
    }
    let length = name.chars().count();
    let closest = known
        .iter()
        .filter(|k| k.chars().count().abs_diff(length) <= 2)
        .map(|k| (edit_distance(name, k), *k))
        .filter(|(d, _)| *d <= 2)
        .min();
    let hint = closest.map(|(_, k)| format!(" (did you mean `{k}`?)")).unwrap_or_default();
    format!("Unknown parameter `{shown}` for {tool}{hint}; expected one of: {}", known.join(", "))
}

/// Longest name a refusal repeats whole; a longer one is shown by its start and its length.
const SHOWN_NAME_CHARS: usize = 64;

/// `name` as a refusal shows it: whole when short, else its first characters and its length.
fn shown_name(name: &str) -> String {
    let length = name.chars().count();
    if length <= SHOWN_NAME_CHARS {
        return name.to_string();
    }
    let start: String = name.chars().take(SHOWN_NAME_CHARS / 2).collect();
    format!("{start}… ({length} characters)")
}

/// Levenshtein distance between two names (also: the built-in models nearest a missing file).
pub(crate) fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diag + usize::from(ca != *cb)).min(row[j] + 1).min(row[j + 1] + 1);
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

