//! MCAP export (docs/tools.md "Open a run in Foxglove"): an interval of a chain as Foxglove
//! messages on a time axis of *simulated* time, so any run — live or recorded — opens in
//! Foxglove's 3D panel without a plugin.
//!
//! It is one more observer of the one re-simulation core, riding along the trajectory
//! sampler (`trajectory::sample_interval_with`): the same interval, the same samples, the same
//! hash checks, the same bounds. Three topics, JSON-encoded, with Foxglove's own JSON schemas
//! (assets/foxglove, from the npm package `@foxglove/schemas` 2.1.0):
//! - `/scene` (`foxglove.SceneUpdate`): one entity per body (an object's base, a robot's link),
//!   framed by that body, holding its colliders as primitives in the pictures' colours; the
//!   whole scene at the start, then only what changed (added, reshaped or recoloured entities,
//!   deletions) whenever the set of bodies or shapes changes.
//! - `/tf` (`foxglove.FrameTransforms`): every body's pose (parent `world`) at every sample,
//!   and at a scene change; poses are those get_object_state reports (f32 in its shortest form).
//! - `/contacts` (`foxglove.SceneUpdate`, only when asked): the contact points of the last
//!   step at every sample, as small spheres in the world frame.
//!
//! The file is built in memory and handed to the files layer, which writes it; nothing here
//! touches a file, the world or the log.

use std::collections::BTreeMap;
use std::io::Cursor;

use rapier3d::glamx::Quat;
use rapier3d::parry::shape::TypedShape;
use rapier3d::prelude::{Pose, SharedShape, Vector};
use serde_json::{json, Value};

use crate::log::fold::{Lent, Moment};
use crate::outputs::Trajectory;
use crate::seeing::sensing::{contacts, render};
use crate::seeing::style;
use crate::seeing::trajectory::{self, Request};
use crate::value::{r32, r32s, Refusal};
use crate::world::World;

/// Foxglove's JSON schema of `foxglove.SceneUpdate` (npm `@foxglove/schemas` 2.1.0,
/// `dist/jsonschema`): what Foxglove's 3D panel recognises by name, embedded in the file.
const SCENE_UPDATE_SCHEMA: &str = include_str!("../../assets/foxglove/SceneUpdate.json");
/// Foxglove's JSON schema of `foxglove.FrameTransforms` (same package).
const FRAME_TRANSFORMS_SCHEMA: &str = include_str!("../../assets/foxglove/FrameTransforms.json");

/// The largest MCAP file an export writes: past it the export is refused, saying what to
/// change (the transforms are already held to `trajectory::MAX_CELLS`; this bounds meshes and
/// contacts too).
pub const MAX_FILE_BYTES: usize = 256 << 20;

/// Bytes a message adds to the file besides its payload: the record's opcode, length, channel,
/// sequence and two times (31 B) and its message-index entry (16 B), rounded up.
const MESSAGE_OVERHEAD: usize = 48;

/// The frame every body's transform is given in: Foxglove's 3D panel follows a display frame,
/// and one fixed root makes every body placeable from any of them.
pub const WORLD_FRAME: &str = "world";

/// Re-simulates `lent` once, sampling it as get_trajectory does and writing the samples as
/// MCAP; `with_contacts` adds the `/contacts` topic. Returns the trajectory (for the summary
/// a reply gives, and so the file's poses are the table's) and the file's bytes, for the
/// files layer to write: nothing here may touch the disk.
pub fn export(lent: &Lent, req: &Request, with_contacts: bool) -> Result<(Trajectory, Vec<u8>), Refusal> {
    let mut out = Export::new(req.object_ids.clone(), with_contacts)?;
    let t = trajectory::sample_interval_with(lent, req, &mut |w, m| out.observe(w, m))?;
    let bytes = out.finish()?;
    Ok((t, bytes))
}

