//! Input parsing for tool arguments: strict about meaning, lenient about encoding.
//!
//! MCP clients send vectors as JSON arrays or as JSON strings holding an array, numbers as
//! integers or floats, and scalars as strings holding their token (`"false"`, `"10"`). Every
//! rule here accepts those encodings, rejects everything else with one sentence that names the
//! parameter, the expected shape and what was received, and turns the value into the f32 the
//! physics engine uses. The tools' parameter types (`physics_mcp::mcp::lenient`) read every
//! value through these rules, as do saved files of the old server. Nothing here touches the
//! world.

use serde_json::Value;

/// A one-sentence, client-facing explanation of why a call was refused.
pub type Refusal = String;

/// The JSON arguments of a tool call, as the client sent them.
pub type Args = serde_json::Map<String, Value>;

/// Renders a received value briefly for an error message (long values are cut).
pub fn show(v: &Value) -> String {
    let s = v.to_string();
    if s.chars().count() > 80 {
        let cut: String = s.chars().take(77).collect();
        format!("{cut}...")
    } else {
        s
    }
}

/// Looks an argument up, treating JSON `null` as absent (clients send both for "not given").
pub fn arg<'a>(args: &'a Args, name: &str) -> Option<&'a Value> {
    args.get(name).filter(|v| !v.is_null())
}

/// Fetches a required argument or says it is missing.
pub fn required<'a>(args: &'a Args, name: &str, shape: &str) -> Result<&'a Value, Refusal> {
    arg(args, name).ok_or_else(|| format!("{name} is required: {shape}"))
}

/// A finite JSON number as f64, or None for anything else (strings included).
fn finite(v: &Value) -> Option<f64> {
    v.as_f64().filter(|x| x.is_finite())
}

/// Converts f64 input to the engine's f32, refusing values that overflow f32 to infinity.
fn to_f32(x: f64) -> Option<f32> {
    let y = x as f32;
    y.is_finite().then_some(y)
}

/// Some clients (the MCP Inspector CLI) send every scalar as a string: `"true"`, `"10"`, `"0.5"`.
/// A string that is, as a whole, one JSON number or boolean token is read as that token;
/// anything else (`" 1"`, `"NaN"`, `"abc"`, `"[1]"`) stays a string, which a scalar refuses.
/// Only top-level scalars: numeric strings inside a vector stay refused.
pub fn scalar(v: &Value) -> std::borrow::Cow<'_, Value> {
    if let Value::String(s) = v {
        let token = !s.is_empty() && s.trim() == s;
        if let Some(inner) = token.then(|| serde_json::from_str::<Value>(s).ok()).flatten() {
            if inner.is_number() || inner.is_boolean() {
                return std::borrow::Cow::Owned(inner);
            }
        }
    }
    std::borrow::Cow::Borrowed(v)
}

/// Some clients send arrays as JSON strings (`"[0, 0, 1]"`): decode those, pass others through.
/// None when a string does not hold JSON.
fn decode_string(v: &Value) -> Option<std::borrow::Cow<'_, Value>> {
    match v {
        Value::String(s) => serde_json::from_str(s).ok().map(std::borrow::Cow::Owned),
        other => Some(std::borrow::Cow::Borrowed(other)),
    }
}

/// Reads an array of exactly `n` finite numbers; a JSON string holding such an array is accepted.
fn fixed_array(name: &str, v: &Value, n: usize, shape: &str) -> Result<Vec<f32>, Refusal> {
    let fail = || format!("{name} must be {shape}; got {}", show(v));
    let inner = decode_string(v).ok_or_else(fail)?;
    let items = inner.as_array().ok_or_else(fail)?;
    if items.len() != n {
        return Err(fail());
    }
    items
        .iter()
        .map(|x| finite(x).and_then(to_f32).ok_or_else(fail))
        .collect()
}

/// Reads a vector `[x, y, z]` of finite numbers.
pub fn vec3(name: &str, v: &Value) -> Result<[f32; 3], Refusal> {
    let a = fixed_array(name, v, 3, "3 finite numbers [x, y, z]")?;
    Ok([a[0], a[1], a[2]])
}

