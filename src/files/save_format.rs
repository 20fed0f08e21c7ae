//! Saved files: JSON that keeps the old PyBullet server's readable fields and adds the
//! authoritative `history` — the chain of state-changing events from create_simulation with
//! their state hashes, and the latest snapshot on it with a blake3 MAC keyed by a secret in
//! the data directory. A file this server wrote (MAC valid) loads from its snapshot; any other
//! is refolded from its events, every recorded hash checked. Readable fields that disagree
//! with the history are refused, naming them. A file without `history` (the old server's)
//! loads approximately: objects are re-created at their saved poses and velocities, robots
//! from the URDF their `urdf_path` (or `file_path`) names in the workspace.

use base64::Engine;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use crate::command::{BlobSource, Command, Shape, EVENT_VERSION};
use crate::limits::Limits;
use crate::log::sqlite::{Event, Kind};
use crate::files::urdf::decide_load_urdf;
use crate::value::{self, r32, r32s, Refusal};
use crate::files::Reader;
use crate::world::{ObjectKind, World};

/// Identifies our files.
pub const SAVE_FORMAT: &str = "physics-mcp-save";
/// Version of the saved-file layout.
pub const SAVE_FORMAT_VERSION: u32 = 1;
/// Largest file load_simulation reads.
pub const MAX_SAVE_BYTES: u64 = 512 * 1024 * 1024;

/// The whole file.
#[derive(Serialize, Deserialize, Debug)]
pub struct SaveFile {
    /// Always `physics-mcp-save` for files this server writes (absent in old-server files).
    #[serde(default)]
    pub format: Option<String>,
    /// Layout version.
    #[serde(default)]
    pub format_version: Option<u32>,
    /// The readable fields (the old server's), informational when `history` is present.
    #[serde(flatten)]
    pub readable: Readable,
    /// The authoritative history.
    #[serde(default)]
    pub history: Option<SavedHistory>,
}

/// The old server's fields, plus `simulation_time`.
#[derive(Serialize, Deserialize, Debug, Default, PartialEq, Clone)]
pub struct Readable {
    /// Gravity.
    #[serde(default)]
    pub gravity: Option<Value>,
    /// Seconds per step.
    #[serde(default)]
    pub timestep: Option<Value>,
    /// Simulated time.
    #[serde(default)]
    pub simulation_time: Option<Value>,
    /// Objects with their poses and velocities.
    #[serde(default)]
    pub objects: Vec<Value>,
    /// Constraints.
    #[serde(default)]
    pub constraints: Vec<Value>,
}

/// The chain of state-changing events, its blobs and the latest snapshot.
#[derive(Serialize, Deserialize, Debug)]
pub struct SavedHistory {
    /// Root first.
    pub events: Vec<SavedEvent>,
    /// blake3 → base64 bytes (URDFs, meshes, large arguments).
    #[serde(default)]
    pub blobs: std::collections::BTreeMap<String, String>,
    /// The latest snapshot on the chain, MAC'd.
    #[serde(default)]
    pub snapshot: Option<SavedSnapshot>,
}

/// One state-changing event.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct SavedEvent {
    /// Its seq in the original log.
    pub seq: u64,
    /// root or change.
    pub kind: String,
    /// Its parent.
    pub parent: Option<u64>,
    /// The tool.
    pub tool: String,
    /// The client's arguments (JSON text).
    pub arguments: String,
    /// The validated command (JSON text).
    pub command: String,
    /// Event encoding version.
    pub version: u32,
    /// blake3 of the result.
    pub result_hash: Option<String>,
    /// State hash after it.
    pub state_hash: String,
    /// Root events: the engine build that made them; absent in files saved before builds
    /// were recorded (such roots read as `engine::UNRECORDED_ENGINE_BUILD`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub engine: Option<String>,
}

/// A snapshot with its MAC.
#[derive(Serialize, Deserialize, Debug)]
pub struct SavedSnapshot {
    /// The event it was taken at.
    pub seq: u64,
    /// blake3 of the bytes.
    pub hash: String,
    /// keyed blake3 over seq, hash and that event's state hash.
    pub mac: String,
    /// postcard bytes, base64.
    pub bytes: String,
}

