//! The value types of tool parameters: strict about meaning, lenient about encoding (docs/tools.md
//! "Conventions"). Each type deserializes the encodings clients really send — a vector as a
//! JSON string holding the array (`"[0, 0, 1]"`), a scalar as a string holding its token
//! (`"false"`, `"240"`, `"0.5"`: the MCP Inspector CLI sends every argument so), an integral
//! float for an integer, gravity as `g`, `[g]` or `[gx, gy, gz]` — through the rules in
//! `value.rs` (ranges, f32 overflow, quaternion normalisation). Each one's JSON Schema is the
//! plain canonical type (`[f64; 3]`, `bool`, `u32`…), never the string forms, so tool schemas
//! stay what a model should send.
//!
//! An error names the parameter by `FIELD`, which `params::parse` replaces with the path of
//! the field that failed.

use std::borrow::Cow;
use std::marker::PhantomData;

use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer};
use serde_json::Value;

use crate::value::{self, Refusal};

/// Stands for the parameter's name in an error until `params::parse` knows which field failed.
pub(crate) const FIELD: &str = "\u{1}";

/// Deserializes a JSON value and reads it with `read`, naming the parameter `FIELD`.
fn read<'de, D: Deserializer<'de>, T>(d: D, read: impl FnOnce(&Value) -> Result<T, Refusal>) -> Result<T, D::Error> {
    let v = Value::deserialize(d)?;
    read(&v).map_err(D::Error::custom)
}

/// Declares a lenient parameter type: `Name(inner)` read by `$read` (a `value.rs` rule given
/// the parameter's name and value), with the JSON Schema of `$schema`.
macro_rules! lenient {
    ($(#[$doc:meta])* $name:ident($inner:ty) as $schema:ty, $read:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name(pub $inner);

        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let rule: fn(&str, &Value) -> Result<$inner, Refusal> = $read;
                read(d, |v| rule(FIELD, v)).map($name)
            }
        }

        impl JsonSchema for $name {
            fn inline_schema() -> bool {
                true
            }
            fn schema_name() -> Cow<'static, str> {
                <$schema>::schema_name()
            }
            fn json_schema(generator: &mut SchemaGenerator) -> Schema {
                <$schema>::json_schema(generator)
            }
        }
    };
}