/// Reads a quaternion `[x, y, z, w]` and normalises it; a zero-length quaternion is refused.
pub fn quat(name: &str, v: &Value) -> Result<[f32; 4], Refusal> {
    let a = fixed_array(name, v, 4, "4 finite numbers [x, y, z, w] (a quaternion)")?;
    let norm = a.iter().map(|x| (*x as f64) * (*x as f64)).sum::<f64>().sqrt();
    if norm.is_nan() || norm <= 1e-12 || !norm.is_finite() {
        return Err(format!(
            "{name} must be a non-zero quaternion [x, y, z, w]; got {}",
            show(v)
        ));
    }
    Ok([
        (a[0] as f64 / norm) as f32,
        (a[1] as f64 / norm) as f32,
        (a[2] as f64 / norm) as f32,
        (a[3] as f64 / norm) as f32,
    ])
}

/// Reads an RGB or RGBA color with components in [0, 1]; RGB gets alpha 1.
pub fn color(name: &str, v: &Value) -> Result<[f32; 4], Refusal> {
    let shape = "3 or 4 numbers in [0, 1] (RGB or RGBA)";
    let len = decode_string(v)
        .and_then(|x| x.as_array().map(|a| a.len()))
        .unwrap_or(0);
    let n = if len == 3 { 3 } else { 4 };
    let a = fixed_array(name, v, n, shape)?;
    if a.iter().any(|c| !(0.0..=1.0).contains(c)) {
        return Err(format!("{name} must be {shape}; got {}", show(v)));
    }
    Ok([a[0], a[1], a[2], if n == 4 { a[3] } else { 1.0 }])
}

/// Reads gravity: `[gx, gy, gz]`, a single number g, or `[g]` (both meaning `[0, 0, g]`).
pub fn gravity(name: &str, v: &Value) -> Result<[f32; 3], Refusal> {
    let fail = || {
        format!(
            "{name} must be 3 finite numbers [x, y, z] or a single number g (meaning [0, 0, g]); got {}",
            show(v)
        )
    };
    if let Some(g) = finite(&scalar(v)) {
        return Ok([0.0, 0.0, to_f32(g).ok_or_else(fail)?]);
    }
    let inner = decode_string(v).ok_or_else(fail)?;
    match inner.as_array().map(|a| a.len()) {
        Some(1) => {
            let g = fixed_array(name, &inner, 1, "1 number").map_err(|_| fail())?[0];
            Ok([0.0, 0.0, g])
        }
        Some(3) => vec3(name, &inner).map_err(|_| fail()),
        _ => Err(fail()),
    }
}

/// Reads a finite number, refusing strings, booleans and out-of-range values.
pub fn number(name: &str, v: &Value) -> Result<f32, Refusal> {
    finite(&scalar(v))
        .and_then(to_f32)
        .ok_or_else(|| format!("{name} must be a finite number; got {}", show(v)))
}

/// Reads a number that must be finite and > 0 (dimensions, radii, timesteps).
pub fn positive(name: &str, v: &Value) -> Result<f32, Refusal> {
    let x = number(name, v)?;
    if x > 0.0 {
        Ok(x)
    } else {
        Err(format!("{name} must be a finite number > 0; got {}", show(v)))
    }
}

/// `positive`, plus the value exactly as the client gave it (f64): a timestep runs in f32 but
/// reported time is computed from the given value, as PyBullet does.
pub fn positive_given(name: &str, v: &Value) -> Result<(f32, f64), Refusal> {
    let x = positive(name, v)?;
    Ok((x, finite(&scalar(v)).unwrap_or(x as f64)))
}

/// Reads a number that must be finite and ≥ 0 (mass, friction, damping).
pub fn non_negative(name: &str, v: &Value) -> Result<f32, Refusal> {
    let x = number(name, v)?;
    if x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("{name} must be a finite number >= 0; got {}", show(v)))
    }
}

