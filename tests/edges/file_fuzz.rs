//! Whatever a model file holds, loading it cannot hurt the server. A seeded fuzzer writes
//! files into the real server's workspace and loads them over HTTP with load_mjcf, load_urdf
//! and load_simulation: mutations of every fixture model (MJCF, URDF, their STL/OBJ meshes and
//! MJCF includes) and of a saved JSON (its fields, and the models and meshes it carries as
//! blobs) — byte flips, truncations, duplicated and deleted spans, inserted elements and
//! attributes, numbers swapped for NaN/1e39/-0/huge, unicode, deep nesting — and, every run, a
//! table of hostile constructs: absolute, `..`, `package://` and `file://` references out of
//! the workspace, symlinks out of it and to /dev/zero, FIFOs and directories where a file is
//! expected, files over the size limits, deeply nested XML and a long joint chain, entity
//! expansion and external entities, include cycles, an STL claiming 10^9 triangles, OBJ
//! indices out of range, a saved history whose model names a file outside. For every call: an
//! answer arrives within 60 s; it is a result or a refusal in one sentence (no panic text, no
//! "Internal error", no backtrace); a refusal leaves the simulation's state hash and head as
//! they were and logs no change (a refused load_simulation creates nothing); a construct that
//! reaches out of the workspace or at a file that is not regular is refused; the server stays
//! up and prints no panic; no reply and no log holds text of a file outside the workspace; a
//! model that loads also steps, and its simulation verifies. At the end, after a SIGTERM
//! restart, nothing is damaged, every simulation kept verifies and every log replays.
//!
//! `PHYSICS_SEED=N` replays a run; `PHYSICS_FUZZ_ROUNDS=N` sets the number of mutated inputs
//! (default 1,000). A failure keeps the test's directory and prints the input's path. The
//! defects it found (deep XML aborting the server, numbers in models panicking the engine,
//! a 10,000-link chain stepping for hours, saved histories adopted unchecked) are fixed and
//! stay among its inputs, each written down where it is made.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use base64::Engine as _;
use common::hard::{assert_unchanged, exited, fingerprint, listed, rng, seed};
use common::{Client, Server};
use futures::FutureExt as _;
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rmcp::model::CallToolRequestParams;
use serde_json::{json, Value};

/// Text planted in every file outside the workspace: no reply and no log may ever hold it.
const MARKER: &str = "OUTSIDE-THE-WORKSPACE-7c1e9d";
/// Each call must be answered within this (a hang is a failure naming the input).
const WATCHDOG: Duration = Duration::from_secs(60);
/// The server's limits on model and mesh files (src/urdf_files.rs).
const MODEL_LIMIT: u64 = 8 << 20;
const MESH_LIMIT: u64 = 64 << 20;
/// Simulations kept for the final verify-and-replay (a sample; see `Fuzz::keep`).
const KEPT: usize = 120;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

fn fifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(ok.success(), "mkfifo {}", path.display());
}

fn symlink(target: &Path, link: &Path) {
    std::os::unix::fs::symlink(target, link).unwrap_or_else(|e| panic!("symlink {}: {e}", link.display()));
}

/// A file of `len` bytes that starts with `head` and is a hole after it (no disk used).
fn sparse(path: &Path, head: &[u8], len: u64) {
    std::fs::write(path, head).unwrap();
    std::fs::OpenOptions::new().write(true).open(path).unwrap().set_len(len).unwrap();
}

/// A binary STL: `triangles` as written, with `claimed` in the header's count.
fn stl(triangles: &[[[f32; 3]; 3]], claimed: u32) -> Vec<u8> {
    let mut b = vec![b' '; 80];
    b.extend(claimed.to_le_bytes());
    for t in triangles {
        b.extend([0f32; 3].iter().flat_map(|x| x.to_le_bytes()));
        for v in t {
            b.extend(v.iter().flat_map(|x| x.to_le_bytes()));
        }
        b.extend([0u8; 2]);
    }
    b
}

const TETRA: [[[f32; 3]; 3]; 4] = [
    [[0.0, 0.0, 0.0], [0.0, 0.1, 0.0], [0.1, 0.0, 0.0]],
    [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 0.1]],
    [[0.0, 0.0, 0.0], [0.0, 0.0, 0.1], [0.0, 0.1, 0.0]],
    [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]],
];

// ---------------------------------------------------------------------------------------------
// Mutations
// ---------------------------------------------------------------------------------------------

/// Replacements for a number.
const NUMBERS: &[&str] = &[
    "NaN", "nan", "inf", "-inf", "Infinity", "1e39", "-1e39", "-0", "0", "1e308", "-1e308", "1e-45", "1e-320",
    "99999999999999999999999999", "-1", "4294967296", "1e9", "-2147483649", "", "0x10", "1,5", "+1", "1e", ".", "-", "1e400",
];

/// Unicode (and a few characters XML does not allow).
const UNICODE: &[&str] = &["💥", "\u{202e}", "名前", "\u{200b}", "e\u{301}", "\u{fffd}", "𝔘𝔫𝔦", "\u{7f}", "\t", "ﬁ", "\u{1}", "\u{feff}"];

/// Elements an MJCF mutation inserts (`{out}` is the outside folder).
const MJCF_ELEMENTS: &[&str] = &[
    r#"<body name="fz"><geom size="0.1"/></body>"#,
    r#"<body><joint type="ball"/><geom size="0.1"/></body>"#,
    r#"<body><freejoint/><geom type="box" size="0 0 0"/></body>"#,
    r#"<geom type="mesh" mesh="nosuch"/>"#,
    r#"<geom type="hfield" hfield="h"/>"#,
    r#"<geom type="sdf"/>"#,
    r#"<geom type="cylinder" fromto="0 0 0 0 0 0" size="0.1"/>"#,
    r#"<geom type="capsule" size="-1"/>"#,
    r#"<geom type="ellipsoid" size="1e39 1 1"/>"#,
    r#"<geom type="plane" size="0 0 0" mass="NaN"/>"#,
    r#"<joint type="slide" axis="0 0 0"/>"#,
    r#"<joint type="hinge" range="1 -1" limited="true"/>"#,
    r#"<site name="s"/>"#,
    r#"<camera/><light/>"#,
    r#"<inertial mass="0" diaginertia="0 0 0" pos="0 0 0"/>"#,
    r#"<inertial mass="-1" fullinertia="1 1 1 2 2 2" pos="0 0 0"/>"#,
    r#"<include file="nosuch.xml"/>"#,
    r#"<include file="{out}/secret.xml"/>"#,
    r#"<include file="../../outside/secret.xml"/>"#,
    r#"<include file="model.xml"/>"#,
    r#"<mesh name="m" file="../../outside/secret.stl"/>"#,
    r#"<mesh name="m2" file="{out}/secret.obj"/>"#,
    r#"<hfield name="h" file="../../outside/secret.png"/>"#,
    r#"<texture name="t" file="{out}/secret.png"/>"#,
    r#"<skin file="../../outside/secret.skn"/>"#,
    r#"<model name="sub" file="{out}/secret.xml"/>"#,
    r#"<tendon><spatial><site site="s"/></spatial></tendon>"#,
    r#"<equality><weld body1="nosuch"/></equality>"#,
    r#"<contact><exclude body1="nosuch" body2="x"/></contact>"#,
    r#"<actuator><motor joint="nosuch"/></actuator>"#,
    r#"<sensor><jointpos joint="nosuch"/></sensor>"#,
    r#"<sensor><force site="nosuch"/><framepos objtype="body" objname="world"/><subtreecom body="world"/><gyro/><actuatorfrc actuator="nosuch"/></sensor>"#,
    r#"<keyframe><key name="k" qpos="1 2 3 NaN"/></keyframe>"#,
    r#"<default class="fz"><geom size="0.1"/></default>"#,
    r#"<compiler angle="degree" eulerseq="zyx" autolimits="false" meshdir="/"/>"#,
    r#"<compiler meshdir="{out}" assetdir="../../outside"/>"#,
    r#"<option timestep="0" gravity="NaN 0 0"/>"#,
    r#"<flexcomp name="f"/>"#,
    r#"<composite type="grid"/>"#,
    r#"<plugin plugin="x"/>"#,
    r#"<replicate count="1000000"><geom size="0.1"/></replicate>"#,
    r#"<replicate count="100"><replicate count="100"><replicate count="100"><geom size="0.1"/></replicate></replicate></replicate>"#,
    r#"<frame pos="1 0 0"><geom size="0.1"/></frame>"#,
    r#"<attach model="sub" body="b" prefix="p"/>"#,
    r#"<!-- comment -->"#,
    r#"<![CDATA[ <body> ]]>"#,
];

/// Elements a URDF mutation inserts.
const URDF_ELEMENTS: &[&str] = &[
    r#"<link name="fz"/>"#,
    r#"<link name="base"/>"#,
    r#"<joint name="fzj" type="revolute"><parent link="nosuch"/><child link="fz"/></joint>"#,
    r#"<joint name="fzj2" type="floating"><parent link="a"/><child link="a"/></joint>"#,
    r#"<joint name="fzj3" type="planar"/>"#,
    r#"<limit lower="NaN" upper="-inf" effort="-1" velocity="1e39"/>"#,
    r#"<mimic joint="x" multiplier="NaN"/>"#,
    r#"<inertial><mass value="-1"/><inertia ixx="NaN" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>"#,
    r#"<collision><geometry><mesh filename="../../outside/secret.stl"/></geometry></collision>"#,
    r#"<collision><geometry><mesh filename="file://{out}/secret.stl"/></geometry></collision>"#,
    r#"<visual><geometry><mesh filename="package://pkg/../../../outside/secret.obj"/></geometry></visual>"#,
    r#"<collision><geometry><mesh filename="package://nosuch/x.stl" scale="NaN 0 -1"/></geometry></collision>"#,
    r#"<visual><geometry><box size="0 0 0"/></geometry></visual>"#,
    r#"<collision><geometry><cylinder radius="-1" length="1e39"/></geometry></collision>"#,
    r#"<collision><geometry><sphere radius="NaN"/></geometry></collision>"#,
    r#"<collision><geometry><capsule radius="1" length="1"/></geometry></collision>"#,
    r#"<origin xyz="NaN 0 0" rpy="1e39 0 0"/>"#,
    r#"<axis xyz="0 0 0"/>"#,
    r#"<dynamics damping="-1" friction="NaN"/>"#,
    r#"<safety_controller/>"#,
    r#"<transmission name="t"><type>x</type></transmission>"#,
    r#"<gazebo reference="x"/>"#,
    r#"<material name="m"><color rgba="2 -1 NaN 1"/></material>"#,
    r#"<!-- comment -->"#,
];

