//! Plain JSON Schema 2020-12 for the tools' input and output schemas.
//!
//! schemars writes what a strict validator or a model does not need and may not understand:
//! `$schema` and `title` boilerplate, and integer and float `format`s (`uint32`, `double`…)
//! that JSON Schema does not define. `plain` drops them, keeping a 32-bit integer's range as
//! `minimum`/`maximum` (schemars already gives the 8- and 16-bit ranges and unsigned minima).

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

/// `schema` as plain JSON Schema 2020-12: no `$schema`, no `title`, only standard `format`s.
pub(crate) fn plain(schema: &JsonObject) -> JsonObject {
    let mut schema = schema.clone();
    schema.remove("$schema");
    clean(&mut schema);
    schema
}

/// Cleans one schema object and, through the keywords that hold subschemas, all below it
/// (never `enum`, `const`, `default` or `examples`, whose values are data).
fn clean(schema: &mut JsonObject) {
    schema.remove("title");
    let format = schema.get("format").and_then(Value::as_str).map(str::to_owned);
    if let Some(format) = format.filter(|f| !STANDARD_FORMATS.contains(&f.as_str())) {
        schema.remove("format");
        let range = match format.as_str() {
            "int32" => Some((i64::from(i32::MIN), i64::from(i32::MAX))),
            "uint32" => Some((0, i64::from(u32::MAX))),
            _ => None,
        };
        if let Some((min, max)) = range {
            schema.entry("minimum").or_insert(min.into());
            schema.entry("maximum").or_insert(max.into());
        }
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
    fn drops_boilerplate_and_nonstandard_formats_at_every_depth() {
        let raw = object(json!({
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": "Thing",
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
                "id": {"type": "integer", "minimum": 0, "maximum": 4294967295u32},
                "at": {"type": "string", "format": "date-time"},
                "xs": {"type": "array", "items": {"type": "number"}},
                "n": {"anyOf": [{"type": "integer", "minimum": -2147483648i64, "maximum": 2147483647}, {"type": "null"}]},
                "big": {"type": "integer", "minimum": 0},
                "d": {"type": "object", "default": {"format": "data, not a keyword"}}
            },
            "$defs": {"Sub": {"type": "number"}}
        }));
        assert_eq!(plain(&raw), want);
    }
}