/// The MAC of a snapshot and of the saved events up to it (`events`, root first, ending at the
/// snapshot's event): only a server holding `key` can produce it, so a load may start from the
/// snapshot without refolding those events. It covers the events too because a load adopts
/// them into the new log as they are: a file whose root command was edited after saving must
/// be refolded (and refused), not trusted. Files saved before it covered the events carry a
/// MAC over the snapshot alone, which no longer matches: they are refolded in full.
pub fn snapshot_mac(key: &[u8; 32], seq: u64, hash: &str, events: &[Event]) -> String {
    mac(key, seq, hash, events).to_hex().to_string()
}

fn mac(key: &[u8; 32], seq: u64, hash: &str, events: &[Event]) -> blake3::Hash {
    let mut h = blake3::Hasher::new_keyed(key);
    h.update(format!("events-v2:{seq}:{hash}").as_bytes());
    for e in events {
        let fields = (
            e.seq,
            e.kind.as_str(),
            e.parent,
            &e.tool,
            &e.arguments,
            &e.command,
            e.version,
            &e.result_hash,
            &e.state_hash,
            &e.engine,
        );
        h.update(&serde_json::to_vec(&fields).unwrap_or_default());
        h.update(b"\n");
    }
    h.finalize()
}

/// Whether a saved snapshot's MAC is ours, compared as `blake3::Hash` values (constant time;
/// a string `==` would tell a forger how many leading characters were right).
fn snapshot_mac_matches(key: &[u8; 32], s: &SavedSnapshot, events: &[Event]) -> bool {
    blake3::Hash::from_hex(&s.mac).is_ok_and(|given| given == mac(key, s.seq, &s.hash, events))
}

/// The readable fields of a world, as saved (and as compared on load).
pub fn readable(world: &World) -> Readable {
    let objects = world
        .objects()
        .filter_map(|(id, obj)| {
            let st = world.object_state(id)?;
            let is_static = world.body(id).is_some_and(|b| b.is_fixed());
            let mut o = match &obj.kind {
                ObjectKind::Primitive { shape } => json!({
                    "object_id": id,
                    "type": "primitive",
                    "shape": shape.name(),
                    "dimensions": shape.dimensions().into_iter().map(r32).collect::<Vec<_>>(),
                }),
                // Both names of the file: the old server documented `urdf_path` and wrote
                // `file_path`, so readers of either find it.
                ObjectKind::Robot { robot } => json!({
                    "object_id": id,
                    "type": "urdf",
                    "urdf_path": robot.file_path,
                    "file_path": robot.file_path,
                    "use_fixed_base": robot.fixed_base,
                    "num_joints": robot.links.len(),
                    "joint_positions": joint_positions(world, id, robot.links.len()),
                }),
                ObjectKind::Mjcf { robot, mjcf } => json!({
                    "object_id": id,
                    "type": "mjcf",
                    "mjcf_path": robot.file_path,
                    "use_fixed_base": robot.fixed_base,
                    "keyframe": mjcf.keyframe,
                    "num_joints": robot.links.len(),
                    "joint_positions": joint_positions(world, id, robot.links.len()),
                }),
            };
            let fields = json!({
                "mass": if is_static { 0.0 } else { r32(obj.mass) },
                "color": obj.color.map(r32s),
                "position": st.position,
                "orientation": st.orientation,
                "linear_velocity": st.linear_velocity,
                "angular_velocity": st.angular_velocity,
            });
            if let (Some(o), Some(f)) = (o.as_object_mut(), fields.as_object()) {
                o.extend(f.clone());
            }
            Some(o)
        })
        .collect();
    Readable {
        gravity: Some(json!(r32s(world.gravity()))),
        timestep: Some(json!(world.timestep_given())),
        simulation_time: Some(json!(world.current_time())),
        objects,
        constraints: world.constraint_summaries(),
    }
}

impl Readable {
    /// A copy in which each object that names its URDF under one key (`urdf_path` or
    /// `file_path`) has the other too, so a file saved before both were written compares
    /// equal to the readable fields its history gives today.
    pub fn with_urdf_path_aliases(&self) -> Readable {
        let mut out = self.clone();
        for o in out.objects.iter_mut().filter_map(Value::as_object_mut) {
            if o.get("type").and_then(Value::as_str) == Some("mjcf") {
                continue;
            }
            if let Some(path) = o.get("urdf_path").or_else(|| o.get("file_path")).cloned() {
                for key in ["urdf_path", "file_path"] {
                    o.entry(key).or_insert_with(|| path.clone());
                }
            }
        }
        out
    }
}