/// Attribute names an inserted attribute takes.
const ATTRIBUTES: &[&str] = &[
    "name", "pos", "size", "mass", "range", "class", "childclass", "quat", "euler", "axisangle", "xyaxes", "zaxis", "fromto", "type",
    "joint", "inertia", "density", "scale", "limited", "file", "mesh", "ref", "armature", "damping", "friction", "contype",
    "conaffinity", "condim", "rgba", "xyz", "rpy", "filename", "link", "value", "lower", "upper", "effort", "velocity", "meshdir",
    "axis", "springref", "stiffness", "margin", "gap", "frictionloss", "diaginertia", "fullinertia", "refpos", "refquat", "vertex", "face",
];

/// Values an inserted attribute takes.
fn attribute_value(rng: &mut ChaCha8Rng) -> String {
    match rng.gen_range(0..8) {
        0 => NUMBERS.choose(rng).unwrap().to_string(),
        1 => vec![*NUMBERS.choose(rng).unwrap(); rng.gen_range(1..8)].join(" "),
        2 => "../../outside/secret.stl".into(),
        3 => "x".repeat(rng.gen_range(1..20_000)),
        4 => UNICODE.choose(rng).unwrap().to_string(),
        5 => "1 2".into(),
        6 => "0 0 0 0".into(),
        _ => "true".into(),
    }
}

/// Spans of number tokens (`-1.5e3`, `.5`).
fn numbers(b: &[u8]) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit() || (matches!(b[i], b'-' | b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        let inside_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !inside_word {
            let start = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || matches!(b[i], b'.' | b'e' | b'E' | b'-' | b'+')) {
                i += 1;
            }
            out.push(start..i);
        } else {
            i += 1;
        }
    }
    out
}

/// Positions just after a tag's name (`<body|`), where an attribute can go.
fn tag_name_ends(b: &[u8]) -> Vec<usize> {
    let mut out = Vec::new();
    for i in 0..b.len() {
        if b[i] == b'<' && b.get(i + 1).is_some_and(u8::is_ascii_alphabetic) {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_alphanumeric() || matches!(b[j], b'_' | b'-' | b':')) {
                j += 1;
            }
            out.push(j);
        }
    }
    out
}

/// Positions just after a `>`, where an element can go.
fn element_ends(b: &[u8]) -> Vec<usize> {
    b.iter().enumerate().filter(|(_, c)| **c == b'>').map(|(i, _)| i + 1).collect()
}

fn pick(rng: &mut ChaCha8Rng, v: &[usize], len: usize) -> usize {
    v.choose(rng).copied().unwrap_or_else(|| rng.gen_range(0..=len))
}

/// One mutation of an XML text (MJCF when `mjcf`, else URDF), described.
fn mutate_xml(rng: &mut ChaCha8Rng, b: &mut Vec<u8>, mjcf: bool, out: &str) -> String {
    let len = b.len();
    match rng.gen_range(0..13) {
        0 if len > 0 => {
            let (at, mask) = (rng.gen_range(0..len), rng.gen_range(1..=255u8));
            b[at] ^= mask;
            format!("flip byte {at} ^ {mask:#x}")
        }
        1 => {
            let at = rng.gen_range(0..=len);
            b.truncate(at);
            format!("truncate at {at}")
        }
        2 if len > 0 => {
            let a = rng.gen_range(0..len);
            let e = (a + rng.gen_range(1..2000)).min(len);
            let span = b[a..e].to_vec();
            let to = rng.gen_range(0..=len);
            let times = if rng.gen_bool(0.1) { rng.gen_range(2..200) } else { 1 };
            for _ in 0..times {
                b.splice(to..to, span.iter().copied());
            }
            format!("duplicate bytes {a}..{e} at {to} x{times}")
        }
        3 if len > 0 => {
            let a = rng.gen_range(0..len);
            let e = (a + rng.gen_range(1..500)).min(len);
            b.drain(a..e);
            format!("delete bytes {a}..{e}")
        }
        4 | 5 => {
            let table = if mjcf { MJCF_ELEMENTS } else { URDF_ELEMENTS };
            let el = table.choose(rng).unwrap().replace("{out}", out);
            let at = pick(rng, &element_ends(b), len);
            b.splice(at..at, el.bytes());
            format!("insert {el} at {at}")
        }
        6 | 7 => {
            let (name, value) = (ATTRIBUTES.choose(rng).unwrap(), attribute_value(rng));
            let at = pick(rng, &tag_name_ends(b), len);
            let attr = format!(" {name}=\"{value}\"");
            b.splice(at..at, attr.bytes());
            format!("insert attribute {name}=\"{}\" at {at}", value.chars().take(40).collect::<String>())
        }
        8 => {
            let spans = numbers(b);
            let Some(span) = spans.choose(rng).cloned() else { return "no number to swap".into() };
            let with = NUMBERS.choose(rng).unwrap();
            b.splice(span.clone(), with.bytes());
            format!("number at {} -> {with:?}", span.start)
        }
        9 => {
            // Many numbers at once (each with probability 1/8), from the end so spans hold.
            let with = NUMBERS.choose(rng).unwrap();
            let mut n = 0;
            for span in numbers(b).into_iter().rev() {
                if rng.gen_bool(0.125) {
                    b.splice(span, with.bytes());
                    n += 1;
                }
            }
            format!("{n} numbers -> {with:?}")
        }
        10 => {
            let u = UNICODE.choose(rng).unwrap();
            // Inside an attribute value (after `="`) or between elements.
            let quotes: Vec<usize> = b.windows(2).enumerate().filter(|(_, w)| w == b"=\"").map(|(i, _)| i + 2).collect();
            let at = pick(rng, &quotes, len);
            b.splice(at..at, u.bytes());
            format!("insert {u:?} at {at}")
        }
        11 => {
            // Around the nesting bound (64 levels): both sides of it.
            let n = rng.gen_range(10..130);
            let tag = if mjcf { *["body", "frame", "default", "worldbody"].choose(rng).unwrap() } else { *["link", "x", "robot"].choose(rng).unwrap() };
            let at = pick(rng, &element_ends(b), len);
            let open = format!("<{tag}>").repeat(n);
            let close = format!("</{tag}>").repeat(n);
            b.splice(at..at, open.bytes().chain(close.bytes()));
            format!("nest {n} <{tag}> at {at}")
        }
        _ => {
            // An element repeated: from a tag start to its `/>` (or the next `>`).
            let starts: Vec<usize> = (0..len).filter(|&i| b[i] == b'<' && b.get(i + 1).is_some_and(u8::is_ascii_alphabetic)).collect();
            let Some(&s) = starts.choose(rng) else { return "no element to repeat".into() };
            let e = b[s..].iter().position(|c| *c == b'>').map_or(len, |p| s + p + 1);
            let el = b[s..e].to_vec();
            let times = rng.gen_range(1..50);
            for _ in 0..times {
                b.splice(e..e, el.iter().copied());
            }
            format!("repeat {} x{times}", String::from_utf8_lossy(&el).chars().take(60).collect::<String>())
        }
    }
}

/// One mutation of a mesh file (binary STL or OBJ text), described.
fn mutate_mesh(rng: &mut ChaCha8Rng, b: &mut Vec<u8>, obj: bool) -> String {
    let len = b.len();
    if obj {
        return match rng.gen_range(0..6) {
            0 => {
                let lines = ["f 1 2 99", "f 0 0 0", "f -50 1 2", "f 4294967296 1 2", "f 1 2", "f 1/2/3 4//5 6", "v nan nan nan", "v 1e39 0 0",
                    "v 1", "vt 0 0", "vn 0 0 0", "mtllib ../../outside/secret.mtl", "usemtl x", "o \u{202e}", "f 1 1 1", "g"];
                let line = lines.choose(rng).unwrap();
                let at = pick(rng, &b.iter().enumerate().filter(|(_, c)| **c == b'\n').map(|(i, _)| i + 1).collect::<Vec<_>>(), len);
                b.splice(at..at, format!("{line}\n").bytes());
                format!("obj: insert line {line:?} at {at}")
            }
            1 => {
                let spans = numbers(b);
                let Some(span) = spans.choose(rng).cloned() else { return "obj: no number".into() };
                let with = *["0", "-99", "99999", "4294967296", "NaN", "1e39", "-0", "", "1.5"].choose(rng).unwrap();
                b.splice(span.clone(), with.bytes());
                format!("obj: number at {} -> {with:?}", span.start)
            }
            _ => mutate_xml(rng, b, false, ""),
        };
    }
    match rng.gen_range(0..5) {
        0 if len >= 84 => {
            let claimed = *[1_000_000_000u32, u32::MAX, 0, 1, 2, 1 << 20].choose(rng).unwrap();
            b[80..84].copy_from_slice(&claimed.to_le_bytes());
            format!("stl: claims {claimed} triangles")
        }
        1 if len >= 96 => {
            let at = 84 + 4 * rng.gen_range(0..(len - 84) / 4);
            let v = *[f32::NAN, f32::INFINITY, -f32::INFINITY, 1e38, -0.0, f32::MIN_POSITIVE / 2.0].choose(rng).unwrap();
            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
            format!("stl: float at {at} -> {v}")
        }
        2 => {
            let at = rng.gen_range(0..=len);
            b.truncate(at);
            format!("stl: truncate at {at}")
        }
        3 => {
            let ascii = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex NaN 1 0\nvertex 1 1e39 0\nendloop\nendfacet\nendsolid x\n";
            *b = ascii.as_bytes().to_vec();
            "stl: ascii with NaN and 1e39".into()
        }
        _ if len > 0 => {
            let (at, mask) = (rng.gen_range(0..len), rng.gen_range(1..=255u8));
            b[at] ^= mask;
            format!("stl: flip byte {at} ^ {mask:#x}")
        }
        _ => "stl: empty".into(),
    }
}

