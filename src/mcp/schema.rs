//! Plain JSON Schema 2020-12 for the tools' input and output schemas.
//!
//! schemars writes what a strict validator or a model does not need and may not understand:
//! `$schema` and `title` boilerplate, and integer and float `format`s (`uint32`, `double`…)
//! that JSON Schema does not define. `plain` drops them (schemars already gives unsigned
//! integers `minimum: 0`).
//! `input` also trims what only costs a model's context (see there).

use rmcp::model::JsonObject;
use serde_json::Value;

/// The `format` values JSON Schema 2020-12 defines (validation spec, section 7.3).
const STANDARD_FORMATS: &[&str] = &[
    "date-time", "date", "time", "duration", "email", "idn-email", "hostname", "idn-hostname",
    "ipv4", "ipv6", "uri", "uri-reference", "iri", "iri-reference", "uuid", "uri-template",
    "json-pointer", "relative-json-pointer", "regex",
];

/// Keywords whose value is one subschema.
const ONE_SCHEMA: &[&str] = &[
    "items", "additionalProperties", "not", "if", "then", "else", "contains", "propertyNames",
    "unevaluatedItems", "unevaluatedProperties", "contentSchema",
];

/// Keywords whose value maps names to subschemas (the names are data, not keywords).
const NAMED_SCHEMAS: &[&str] = &["properties", "patternProperties", "$defs", "definitions", "dependentSchemas"];

/// Keywords whose value is a list of subschemas.
const SCHEMA_LISTS: &[&str] = &["allOf", "anyOf", "oneOf", "prefixItems"];

/// `schema` as plain JSON Schema 2020-12: no `$schema`, no `title`, only standard `format`s;
/// and no top-level `description` (the Rust type's doc comment: the tool's own description
/// is what a client shows).
pub(crate) fn plain(schema: &JsonObject) -> JsonObject {
    let mut schema = schema.clone();
    schema.remove("$schema");
    schema.remove("description");
    clean(&mut schema);
    schema
}

/// A tool's input schema: `plain`, and an optional parameter's type without `"null"` — being
/// left out of `required` already says it may be omitted, and every byte of an input schema
/// is in a model's context on every turn (the server still reads `null` as "not given").
/// Output schemas keep `null`, since results do carry it.
pub(crate) fn input(schema: &JsonObject) -> JsonObject {
    let mut schema = plain(schema);
    optional_without_null(&mut schema);
    drop_zero_minimum(&mut schema);
    // A parameter's own description says what a nested type is for; the type's doc comment
    // would repeat it on every turn.
    if let Some(Value::Object(defs)) = schema.get_mut("$defs") {
        for def in defs.values_mut().filter_map(Value::as_object_mut) {
            def.remove("description");
            optional_without_null(def);
        }
    }
    schema
}

/// Integers without `minimum: 0`: ids, indices and counts say they are not negative by what
/// they are, the server refuses a negative one with a sentence naming it, and the ~57 of them
/// cost ~600 bytes of every model's context on every turn. (Output schemas keep it.)
fn drop_zero_minimum(schema: &mut JsonObject) {
    if schema.get("minimum") == Some(&Value::from(0)) {
        schema.remove("minimum");
    }
    for value in schema.values_mut() {
        match value {
            Value::Object(sub) => drop_zero_minimum(sub),
            Value::Array(list) => list.iter_mut().filter_map(Value::as_object_mut).for_each(drop_zero_minimum),
            _ => {}
        }
    }
}