/// Names the readable fields of `file` that disagree with `world` (None when they agree).
/// Time fields may also be as builds before event version 2 wrote them (the f32 timestep and
/// the engine's summed clock), so the files they saved keep loading.
pub fn disagreeing_fields(file: &Readable, world: &World) -> Option<String> {
    let actual = readable(world);
    let legacy_timestep = Some(json!(r32(world.timestep())));
    let legacy_time = Some(json!(world.engine_time()));
    let mut bad = Vec::new();
    if file.gravity != actual.gravity {
        bad.push("gravity".to_string());
    }
    if file.timestep != actual.timestep && file.timestep != legacy_timestep {
        bad.push("timestep".to_string());
    }
    if file.simulation_time != actual.simulation_time && file.simulation_time != legacy_time {
        bad.push("simulation_time".to_string());
    }
    if file.objects.len() != actual.objects.len() {
        bad.push("objects (count)".to_string());
    } else {
        for (i, (a, b)) in file.objects.iter().zip(&actual.objects).enumerate() {
            if let (Value::Object(a), Value::Object(b)) = (a, b) {
                for (k, v) in b {
                    if a.get(k) != Some(v) {
                        bad.push(format!("objects[{i}].{k}"));
                    }
                }
            } else if a != b {
                bad.push(format!("objects[{i}]"));
            }
        }
    }
    if file.constraints != actual.constraints {
        bad.push("constraints".to_string());
    }
    (!bad.is_empty()).then(|| {
        bad.truncate(8);
        bad.join(", ")
    })
}

/// A saved file's blobs (base64 by blake3) as a source for decoding its events.
pub struct SavedBlobs<'a>(pub &'a std::collections::BTreeMap<String, String>);

impl BlobSource for SavedBlobs<'_> {
    fn blob(&self, hash: &str) -> Option<Vec<u8>> {
        base64::engine::general_purpose::STANDARD.decode(self.0.get(hash)?).ok()
    }
}

/// The blobs the commands of `chain` refer to, base64 by hash (a saved file's `blobs`).
pub fn chain_blobs(chain: &[Event], src: &dyn BlobSource) -> std::collections::BTreeMap<String, String> {
    crate::log::fold::chain_blobs(chain, src)
        .into_iter()
        .map(|(hash, bytes)| (hash, base64::engine::general_purpose::STANDARD.encode(bytes)))
        .collect()
}

/// The saved form of a chain event.
pub fn saved_event(e: &Event) -> SavedEvent {
    SavedEvent {
        seq: e.seq,
        kind: e.kind.as_str().into(),
        parent: e.parent,
        tool: e.tool.clone(),
        arguments: e.arguments.clone(),
        command: command_as_done(e),
        version: e.version,
        result_hash: e.result_hash.clone(),
        state_hash: e.state_hash.clone(),
        engine: e.engine.clone(),
    }
}

/// The command text a saved event carries: as carried out (`Command::as_done`), since the
/// file keeps no result to correct a step that older builds logged as the steps asked. Any
/// other command keeps its recorded text byte for byte.
fn command_as_done(e: &Event) -> String {
    let text = e.command.clone().unwrap_or_default();
    match serde_json::from_str::<Command>(&text) {
        Ok(cmd @ Command::StepSimulation { .. }) => {
            let done = crate::log::fold::upcast(cmd.clone(), e);
            if done == cmd { text } else { serde_json::to_string(&done).unwrap_or(text) }
        }
        _ => text,
    }
}

/// A saved event back as a log event (to be inherited by the loaded simulation).
pub fn log_event(e: &SavedEvent) -> Event {
    Event {
        seq: e.seq,
        kind: if e.kind == "root" { Kind::Root } else { Kind::Change },
        parent: e.parent,
        tool: e.tool.clone(),
        arguments: e.arguments.clone(),
        command: Some(e.command.clone()),
        version: e.version,
        ok: true,
        mutates: true,
        inherited: true,
        result: None,
        result_hash: e.result_hash.clone(),
        state_hash: e.state_hash.clone(),
        engine: e.engine.clone(),
        summary: None,
    }
}