/// A hostile JSON value.
fn hostile_json(rng: &mut ChaCha8Rng) -> Value {
    match rng.gen_range(0..16) {
        0 => json!("NaN"),
        1 => json!(1e39),
        2 => json!(-0.0),
        3 => json!(f64::MAX),
        4 => json!(u64::MAX),
        5 => json!(i64::MIN),
        6 => Value::Null,
        7 => json!(true),
        8 => json!([]),
        9 => json!({}),
        10 => json!(""),
        11 => json!("x".repeat(rng.gen_range(1..100_000))),
        12 => json!(UNICODE.choose(rng).unwrap()),
        13 => {
            let mut v = json!(1);
            for _ in 0..rng.gen_range(10..200) {
                v = json!([v]);
            }
            v
        }
        14 => json!([1e39, 1e39, 1e39]),
        _ => json!("../../outside/secret.urdf"),
    }
}

/// Every path (object keys and array indices) to a node of `v`.
fn json_paths(v: &Value, at: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                at.push(json!(k));
                json_paths(x, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(json!(i));
                json_paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn node<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k {
        Value::String(k) => &mut v[k.as_str()],
        k => &mut v[k.as_u64().unwrap() as usize],
    })
}

/// One structural mutation of a saved file, described.
fn mutate_json(rng: &mut ChaCha8Rng, v: &mut Value) -> String {
    let mut paths = Vec::new();
    json_paths(v, &mut Vec::new(), &mut paths);
    // Every field is fair game: the result hashes and the root's kind and parent too (a load
    // once adopted them unchecked, and the new log then failed replay and verify).
    // Mostly not the whole file, and mostly the leaves.
    let path = paths[1..].choose(rng).cloned().unwrap_or_default();
    let shown = Value::Array(path.clone()).to_string();
    match rng.gen_range(0..6) {
        0..=2 => {
            let with = hostile_json(rng);
            let said = with.to_string().chars().take(40).collect::<String>();
            *node(v, &path) = with;
            format!("json {shown} -> {said}")
        }
        3 => {
            let Some((last, parent)) = path.split_last() else { return "json: nothing".into() };
            match (node(v, parent), last) {
                (Value::Object(m), Value::String(k)) => {
                    m.remove(k);
                }
                (Value::Array(a), Value::Number(i)) => {
                    a.remove(i.as_u64().unwrap() as usize);
                }
                _ => {}
            }
            format!("json: remove {shown}")
        }
        4 => {
            // A number nudged (a recorded value that no longer matches its hash).
            match node(v, &path) {
                Value::Number(n) => {
                    let x = n.as_f64().unwrap_or(0.0);
                    let nudged = if rng.gen_bool(0.5) { x + 1.0 } else { -x };
                    *node(v, &path) = json!(nudged);
                    format!("json {shown}: {x} -> {nudged}")
                }
                Value::String(s) if !s.is_empty() => {
                    let mut s = s.clone().into_bytes();
                    let at = rng.gen_range(0..s.len());
                    s[at] = if s[at] == b'0' { b'1' } else { b'0' };
                    *node(v, &path) = json!(String::from_utf8_lossy(&s));
                    format!("json {shown}: one character changed at {at}")
                }
                _ => "json: not a number".into(),
            }
        }
        _ => {
            // An array element repeated.
            let Some((_, parent)) = path.split_last() else { return "json: nothing".into() };
            if let Value::Array(a) = node(v, parent) {
                if let Some(x) = a.choose(rng).cloned() {
                    let times = rng.gen_range(1..20);
                    for _ in 0..times {
                        a.push(x.clone());
                    }
                    return format!("json: an element of {} repeated x{times}", Value::Array(parent.to_vec()));
                }
            }
            "json: no array".into()
        }
    }
}

fn b64() -> base64::engine::GeneralPurpose {
    base64::engine::general_purpose::STANDARD
}

/// Mutates one blob a saved file carries (a model or a mesh): its bytes are mutated as a
/// file of that kind, stored under their new hash, and every command naming the old hash
/// names the new one. Without the snapshot, a load must refold (and parse) it.
fn mutate_blob(rng: &mut ChaCha8Rng, save: &mut Value) -> String {
    let Some(blobs) = save["history"]["blobs"].as_object().cloned() else { return "no blobs".into() };
    let Some((hash, text)) = blobs.iter().collect::<Vec<_>>().choose(rng).map(|(h, t)| (h.to_string(), t.as_str().unwrap_or("").to_string()))
    else {
        return "no blobs".into();
    };
    let mut bytes = b64().decode(&text).unwrap_or_default();
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(400)]).to_string();
    let what = if head.contains("<mujoco") {
        mutate_xml(rng, &mut bytes, true, "/nonexistent")
    } else if head.contains("<robot") {
        mutate_xml(rng, &mut bytes, false, "/nonexistent")
    } else {
        mutate_mesh(rng, &mut bytes, head.starts_with('#') || head.starts_with("v "))
    };
    let new = blake3::hash(&bytes).to_hex().to_string();
    save["history"]["blobs"][&new] = json!(b64().encode(&bytes));
    if let Some(events) = save["history"]["events"].as_array_mut() {
        for e in events {
            if let Some(c) = e["command"].as_str() {
                e["command"] = json!(c.replace(&hash, &new));
            }
        }
    }
    if rng.gen_bool(0.7) {
        save["history"].as_object_mut().unwrap().remove("snapshot");
    }
    format!("blob {}: {what}", &hash[..12])
}

// ---------------------------------------------------------------------------------------------
// The fuzzer
// ---------------------------------------------------------------------------------------------

/// One input: a call on files written in the workspace.
struct Case {
    /// What it is (printed on failure with the folder holding its files).
    what: String,
    tool: &'static str,
    /// `file_path` (workspace-relative).
    file: String,
    /// More arguments.
    extra: Value,
    /// Reaches out of the workspace, at a file that is not regular, over a limit, or in a
    /// cycle: only a refusal is right.
    must_refuse: bool,
}

impl Case {
    fn new(what: impl Into<String>, tool: &'static str, file: impl Into<String>, must_refuse: bool) -> Case {
        Case { what: what.into(), tool, file: file.into(), extra: json!({}), must_refuse }
    }
}

struct Fuzz {
    seed: u64,
    server: Server,
    c: Client,
    /// The simulations kept for the final checks (a sample of those a model or a saved file
    /// was loaded into; see `keep`).
    sims: Vec<String>,
    /// How many were offered to `keep`, and the generator that samples them.
    offered: usize,
    sample: ChaCha8Rng,
    /// The input each kept simulation was made by.
    made_by: std::collections::BTreeMap<String, String>,
    /// stderr lines already looked at.
    seen: usize,
    accepted: usize,
    refused: usize,
    slowest: (Duration, String),
}