/// An object schema's optional properties without `"null"`: `["integer", "null"]` becomes
/// `"integer"`, and `anyOf: [{$ref}, {type: null}]` the `$ref` alone.
fn optional_without_null(schema: &mut JsonObject) {
    let required: Vec<Value> = schema.get("required").and_then(Value::as_array).cloned().unwrap_or_default();
    let Some(Value::Object(props)) = schema.get_mut("properties") else { return };
    for (name, prop) in props.iter_mut() {
        if required.iter().any(|r| r.as_str() == Some(name)) {
            continue;
        }
        let Some(prop) = prop.as_object_mut() else { continue };
        if let Some(Value::Array(types)) = prop.get("type") {
            if types.len() == 2 && types.iter().any(|t| t == "null") {
                if let Some(other) = types.iter().find(|t| *t != "null").cloned() {
                    prop.insert("type".into(), other);
                }
            }
        }
        let single = match prop.get("anyOf") {
            Some(Value::Array(alts)) if alts.len() == 2 && alts.iter().any(|a| a.get("type") == Some(&Value::from("null"))) => {
                alts.iter().find(|a| a.get("type") != Some(&Value::from("null"))).and_then(Value::as_object).cloned()
            }
            _ => None,
        };
        if let Some(single) = single {
            prop.remove("anyOf");
            for (k, v) in single {
                prop.entry(k).or_insert(v);
            }
        }
    }
}

/// Cleans one schema object and, through the keywords that hold subschemas, all below it
/// (never `enum`, `const`, `default` or `examples`, whose values are data).
fn clean(schema: &mut JsonObject) {
    schema.remove("title");
    let format = schema.get("format").and_then(Value::as_str).map(str::to_owned);
    if format.is_some_and(|f| !STANDARD_FORMATS.contains(&f.as_str())) {
        schema.remove("format");
    }
    for (keyword, value) in schema.iter_mut() {
        let keyword = keyword.as_str();
        match value {
            Value::Object(sub) if ONE_SCHEMA.contains(&keyword) => clean(sub),
            Value::Object(named) if NAMED_SCHEMAS.contains(&keyword) => {
                named.values_mut().filter_map(Value::as_object_mut).for_each(clean)
            }
            Value::Array(list) if SCHEMA_LISTS.contains(&keyword) => {
                list.iter_mut().filter_map(Value::as_object_mut).for_each(clean)
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn object(v: Value) -> JsonObject {
        v.as_object().cloned().unwrap()
    }

    #[test]
    fn input_schemas_drop_null_from_optional_parameters_only() {
        let raw = object(json!({
            "type": "object",
            "properties": {
                "a": {"type": ["number", "null"]},
                "b": {"type": ["array", "null"], "items": {"type": "number"}},
                "c": {"type": ["string", "null"]}
            },
            "required": ["c"]
        }));
        let want = object(json!({
            "type": "object",
            "properties": {
                "a": {"type": "number"},
                "b": {"type": "array", "items": {"type": "number"}},
                "c": {"type": ["string", "null"]}
            },
            "required": ["c"]
        }));
        assert_eq!(input(&raw), want);
    }

    #[test]
    fn drops_boilerplate_and_nonstandard_formats_at_every_depth() {
        let raw = object(json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": "Thing",
            "description": "The Rust type's doc comment.",
            "type": "object",
            "properties": {
                "title": {"type": "string", "title": "kept as a property name"},
                "id": {"type": "integer", "format": "uint32", "minimum": 0},
                "at": {"type": "string", "format": "date-time"},
                "xs": {"type": "array", "items": {"type": "number", "format": "double"}},
                "n": {"anyOf": [{"type": "integer", "format": "int32"}, {"type": "null"}]},
                "big": {"type": "integer", "format": "uint64", "minimum": 0},
                "d": {"type": "object", "default": {"format": "data, not a keyword"}}
            },
            "$defs": {"Sub": {"title": "Sub", "type": "number", "format": "float"}}
        }));
        let want = object(json!({
            "type": "object",
            "properties": {
                "title": {"type": "string"},
                "id": {"type": "integer", "minimum": 0},
                "at": {"type": "string", "format": "date-time"},
                "xs": {"type": "array", "items": {"type": "number"}},
                "n": {"anyOf": [{"type": "integer"}, {"type": "null"}]},
                "big": {"type": "integer", "minimum": 0},
                "d": {"type": "object", "default": {"format": "data, not a keyword"}}
            },
            "$defs": {"Sub": {"type": "number"}}
        }));
        assert_eq!(plain(&raw), want);
    }
}