/// A time in simulated seconds as MCAP's nanoseconds (log and publish time).
fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// A time as Foxglove's `{sec, nsec}`.
fn stamp(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn xyz(v: [f64; 3]) -> Value {
    json!({"x": v[0], "y": v[1], "z": v[2]})
}

fn xyzw(q: [f64; 4]) -> Value {
    json!({"x": q[0], "y": q[1], "z": q[2], "w": q[3]})
}

/// A pose as Foxglove's `{position, orientation}`, numbers as the read tools report them.
fn pose(p: &Pose) -> Value {
    json!({"position": xyz(r32s(p.translation.to_array())), "orientation": xyzw(r32s(p.rotation.to_array()))})
}

fn size(v: Vector) -> Value {
    xyz(r32s(v.to_array()))
}

fn rgba(c: [f32; 4]) -> Value {
    json!({"r": r32(c[0]), "g": r32(c[1]), "b": r32(c[2]), "a": r32(c[3])})
}

/// What one collider looks like, cheaply compared: its handle (a new collider gets a new
/// generation), its shape's address (shapes are never changed in place), its colour and its
/// pose on the body, bit for bit.
type Look = (u64, usize, [u32; 4], [u32; 7]);

/// One body: a frame of its own, the colliders on it and where they sit on it.
struct Body {
    /// `object_{id}`, `object_{id}/link_{i}`, or `object_{id}/world` (an MJCF worldbody's static
    /// geoms under a free base).
    frame: String,
    object_id: u32,
    link_index: i64,
    /// The body's world pose (a collider without a body: the collider's).
    pose: Pose,
    /// (shape, pose on the body, colour) per collider.
    parts: Vec<(SharedShape, Pose, [f32; 4])>,
    /// What the entity shows, cheaply (see `Look`).
    signature: Vec<Look>,
}

/// The world's bodies (those of `ids` only, when given): every object's base and every robot
/// link, whether or not it has a collider (so every object's pose is in `/tf`), then any other
/// body a collider hangs on; each with its colliders in `World::scene` order.
fn bodies(w: &World, ids: Option<&[u32]>) -> Vec<Body> {
    let physics = w.physics();
    let wanted = |id: u32| ids.is_none_or(|ids| ids.contains(&id));
    let mut out: Vec<Body> = Vec::new();
    // Where each body is in `out`, by (object, rapier body; a body-less collider by its own handle).
    let mut at: BTreeMap<(u32, bool, (u32, u32)), usize> = BTreeMap::new();
    let mut add = |out: &mut Vec<Body>, key, frame: String, object_id, link_index, pose| {
        *at.entry(key).or_insert_with(|| {
            // Two extra bodies of one object (not made today) would still get two frames.
            let frame = if out.iter().any(|b: &Body| b.frame == frame) { format!("{frame}_{}", out.len()) } else { frame };
            out.push(Body { frame, object_id, link_index, pose, parts: vec![], signature: vec![] });
            out.len() - 1
        })
    };
    for (id, obj) in w.objects().filter(|(id, _)| wanted(*id)) {
        let mut links = vec![(-1, obj.body)];
        links.extend(obj.kind.robot().into_iter().flat_map(|r| r.links.iter().enumerate().map(|(i, l)| (i as i64, l.body))));
        for (link, h) in links {
            let Some(b) = physics.bodies.get(h) else { continue };
            let frame = if link < 0 { format!("object_{id}") } else { format!("object_{id}/link_{link}") };
            add(&mut out, (id, true, h.into_raw_parts()), frame, id, link, *b.position());
        }
    }
    for p in w.scene().parts.iter().filter(|p| wanted(p.object_id)) {
        let collider = physics.colliders.get(p.collider);
        let body = collider.and_then(|c| c.parent()).and_then(|h| Some((h, physics.bodies.get(h)?)));
        let i = match body {
            Some((h, b)) => add(&mut out, (p.object_id, true, h.into_raw_parts()), format!("object_{}/world", p.object_id), p.object_id, p.link_index, *b.position()),
            None => add(&mut out, (p.object_id, false, p.collider.into_raw_parts()), format!("object_{}/world", p.object_id), p.object_id, p.link_index, p.pose),
        };
        let offset = match body {
            Some(_) => collider.and_then(|c| c.position_wrt_parent().copied()).unwrap_or(Pose::IDENTITY),
            None => Pose::IDENTITY,
        };
        let color = style::object_rgba(p.object_id, p.color);
        let (index, generation) = p.collider.into_raw_parts();
        let [tx, ty, tz] = offset.translation.to_array();
        let [qx, qy, qz, qw] = offset.rotation.to_array();
        out[i].signature.push((
            u64::from(index) << 32 | u64::from(generation),
            std::sync::Arc::as_ptr(&p.shape.0) as *const () as usize,
            color.map(f32::to_bits),
            [tx, ty, tz, qx, qy, qz, qw].map(f32::to_bits),
        ));
        out[i].parts.push((p.shape.clone(), offset, color));
    }
    out
}

/// Foxglove primitives of an entity, by kind (`cubes`, `spheres`, `cylinders`, `triangles`).
#[derive(Default)]
struct Primitives {
    cubes: Vec<Value>,
    spheres: Vec<Value>,
    cylinders: Vec<Value>,
    triangles: Vec<Value>,
}

impl Primitives {
    /// Adds `shape`, placed at `at` on its body, drawn in `color`: boxes, balls and cylinders as
    /// Foxglove's own primitives, a capsule as a cylinder between two spheres, anything else
    /// (meshes, convex hulls) as the triangles the camera draws (`render::triangulate`).
    fn add(&mut self, shape: &SharedShape, at: &Pose, color: [f32; 4]) {
        let color = rgba(color);
        match shape.as_typed_shape() {
            TypedShape::Cuboid(c) => self.cubes.push(json!({"pose": pose(at), "size": size(c.half_extents * 2.0), "color": color})),
            TypedShape::Ball(b) => self.spheres.push(json!({"pose": pose(at), "size": size(Vector::splat(b.radius * 2.0)), "color": color})),
            TypedShape::Cylinder(c) => {
                // parry's cylinders stand on their y axis, Foxglove's on z.
                let upright = *at * Pose::from_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2));
                let d = c.radius * 2.0;
                self.cylinders.push(cylinder(&upright, Vector::new(d, d, c.half_height * 2.0), color));
            }
            TypedShape::Capsule(c) => {
                let (a, b) = (c.segment.a, c.segment.b);
                let d = c.radius * 2.0;
                for end in [a, b] {
                    let p = *at * Pose::from_translation(end);
                    self.spheres.push(json!({"pose": pose(&p), "size": size(Vector::splat(d)), "color": color}));
                }
                let axis = b - a;
                if axis.length() > 0.0 {
                    let turn = Quat::from_rotation_arc(Vector::Z, axis.normalize());
                    let mid = *at * Pose::from_parts((a + b) * 0.5, turn);
                    self.cylinders.push(cylinder(&mid, Vector::new(d, d, axis.length()), color));
                }
            }
            _ => {
                let (points, indices) = render::triangulate(shape.as_ref());
                let points: Vec<Value> = points.iter().map(|p| xyz(r32s(p.to_array()))).collect();
                let indices: Vec<u32> = indices.iter().flatten().copied().collect();
                self.triangles.push(json!({"pose": pose(at), "points": points, "color": color, "colors": [], "indices": indices}));
            }
        }
    }
}