lenient!(
    /// A vector `[x, y, z]` of finite numbers that fit f32.
    Vec3([f32; 3]) as [f64; 3],
    value::vec3
);
lenient!(
    /// A vector `[x, y, z]` at full precision (camera matrices are computed in f64).
    Vec3d([f64; 3]) as [f64; 3],
    |name, v| value::numbers64(name, v, "3 finite numbers [x, y, z]")
);
lenient!(
    /// A quaternion `[x, y, z, w]`, normalised; zero length is refused.
    Quat([f32; 4]) as [f64; 4],
    value::quat
);
lenient!(
    /// An RGB (alpha 1) or RGBA color, components in [0, 1].
    Color([f32; 4]) as Vec<f64>,
    value::color
);
lenient!(
    /// Gravity `[gx, gy, gz]`; a single number g or `[g]` means `[0, 0, g]`.
    Gravity([f32; 3]) as [f64; 3],
    value::gravity
);
lenient!(
    /// A finite number that fits f32.
    Num(f32) as f64,
    value::number
);
lenient!(
    /// A finite number > 0 (dimensions, radii, distances).
    Positive(f32) as f64,
    value::positive
);
lenient!(
    /// A finite number > 0 as the engine uses it (f32) and as the client gave it (f64):
    /// reported time is computed from the given value, as PyBullet does.
    PositiveGiven((f32, f64)) as f64,
    value::positive_given
);
lenient!(
    /// A finite number ≥ 0 (mass, friction, damping, gains).
    NonNegative(f32) as f64,
    value::non_negative
);
lenient!(
    /// A finite number at full precision.
    Num64(f64) as f64,
    value::number64
);
lenient!(
    /// A list of finite numbers, any length.
    NumList(Vec<f64>) as Vec<f64>,
    value::number_list
);
lenient!(
    /// A list of `[x, y, z]` vectors.
    Vec3List(Vec<[f32; 3]>) as Vec<[f64; 3]>,
    value::vec3_list
);
lenient!(
    /// A 4×4 matrix: 16 finite numbers, column-major.
    Matrix([f64; 16]) as Vec<f64>,
    |name, v| value::numbers64(name, v, "16 finite numbers (a 4x4 matrix, column-major)")
);
lenient!(
    /// true or false.
    Bool(bool) as bool,
    value::boolean
);
lenient!(
    /// A string (no other type is turned into one).
    Text(String) as String,
    |name, v| match v {
        Value::String(s) => Ok(s.clone()),
        other => Err(format!("{name} must be a string; got {}", value::show(other))),
    }
);
lenient!(
    /// A joint control mode as PyBullet spells it, normalised to its upper-case name: any
    /// case, with or without `_CONTROL` (`"position"`, `"Position_Control"`), or PyBullet's
    /// integer constant (`p.VELOCITY_CONTROL` 0, `TORQUE_CONTROL` 1, `POSITION_CONTROL` 2,
    /// `PD_CONTROL` 3, `STABLE_PD_CONTROL` 4); the tool says which modes it supports.
    ControlModeName(String) as String,
    |name, v| {
        const BY_NUMBER: [&str; 5] = ["VELOCITY_CONTROL", "TORQUE_CONTROL", "POSITION_CONTROL", "PD_CONTROL", "STABLE_PD_CONTROL"];
        match v {
            Value::String(s) if s.trim().parse::<i64>().is_err() => {
                let upper = s.trim().to_ascii_uppercase().replace([' ', '-'], "_");
                Ok(if upper.ends_with("_CONTROL") || upper.is_empty() { upper } else { format!("{upper}_CONTROL") })
            }
            Value::Number(_) | Value::String(_) => {
                let i = value::integer(name, v)?;
                usize::try_from(i).ok().and_then(|i| BY_NUMBER.get(i)).map(|s| (*s).to_string()).ok_or_else(|| {
                    format!("{name} must be POSITION_CONTROL, VELOCITY_CONTROL or TORQUE_CONTROL (PyBullet's 2, 0 or 1); got {i}")
                })
            }
            other => Err(format!("{name} must be a string such as POSITION_CONTROL; got {}", value::show(other))),
        }
    }
);
lenient!(
    /// An object id: an integer ≥ 0 (whether it exists is the world's question).
    ObjectId(u32) as u32,
    |name, v| {
        let i = value::integer(name, v)?;
        u32::try_from(i).map_err(|_| format!("{name} must be an object id (integer >= 0); got {}", value::show(v)))
    }
);

/// An integer (integral floats and integer strings too), described as the integer type `S`;
/// the range a tool needs is checked where the value is used, with its own sentence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Int<S>(pub i64, PhantomData<S>);

impl<S> Int<S> {
    /// The integer.
    pub fn get(self) -> i64 {
        self.0
    }
}

impl<'de, S> Deserialize<'de> for Int<S> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        read(d, |v| value::integer(FIELD, v)).map(|i| Int(i, PhantomData))
    }
}

impl<S: JsonSchema> JsonSchema for Int<S> {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> Cow<'static, str> {
        S::schema_name()
    }
    fn json_schema(generator: &mut SchemaGenerator) -> Schema {
        S::json_schema(generator)
    }
}

/// An optional integer with a default.
pub fn int_or<S>(v: Option<Int<S>>, default: i64) -> i64 {
    v.map_or(default, Int::get)
}

/// `link_index`: −1 (the base, the default) or a link index; the world checks the range.
pub fn link_index(v: Option<Int<i64>>) -> Result<i32, Refusal> {
    link_index_named(v, "link_index")
}

/// `link_index` for a parameter of another name (`link_index_a`, `link_index_b`).
pub fn link_index_named(v: Option<Int<i64>>, name: &str) -> Result<i32, Refusal> {
    let i = int_or(v, -1);
    i32::try_from(i).map_err(|_| format!("{name} must be -1 (base) or a link index; got {i}"))
}

