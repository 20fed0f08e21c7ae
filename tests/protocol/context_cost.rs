//! What a model reads of the tools (docs/tools.md "Conventions"): the compact JSON
//! `{name, description, inputSchema}` of every tool in tools/list must stay ≤ 40 KiB in all and
//! ≤ 600 bytes per tool on average (SPEC "Conventions") — those bytes are in every agent's
//! context before it does anything — while every parameter keeps a description and no schema
//! carries `format`, `$schema` or `title` noise.

use crate::common;

use common::Server;
use serde_json::{json, Value};

/// The documented ceiling on the context cost of all tools together, in bytes.
const TOTAL_MAX: usize = 40 * 1024;
/// The documented ceiling on the mean context cost of one tool, in bytes.
const MEAN_MAX: usize = 600;

/// Every string-valued `format`, `$schema` or `title` keyword in `schema` (a property *named*
/// so has an object value and passes), as JSON pointers.
fn noise(schema: &Value, at: &str, found: &mut Vec<String>) {
    match schema {
        Value::Object(map) => {
            for (k, v) in map {
                let here = format!("{at}/{k}");
                match (k.as_str(), v) {
                    ("format" | "$schema" | "title", Value::String(_)) => found.push(here),
                    _ => noise(v, &here, found),
                }
            }
        }
        Value::Array(items) => items.iter().enumerate().for_each(|(i, v)| noise(v, &format!("{at}/{i}"), found)),
        _ => {}
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn tools_list_costs_at_most_40_kib_and_600_bytes_a_tool_and_every_parameter_is_described() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(dir.path(), &[]);
    let c = server.client().await;
    let tools = c.service.list_all_tools().await.expect("tools/list");
    assert!(tools.len() >= 40, "expected the full tool set, got {}", tools.len());

    let mut total = 0;
    let mut sizes = Vec::new();
    let mut problems = Vec::new();
    for t in &tools {
        let schema = Value::Object((*t.input_schema).clone());
        let seen = json!({"name": t.name, "description": t.description, "inputSchema": schema});
        let bytes = serde_json::to_string(&seen).unwrap().len();
        total += bytes;
        sizes.push((bytes, t.name.to_string()));

        let mut found = Vec::new();
        noise(&schema, "", &mut found);
        if let Some(out) = &t.output_schema {
            noise(&Value::Object((**out).clone()), "(output)", &mut found);
        }
        problems.extend(found.into_iter().map(|p| format!("{}: {p}", t.name)));
        if t.description.as_deref().is_none_or(str::is_empty) {
            problems.push(format!("{}: no description", t.name));
        }
        for (name, p) in schema["properties"].as_object().into_iter().flatten() {
            if p["description"].as_str().is_none_or(str::is_empty) {
                problems.push(format!("{}: parameter {name} has no description", t.name));
            }
        }
    }
    sizes.sort();
    let mean = total / tools.len();
    eprintln!("context cost: {} tools, {total} bytes, mean {mean} B/tool; largest {:?}", tools.len(), &sizes[sizes.len().saturating_sub(5)..]);
    assert!(problems.is_empty(), "schema problems: {problems:#?}");
    assert!(total <= TOTAL_MAX, "context cost {total} B over {} tools is over {TOTAL_MAX} (largest: {:?})", tools.len(), &sizes[sizes.len() - 5..]);
    assert!(mean <= MEAN_MAX, "context cost {mean} B per tool on average is over {MEAN_MAX} (largest: {:?})", &sizes[sizes.len() - 5..]);
}