/// Reads a list of finite numbers (any length; a JSON string holding one is accepted), as
/// f64 for the callers that compute with them (IK limits and poses, generated URDFs).
pub fn number_list(name: &str, v: &Value) -> Result<Vec<f64>, Refusal> {
    let fail = || format!("{name} must be a list of finite numbers; got {}", show(v));
    let inner = decode_string(v).ok_or_else(fail)?;
    let items = inner.as_array().ok_or_else(fail)?;
    items.iter().map(|x| finite(x).ok_or_else(fail)).collect()
}

/// Reads a finite number at full precision (camera matrices are computed in f64).
pub fn number64(name: &str, v: &Value) -> Result<f64, Refusal> {
    finite(&scalar(v)).ok_or_else(|| format!("{name} must be a finite number; got {}", show(v)))
}

/// Reads exactly `n` finite numbers at full precision (`shape` describes them for the error).
pub fn numbers64<const N: usize>(name: &str, v: &Value, shape: &str) -> Result<[f64; N], Refusal> {
    let fail = || format!("{name} must be {shape}; got {}", show(v));
    let list = number_list(name, v).map_err(|_| fail())?;
    list.try_into().map_err(|_| fail())
}

/// Reads a list of `[x, y, z]` vectors (a JSON string holding the list is accepted too).
pub fn vec3_list(name: &str, v: &Value) -> Result<Vec<[f32; 3]>, Refusal> {
    let fail = || format!("{name} must be a list of [x, y, z] vectors; got {}", show(v));
    let inner = decode_string(v).ok_or_else(fail)?;
    let items = inner.as_array().ok_or_else(fail)?;
    items
        .iter()
        .enumerate()
        .map(|(i, x)| vec3(&format!("{name}[{i}]"), x))
        .collect()
}

/// Reads an integer; integral floats (`10.0`) are accepted, `10.5` and strings are not.
pub fn integer(name: &str, v: &Value) -> Result<i64, Refusal> {
    let fail = || format!("{name} must be an integer; got {}", show(v));
    let s = scalar(v);
    if let Some(i) = s.as_i64() {
        return Ok(i);
    }
    match finite(&s) {
        Some(x) if x.fract() == 0.0 && x.abs() < 9.0e15 => Ok(x as i64),
        _ => Err(fail()),
    }
}

/// Reads a boolean (`"true"` / `"false"` strings too, see `scalar`).
pub fn boolean(name: &str, v: &Value) -> Result<bool, Refusal> {
    scalar(v).as_bool().ok_or_else(|| format!("{name} must be true or false; got {}", show(v)))
}

/// Longest simulation label, in characters: a label is for a person to tell runs apart.
pub const MAX_LABEL_CHARS: usize = 100;

/// A simulation's label (`name` on create, fork and load): 1–100 characters, no control
/// characters, so it reads on one line wherever ids are shown.
pub fn label<'a>(name: &str, v: &'a str) -> Result<&'a str, Refusal> {
    let n = v.chars().count();
    if v.trim().is_empty() || n > MAX_LABEL_CHARS {
        return Err(format!("{name} must be 1-{MAX_LABEL_CHARS} characters on one line, not blank; got {n} characters"));
    }
    if let Some(c) = v.chars().find(|c| breaks_a_line(*c)) {
        return Err(format!("{name} must be 1-{MAX_LABEL_CHARS} characters on one line; it holds U+{:04X}", c as u32));
    }
    Ok(v)
}

/// Characters that break a line or change how the text around them is shown: controls, line
/// and paragraph separators, zero-width and bidirectional formatting marks.
fn breaks_a_line(c: char) -> bool {
    c.is_control() || matches!(c, '\u{2028}' | '\u{2029}' | '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2060}'..='\u{2064}' | '\u{2066}'..='\u{2069}' | '\u{FEFF}')
}

/// Reads a required string argument.
pub fn string(args: &Args, name: &str) -> Result<String, Refusal> {
    match required(args, name, "a string")? {
        Value::String(s) => Ok(s.clone()),
        v => Err(format!("{name} must be a string; got {}", show(v))),
    }
}