fn cylinder(at: &Pose, dims: Vector, color: Value) -> Value {
    json!({"pose": pose(at), "size": size(dims), "bottom_scale": 1.0, "top_scale": 1.0, "color": color})
}

/// A `foxglove.SceneEntity` with every list the schema requires.
fn entity(id: &str, frame: &str, ns: u64, metadata: Value, p: Primitives) -> Value {
    json!({
        "timestamp": stamp(ns), "frame_id": frame, "id": id, "lifetime": stamp(0), "frame_locked": true,
        "metadata": metadata, "arrows": [], "cubes": p.cubes, "spheres": p.spheres, "cylinders": p.cylinders,
        "lines": [], "triangles": p.triangles, "texts": [], "models": [],
    })
}

/// The MCAP being written, and what it has shown so far.
struct Export {
    writer: mcap::Writer<Cursor<Vec<u8>>>,
    /// Channel ids of `/scene`, `/tf` and `/contacts` (when asked).
    scene: u16,
    tf: u16,
    contacts: Option<u16>,
    /// The next message's sequence number per channel.
    sequence: BTreeMap<u16, u32>,
    ids: Option<Vec<u32>>,
    /// Each entity on `/scene` now, with its signature when last sent.
    shown: BTreeMap<String, Vec<Look>>,
    /// Bytes of messages written so far (the writer holds the open chunk).
    bytes: usize,
    /// Why the export stopped (too large, or the writer failed), if it did.
    failed: Option<Refusal>,
}

fn mcap_error(e: mcap::McapError) -> Refusal {
    format!("The MCAP file could not be written: {e}")
}

impl Export {
    fn new(ids: Option<Vec<u32>>, with_contacts: bool) -> Result<Export, Refusal> {
        let options = mcap::WriteOptions::new().library(format!("physics-mcp {}", env!("CARGO_PKG_VERSION")));
        let mut writer = options.create(Cursor::new(Vec::new())).map_err(mcap_error)?;
        let none = BTreeMap::new();
        let scene_schema = writer.add_schema("foxglove.SceneUpdate", "jsonschema", SCENE_UPDATE_SCHEMA.as_bytes()).map_err(mcap_error)?;
        let tf_schema = writer.add_schema("foxglove.FrameTransforms", "jsonschema", FRAME_TRANSFORMS_SCHEMA.as_bytes()).map_err(mcap_error)?;
        let scene = writer.add_channel(scene_schema, "/scene", "json", &none).map_err(mcap_error)?;
        let tf = writer.add_channel(tf_schema, "/tf", "json", &none).map_err(mcap_error)?;
        let contacts = with_contacts.then(|| writer.add_channel(scene_schema, "/contacts", "json", &none)).transpose().map_err(mcap_error)?;
        Ok(Export { writer, scene, tf, contacts, sequence: BTreeMap::new(), ids, shown: BTreeMap::new(), bytes: 0, failed: None })
    }