impl Fuzz {
    /// Calls `tool` under the watchdog: Ok(structuredContent) or Err(refusal text), after
    /// checking the answer (no outside text; a refusal is one sentence) and that the server
    /// is up and did not panic.
    async fn answer(&mut self, what: &str, tool: &str, args: Value) -> Result<Value, String> {
        let started = Instant::now();
        let call = self.c.service.call_tool(CallToolRequestParams::new(tool.to_string()).with_arguments(args.as_object().unwrap().clone()));
        let reply = tokio::time::timeout(WATCHDOG, call).await;
        let took = started.elapsed();
        if took > self.slowest.0 {
            self.slowest = (took, format!("{tool}: {what}"));
        }
        let reply = reply
            .unwrap_or_else(|_| panic!("{what}: {tool} got no answer within {WATCHDOG:?} (the server hangs on this input)"))
            .unwrap_or_else(|e| panic!("{what}: {tool} got no answer, the request failed: {e}"));
        assert!(!exited(&mut self.server), "{what}: {tool}: the server process died");
        let text = reply.content.iter().filter_map(|c| c.as_text().map(|t| t.text.clone())).collect::<Vec<_>>().join(" ");
        // A panic is printed before its reply is sent, but read from the server's stderr by
        // another thread: give it a moment to arrive.
        let mut panics = self.new_panics();
        let deadline = Instant::now() + Duration::from_secs(2);
        while panics.is_empty() && text.contains("Internal error") && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(20)).await;
            panics = self.new_panics();
        }
        // Numbers in models once reached the engine unchecked (a negative cylinder, a vertex
        // at -1e308, a body at 1e400, a 1e26 m cylinder) and panicked it at load or at every
        // later step: every panic now fails.
        if let Some(p) = panics.first() {
            panic!("{what}: {tool}: the server panicked: {p}");
        }
        let whole = serde_json::to_string(&reply).unwrap();
        assert!(!whole.contains(MARKER), "{what}: {tool}'s reply holds text of a file outside the workspace: {}", whole.chars().take(600).collect::<String>());
        if reply.is_error == Some(true) {
            one_sentence(&text, &format!("{what}: {tool}"));
            Err(text)
        } else {
            Ok(reply.structured_content.unwrap_or_else(|| panic!("{what}: {tool} answered without structuredContent")))
        }
    }

    /// The lines saying the server panicked (or overflowed its stack) since the last look.
    fn new_panics(&mut self) -> Vec<String> {
        let lines = self.server.stderr.lock().unwrap();
        let found = lines[self.seen..].iter().filter(|l| l.contains("panicked") || l.contains("stack overflow")).cloned().collect();
        self.seen = lines.len();
        found
    }

    /// Keeps `sim` for the final checks: the first [`KEPT`], then a uniform sample of all
    /// (reservoir sampling). The one left out is replayed now and destroyed, so every log
    /// replays and long runs stay within --max-sims.
    async fn keep(&mut self, sim: String, what: &str) {
        self.made_by.insert(sim.clone(), what.to_string());
        self.offered += 1;
        if self.sims.len() < KEPT {
            self.sims.push(sim);
            return;
        }
        let at = self.sample.gen_range(0..self.offered);
        let out = if at < KEPT { std::mem::replace(&mut self.sims[at], sim) } else { sim };
        if let Err(why) = replays(&self.server.data, &out) {
            panic!("{out} does not replay: {why} — {}", self.made_by[&out]);
        }
        self.c.call("destroy_simulation", json!({"sim_id": out})).await;
    }

    /// A new simulation with a ground, for one input.
    async fn new_sim(&mut self) -> String {
        let sim = self.c.new_sim(json!({})).await;
        self.c.ground(&sim).await;
        sim
    }

    async fn simulations(&self) -> usize {
        listed(&self.c.call("list_simulations", json!({})).await).0.len()
    }

    /// Runs one input and checks every property. A model goes into a simulation of its own,
    /// kept for the final checks when the model loaded (destroyed when it was refused).
    async fn run(&mut self, case: &Case) {
        let what = format!("{} [{} {}] (seed={})", case.what, case.tool, case.file, self.seed);
        let mut args = json!({"file_path": case.file});
        for (k, v) in case.extra.as_object().unwrap() {
            args[k] = v.clone();
        }
        let loads_model = case.tool != "load_simulation";
        let target = if loads_model { self.new_sim().await } else { String::new() };
        let before = if loads_model {
            args["sim_id"] = json!(target);
            Some(fingerprint(&self.c, &target).await)
        } else {
            None
        };
        let count = if loads_model { 0 } else { self.simulations().await };
        match self.answer(&what, case.tool, args).await {
            Err(_) => {
                self.refused += 1;
                match &before {
                    Some(before) => {
                        assert_unchanged(&self.c, &target, before, &what).await;
                        self.c.call("destroy_simulation", json!({"sim_id": target})).await;
                    }
                    None => assert_eq!(self.simulations().await, count, "{what}: a refused load_simulation left a simulation"),
                }
            }
            Ok(v) => {
                self.accepted += 1;
                assert!(!case.must_refuse, "{what}: accepted, but only a refusal is right: {}", v.to_string().chars().take(400).collect::<String>());
                let sim = if loads_model { target } else { v["simulation_id"].as_str().expect("simulation_id").to_string() };
                // What loaded also steps, its state can be read, and it refolds (verify):
                // what was accepted once is accepted by every fold.
                let before = fingerprint(&self.c, &sim).await;
                if self.answer(&what, "step_simulation", json!({"sim_id": sim, "steps": 3})).await.is_err() {
                    assert_unchanged(&self.c, &sim, &before, &format!("{what}, then a refused step")).await;
                }
                if let Some(id) = v["object_id"].as_u64() {
                    let _ = self.answer(&what, "get_object_state", json!({"sim_id": sim, "object_id": id})).await;
                    let _ = self.answer(&what, "get_sensor_data", json!({"sim_id": sim, "object_id": id})).await;
                }
                let verified = self.answer(&what, "verify_simulation", json!({"sim_id": sim})).await;
                assert!(verified.as_ref().is_ok_and(|v| v["ok"] == json!(true)), "{what}: then verify_simulation: {verified:?}");
                self.keep(sim, &what).await;
            }
        }
    }
}

/// A refusal is one sentence: not empty, no panic text, no backtrace, no "Internal error".
/// (Names quoted from a file are quoted as written — a name holding a newline makes a refusal
/// of two lines, a long name a long refusal, within the reply budget — so neither the line
/// count nor the length is held against it.)
fn one_sentence(text: &str, what: &str) {
    let bad = ["panicked", "Internal error", "backtrace", "RUST_BACKTRACE", "stack overflow", ".rs:"];
    assert!(!text.trim().is_empty(), "{what}: an empty refusal");
    if let Some(b) = bad.iter().find(|b| text.contains(**b)) {
        panic!("{what}: the refusal says {b:?}: {text}");
    }
    let frame = |l: &str| {
        let l = l.trim_start();
        l.starts_with("at ") || l.split_once(": ").is_some_and(|(n, _)| !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()))
    };
    assert!(!text.lines().skip(1).any(frame), "{what}: the refusal looks like a backtrace: {text}");
}

// ---------------------------------------------------------------------------------------------
// Inputs
// ---------------------------------------------------------------------------------------------