/// Reports an f32 as the f64 with the same shortest decimal form, so results read `0.1`, not
/// `0.10000000149011612` (serde_json widens f32 to f64 before printing).
///
/// A non-finite value (only a bug or a corrupt state makes one) stays non-finite: serde_json
/// writes it as JSON `null`, which no client can mistake for a measurement, and a typed result
/// refuses to decode it; turning it into 0 would report a plausible, wrong number.
pub fn r32(x: f32) -> f64 {
    if !x.is_finite() {
        return f64::from(x);
    }
    format!("{x}").parse::<f64>().unwrap_or(f64::from(x))
}

/// `r32` over a fixed-size array.
pub fn r32s<const N: usize>(a: [f32; N]) -> [f64; N] {
    a.map(r32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn non_finite_results_are_null_not_zero() {
        assert!(r32(f32::NAN).is_nan());
        assert_eq!(r32(f32::NEG_INFINITY), f64::NEG_INFINITY);
        assert_eq!(json!(r32s([0.1, f32::INFINITY, f32::NAN])), json!([0.1, null, null]));
    }

    #[test]
    fn vectors_accept_arrays_and_json_strings_only() {
        assert_eq!(vec3("p", &json!([1, 2.5, -3])).unwrap(), [1.0, 2.5, -3.0]);
        assert_eq!(vec3("p", &json!("[0, 0, 1]")).unwrap(), [0.0, 0.0, 1.0]);
        let e = vec3("position", &json!([1, 2])).unwrap_err();
        assert_eq!(e, "position must be 3 finite numbers [x, y, z]; got [1,2]");
        assert!(vec3("p", &json!(["1", "2", "3"])).is_err());
        assert!(vec3("p", &json!([1e39, 0, 0])).is_err(), "overflows f32");
        assert!(vec3("p", &json!("nan")).is_err());
    }

    #[test]
    fn gravity_shorthands() {
        assert_eq!(gravity("g", &json!(-9.81)).unwrap(), [0.0, 0.0, -9.81]);
        assert_eq!(gravity("g", &json!([-9.81])).unwrap(), [0.0, 0.0, -9.81]);
        assert_eq!(gravity("g", &json!([0, -9.81, 0])).unwrap(), [0.0, -9.81, 0.0]);
        assert_eq!(gravity("g", &json!("-9.81")).unwrap(), [0.0, 0.0, -9.81]);
        assert_eq!(gravity("g", &json!("[-9.81]")).unwrap(), [0.0, 0.0, -9.81]);
        assert!(gravity("g", &json!([1, 2])).is_err());
    }

    #[test]
    fn quaternions_normalise_and_refuse_zero() {
        let q = quat("q", &json!([0, 0, 0, 2])).unwrap();
        assert_eq!(q, [0.0, 0.0, 0.0, 1.0]);
        assert!(quat("q", &json!([0, 0, 0, 0])).is_err());
    }

    #[test]
    fn integers_accept_integral_floats() {
        assert_eq!(integer("n", &json!(10.0)).unwrap(), 10);
        assert!(integer("n", &json!(10.5)).is_err());
        assert!(integer("n", &json!(" 10")).is_err());
        assert!(integer("n", &json!("abc")).is_err());
    }

    #[test]
    fn scalars_in_strings_are_read_as_their_token() {
        assert_eq!(integer("n", &json!("240")).unwrap(), 240);
        assert_eq!(integer("n", &json!("10.0")).unwrap(), 10);
        assert_eq!(number("x", &json!("0.5")).unwrap(), 0.5);
        assert!(boolean("b", &json!("false")).is_ok_and(|b| !b));
        for bad in ["NaN", "inf", "1e39", " 1", "", "[1]", "\"1\""] {
            assert!(number("x", &json!(bad)).is_err(), "{bad:?}");
        }
        assert!(boolean("b", &json!("yes")).is_err());
        assert!(vec3("p", &json!(["1", "2", "3"])).is_err(), "only top-level scalars");
    }

    #[test]
    fn shortest_f32_rendering() {
        assert_eq!(serde_json::to_string(&r32(0.1f32)).unwrap(), "0.1");
        assert_eq!(r32(1.0 / 240.0), 0.004166667);
    }
}
