//! The one-line summary a read event records of what it returned (schema v3's `summary`
//! column), shown by get_history so a model looking back sees what a read saw without asking
//! again. One generic rendering of any result: its top-level scalars and short arrays as
//! `key=value`, numbers to 4 significant digits (at most 4 decimals), bigger parts by their
//! size, the whole cut to `MAX_CHARS`. It is a convenience for readers and part of no hash.

use serde_json::Value;

/// Longest summary, in characters.
pub const MAX_CHARS: usize = 160;

/// Arrays of at most this many scalars are shown in full; longer ones by their length.
const SHORT_ARRAY: usize = 6;

/// Strings longer than this (in characters) are cut.
const SHORT_STRING: usize = 40;

/// One line (at most `MAX_CHARS` characters) describing `v`: for an object, its scalar fields
/// then its short arrays as `key=value` (each group in key order), then its bigger fields by
/// their size (`contacts=[12 items]`, `info={5 fields}`).
pub fn one_line(v: &Value) -> String {
    let text = match v {
        Value::Object(m) if m.is_empty() => "{}".to_string(),
        Value::Object(m) => {
            // Scalars (ids, counts, flags) first, then short arrays, then the rest by size.
            let rank = |x: &Value| match x {
                Value::Array(_) if inline(x).is_some() => 1,
                Value::Array(_) | Value::Object(_) => 2,
                _ => 0,
            };
            let mut fields: Vec<(&String, &Value)> = m.iter().collect();
            fields.sort_by_key(|(_, x)| rank(x));
            fields
                .iter()
                .map(|(k, x)| format!("{k}={}", inline(x).unwrap_or_else(|| size_of(x))))
                .collect::<Vec<_>>()
                .join(" ")
        }
        other => inline(other).unwrap_or_else(|| size_of(other)),
    };
    cut(&text, MAX_CHARS)
}

/// `text` cut to at most `max` characters, ending in "…" when cut.
pub fn cut(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        return text.to_string();
    }
    let mut out: String = text.chars().take(max.saturating_sub(1)).collect();
    out.push('…');
    out
}

/// A scalar, or an array of a few scalars, as shown inline; `None` for anything bigger.
fn inline(v: &Value) -> Option<String> {
    match v {
        Value::Array(items) if items.len() <= SHORT_ARRAY => {
            let shown: Option<Vec<String>> = items.iter().map(scalar).collect();
            shown.map(|s| format!("[{}]", s.join(",")))
        }
        other => scalar(other),
    }
}

/// An array or object by its size.
fn size_of(v: &Value) -> String {
    match v {
        Value::Array(items) if items.len() == 1 => "[1 item]".to_string(),
        Value::Array(items) => format!("[{} items]", items.len()),
        Value::Object(m) if m.len() == 1 => "{1 field}".to_string(),
        Value::Object(m) => format!("{{{} fields}}", m.len()),
        other => scalar(other).unwrap_or_default(),
    }
}

fn scalar(v: &Value) -> Option<String> {
    Some(match v {
        Value::Null => "null".to_string(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) if n.is_f64() => number(n.as_f64().unwrap_or(0.0)),
        Value::Number(n) => n.to_string(),
        Value::String(s) => string(s),
        Value::Array(_) | Value::Object(_) => return None,
    })
}

/// Hex characters of a hash shown where a short form will do (get_history's default, read
/// summaries, the `history` CLI): enough to tell states apart at a glance.
pub const SHORT_HASH: usize = 12;

/// `s`'s short form if it is a 64-hex hash (a state or result hash), else None.
pub fn short_hash(s: &str) -> Option<&str> {
    (s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit())).then(|| &s[..SHORT_HASH])
}

/// A string: a 64-hex hash by its short form (as get_history shows hashes), a long one cut;
/// quoted (JSON) when it is empty or holds spaces, '=' or ',' so it reads as one value.
fn string(s: &str) -> String {
    let s = match short_hash(s) {
        Some(short) => short.to_string(),
        None => cut(s, SHORT_STRING),
    };
    if s.is_empty() || s.chars().any(|c| c.is_whitespace() || c.is_control() || matches!(c, '=' | ',' | '"')) {
        serde_json::to_string(&s).unwrap_or(s)
    } else {
        s
    }
}

/// Below this a number is shown as 0 (float noise such as -2.8e-17); between it and what 4
/// decimals show, in scientific notation.
const TINY: f64 = 1e-9;

/// `x` to at most 4 significant digits and at most 4 decimals (0.1 mm, as get_trajectory's
/// default precision), without trailing zeros; whole numbers keep all their digits.
fn number(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    let magnitude = if x == 0.0 { 0 } else { x.abs().log10().floor() as i32 };
    let decimals = (3 - magnitude).clamp(0, 4) as usize;
    match trim_zeros(&format!("{x:.decimals$}")) {
        // Below 4 decimals but not noise (a 1e-5 kg mass is not a static body's 0): say so.
        "0" | "-0" if x.abs() >= TINY => format!("{x:.1e}"),
        "-0" => "0".to_string(),
        shown => shown.to_string(),
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(number(0.0), "0");
        assert_eq!(number(-0.0), "0");
        assert_eq!(number(0.123456), "0.1235");
        assert_eq!(number(1.0), "1");
        assert_eq!(number(-9.80665), "-9.807");
        assert_eq!(number(12345.678), "12346");
        assert_eq!(number(0.06857), "0.0686");
        assert_eq!(number(-0.000396), "-0.0004");
        assert_eq!(number(0.00004), "4.0e-5");
        assert_eq!(number(-1e-5), "-1.0e-5");
        assert_eq!(number(-2.8e-17), "0");
    }

    #[test]
    fn an_object_shows_its_scalars_and_short_arrays_then_the_rest_by_size() {
        let v = json!({
            "object_id": 2,
            "position": [0.0, 1.0, 0.49999912],
            "contacts": [{}, {}, {}],
            "joints": [1, 2, 3, 4, 5, 6, 7],
            "state_hash": "ab".repeat(32),
            "name": "a box",
            "in_contact": false,
        });
        assert_eq!(
            one_line(&v),
            "in_contact=false name=\"a box\" object_id=2 state_hash=abababababab position=[0,1,0.5] contacts=[3 items] joints=[7 items]"
        );
        assert_eq!(one_line(&json!({})), "{}");
        assert_eq!(one_line(&json!([1, 2])), "[1,2]");
        assert_eq!(one_line(&json!({"info": {"a": 1}})), "info={1 field}");
    }

    #[test]
    fn a_summary_is_one_line_of_at_most_160_characters() {
        let v = json!({"text": "line one\nline two", "many": (0..100).map(|i| (format!("k{i}"), json!(i))).collect::<serde_json::Map<_, _>>()});
        let s = one_line(&v);
        assert!(!s.contains('\n'), "{s}");
        let wide: serde_json::Map<String, Value> = (0..100).map(|i| (format!("field{i:03}"), json!(i as f64 / 3.0))).collect();
        let s = one_line(&Value::Object(wide));
        assert_eq!(s.chars().count(), MAX_CHARS);
        assert!(s.ends_with('…') && s.starts_with("field000=0 field001=0.3333 field002=0.6667"), "{s}");
    }
}