fn bad(why: impl std::fmt::Display) -> Refusal {
    format!("The file is not a valid saved simulation: {why}")
}

/// Rebuilds the world a saved history describes, never trusting it byte for byte unless the
/// MAC over its snapshot and the events before it is ours: the chain is checked for shape
/// (a root first, without a parent; kinds root or change), every command against the limits,
/// every recorded state hash, and the result hashes of this event version. The world keeps
/// the identity its events were recorded under (the caller gives it the new one);
/// `progress(done, total)` reports refold progress.
pub fn world_from_history(
    h: &SavedHistory,
    key: &[u8; 32],
    limits: &Limits,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(World, Vec<Event>), Refusal> {
    // The new log adopts the blobs as they are, also those only events before a trusted
    // snapshot use (never refolded here): each must be the bytes its name hashes.
    for (hash, b64) in &h.blobs {
        let bytes = base64::engine::general_purpose::STANDARD.decode(b64).map_err(|_| bad(format!("blob {hash} is not base64")))?;
        if crate::digest::content_hash(&bytes) != *hash {
            return Err(bad(format!("blob {hash} does not match its hash")));
        }
    }
    if let Some(e) = h.events.iter().find(|e| e.kind != "root" && e.kind != "change") {
        return Err(bad(format!("event {} has kind {:?} (root or change expected)", e.seq, e.kind)));
    }
    let events: Vec<Event> = h.events.iter().map(log_event).collect();
    let world = world_from_events(&events, &SavedBlobs(&h.blobs), h.snapshot.as_ref(), key, limits, progress)?;
    Ok((world, events))
}

/// `world_from_history` on events already converted (the benchmark times conversion and
/// storage separately from the rebuild).
pub fn world_from_events(
    events: &[Event],
    blobs: &dyn BlobSource,
    snapshot: Option<&SavedSnapshot>,
    key: &[u8; 32],
    limits: &Limits,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<World, Refusal> {
    let first = events.first().ok_or_else(|| bad("history.events is empty"))?;
    if first.kind != Kind::Root || first.parent.is_some() {
        return Err(bad("history.events does not start with a root event without a parent"));
    }
    for (i, e) in events.iter().enumerate() {
        if e.version > EVENT_VERSION {
            return Err(bad(format!("event {} has version {}, newer than this server", e.seq, e.version)));
        }
        let chained = i == 0 || (e.parent == Some(events[i - 1].seq) && e.seq > events[i - 1].seq);
        if !chained || (i > 0 && e.kind != Kind::Change && e.kind != Kind::Root) {
            return Err(bad(format!("history.events is not a chain at seq {}", e.seq)));
        }
    }
    // Start from our own snapshot when its MAC proves this server wrote it.
    let trusted = snapshot.and_then(|s| {
        let at = events.iter().position(|e| e.seq == s.seq)?;
        let mac_ok = snapshot_mac_matches(key, s, &events[..=at]);
        let bytes = base64::engine::general_purpose::STANDARD.decode(&s.bytes).ok()?;
        let hash_ok = crate::digest::content_hash(&bytes) == s.hash;
        // An older-version snapshot lacks the values as given: refold instead.
        (mac_ok && hash_ok && World::foldable_snapshot(&bytes)).then_some((at, bytes))
    });
    let (start, mut world) = match trusted {
        Some((at, bytes)) => {
            // Under the identity its events were recorded with, so results compare.
            let (recorded_id, gui) = identity_at(&events[..=at], blobs)?;
            let w = World::restore(&recorded_id, gui, &bytes).map_err(bad)?;
            (at, w)
        }
        None => {
            let (w, outcome) = crate::log::fold::create_root(first, blobs).map_err(bad)?;
            check_result_hash(first, Some(outcome))?;
            (0, w)
        }
    };
    let total = (events.len() - start) as u64;
    crate::log::fold::check_hash(&world, &events[start]).map_err(bad)?;
    // Every state hash, and every result hash of this event version (older results were
    // computed under older rules, as replay has it): the new log adopts them as they are.
    for (i, e) in events[start + 1..].iter().enumerate() {
        let (_, outcome) = crate::log::fold::fold_event(&mut world, e, blobs, limits, true).map_err(bad)?;
        check_result_hash(e, outcome)?;
        if e.kind == Kind::Root {
            // A fork or load inside the chain: later results name its simulation.
            let (recorded_id, gui) = identity_at(std::slice::from_ref(e), blobs)?;
            world = world.with_identity(&recorded_id, gui);
        }
        progress(i as u64 + 1, total);
    }
    Ok(world)
}

/// Refuses an event of this version whose recorded result hash is not that of the result its
/// command gives (`outcome`; None for fork and load roots, which record no result to check).
fn check_result_hash(e: &Event, outcome: Option<crate::outputs::Outcome>) -> Result<(), Refusal> {
    if let (Some(o), Some(recorded), true) = (outcome, &e.result_hash, crate::command::result_rechecked(e.version)) {
        if crate::digest::result_hash(&o.to_value().to_string()) != *recorded {
            return Err(bad(format!("event {} records a result hash its command does not give", e.seq)));
        }
    }
    Ok(())
}

/// The simulation id and gui flag the events up to the last of `events` were recorded under:
/// those of the last root among them (create, fork or load).
fn identity_at(events: &[Event], blobs: &dyn BlobSource) -> Result<(String, bool), Refusal> {
    let root = events.iter().rev().find(|e| e.kind == Kind::Root).ok_or_else(|| bad("history.events has no root"))?;
    let cmd = crate::log::fold::decode(root, blobs).map_err(bad)?;
    match cmd.as_ref().and_then(crate::log::fold::root_identity) {
        Some((id, gui, _)) => Ok((id.to_string(), gui)),
        None => Err(bad(format!("event {} is a root without a root command", root.seq))),
    }
}

/// Passes to `emit`, root first, the commands (with their tools) that re-create an old-server
/// file's objects (no history): the world is approximately the saved one — objects at their
/// saved poses and velocities, robots read from the workspace through `reader` exactly as
/// load_urdf reads them (joints at zero: the old server saved no joint state). Each command is
/// emitted as soon as it is built; the files are read once each, within the request's budget.
pub fn commands_from_readable(
    r: &Readable,
    id: &str,
    reader: &mut Reader,
    emit: &mut dyn FnMut(&str, Command) -> Result<(), Refusal>,
) -> Result<(), Refusal> {
    let gravity = match &r.gravity {
        Some(g) => value::gravity("gravity", g).map_err(bad)?,
        None => [0.0, 0.0, -9.81],
    };
    emit("load_simulation", Command::CreateSimulation { simulation_id: id.into(), gravity, gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) })?;
    if let Some(t) = &r.timestep {
        let (timestep, given) = value::positive_given("timestep", t).map_err(bad)?;
        emit("set_timestep", Command::SetTimestep { timestep, timestep_given: Some(given) })?;
    }
    let empty = serde_json::Map::new();
    // The file's object ids → the ids the re-created objects get (0, 1, … in file order; a
    // robot is one object).
    let mut ids = std::collections::BTreeMap::new();
    for (i, o) in r.objects.iter().enumerate() {
        if let Some(old) = o.get("object_id").and_then(Value::as_i64) {
            ids.insert(old, i as u32);
        }
    }
    for (i, o) in r.objects.iter().enumerate() {
        let o = o.as_object().unwrap_or(&empty);
        let field = |k: &str| value::arg(o, k);
        let name = |k: &str| format!("objects[{i}].{k}");
        let pose = Pose {
            position: field("position").map(|v| value::vec3(&name("position"), v)).transpose().map_err(bad)?.unwrap_or_default(),
            orientation: field("orientation").map(|v| value::quat(&name("orientation"), v)).transpose().map_err(bad)?.unwrap_or([0.0, 0.0, 0.0, 1.0]),
        };
        match field("type").and_then(Value::as_str).unwrap_or("primitive") {
            "primitive" => {
                let (tool, cmd) = primitive_from_readable(o, i, pose)?;
                emit(&tool, cmd)?
            }
            "urdf" => emit("load_urdf", urdf_from_readable(o, i, pose, reader)?)?,
            "mjcf" => emit("load_mjcf", mjcf_from_readable(o, i, pose, reader)?)?,
            other => return Err(bad(format!("{} is {other:?}, not primitive, urdf or mjcf", name("type")))),
        }
        let lin = field("linear_velocity").map(|v| value::vec3(&name("linear_velocity"), v)).transpose().map_err(bad)?;
        let ang = field("angular_velocity").map(|v| value::vec3(&name("angular_velocity"), v)).transpose().map_err(bad)?;
        if lin.is_some() || ang.is_some() {
            emit("set_object_velocity", Command::SetObjectVelocity { object_id: i as u32, linear_velocity: lin, angular_velocity: ang })?;
        }
    }
    for (i, c) in r.constraints.iter().enumerate() {
        emit("create_constraint", constraint_from_readable(c, i, &ids)?)?;
    }
    Ok(())
}

/// A readable object's saved base pose (the same fields for primitives and robots).
struct Pose {
    position: [f32; 3],
    orientation: [f32; 4],
}

/// One readable primitive as the add_* command that re-creates it.
fn primitive_from_readable(o: &serde_json::Map<String, Value>, i: usize, pose: Pose) -> Result<(String, Command), Refusal> {
    let field = |k: &str| value::arg(o, k);
    let name = |k: &str| format!("objects[{i}].{k}");
    let dims: Vec<f32> = match field("dimensions").and_then(Value::as_array) {
        Some(d) => d.iter().map(|x| value::positive(&name("dimensions"), x)).collect::<Result<_, _>>().map_err(bad)?,
        None => return Err(bad(format!("{} is missing", name("dimensions")))),
    };
    let dim = |k: usize| dims.get(k).copied().ok_or_else(|| bad(format!("{} is too short", name("dimensions"))));
    let shape = match field("shape").and_then(Value::as_str).unwrap_or("") {
        "box" => Shape::Box { half_extents: [dim(0)?, dim(1)?, dim(2)?] },
        "sphere" => Shape::Sphere { radius: dim(0)? },
        "cylinder" => Shape::Cylinder { radius: dim(0)?, height: dim(1)? },
        "capsule" => Shape::Capsule { radius: dim(0)?, height: dim(1)? },
        other => return Err(bad(format!("{} {other:?} is not box, sphere, cylinder or capsule", name("shape")))),
    };
    Ok((
        format!("add_{}", shape.name()),
        Command::AddBody {
            shape,
            position: pose.position,
            orientation: pose.orientation,
            mass: field("mass").map(|v| value::non_negative(&name("mass"), v)).transpose().map_err(bad)?.unwrap_or(1.0),
            color: field("color").map(|v| value::color(&name("color"), v)).transpose().map_err(bad)?,
            collides: true,
        },
    ))
}

/// One readable robot as load_urdf's command, built by load_urdf's own adapter from the
/// arguments the old server passed to loadURDF: the same sandbox, built-in assets and blob
/// reading, so the URDF and its meshes travel in the new log like any load_urdf's.
fn urdf_from_readable(o: &serde_json::Map<String, Value>, i: usize, pose: Pose, reader: &mut Reader) -> Result<Command, Refusal> {
    let name = |k: &str| format!("objects[{i}].{k}");
    let path = |k: &str| match value::arg(o, k) {
        None => Ok(None),
        Some(Value::String(p)) => Ok(Some(p.as_str())),
        Some(v) => Err(bad(format!("{} must be a string; got {}", name(k), value::show(v)))),
    };
    // The old server documented `urdf_path` and wrote `file_path`; ours write both.
    let (key, file) = match (path("urdf_path")?, path("file_path")?) {
        (Some(a), Some(b)) if a != b => {
            return Err(bad(format!("{} and {} name different files", name("urdf_path"), name("file_path"))))
        }
        (Some(p), _) => ("urdf_path", p),
        (None, Some(p)) => ("file_path", p),
        (None, None) => return Err(bad(format!("{} (or file_path) is missing", name("urdf_path")))),
    };
    let fixed_base = match value::arg(o, "use_fixed_base") {
        None => false,
        Some(Value::Bool(b)) => *b,
        Some(v) => return Err(bad(format!("{} must be true or false; got {}", name("use_fixed_base"), value::show(v)))),
    };
    // As load_urdf's arguments (read by the same rules; the simulation is the one being built).
    let args = value::Args::from_iter([
        ("sim_id".to_string(), json!("")),
        ("file_path".to_string(), json!(file)),
        ("position".to_string(), json!(pose.position)),
        ("orientation".to_string(), json!(pose.orientation)),
        ("use_fixed_base".to_string(), json!(fixed_base)),
    ]);
    decide_load_urdf(reader, &args).map_err(|why| format!("{} cannot be loaded: {why}", name(key)))
}

/// One readable MJCF object as the load_mjcf command that re-creates it (read from the
/// workspace as load_mjcf reads it; joints at the file's keyframe, or qpos0).
fn mjcf_from_readable(o: &serde_json::Map<String, Value>, i: usize, pose: Pose, reader: &mut Reader) -> Result<Command, Refusal> {
    let name = |k: &str| format!("objects[{i}].{k}");
    let file = match value::arg(o, "mjcf_path") {
        Some(Value::String(p)) => p.clone(),
        Some(v) => return Err(bad(format!("{} must be a string; got {}", name("mjcf_path"), value::show(v)))),
        None => return Err(bad(format!("{} is missing", name("mjcf_path")))),
    };
    let fixed_base = match value::arg(o, "use_fixed_base") {
        None => false,
        Some(Value::Bool(b)) => *b,
        Some(v) => return Err(bad(format!("{} must be true or false; got {}", name("use_fixed_base"), value::show(v)))),
    };
    let mut args = value::Args::from_iter([
        ("sim_id".to_string(), json!("")),
        ("file_path".to_string(), json!(file)),
        ("position".to_string(), json!(pose.position)),
        ("orientation".to_string(), json!(pose.orientation)),
        ("use_fixed_base".to_string(), json!(fixed_base)),
    ]);
    if let Some(Value::String(k)) = value::arg(o, "keyframe") {
        args.insert("keyframe".to_string(), json!(k));
    }
    crate::files::mjcf::decide_load_mjcf(reader, &args).map_err(|why| format!("{} cannot be loaded: {why}", name("mjcf_path")))
}

/// One readable constraint as the command that re-creates it (object ids mapped to the
/// re-created objects').
fn constraint_from_readable(
    c: &Value,
    i: usize,
    ids: &std::collections::BTreeMap<i64, u32>,
) -> Result<Command, Refusal> {
    let empty = serde_json::Map::new();
    let c = c.as_object().unwrap_or(&empty);
    let name = |k: &str| format!("constraints[{i}].{k}");
    let object = |k: &str| -> Result<Option<u32>, Refusal> {
        let v = value::arg(c, k).ok_or_else(|| bad(format!("{} is missing", name(k))))?;
        let id = value::integer(&name(k), v).map_err(bad)?;
        if id == -1 && k == "child_id" {
            return Ok(None);
        }
        ids.get(&id).copied().map(Some).ok_or_else(|| bad(format!("{} names no saved object ({id})", name(k))))
    };
    let parent_id = object("parent_id")?.ok_or_else(|| bad(format!("{} is missing", name("parent_id"))))?;
    let joint_type = value::arg(c, "joint_type")
        .and_then(Value::as_str)
        .and_then(crate::command::ConstraintType::parse)
        .ok_or_else(|| bad(format!("{} is not fixed, prismatic, spherical or revolute", name("joint_type"))))?;
    let v3 = |k: &str, d: [f32; 3]| value::arg(c, k).map(|v| value::vec3(&name(k), v)).transpose().map(|v| v.unwrap_or(d)).map_err(bad);
    let q = |k: &str| value::arg(c, k).map(|v| value::quat(&name(k), v)).transpose().map(|v| v.unwrap_or([0.0, 0.0, 0.0, 1.0])).map_err(bad);
    Ok(Command::CreateConstraint {
        spec: crate::command::ConstraintSpec {
            parent_id,
            child_id: object("child_id")?,
            joint_type,
            joint_axis: v3("joint_axis", [0.0, 0.0, 1.0])?,
            parent_frame_position: v3("parent_frame_position", [0.0; 3])?,
            child_frame_position: v3("child_frame_position", [0.0; 3])?,
            parent_frame_orientation: q("parent_frame_orientation")?,
            child_frame_orientation: q("child_frame_orientation")?,
        },
    })
}

/// A robot's joint positions as saved (URDF and MJCF alike): what a reader re-sets them to (a
/// ball joint's is its quaternion [x, y, z, w]).
fn joint_positions(world: &World, id: u32, joints: usize) -> Vec<crate::outputs::JointValue> {
    (0..joints).filter_map(|i| world.joint_state(id, i).map(|j| j.joint_position)).collect()
}