/// How much of a result a model asked for (`detail`, one meaning on every tool that has it):
/// compact by default, everything with "full".
pub fn full_detail(detail: Option<&Text>) -> Result<bool, Refusal> {
    match detail.map(|t| t.0.as_str()) {
        None | Some("compact") => Ok(false),
        Some("full") => Ok(true),
        Some(other) => Err(format!("detail must be \"compact\" or \"full\"; got {other:?}")),
    }
}

/// A simulation's optional label (`name` on create, fork and load), checked as the log will
/// hold it (`value::label`).
pub fn label(name: Option<Text>) -> Result<Option<String>, Refusal> {
    name.map(|t| crate::value::label("name", &t.0).map(str::to_string)).transpose()
}

/// A camera in set_camera's terms, any of them given: `{distance, yaw, pitch, target}` (a
/// picture's result `camera` passes back as it is; its `source` is ignored).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CameraTerms {
    /// Distance to the target (m, > 0).
    pub distance: Option<f64>,
    /// Yaw (degrees).
    pub yaw: Option<f64>,
    /// Pitch (degrees).
    pub pitch: Option<f64>,
    /// Point looked at.
    pub target: Option<[f64; 3]>,
}

impl<'de> Deserialize<'de> for CameraTerms {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        read(d, |v| {
            // Some clients send objects as JSON strings, as they do arrays.
            let decoded = v.as_str().and_then(|s| serde_json::from_str::<Value>(s).ok());
            let v = decoded.as_ref().unwrap_or(v);
            let map = v.as_object().ok_or_else(|| format!("{FIELD} must be an object {{distance, yaw, pitch, target}}; got {}", value::show(v)))?;
            let mut t = CameraTerms::default();
            for (k, x) in map {
                let name = format!("{FIELD}.{k}");
                match k.as_str() {
                    "distance" => t.distance = Some(f64::from(value::positive(&name, x)?)),
                    "yaw" => t.yaw = Some(f64::from(value::number(&name, x)?)),
                    "pitch" => t.pitch = Some(f64::from(value::number(&name, x)?)),
                    "target" => t.target = Some(value::vec3(&name, x)?.map(f64::from)),
                    "source" => {}
                    other => return Err(format!("{FIELD} has no term {other}; give distance, yaw, pitch or target")),
                }
            }
            Ok(t)
        })
    }
}

impl JsonSchema for CameraTerms {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> Cow<'static, str> {
        "CameraTerms".into()
    }
    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        schemars::json_schema!({"type": "object"})
    }
}

/// The JSON Schema of set_actuator_controls' `controls`: a list or an object of numbers (the
/// rule says which), kept to one line of tools/list.
pub struct ControlsSchema;

impl JsonSchema for ControlsSchema {
    fn inline_schema() -> bool {
        true
    }
    fn schema_name() -> Cow<'static, str> {
        "Controls".into()
    }
    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        schemars::json_schema!({"type": ["array", "object"]})
    }
}

lenient!(
    /// Actuator controls: finite numbers in actuator order, or an object of them by name.
    Controls(crate::command::ActuatorControls) as ControlsSchema,
    |name, v| {
        use crate::command::ActuatorControls;
        match v {
            Value::Array(xs) => {
                let us = xs.iter().enumerate().map(|(i, x)| value::number64(&format!("{name}[{i}]"), x)).collect::<Result<_, _>>()?;
                Ok(ActuatorControls::InOrder(us))
            }
            Value::Object(by) => {
                let us = by.iter().map(|(k, x)| Ok((k.clone(), value::number64(&format!("{name}.{k}"), x)?))).collect::<Result<_, Refusal>>()?;
                Ok(ActuatorControls::ByName(us))
            }
            other => Err(format!(
                "{name} must be a list of numbers (one per actuator, in order) or an object of numbers by actuator name; got {}",
                value::show(other)
            )),
        }
    }
);