/// The hostile constructs, always run: files written under `h/` in the workspace.
fn hostile_table(ws: &Path, out: &Path) -> Vec<Case> {
    let h = ws.join("h");
    std::fs::create_dir_all(&h).unwrap();
    let o = out.display().to_string();
    let w = |name: &str, text: &str| std::fs::write(h.join(name), text).unwrap();
    let mjcf_with = |inside: &str| format!("<mujoco><worldbody>{inside}</worldbody></mujoco>");
    let mesh_mjcf = |file: &str| {
        format!(r#"<mujoco><asset><mesh name="m" file="{file}"/></asset><worldbody><body pos="0 0 1"><freejoint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>"#)
    };
    let mesh_urdf = |file: &str| {
        format!(
            r#"<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial><collision><geometry><mesh filename="{file}"/></geometry></collision></link></robot>"#
        )
    };
    let robot = r#"<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link></robot>"#;
    let ok_body = r#"<body pos="0 0 1"><joint type="hinge"/><geom size="0.1"/></body>"#;
    let mut cases = Vec::new();
    let mut mj = |name: &str, what: &str, refuse: bool| cases.push(Case::new(what, "load_mjcf", format!("h/{name}"), refuse));

    // Includes out of the workspace: absolute, `..`, through a symlink, through a symlinked folder.
    w("inc_abs.xml", &format!(r#"<mujoco><include file="{o}/secret.xml"/><worldbody/></mujoco>"#));
    mj("inc_abs.xml", "<include> of an absolute path outside", true);
    w("inc_up.xml", r#"<mujoco><include file="../../outside/secret.xml"/><worldbody/></mujoco>"#);
    mj("inc_up.xml", "<include> of ../ outside", true);
    symlink(&out.join("secret.xml"), &h.join("link_secret.xml"));
    w("inc_link.xml", r#"<mujoco><include file="link_secret.xml"/><worldbody/></mujoco>"#);
    mj("inc_link.xml", "<include> of a symlink to outside", true);
    mj("link_secret.xml", "main file a symlink to outside", true);
    symlink(out, &h.join("outdir"));
    w("inc_outdir.xml", r#"<mujoco><include file="outdir/secret.xml"/><worldbody/></mujoco>"#);
    mj("inc_outdir.xml", "<include> through a symlinked folder outside", true);
    mj("outdir/secret.xml", "main file through a symlinked folder outside", true);
    // /dev/zero, FIFOs and folders where a file is expected.
    symlink(Path::new("/dev/zero"), &h.join("zero.xml"));
    symlink(Path::new("/dev/zero"), &h.join("zero.stl"));
    symlink(Path::new("/dev/zero"), &h.join("zero.urdf"));
    symlink(Path::new("/dev/zero"), &h.join("zero.json"));
    fifo(&h.join("pipe.xml"));
    fifo(&h.join("pipe.stl"));
    fifo(&h.join("pipe.urdf"));
    fifo(&h.join("pipe.json"));
    for d in ["dir.xml", "dir.stl", "dir.urdf", "dir.json"] {
        std::fs::create_dir_all(h.join(d)).unwrap();
    }
    mj("zero.xml", "main file a symlink to /dev/zero", true);
    mj("pipe.xml", "main file a FIFO", true);
    mj("dir.xml", "main file a directory", true);
    for (file, what) in [("zero.xml", "a symlink to /dev/zero"), ("pipe.xml", "a FIFO"), ("dir.xml", "a directory")] {
        let name = format!("inc_{}", file);
        w(&name, &format!(r#"<mujoco><include file="{file}"/><worldbody/></mujoco>"#));
        mj(&name, &format!("<include> of {what}"), true);
    }
    // Meshes out of the workspace or not regular.
    for (name, file, what) in [
        ("mesh_abs.xml", format!("{o}/secret.stl"), "<mesh file> absolute outside"),
        ("mesh_up.xml", "../../outside/secret.stl".into(), "<mesh file> ../ outside"),
        ("mesh_link.xml", "link_secret.stl".into(), "<mesh file> a symlink to outside"),
        ("mesh_outdir.xml", "outdir/secret.obj".into(), "<mesh file> through a symlinked folder"),
        ("mesh_zero.xml", "zero.stl".into(), "<mesh file> a symlink to /dev/zero"),
        ("mesh_pipe.xml", "pipe.stl".into(), "<mesh file> a FIFO"),
        ("mesh_dir.xml", "dir.stl".into(), "<mesh file> a directory"),
        ("mesh_fileurl.xml", format!("file://{o}/secret.stl"), "<mesh file> file:// outside"),
    ] {
        w(name, &mesh_mjcf(&file));
        mj(name, what, true);
    }
    symlink(&out.join("secret.stl"), &h.join("link_secret.stl"));
    for (name, compiler, what) in [
        ("meshdir_abs.xml", format!(r#"<compiler meshdir="{o}"/>"#), "<compiler meshdir> absolute outside"),
        ("meshdir_up.xml", r#"<compiler meshdir="../../outside"/>"#.into(), "<compiler meshdir> ../ outside"),
        ("assetdir_abs.xml", format!(r#"<compiler assetdir="{o}"/>"#), "<compiler assetdir> absolute outside"),
        ("assetdir_up.xml", r#"<compiler assetdir="../../outside"/>"#.into(), "<compiler assetdir> ../ outside"),
    ] {
        w(name, &mesh_mjcf("secret.stl").replacen("<mujoco>", &format!("<mujoco>{compiler}"), 1));
        mj(name, what, true);
    }
    // Symlinks: a loop, one escaping by a relative target, one inside the workspace.
    symlink(Path::new("loop_b.xml"), &h.join("loop_a.xml"));
    symlink(Path::new("loop_a.xml"), &h.join("loop_b.xml"));
    mj("loop_a.xml", "main file a symlink loop", true);
    w("inc_loop.xml", r#"<mujoco><include file="loop_a.xml"/><worldbody/></mujoco>"#);
    mj("inc_loop.xml", "<include> of a symlink loop", true);
    w("mesh_loop.xml", &mesh_mjcf("loop_a.xml"));
    mj("mesh_loop.xml", "<mesh file> a symlink loop", true);
    symlink(Path::new("../../outside/secret.xml"), &h.join("rel_secret.xml"));
    mj("rel_secret.xml", "main file a relative symlink out of the workspace", true);
    w("inc_rel.xml", r#"<mujoco><include file="rel_secret.xml"/><worldbody/></mujoco>"#);
    mj("inc_rel.xml", "<include> of a relative symlink out of the workspace", true);
    // Odd names: a newline, spaces and unicode, a trailing slash, the folder itself.
    w("new\nline.xml", &mjcf_with(ok_body));
    mj("new\nline.xml", "a file name holding a newline", false);
    w("spaced 名前 💥.xml", &mjcf_with(ok_body));
    mj("spaced 名前 💥.xml", "a file name with spaces and unicode", false);
    mj("robot.xml/", "a path with a trailing slash", true);
    mj("..", "the workspace itself", true);
    mj("", "a folder (h/)", true);
    // Includes fanning out: 2 of the next file at each of 16 levels (65,536 inclusions).
    for i in 0..16 {
        w(&format!("fan{i}.xml"), &format!(r#"<mujoco><include file="fan{0}.xml"/><include file="fan{0}.xml"/></mujoco>"#, i + 1));
    }
    w("fan16.xml", r#"<mujoco><worldbody><geom size="0.01"/></worldbody></mujoco>"#);
    mj("fan0.xml", "includes fanning out to 65,536 inclusions", false);
    // Sub-models in other files (the parser would read them itself).
    w("robot.xml", &mjcf_with(ok_body));
    w("model_in.xml", r#"<mujoco><asset><model name="m" file="robot.xml"/></asset><worldbody/></mujoco>"#);
    mj("model_in.xml", "<asset><model file> inside the workspace", true);
    w("model_out.xml", &format!(r#"<mujoco><asset><model name="m" file="{o}/secret.xml"/></asset><worldbody/></mujoco>"#));
    mj("model_out.xml", "<asset><model file> outside", true);
    // Over the limits: the model alone, the model with its include, a mesh, meshes together.
    let pad = |size: u64| format!("<mujoco><worldbody>{ok_body}</worldbody><!--{}--></mujoco>", "x".repeat(size as usize));
    w("big.xml", &pad(MODEL_LIMIT));
    mj("big.xml", "MJCF over 8 MiB", true);
    w("half_a.xml", &pad(MODEL_LIMIT / 2 + 10));
    w("half_b.xml", &pad(MODEL_LIMIT / 2 + 10).replacen("<mujoco><worldbody>", r#"<mujoco><include file="half_a.xml"/><worldbody>"#, 1));
    mj("half_b.xml", "MJCF with its include over 8 MiB", true);
    sparse(&h.join("huge.stl"), &stl(&TETRA, 4), MESH_LIMIT + 1);
    w("mesh_huge.xml", &mesh_mjcf("huge.stl"));
    mj("mesh_huge.xml", "MJCF mesh over 64 MiB (sparse)", true);
    sparse(&h.join("big_a.stl"), &stl(&TETRA, 4), MESH_LIMIT / 2 + 1000);
    sparse(&h.join("big_b.stl"), &stl(&TETRA, 4), MESH_LIMIT / 2 + 1000);
    w("mesh_two_big.xml", r#"<mujoco><asset><mesh name="a" file="big_a.stl"/><mesh name="b" file="big_b.stl"/></asset><worldbody><body><geom type="mesh" mesh="a"/><geom type="mesh" mesh="b"/></body></worldbody></mujoco>"#);
    mj("mesh_two_big.xml", "MJCF meshes together over 64 MiB", true);
    // Deep XML: 10,000 levels.
    // XML nesting was not bounded before the parsers recurse: deep nesting overflowed the
    // stack and aborted the server (250 nested <default> at load; 200 at a later verify or
    // fork). Now 64 levels load (and verify and fork, below) and deeper is refused.
    for tag in ["body", "frame", "default"] {
        let (open, close) = match tag {
            "default" => ((0..61).map(|i| format!(r#"<default class="c{i}">"#)).collect::<String>(), "</default>".repeat(61)),
            _ => (format!("<{tag}>").repeat(61), format!("</{tag}>").repeat(61)),
        };
        let text = match tag {
            "default" => format!("<mujoco>{open}{close}<worldbody/></mujoco>"),
            _ => mjcf_with(&format!("{open}{}{close}", r#"<geom size="0.1"/>"#)),
        };
        w(&format!("limit_{tag}.xml"), &text);
        mj(&format!("limit_{tag}.xml"), &format!("63 levels of <{tag}> (the bound is 64)"), false);
    }
    let deep = |_: usize| 10_000;
    let n = deep(300);
    w("deep_body.xml", &mjcf_with(&format!("{}{}", r#"<body><geom size="0.1"/>"#.repeat(n), "</body>".repeat(n))));
    mj("deep_body.xml", &format!("{n} nested <body>"), false);
    let n = deep(1000);
    w("deep_unknown.xml", &format!("<mujoco>{}{}<worldbody/></mujoco>", "<a>".repeat(n), "</a>".repeat(n)));
    mj("deep_unknown.xml", &format!("{n} nested unknown elements"), false);
    let n = deep(100);
    w("deep_default.xml", &format!("<mujoco>{}{}<worldbody/></mujoco>", (0..n).map(|i| format!(r#"<default class="c{i}">"#)).collect::<String>(), "</default>".repeat(n)));
    mj("deep_default.xml", &format!("{n} nested <default> classes"), false);
    let n = deep(500);
    w("deep_frame.xml", &mjcf_with(&format!("{}{}{}", "<frame>".repeat(n), r#"<geom size="0.1"/>"#, "</frame>".repeat(n))));
    mj("deep_frame.xml", &format!("{n} nested <frame>"), false);
    w("wide.xml", &mjcf_with(&r#"<body><geom size="0.01"/></body>"#.repeat(2_000)));
    mj("wide.xml", "2,000 sibling bodies in one place", false);
    // Entities.
    let laughs = (1..10).map(|i| format!(r#"<!ENTITY l{i} "{}">"#, format!("&l{};", i - 1).repeat(10))).collect::<String>();
    w("laughs.xml", &format!(r#"<?xml version="1.0"?><!DOCTYPE mujoco [<!ENTITY l0 "lol">{laughs}]><mujoco model="&l9;"><worldbody/></mujoco>"#));
    mj("laughs.xml", "billion laughs", false);
    w("xxe.xml", &format!(r#"<?xml version="1.0"?><!DOCTYPE mujoco [<!ENTITY x SYSTEM "file://{o}/secret.txt">]><mujoco model="&x;"><worldbody><body name="&x;" pos="0 0 1"><joint type="hinge"/><geom size="0.1"/></body></worldbody></mujoco>"#));
    mj("xxe.xml", "external entity (SYSTEM file://) outside", false);
    w("xxe_param.xml", &format!(r#"<?xml version="1.0"?><!DOCTYPE mujoco [<!ENTITY % p SYSTEM "file://{o}/secret.dtd"> %p;]><mujoco><worldbody/></mujoco>"#));
    mj("xxe_param.xml", "external parameter entity outside", false);
    // Include cycles and depth.
    w("cyc_a.xml", r#"<mujoco><include file="cyc_b.xml"/><worldbody/></mujoco>"#);
    w("cyc_b.xml", r#"<mujoco><include file="cyc_a.xml"/></mujoco>"#);
    mj("cyc_a.xml", "include cycle a -> b -> a", true);
    w("cyc_self.xml", r#"<mujoco><include file="cyc_self.xml"/><worldbody/></mujoco>"#);
    mj("cyc_self.xml", "a file including itself", true);
    for i in 0..30 {
        w(&format!("chain{i}.xml"), &format!(r#"<mujoco><include file="chain{}.xml"/></mujoco>"#, i + 1));
    }
    w("chain30.xml", "<mujoco><worldbody/></mujoco>");
    mj("chain0.xml", "includes nested 30 deep", true);
    mj("chain22.xml", "includes nested 8 deep", false);
    w("diamond.xml", r#"<mujoco><include file="robot.xml"/><include file="robot.xml"/></mujoco>"#);
    mj("diamond.xml", "one file included twice", false);
    w("inc_nonmujoco.xml", r#"<mujoco><include file="../mjcf/../two_link_arm.urdf"/><worldbody/></mujoco>"#);
    mj("inc_nonmujoco.xml", "<include> of a URDF", true);
    w("inc_ws_abs.xml", &format!(r#"<mujoco><include file="{}"/></mujoco>"#, h.join("robot.xml").display()));
    mj("inc_ws_abs.xml", "<include> of an absolute path inside the workspace", false);
    // Meshes: an STL claiming 10^9 triangles, OBJ indices out of range, empty and degenerate.
    std::fs::write(h.join("claims.stl"), stl(&TETRA, 1_000_000_000)).unwrap();
    w("mesh_claims.xml", &mesh_mjcf("claims.stl"));
    mj("mesh_claims.xml", "STL claiming 10^9 triangles", false);
    w("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
    w("mesh_oob.xml", &mesh_mjcf("oob.obj"));
    mj("mesh_oob.xml", "OBJ face index out of range", true);
    w("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -50\n");
    w("mesh_neg.xml", &mesh_mjcf("neg.obj"));
    mj("mesh_neg.xml", "OBJ negative face index out of range", true);
    w("zero_idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    w("mesh_zero_idx.xml", &mesh_mjcf("zero_idx.obj"));
    mj("mesh_zero_idx.xml", "OBJ face index 0", true);
    w("empty.stl", "");
    w("mesh_empty.xml", &mesh_mjcf("empty.stl"));
    mj("mesh_empty.xml", "empty STL", true);
    w("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    w("mesh_flat.xml", &mesh_mjcf("flat.obj"));
    mj("mesh_flat.xml", "OBJ of one degenerate triangle", false);
    std::fs::write(h.join("nan.stl"), stl(&[[[f32::NAN, 0.0, 0.0], [1.0, f32::INFINITY, 0.0], [0.0, 0.0, 1e38]]], 1)).unwrap();
    w("mesh_nan.xml", &mesh_mjcf("nan.stl"));
    mj("mesh_nan.xml", "STL with NaN and infinite vertices", false);
    w("empty.xml", "");
    mj("empty.xml", "empty MJCF", true);
    w("keyframe.xml", &format!(r#"<mujoco><worldbody>{ok_body}</worldbody><keyframe><key name="k" qpos="NaN 1e39"/></keyframe></mujoco>"#));
    cases.push(Case { extra: json!({"keyframe": "k"}), ..Case::new("keyframe qpos NaN and too long", "load_mjcf", "h/keyframe.xml", false) });

    // URDF.
    let mut ur = |name: &str, what: &str, refuse: bool| cases.push(Case::new(what, "load_urdf", format!("h/{name}"), refuse));
    for (name, file, what) in [
        ("m_abs.urdf", format!("{o}/secret.stl"), "URDF mesh absolute outside"),
        ("m_up.urdf", "../../outside/secret.stl".into(), "URDF mesh ../ outside"),
        ("m_pkg.urdf", "package://pkg/../../../outside/secret.stl".into(), "URDF mesh package:// escaping"),
        ("m_pkg_abs.urdf", format!("package:/{o}/secret.stl"), "URDF mesh package:// with an absolute rest"),
        ("m_file_abs.urdf", format!("file://{o}/secret.stl"), "URDF mesh file:// absolute outside"),
        ("m_file_up.urdf", "file://../../outside/secret.stl".into(), "URDF mesh file:// ../ outside"),
        ("m_link.urdf", "link_secret.stl".into(), "URDF mesh a symlink to outside"),
        ("m_outdir.urdf", "outdir/secret.obj".into(), "URDF mesh through a symlinked folder"),
        ("m_zero.urdf", "zero.stl".into(), "URDF mesh a symlink to /dev/zero"),
        ("m_pipe.urdf", "pipe.stl".into(), "URDF mesh a FIFO"),
        ("m_dir.urdf", "dir.stl".into(), "URDF mesh a directory"),
        ("m_huge.urdf", "huge.stl".into(), "URDF mesh over 64 MiB (sparse)"),
        ("m_empty_name.urdf", "".into(), "URDF mesh with an empty filename"),
        ("m_pkg_only.urdf", "package://".into(), "URDF mesh package:// alone"),
        ("m_file_only.urdf", "file://".into(), "URDF mesh file:// alone"),
        ("m_oob.urdf", "oob.obj".into(), "URDF OBJ face index out of range"),
        ("m_empty.urdf", "empty.stl".into(), "URDF empty STL"),
    ] {
        w(name, &mesh_urdf(&file));
        ur(name, what, true);
    }
    w("m_claims.urdf", &mesh_urdf("claims.stl"));
    ur("m_claims.urdf", "URDF STL claiming 10^9 triangles", false);
    w("m_nan.urdf", &mesh_urdf("nan.stl"));
    ur("m_nan.urdf", "URDF STL with NaN and infinite vertices", false);
    w("m_two_big.urdf", &mesh_urdf("big_a.stl").replace("</link></robot>", r#"<collision><geometry><mesh filename="big_b.stl"/></geometry></collision></link></robot>"#));
    ur("m_two_big.urdf", "URDF meshes together over 64 MiB", true);
    symlink(&out.join("secret.urdf"), &h.join("link_secret.urdf"));
    ur("link_secret.urdf", "URDF main file a symlink to outside", true);
    ur("outdir/secret.urdf", "URDF main file through a symlinked folder", true);
    ur("zero.urdf", "URDF main file a symlink to /dev/zero", true);
    ur("pipe.urdf", "URDF main file a FIFO", true);
    ur("dir.urdf", "URDF main file a directory", true);
    w("big.urdf", &format!("{robot}<!--{}-->", "x".repeat(MODEL_LIMIT as usize)));
    ur("big.urdf", "URDF over 8 MiB", true);
    let n = deep(1000);
    w("deep.urdf", &robot.replace("</link>", &format!("{}{}</link>", "<x>".repeat(n), "</x>".repeat(n))));
    ur("deep.urdf", &format!("URDF with {n} nested elements"), false);
    w("deep_robot.urdf", &format!("{}{}", "<robot>".repeat(n), "</robot>".repeat(n)));
    ur("deep_robot.urdf", &format!("{n} nested <robot>"), false);
    let chain = |n: usize| {
        let mut s = String::from(r#"<robot name="chain">"#);
        for i in 0..=n {
            s += &format!(r#"<link name="l{i}"><inertial><mass value="0.1"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial><collision><geometry><sphere radius="0.01"/></geometry></collision></link>"#);
        }
        for i in 0..n {
            s += &format!(r#"<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{}"/><origin xyz="0 0 0.02"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#, i + 1);
        }
        s + "</robot>"
    };
    w("chain200.urdf", &chain(200));
    ur("chain200.urdf", "a chain of 200 links", false);
    // Subnormal inertias (1e-45: their inverses overflow) once made engine rule 2's tree path
    // slice its solver out of bounds and panic (seed 669911269235257830 mutated this fixture
    // so); such robots now take the dense path (crates/rapier3d/PATCHES.md, patch 2).
    let limits = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/joint_limits.urdf")).unwrap();
    // The fuzzer's inertias, link by link: a's iyy, b's ixx, e's ixy, f's ixx and ixz.
    let unit = r#"<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>"#;
    let tiny = [("a", r#"iyy="0.01""#, r#"iyy="1e-45""#), ("b", r#"ixx="0.01""#, r#"ixx="1e-45""#), ("e", r#"ixy="0""#, r#"ixy="1e-45""#), ("f", r#"ixx="0.01" ixy="0" ixz="0""#, r#"ixx="1e-45" ixy="0" ixz="1e-45""#)];
    let subnormal = tiny.iter().fold(limits.clone(), |text, (link, from, to)| {
        let before = format!(r#"<link name="{link}"><inertial><mass value="1"/>{unit}"#);
        text.replace(&before, &before.replace(from, to))
    });
    assert_ne!(subnormal, limits, "the fixture's inertias were found");
    w("subnormal_inertia.urdf", &subnormal);
    ur("subnormal_inertia.urdf", "a robot with subnormal inertias", false);
    // An infinite inertia (1e39 is past f32) on the first link under a fixed base: the tree
    // path's dynamics went non-finite, the link was quarantined (disabled) and its multibody
    // kept a stale solver id, so the joint constraints of its other links sliced out of bounds
    // and panicked (seed 11276948260366473473 mutated this fixture so; PATCHES.md patch 7).
    let first = r#"<link name="a"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01""#;
    let infinite = limits.replace(first, &first.replace(r#"iyy="0.01""#, r#"iyy="1e39""#));
    assert_ne!(infinite, limits, "the fixture's first inertia was found");
    w("infinite_inertia.urdf", &infinite);
    ur("infinite_inertia.urdf", "a robot whose first link has an infinite inertia", false);
    // One step of a chain of n links costs O(n^3) time and O(n^2) memory: this 3.8 MB URDF
    // (under the 8 MiB limit) once loaded and then made a one-step step_simulation run for
    // hours. A model has at most 512 joints now.
    w("chain10000.urdf", &chain(10_000));
    ur("chain10000.urdf", "a chain of 10,000 links", true);
    w("cycle.urdf", &robot.replace("</robot>", r#"<link name="b"/><joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint><joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint></robot>"#));
    ur("cycle.urdf", "URDF joints in a cycle", true);
    w("two_parents.urdf", &robot.replace("</robot>", r#"<link name="b"/><link name="c"/><joint name="j1" type="fixed"><parent link="a"/><child link="c"/></joint><joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint></robot>"#));
    ur("two_parents.urdf", "URDF link with two parents", true);
    w("laughs.urdf", &format!(r#"<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY l0 "lol">{laughs}]><robot name="&l9;"><link name="a"/></robot>"#));
    ur("laughs.urdf", "URDF billion laughs", false);
    w("xxe.urdf", &format!(r#"<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY x SYSTEM "file://{o}/secret.txt">]><robot name="&x;"><link name="&x;"/></robot>"#));
    ur("xxe.urdf", "URDF external entity outside", false);
    w("empty.urdf", "");
    ur("empty.urdf", "empty URDF", true);

    // Saved files.
    let mut sv = |name: &str, what: &str, refuse: bool| cases.push(Case::new(what, "load_simulation", format!("h/{name}"), refuse));
    symlink(&out.join("secret.json"), &h.join("link_secret.json"));
    sv("link_secret.json", "saved file a symlink to outside", true);
    sv("outdir/secret.json", "saved file through a symlinked folder", true);
    sv("zero.json", "saved file a symlink to /dev/zero", true);
    sv("pipe.json", "saved file a FIFO", true);
    sv("dir.json", "saved file a directory", true);
    w("deep.json", &format!("{}{}", "[".repeat(10_000), "]".repeat(10_000)));
    sv("deep.json", "saved file nested 10,000 deep", true);
    w("deep_obj.json", &format!(r#"{{"objects": {}1{}}}"#, r#"{"a":"#.repeat(10_000), "}".repeat(10_000)));
    sv("deep_obj.json", "saved file with objects nested 10,000 deep", true);
    let readable = |entry: Value| json!({"gravity": [0, 0, -9.81], "timestep": 0.004, "objects": [entry]}).to_string();
    for (name, path, what) in [
        ("r_abs.json", format!("{o}/secret.urdf"), "readable robot urdf_path absolute outside"),
        ("r_up.json", "../outside/secret.urdf".into(), "readable robot urdf_path ../ outside"),
        ("r_link.json", "h/link_secret.urdf".into(), "readable robot urdf_path a symlink to outside"),
        ("r_pipe.json", "h/pipe.urdf".into(), "readable robot urdf_path a FIFO"),
        ("r_zero.json", "h/zero.urdf".into(), "readable robot urdf_path /dev/zero"),
        ("r_dir.json", "h/dir.urdf".into(), "readable robot urdf_path a directory"),
    ] {
        w(name, &readable(json!({"id": 0, "type": "urdf", "urdf_path": path, "position": [0, 0, 1], "orientation": [0, 0, 0, 1]})));
        sv(name, what, true);
    }
    for (name, path, what) in [
        ("j_abs.json", format!("{o}/secret.xml"), "readable MJCF mjcf_path absolute outside"),
        ("j_pipe.json", "h/pipe.xml".into(), "readable MJCF mjcf_path a FIFO"),
        ("j_inc.json", "h/inc_abs.xml".into(), "readable MJCF whose include is outside"),
    ] {
        w(name, &readable(json!({"id": 0, "type": "mjcf", "mjcf_path": path, "position": [0, 0, 1], "orientation": [0, 0, 0, 1]})));
        sv(name, what, true);
    }
    cases
}

/// A saved file whose history loads a model naming a file outside (a sub-model), with no
/// snapshot: the load must refold and refuse it without opening the file.
fn plant_sub_model_in_save(save: &Value, out: &Path) -> Option<Value> {
    let mut save = save.clone();
    let events = save["history"]["events"].as_array()?.clone();
    let (i, cmd) = events.iter().enumerate().find_map(|(i, e)| {
        let cmd: Value = serde_json::from_str(e["command"].as_str()?).ok()?;
        cmd.get("LoadMjcf").or(Some(&cmd)).filter(|c| c["mjcf"].is_string()).cloned().map(|c| (i, c))
    })?;
    let old = cmd["mjcf"].as_str()?.to_string();
    let bytes = b64().decode(save["history"]["blobs"][&old].as_str()?).ok()?;
    let text = String::from_utf8(bytes).ok()?.replacen(
        "<worldbody>",
        &format!(r#"<asset><model name="m" file="{}/secret.xml"/></asset><worldbody>"#, out.display()),
        1,
    );
    let new = blake3::hash(text.as_bytes()).to_hex().to_string();
    save["history"]["blobs"][&new] = json!(b64().encode(text.as_bytes()));
    let c = save["history"]["events"][i]["command"].as_str()?.replace(&old, &new);
    save["history"]["events"][i]["command"] = json!(c);
    save["history"].as_object_mut()?.remove("snapshot");
    Some(save)
}

/// A random mutated input in `r{round}/`.
fn mutated(rng: &mut ChaCha8Rng, ws: &Path, round: usize, out: &str, save: &str) -> Case {
    let dir = ws.join(format!("r{round}"));
    std::fs::create_dir_all(&dir).unwrap();
    let rel = |p: &str| format!("r{round}/{p}");
    let times = |rng: &mut ChaCha8Rng| if rng.gen_bool(0.7) { 1 } else { rng.gen_range(2..5) };
    let fx = fixtures();
    let kind = rng.gen_range(0..100);
    if kind < 40 {
        // MJCF: a fixture, maybe split into a main file and an include; its meshes beside it.
        let mut names: Vec<String> = std::fs::read_dir(fx.join("mjcf"))
            .unwrap()
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|n| n.ends_with(".xml"))
            .collect();
        names.sort();
        let name = names.choose(rng).unwrap().clone();
        let mut text = std::fs::read_to_string(fx.join("mjcf").join(&name)).unwrap();
        let mut what = vec![format!("mjcf/{name}")];
        let mut include: Option<String> = None;
        if rng.gen_bool(0.35) {
            let doc = roxmltree::Document::parse(&text).unwrap();
            let children: Vec<_> = doc.root_element().children().filter(|n| n.is_element()).map(|n| n.range()).collect();
            let r = children.choose(rng).unwrap().clone();
            include = Some(format!("<mujoco>{}</mujoco>", &text[r.clone()]));
            text = format!("{}<include file=\"inc.xml\"/>{}", &text[..r.start], &text[r.end..]);
            what.push("split into model.xml + inc.xml".into());
        }
        if name == "mesh_robot.xml" {
            std::fs::create_dir_all(dir.join("meshes")).unwrap();
            for m in ["tetra.stl", "lshape.obj"] {
                let mut b = std::fs::read(fx.join("mjcf/meshes").join(m)).unwrap();
                if rng.gen_bool(0.5) {
                    for _ in 0..times(rng) {
                        what.push(format!("{m}: {}", mutate_mesh(rng, &mut b, m.ends_with(".obj"))));
                    }
                }
                std::fs::write(dir.join("meshes").join(m), b).unwrap();
            }
        }
        let mut main = text.into_bytes();
        let mut inc = include.map(String::into_bytes);
        for _ in 0..times(rng) {
            match &mut inc {
                Some(inc) if rng.gen_bool(0.5) => what.push(format!("inc.xml: {}", mutate_xml(rng, inc, true, out))),
                _ => what.push(format!("model.xml: {}", mutate_xml(rng, &mut main, true, out))),
            }
        }
        std::fs::write(dir.join("model.xml"), main).unwrap();
        if let Some(inc) = inc {
            std::fs::write(dir.join("inc.xml"), inc).unwrap();
        }
        let mut case = Case::new(what.join("; "), "load_mjcf", rel("model.xml"), false);
        if rng.gen_bool(0.2) {
            case.extra = json!({"position": [0, 0, rng.gen_range(-1.0..3.0)], "orientation": [0, 0, 0.3826834, 0.9238795], "use_fixed_base": rng.gen_bool(0.5)});
        }
        if rng.gen_bool(0.1) {
            case.extra["keyframe"] = json!(*["k", "init", "", "💥"].choose(rng).unwrap());
        }
        case
    } else if kind < 75 {
        // URDF: a fixture (mesh_bot with its meshes), maybe given a mesh it did not have.
        let names = ["two_link_arm.urdf", "iiwa14.urdf", "wheeled_base.urdf", "continuous_limits.urdf", "joint_limits.urdf", "mesh_bot"];
        let name = *names.choose(rng).unwrap();
        let mut what = vec![name.to_string()];
        std::fs::create_dir_all(dir.join("urdf")).unwrap();
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        let mut text = if name == "mesh_bot" {
            std::fs::read(fx.join("mesh_bot/urdf/mesh_bot.urdf")).unwrap()
        } else {
            std::fs::read(fx.join(name)).unwrap()
        };
        if name != "mesh_bot" && rng.gen_bool(0.3) {
            let mesh = *["package://r/meshes/cube.stl", "../meshes/tetra.obj"].choose(rng).unwrap();
            let s = String::from_utf8(text).unwrap().replacen(
                "</link>",
                &format!(r#"<collision><geometry><mesh filename="{mesh}" scale="0.5 0.5 0.5"/></geometry></collision></link>"#),
                1,
            );
            text = s.into_bytes();
            what.push(format!("given mesh {mesh}"));
        }
        for m in ["cube.stl", "tetra.obj"] {
            let mut b = std::fs::read(fx.join("mesh_bot/meshes").join(m)).unwrap();
            if rng.gen_bool(0.4) {
                for _ in 0..times(rng) {
                    what.push(format!("{m}: {}", mutate_mesh(rng, &mut b, m.ends_with(".obj"))));
                }
            }
            std::fs::write(dir.join("meshes").join(m), b).unwrap();
        }
        for _ in 0..times(rng) {
            what.push(mutate_xml(rng, &mut text, false, out));
        }
        std::fs::write(dir.join("urdf/robot.urdf"), text).unwrap();
        let mut case = Case::new(what.join("; "), "load_urdf", rel("urdf/robot.urdf"), false);
        if rng.gen_bool(0.2) {
            case.extra = json!({"position": [0, 0, 1], "use_fixed_base": rng.gen_bool(0.5)});
        }
        case
    } else {
        // A saved file: its fields, or a model or mesh it carries, or its bytes.
        let mut v: Value = serde_json::from_str(save).unwrap();
        let mut what = vec!["saved file".to_string()];
        let how = rng.gen_range(0..10);
        if how < 3 {
            v.as_object_mut().unwrap().remove("history");
            what.push("without history".into());
        }
        if how >= 7 {
            what.push(mutate_blob(rng, &mut v));
        } else {
            for _ in 0..times(rng) {
                what.push(mutate_json(rng, &mut v));
            }
        }
        let bytes_too = rng.gen_bool(0.2);
        // A load whose snapshot's MAC was ours once trusted the events before it without
        // refolding them, so an edited root command loaded and the new log failed verify. The
        // MAC covers the events now: half the inputs that edit them keep the snapshot (the MAC
        // no longer matches), half go without it (the load refolds everything).
        let edits_events = bytes_too
            || what.iter().any(|w| w.contains(r#""history","events""#) || w.contains(r#""history","blobs""#) || w.starts_with(r#"json ["history"]"#) || w.starts_with("blob"));
        if edits_events && rng.gen_bool(0.5) {
            if let Some(h) = v.get_mut("history").and_then(Value::as_object_mut) {
                h.remove("snapshot");
            }
        }
        let mut bytes = serde_json::to_vec_pretty(&v).unwrap();
        if bytes_too {
            what.push(format!("bytes: {}", mutate_xml(rng, &mut bytes, false, out)));
        }
        std::fs::write(dir.join("save.json"), bytes).unwrap();
        Case::new(what.join("; "), "load_simulation", rel("save.json"), false)
    }
}

/// Bytes `needle` occurs in any file under `dir`, by path.
fn files_holding(dir: &Path, needle: &[u8]) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_file() && std::fs::read(&p).is_ok_and(|b| b.windows(needle.len()).any(|w| w == needle)) {
            found.push(p);
        }
    }
    found
}

async fn fuzz_files(seed: u64, dir: &Path) {
    let mut rng = rng(seed);
    let rounds: usize = std::env::var("PHYSICS_FUZZ_ROUNDS").ok().and_then(|s| s.parse().ok()).unwrap_or(1000);
    // Outside the workspace: files whose text must never come back.
    let outside = dir.join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    let secret_body = format!(r#"<body name="{MARKER}" pos="0 0 1"><joint type="hinge"/><geom size="0.1"/></body>"#);
    std::fs::write(outside.join("secret.xml"), format!(r#"<mujoco model="{MARKER}"><worldbody>{secret_body}</worldbody></mujoco>"#)).unwrap();
    std::fs::write(outside.join("secret.urdf"), format!(r#"<robot name="{MARKER}"><link name="{MARKER}"/></robot>"#)).unwrap();
    let mut secret_stl = stl(&TETRA, 4);
    secret_stl[..MARKER.len()].copy_from_slice(MARKER.as_bytes());
    std::fs::write(outside.join("secret.stl"), secret_stl).unwrap();
    std::fs::write(outside.join("secret.obj"), format!("o {MARKER}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")).unwrap();
    std::fs::write(outside.join("secret.json"), format!(r#"{{"format": "{MARKER}", "objects": [{{"id": "{MARKER}"}}]}}"#)).unwrap();
    std::fs::write(outside.join("secret.txt"), MARKER).unwrap();
    std::fs::write(outside.join("secret.dtd"), format!(r#"<!ENTITY leak "{MARKER}">"#)).unwrap();

    let server = Server::start(dir, &["--max-sims", "400"]);
    server.copy_fixtures();
    let ws = server.workspace.clone();
    let c = server.client().await;
    let mut f = Fuzz {
        seed,
        server,
        c,
        sims: Vec::new(),
        offered: 0,
        sample: common::hard::rng(seed ^ 0x5eed),
        made_by: Default::default(),
        seen: 0,
        accepted: 0,
        refused: 0,
        slowest: (Duration::ZERO, String::new()),
    };
    // The saved file the mutations start from: primitives, a robot, an MJCF model, steps.
    let base = f.new_sim().await;
    f.sims.push(base.clone());
    let calls = json!([
        {"tool": "add_box", "arguments": {"dimensions": [0.1, 0.2, 0.3], "position": [0, 0, 1], "mass": 2}},
        {"tool": "add_sphere", "arguments": {"radius": 0.1, "position": [1, 0, 1]}},
        {"tool": "add_capsule", "arguments": {"radius": 0.05, "height": 0.2, "position": [0, 1, 1]}},
        {"tool": "load_urdf", "arguments": {"file_path": "two_link_arm.urdf", "position": [2, 0, 1]}},
        {"tool": "load_urdf", "arguments": {"file_path": "mesh_bot/urdf/mesh_bot.urdf", "position": [3, 0, 1]}},
        {"tool": "load_mjcf", "arguments": {"file_path": "mjcf/mesh_robot.xml", "position": [-2, 0, 0]}},
        {"tool": "step_simulation", "arguments": {"steps": 10}},
        {"tool": "set_object_velocity", "arguments": {"object_id": 1, "linear_velocity": [1, 0, 0]}},
        {"tool": "step_simulation", "arguments": {"steps": 5}}
    ]);
    f.c.call("batch", json!({"sim_id": base, "calls": calls})).await;
    f.c.call("save_simulation", json!({"sim_id": base, "file_path": "base_save.json"})).await;
    let save = std::fs::read_to_string(ws.join("base_save.json")).unwrap();

    // The hostile table, in a seeded order, then the mutations.
    let mut cases = hostile_table(&ws, &outside);
    let save_value: Value = serde_json::from_str(&save).unwrap();
    if let Some(planted) = plant_sub_model_in_save(&save_value, &outside) {
        std::fs::write(ws.join("h/planted_sub_model.json"), planted.to_string()).unwrap();
        cases.push(Case::new("saved history whose MJCF blob names a sub-model outside", "load_simulation", "h/planted_sub_model.json", true));
    } else {
        panic!("the base save carries no load_mjcf command to plant a sub-model in");
    }
    cases.shuffle(&mut rng);
    let started = Instant::now();
    let hostile = cases.len();
    for case in &cases {
        f.run(case).await;
    }
    eprintln!("hostile table: {hostile} inputs in {:.1} s", started.elapsed().as_secs_f64());
    let out = outside.display().to_string();
    let started = Instant::now();
    for round in 0..rounds {
        let case = mutated(&mut rng, &ws, round, &out, &save);
        f.run(&case).await;
    }
    eprintln!(
        "mutations: {rounds} inputs in {:.1} s; {} accepted, {} refused in all; slowest call {:.1} s ({})",
        started.elapsed().as_secs_f64(),
        f.accepted,
        f.refused,
        f.slowest.0.as_secs_f64(),
        f.slowest.1.chars().take(200).collect::<String>()
    );

    // No log holds text of a file outside the workspace.
    let leaked = files_holding(&f.server.data, MARKER.as_bytes());
    assert!(leaked.is_empty(), "text of a file outside the workspace is in the data directory: {leaked:?} (seed={seed})");

    // After a SIGTERM restart (every log refolded): nothing damaged, every simulation there,
    // verifying, and every log replays.
    let Fuzz { server, sims, made_by, .. } = f;
    let made = |sim: &str| made_by.get(sim).cloned().unwrap_or_else(|| "the base simulation".into());
    let started = Instant::now();
    tokio::task::spawn_blocking(move || server.terminate_within(Duration::from_secs(10))).await.unwrap();
    let server = Server::start(dir, &["--max-sims", "400"]);
    let c = server.client().await;
    let (live, damaged) = listed(&c.call("list_simulations", json!({})).await);
    assert!(damaged.is_empty(), "damaged after the restart: {damaged:?} (seed={seed})");
    for sim in &sims {
        assert!(live.contains(sim), "{sim} is gone after the restart — {}", made(sim));
    }
    for sim in &live {
        let v = c.call("verify_simulation", json!({"sim_id": sim})).await;
        assert_eq!(v["ok"], json!(true), "{sim} does not verify after the restart: {v} — {}", made(sim));
        if let Err(why) = replays(&server.data, sim) {
            panic!("{sim} does not replay: {why} — {}", made(sim));
        }
    }
    let panics: Vec<String> = server.stderr.lock().unwrap().iter().filter(|l| l.contains("panicked")).cloned().collect();
    assert!(panics.is_empty(), "the restarted server panicked: {panics:?} (seed={seed})");
    eprintln!("restart, verify and replay of {} simulations: {:.1} s", live.len(), started.elapsed().as_secs_f64());
}

/// `physics-mcp replay` of simulation `id`'s log, every recorded hash checked.
fn replays(data: &Path, id: &str) -> Result<(), String> {
    let out = Command::new(env!("CARGO_BIN_EXE_physics-mcp")).arg("replay").arg(data.join(format!("{id}.sqlite"))).output().unwrap();
    if out.status.success() {
        Ok(())
    } else {
        Err(format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn model_file_contents_never_hurt_the_server() {
    let seed = seed();
    let dir = tempfile::Builder::new().prefix("file_fuzz-").tempdir().unwrap();
    let ran = std::panic::AssertUnwindSafe(fuzz_files(seed, dir.path())).catch_unwind().await;
    if let Err(panic) = ran {
        let kept = dir.keep();
        eprintln!("seed={seed}: the inputs are kept in {}/workspace (hostile ones under h/, round N under rN/)", kept.display());
        std::panic::resume_unwind(panic);
    }
}