    /// The re-simulation observer: the scene when it changed, the transforms at every sample
    /// (and with a scene change), the contacts at every sample. False once the export failed.
    fn observe(&mut self, w: &World, m: &Moment) -> bool {
        let done = self.moment(w, m.sample);
        if let Err(why) = done {
            self.failed = Some(why);
        }
        self.failed.is_none()
    }

    fn moment(&mut self, w: &World, sample: bool) -> Result<(), Refusal> {
        let ns = nanos(w.current_time());
        let bodies = bodies(w, self.ids.as_deref());
        let changed = self.scene_update(&bodies, ns)?;
        if sample || changed {
            let transforms: Vec<Value> = bodies
                .iter()
                .map(|b| {
                    json!({"timestamp": stamp(ns), "parent_frame_id": WORLD_FRAME, "child_frame_id": b.frame,
                        "translation": xyz(r32s(b.pose.translation.to_array())), "rotation": xyzw(r32s(b.pose.rotation.to_array()))})
                })
                .collect();
            self.write(self.tf, ns, &json!({ "transforms": transforms }))?;
        }
        if let (Some(channel), true) = (self.contacts, sample) {
            let mut points = Primitives::default();
            for c in contacts::contacts(w, None) {
                let at = Pose::from_translation(Vector::from_array(c.position_on_a.map(|x| x as f32)));
                points.spheres.push(json!({"pose": pose(&at), "size": xyz([0.02; 3]), "color": rgba([0.9, 0.1, 0.1, 1.0])}));
            }
            let meta = json!([{"key": "count", "value": points.spheres.len().to_string()}]);
            let update = json!({"deletions": [], "entities": [entity("contacts", WORLD_FRAME, ns, meta, points)]});
            self.write(channel, ns, &update)?;
        }
        Ok(())
    }

    /// Sends what of the scene changed since it was last sent (all of it the first time):
    /// new and changed entities, deletions of the bodies gone. Whether anything was sent.
    fn scene_update(&mut self, bodies: &[Body], ns: u64) -> Result<bool, Refusal> {
        let mut entities = Vec::new();
        // A body without colliders (a robot's massless link) is a frame, not an entity.
        let drawn: Vec<&Body> = bodies.iter().filter(|b| !b.parts.is_empty()).collect();
        for b in &drawn {
            if self.shown.get(&b.frame) == Some(&b.signature) {
                continue;
            }
            let mut p = Primitives::default();
            for (shape, at, color) in &b.parts {
                p.add(shape, at, *color);
            }
            let meta = json!([{"key": "object_id", "value": b.object_id.to_string()}, {"key": "link_index", "value": b.link_index.to_string()}]);
            entities.push(entity(&b.frame, &b.frame, ns, meta, p));
            self.shown.insert(b.frame.clone(), b.signature.clone());
        }
        let gone: Vec<String> = self.shown.keys().filter(|f| !drawn.iter().any(|b| &b.frame == *f)).cloned().collect();
        let deletions: Vec<Value> = gone
            .iter()
            .map(|id| {
                self.shown.remove(id);
                json!({"timestamp": stamp(ns), "type": 0, "id": id})
            })
            .collect();
        let first = !self.sequence.contains_key(&self.scene);
        if entities.is_empty() && deletions.is_empty() && !first {
            return Ok(false);
        }
        self.write(self.scene, ns, &json!({"deletions": deletions, "entities": entities}))?;
        Ok(true)
    }

    /// Writes one message at simulated time `ns` (log and publish time alike).
    fn write(&mut self, channel: u16, ns: u64, message: &Value) -> Result<(), Refusal> {
        let data = serde_json::to_vec(message).map_err(|e| format!("The MCAP file could not be written: {e}"))?;
        let sequence = self.sequence.entry(channel).or_insert(0);
        let header = mcap::records::MessageHeader { channel_id: channel, sequence: *sequence, log_time: ns, publish_time: ns };
        *sequence += 1;
        self.writer.write_to_known_channel(&header, &data).map_err(mcap_error)?;
        // The message record's header (opcode, length, channel, sequence, two times) and its
        // chunk-index entry come on top of the payload: counted so the bound holds for the file.
        self.bytes += data.len() + MESSAGE_OVERHEAD;
        if self.bytes > MAX_FILE_BYTES {
            return Err(format!(
                "the MCAP file would be over {} MiB; give a larger every, a shorter interval or fewer object_ids",
                MAX_FILE_BYTES >> 20
            ));
        }
        Ok(())
    }

    /// The finished file (summary, indexes), or why there is none.
    fn finish(mut self) -> Result<Vec<u8>, Refusal> {
        if let Some(why) = self.failed.take() {
            return Err(why);
        }
        self.writer.finish().map_err(mcap_error)?;
        Ok(self.writer.into_inner().into_inner())
    }
}
