//! MuJoCo MJCF models: the event's MJCF text → a robot in the world, through `rapier3d-mjcf`
//! (its `mjcf-rs` parser and its conversion to rapier bodies, colliders and joint frames),
//! adapted to our object/link/joint model so every robot tool works on it as on a URDF robot.
//!
//! Pure like the URDF path: the adapter splices `<include>`s into the text before the event is
//! made, `Command::validate` prepares the model to refuse bad input, and `World::apply`
//! prepares it again (the same text gives the same robot) to insert it.
//!
//! The mapping (docs/tools.md "MJCF models"):
//! - Link −1 is the base: the static worldbody (with its geoms, floor planes included), or the
//!   single top-level body when it has a free joint (the worldbody's geoms then sit on a static
//!   body of their own). Every hinge or slide joint is one link, numbered in file order (depth
//!   first, as MuJoCo numbers joints); a body with several joints is a chain of links at the
//!   body's frame (the crate's massless spacers carry the earlier joints); a jointless body is
//!   merged into its parent's link (colliders and mass).
//! - A link's rapier body frame is the MuJoCo body frame, so get_link_state reports `xpos`.
//!   The joint's `ref` is folded into the parent-side joint frame, so a rapier coordinate is
//!   MuJoCo's qpos and limits are `range` as written.
//! - The crate's joint motors are not used (our motors drive the joints); `damping` is the
//!   multibody's per-DoF damping and `armature` is added to the joint-space mass diagonal (the
//!   crate's routing, reproduced here on our insertion).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::body::{GeomType, JointType};
use rapier3d_mjcf::mjcf_rs::Model;
use rapier3d_mjcf::{ContactFilterMode, MjcfLoaderOptions, MjcfRobot};
use serde::{Deserialize, Serialize};

use super::robot::{Robot, RobotLink};
use super::urdf::{JointKind, JointSpec};
use super::{DynamicsExtras, Object, ObjectKind, World};
use crate::command::Blob;
use crate::outputs::{MjcfBodyLink, MjcfLoaded};
use crate::value::{r32s, Refusal};

/// Half-thickness of the box that stands in for an MJCF plane (a rapier half-space has an
/// infinite bounding box, which the renderer and the viewer cannot frame).
const PLANE_HALF_THICKNESS: f32 = 0.5;
/// Half-extent of a plane whose MJCF size is 0 ("infinite" in MuJoCo).
const PLANE_INFINITE_HALF_EXTENT: f32 = 100.0;

/// What an MJCF object keeps beside its `Robot` (saved files, results, removal).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct MjcfInfo {
    /// The keyframe the joints started at, if one was named.
    pub keyframe: Option<String>,
    /// Every body in file order with the link carrying its frame.
    pub bodies: Vec<MjcfBodyLink>,
    /// What of the file is not simulated.
    pub ignored: Vec<String>,
    /// With a free-joint root: the static body holding the worldbody's geoms (a floor), if any.
    pub world_body: Option<RigidBodyHandle>,
    /// That body's colliders.
    pub world_colliders: Vec<ColliderHandle>,
    /// Body pairs whose contacts are off (merged bodies by their link): `<contact><exclude>`,
    /// then (loads with `parent_filter`) each multi-joint body and its parent body, which MuJoCo
    /// never lets touch and no joint of ours parts (`parent_pairs_across_spacers`).
    pub excluded: Vec<(RigidBodyHandle, RigidBodyHandle)>,
}

/// Every MJCF object's `<exclude>` pairs (merged bodies by their link), for the step's
/// contact filter (`filters::ContactFilter`).
pub(super) fn excluded_body_pairs(w: &World) -> Vec<(RigidBodyHandle, RigidBodyHandle)> {
    let mut out = Vec::new();
    for obj in w.tables.objects.values() {
        if let ObjectKind::Mjcf { mjcf, .. } = &obj.kind {
            out.extend(mjcf.excluded.iter().copied());
        }
    }
    out
}

/// A parsed and converted model, checked, ready to insert.
#[derive(Clone)]
pub struct Prepared {
    model: Model,
    robot: MjcfRobot,
    ignored: Vec<String>,
    keyframe_qpos: Option<Vec<f64>>,
    /// The keyframe's `ctrl` (empty: none).
    keyframe_ctrl: Vec<f64>,
    /// What the actuators need beyond the parser's (`actuators::actuator_extras`).
    actuator_extras: Vec<super::actuators::ActuatorExtras>,
    /// The first ball joint's name (loads before event version 9 refuse it).
    ball_joint: Option<String>,
}

/// The note `scan` writes for a model with actuators, replaced by per-actuator notes when a
/// load simulates them.
const ACTUATORS_IGNORED: &str = "<actuator>: actuators are not simulated; drive joints with set_joint_motor_control";

/// The note `scan` writes for a model with sensors, replaced by per-sensor notes when a load
/// keeps them.
const SENSORS_IGNORED: &str = "<sensor>: sensors are not simulated; read state with the sensing tools";

/// The note `scan` writes for a model with tendons, replaced by per-tendon notes when a load
/// builds them (event version 8).
const TENDONS_IGNORED: &str = "<tendon>: fixed tendons are not simulated";

/// The note `scan` writes for a model with equality constraints, replaced by notes for the
/// ones not built when a load builds them (event version 8).
const EQUALITY_IGNORED: &str = "<equality>: equality constraints are not simulated";

/// The note `scan` writes for a model with contact pairs, replaced by notes for the ones not
/// built when a load builds them (event version 9).
const PAIRS_IGNORED: &str = "<contact><pair>: explicit contact pairs are not applied";

/// Elements the engine cannot simulate and the server refuses (docs/tools.md "MJCF models") (never dropped silently).
const REFUSED_ELEMENTS: [(&str, &str); 6] = [
    ("spatial", "spatial tendons are not supported"),
    ("flex", "flex (deformable) objects are not supported"),
    ("flexcomp", "flex (deformable) objects are not supported"),
    ("composite", "composite objects are not supported"),
    ("plugin", "engine plugins are not supported"),
    ("include", "<include> must be resolved by the server before loading"),
];

/// Whether an attribute's number(s) say anything but zero (an unreadable value counts as set).
fn nonzero(v: &str) -> bool {
    v.split_whitespace().any(|x| x.parse::<f64>() != Ok(0.0))
}

/// Scans the text: the root must be `<mujoco>`, no refused element, and notes what is ignored.
fn scan(xml: &str) -> Result<Vec<String>, Refusal> {
    use xml::reader::{EventReader, XmlEvent};
    let mut first = true;
    let mut found: BTreeSet<String> = BTreeSet::new();
    let mut notes: Vec<String> = Vec::new();
    let mut note = |s: String| {
        if !notes.contains(&s) {
            notes.push(s);
        }
    };
    let mut stack: Vec<String> = Vec::new();
    for event in EventReader::new(xml.as_bytes()) {
        match event {
            Ok(XmlEvent::StartElement { name, attributes, .. }) => {
                let tag = name.local_name.clone();
                if first {
                    first = false;
                    if tag != "mujoco" {
                        return Err(format!("file_path is not an MJCF model: its root element is <{tag}>, not <mujoco>"));
                    }
                }
                if let Some((_, why)) = REFUSED_ELEMENTS.iter().find(|(t, _)| *t == tag) {
                    return Err(format!("file_path uses <{tag}>: {why}"));
                }
                let parent = stack.last().map(String::as_str).unwrap_or("");
                let attr = |n: &str| attributes.iter().find(|a| a.name.local_name == n).map(|a| a.value.clone());
                if tag == "option" {
                    for a in ["viscosity", "density"] {
                        if attr(a).is_some_and(|v| nonzero(&v)) {
                            note(format!("<option {a}>: fluid forces are not simulated"));
                        }
                    }
                    for a in ["integrator", "cone", "impratio", "noslip_iterations", "o_solref", "o_solimp"] {
                        if attr(a).is_some() {
                            note(format!("<option {a}>: the engine's own solver settings apply"));
                        }
                    }
                }
                if tag == "flag" && parent == "option" {
                    note("<option><flag>: the engine's own settings apply".into());
                }
                for a in ["solref", "solimp", "solreflimit", "solimplimit", "solmix", "solreffriction", "solimpfriction"] {
                    if attr(a).is_some() {
                        note(format!("{a} (on <{tag}>): rapier's contact and limit softness apply"));
                    }
                }
                for a in ["margin", "gap"] {
                    if (tag == "geom" || tag == "joint") && attr(a).is_some_and(|v| nonzero(&v)) {
                        note(format!("{a} (on <{tag}>): contacts start at touch"));
                    }
                }
                if tag == "joint" {
                    for (a, why) in [
                        ("stiffness", "joint springs are not simulated"),
                        ("frictionloss", "joint dry friction is not simulated"),
                        ("springdamper", "joint springs are not simulated"),
                    ] {
                        if attr(a).is_some_and(|v| nonzero(&v)) {
                            note(format!("joint {a}: {why}"));
                        }
                    }
                }
                if tag == "body" && attr("gravcomp").is_some() {
                    note("body gravcomp: gravity compensation is not simulated".into());
                }
                found.insert(tag.clone());
                stack.push(tag);
            }
            Ok(XmlEvent::EndElement { .. }) => {
                stack.pop();
            }
            Ok(_) => {}
            Err(e) => return Err(format!("file_path is not well-formed XML: {e}")),
        }
    }
    if first {
        return Err("file_path is not an MJCF model: it has no root element".into());
    }
    for (tag, why) in [
        ("actuator", ACTUATORS_IGNORED),
        ("tendon", TENDONS_IGNORED),
        ("equality", EQUALITY_IGNORED),
        ("sensor", SENSORS_IGNORED),
        ("pair", PAIRS_IGNORED),
    ] {
        if found.contains(tag) {
            note(why.into());
        }
    }
    Ok(notes)
}

/// Prepares the model the event's blobs hold (the check and the fold share it).
pub fn prepare_blob(mjcf: &Blob, meshes: &BTreeMap<String, Blob>, keyframe: Option<&str>) -> Result<Prepared, Refusal> {
    if !mjcf.is_loaded() {
        return Err("the MJCF text is missing from the event".into());
    }
    let text = std::str::from_utf8(&mjcf.bytes).map_err(|_| "file_path is not an MJCF model: it is not UTF-8 text".to_string())?;
    prepare(text, meshes, keyframe)
}

/// The folder the parser is told the model is in. It is never read: [`parse_model`] refuses
/// every element the parser would open a file for, and meshes come from the event's blobs.
const NO_FOLDER: &str = "/nonexistent-physics-mcp-mjcf-base";

/// An element of a model that names a file the parser would open itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileReference {
    /// The element's tag (`include`, `model`).
    pub tag: String,
    /// Its `file` attribute as written.
    pub file: String,
}

/// The first element of `xml` that mjcf-rs would read a file for — `<include file>` (the
/// server splices includes into the text before the event is made) or `<asset><model file>`
/// (a sub-model, not supported) — matched by local name as the parser matches them. None when
/// the model is self-contained; text that is not XML has none (the parser refuses it).
pub fn file_reference(xml: &str) -> Option<FileReference> {
    file_references(xml).into_iter().next()
}

/// Every element of `xml` that mjcf-rs would read a file for, in document order
/// (`file_reference`'s list).
pub fn file_references(xml: &str) -> Vec<FileReference> {
    let Ok(doc) = roxmltree::Document::parse(xml) else { return Vec::new() };
    doc.descendants()
        .filter(|n| n.is_element() && matches!(n.tag_name().name(), "include" | "model"))
        .filter(|n| n.tag_name().name() == "include" || n.attribute("file").is_some())
        .map(|n| FileReference { tag: n.tag_name().name().to_string(), file: n.attribute("file").unwrap_or("").to_string() })
        .collect()
}

/// The one place MJCF text reaches the parser: refused first if any element would make the
/// parser open a file (`file_reference`), so parsing reads nothing but `xml`.
pub fn parse_model(xml: &str) -> Result<Model, Refusal> {
    super::xml_guard::check(xml, "file_path")?;
    if let Some(r) = file_reference(xml) {
        return Err(match r.tag.as_str() {
            "include" => format!("<include file=\"{}\"> must be resolved by the server before loading", r.file),
            _ => format!("<asset><model file=\"{}\"> (a sub-model in another file) is not supported", r.file),
        });
    }
    Model::from_str(xml, Path::new(NO_FOLDER)).map_err(|e| {
        let msg = e.to_string();
        let first = msg.lines().next().unwrap_or("").trim().to_string();
        format!("file_path is not a valid MJCF model: {first}")
    })
}

impl Prepared {
    /// The model's first ball joint, by name (None: it has none).
    pub fn ball_joint(&self) -> Option<&str> {
        self.ball_joint.as_deref()
    }

    /// The model's `<option>` timestep (s) and gravity (m/s²), as written.
    pub fn options(&self) -> super::mjcf_options::ModelOptions {
        super::mjcf_options::ModelOptions { timestep: self.model.option.timestep, gravity: self.model.option.gravity }
    }

    /// At most [`crate::limits::MAX_MODEL_ELEMENTS`] actuators, sensors, equality constraints,
    /// tendons and contact pairs each (a pair is looked up among every geom, kept, hashed,
    /// snapshotted and put in the contact hook's map every step), and as many joint terms in the
    /// tendons and their actuators' copies; and joint anchors (`<joint pos>`) within
    /// [`crate::limits::MAX_EXTENT_M`]: a hinge anchored
    /// at 1e308 m loads, then panics rapier's joint-limit solve on every step. Checked at the
    /// edge only (`Command::within_extent`), not in [`prepare`], which every fold runs: logs that
    /// loaded such a model before the bound fold as they always did.
    pub fn joints_within_extent(&self) -> Result<(), Refusal> {
        let most = crate::limits::MAX_MODEL_ELEMENTS;
        let m = &self.model;
        for (what, count) in [("actuators", m.actuators.len()), ("sensors", m.sensors.len()), ("equality constraints", m.equality.len()), ("tendons", m.tendons.len()), ("contact pairs", m.contact.pairs.len())] {
            if count > most {
                return Err(format!("file_path has {count} {what}; a model may have at most {most}"));
            }
        }
        // Each tendon-driven actuator carries its tendon's joint list, and every step, hash and
        // snapshot walks them all: one tendon listing a joint 400,000 times under 1,024
        // actuators would be gigabytes.
        let entries = |t: &str| m.tendons.iter().find(|x| x.name.as_deref() == Some(t)).map_or(0, |x| x.joints.len());
        let terms: usize = m.tendons.iter().map(|t| t.joints.len()).sum::<usize>()
            + m.actuators.iter().filter_map(|a| a.tendon.as_deref()).map(entries).sum::<usize>();
        if terms > most {
            return Err(format!("file_path's tendons and the actuators on them list {terms} joint terms in all; a model may have at most {most}"));
        }
        let bound = crate::limits::MAX_EXTENT_M;
        for (id, entry) in self.model.bodies_iter() {
            for j in &entry.body.joints {
                let body = || entry.body.name.clone().unwrap_or_else(|| format!("#{id}"));
                let joint = j.name.clone().unwrap_or_else(|| format!("of body {}", body()));
                if !j.pos.iter().all(|x| x.abs() <= bound) {
                    return Err(format!("joint {joint} has pos {:?}, not finite numbers within {bound} m", j.pos));
                }
                if matches!(j.type_, JointType::Hinge | JointType::Slide) {
                    super::robot::axis_refusal(&joint, j.axis)?;
                }
            }
        }
        Ok(())
    }
}

/// Parses, checks and converts MJCF text (includes already spliced; meshes by `<mesh file>`).
pub fn prepare(xml: &str, meshes: &BTreeMap<String, Blob>, keyframe: Option<&str>) -> Result<Prepared, Refusal> {
    let mut ignored = scan(xml)?;
    let model = parse_model(xml)?;
    let base = Path::new(NO_FOLDER);
    ignored.insert(
        0,
        format!(
            "<option timestep=\"{}\" gravity=\"{} {} {}\">: the simulation's own timestep and gravity apply",
            model.option.timestep, model.option.gravity[0], model.option.gravity[1], model.option.gravity[2]
        ),
    );
    let body_name = |id: usize| model.bodies[id].body.name.clone().unwrap_or_else(|| format!("#{id}"));
    crate::limits::check_model_joints(model.bodies_iter().map(|(_, e)| e.body.joints.len()).sum())?;
    let mut top_level = 0usize;
    let mut free_root = false;
    let mut ball_joint = None;
    for (id, entry) in model.bodies_iter() {
        if entry.parent == Some(0) {
            top_level += 1;
        }
        for j in &entry.body.joints {
            let jname = j.name.clone().unwrap_or_else(|| format!("of body {}", body_name(id)));
            match j.type_ {
                JointType::Ball => {
                    if j.range.is_some() && j.limited.resolve(model.compiler.autolimits, true) {
                        ignored.push(format!("joint {jname} range: a ball joint's cone limit is not simulated"));
                    }
                    ball_joint.get_or_insert(jname);
                }
                JointType::Free => {
                    if entry.parent != Some(0) || entry.body.joints.len() != 1 {
                        return Err(format!(
                            "joint {jname} is a free joint below the top level or beside other joints; only a top-level body's sole joint may be free"
                        ));
                    }
                    free_root = true;
                }
                JointType::Hinge | JointType::Slide => {
                    let a = j.axis;
                    if !(a.iter().all(|x| x.is_finite()) && a.iter().map(|x| x * x).sum::<f64>() > 1e-18) {
                        return Err(format!("joint {jname} has a zero or invalid axis"));
                    }
                }
            }
        }
        if entry.body.mocap {
            return Err(format!("body {} is a mocap body, which is not supported", body_name(id)));
        }
        bounded_body(&entry.body, &body_name(id))?;
    }
    // The worldbody's own geoms (`bodies_iter` leaves it out): a negative size there reaches
    // parry's shape constructors, which assert. Only that is refused here — this runs on every
    // fold, and a worldbody geom of size 0 or beyond the bounds was accepted before, so logs
    // holding one must fold as they always did.
    for (i, g) in model.bodies.first().map(|w| w.body.geoms.as_slice()).unwrap_or_default().iter().enumerate() {
        if g.size[..used_sizes(g)].iter().any(|x| x.is_nan() || *x < 0.0) {
            let geom = g.name.clone().unwrap_or_else(|| format!("#{i} of the worldbody"));
            return Err(format!("geom {geom} has size {:?}; sizes must be numbers >= 0", g.size));
        }
    }
    if free_root && top_level != 1 {
        return Err("a free joint is supported only on the single top-level body (the model's free base)".into());
    }
    for (id, entry) in model.bodies.iter().enumerate() {
        for (gi, g) in entry.body.geoms.iter().enumerate() {
            let gname = g.name.clone().unwrap_or_else(|| format!("#{gi} of body {}", if id == 0 { "world".into() } else { body_name(id) }));
            match g.type_ {
                GeomType::Hfield => return Err(format!("geom {gname} is a height field, which is not supported")),
                GeomType::Sdf => return Err(format!("geom {gname} is an SDF geom, which is not supported")),
                _ => {}
            }
            if g.condim != 3 {
                let s = format!("condim=\"{}\": contacts use rapier's friction cone (condim 3)", g.condim);
                if !ignored.contains(&s) {
                    ignored.push(s);
                }
            }
        }
    }
    for e in &model.contact.excludes {
        for name in [&e.body1, &e.body2] {
            if name != "world" && model.body_id_by_name(name).is_none() {
                return Err(format!("<exclude> names body {name}, which is not in the model"));
            }
        }
    }
    let options = MjcfLoaderOptions {
        disable_joint_motors: true,
        contact_filter_mode: ContactFilterMode::Asymmetric,
        ..MjcfLoaderOptions::default()
    };
    let mesh_geoms = super::mjcf_mesh::prepare(xml, &model, meshes, &mut ignored)?;
    let mut robot = if mesh_geoms.is_empty() {
        MjcfRobot::from_model(&model, options, base)
    } else {
        MjcfRobot::from_model(&super::mjcf_mesh::placeholders(&model, &mesh_geoms), options, base)
    };
    super::mjcf_mesh::finish(&mut robot, &model, &mesh_geoms);
    // A geom the crate could not build would be a silently missing collider: refuse instead.
    for b in robot.bodies.iter().filter(|b| !b.is_intermediate) {
        let entry = &model.bodies[b.mjcf_body_id];
        let wanted = entry
            .body
            .geoms
            .iter()
            .filter(|g| g.type_ != GeomType::Plane && !(g.contype == 0 && g.conaffinity == 0))
            .count();
        if b.colliders.len() != wanted {
            let who = if b.mjcf_body_id == 0 { "the worldbody".to_string() } else { format!("body {}", body_name(b.mjcf_body_id)) };
            return Err(format!("a geom of {who} could not be built (check its type and size)"));
        }
    }
    let (keyframe_qpos, keyframe_ctrl) = match keyframe {
        None => (None, Vec::new()),
        Some(name) => {
            let key = model
                .keyframes
                .iter()
                .find(|k| k.name.as_deref() == Some(name))
                .ok_or_else(|| format!("keyframe {name} is not a <key> of this model"))?;
            (Some(key.qpos.clone()), key.ctrl.clone())
        }
    };
    let actuator_extras = super::actuators::actuator_extras(xml);
    Ok(Prepared { model, robot, ignored, keyframe_qpos, keyframe_ctrl, actuator_extras, ball_joint })
}

fn rel(from: &Pose, to: &Pose) -> Pose {
    from.inverse() * *to
}

/// Our collider settings on a crate collider: MuJoCo's contype/conaffinity rule (either
/// direction), no crate hooks, MuJoCo's max friction combination.
fn adapt_collider(c: &mut Collider) {
    let mut g = c.collision_groups();
    g.test_mode = InteractionTestMode::Or;
    c.set_collision_groups(g);
    c.set_active_hooks(ActiveHooks::empty());
    c.set_friction_combine_rule(CoefficientCombineRule::Max);
    c.set_restitution(0.0);
}

/// Stand-ins for MJCF planes (the crate skips them): a thin box whose top face is the plane.
fn plane_colliders(model: &Model, mjcf_body: usize) -> Vec<Collider> {
    model.bodies[mjcf_body]
        .body
        .geoms
        .iter()
        .filter(|g| g.type_ == GeomType::Plane && !(g.contype == 0 && g.conaffinity == 0))
        .map(|g| {
            let half = |s: f64| if s > 0.0 { s as f32 } else { PLANE_INFINITE_HALF_EXTENT };
            let pose: Pose = g.pose.into();
            let down = Pose::from_translation(Vector::new(0.0, 0.0, -PLANE_HALF_THICKNESS));
            let groups = InteractionGroups::new(
                Group::from_bits_retain(g.contype),
                Group::from_bits_retain(g.conaffinity),
                InteractionTestMode::Or,
            );
            ColliderBuilder::cuboid(half(g.size[0]), half(g.size[1]), PLANE_HALF_THICKNESS)
                .position(pose * down)
                .density(0.0)
                .friction(g.friction[0] as f32)
                .friction_combine_rule(CoefficientCombineRule::Max)
                .restitution(0.0)
                .collision_groups(groups)
                .build()
        })
        .collect()
}

/// A body's "additional" mass properties as the crate set them (zero for spacers).
pub(super) fn body_mprops(b: &RigidBody) -> MassProperties {
    match b.mass_properties().additional_local_mprops.as_deref() {
        Some(RigidBodyAdditionalMassProps::MassProps(mp)) => *mp,
        _ => MassProperties::default(),
    }
}

impl World {
    /// Inserts a prepared MJCF model (from its text and mesh blobs) with its frame at `pose`;
    /// returns load_mjcf's result.
    pub(super) fn insert_mjcf(
        &mut self,
        prepared: Prepared,
        file_path: &str,
        (blob, meshes): (&Blob, &BTreeMap<String, Blob>),
        pose: Pose,
        (fixed_base, parent_filter, with_actuators, with_constraints, version9): (bool, bool, bool, bool, bool),
        keyframe: Option<&str>,
    ) -> MjcfLoaded {
        let Prepared { model, robot, mut ignored, keyframe_qpos, keyframe_ctrl, actuator_extras, .. } = prepared;
        let MjcfRobot { bodies: mut mbodies, joints: mjoints, qpos_dofs, .. } = robot;
        let n = mbodies.len();
        let world_pose: Vec<Pose> = mbodies.iter().map(|b| *b.body.position()).collect();
        // The free root, if the model's single top-level body has a free joint.
        let free_root = (1..n).find(|i| {
            let e = &model.bodies[mbodies[*i].mjcf_body_id];
            !mbodies[*i].is_intermediate && e.body.joints.iter().any(|j| j.type_ == JointType::Free)
        });
        let base = free_root.unwrap_or(0);
        // Which crate body each one is merged into (itself when it is kept).
        let mut owner: Vec<usize> = (0..n).collect();
        let fixed_joint = |j: &rapier3d_mjcf::MjcfJoint| j.name.is_none() && j.joint.locked_axes == JointAxesMask::LOCKED_FIXED_AXES;
        for j in mjoints.iter().filter(|j| fixed_joint(j)) {
            owner[j.link2] = owner[j.link1];
        }
        for i in 1..n {
            let e = &model.bodies[mbodies[i].mjcf_body_id];
            if !mbodies[i].is_intermediate && e.parent == Some(0) && e.body.joints.is_empty() {
                owner[i] = 0;
            }
        }
        // Planes (the crate skips them) join their body's colliders.
        for b in mbodies.iter_mut() {
            if !b.is_intermediate {
                b.colliders.extend(plane_colliders(&model, b.mjcf_body_id));
            }
        }
        // `<contact><pair>` (event version 9): each collider tagged with its geom until inserted.
        let with_pairs = version9 && !model.contact.pairs.is_empty();
        if with_pairs {
            for b in mbodies.iter_mut().filter(|b| !b.is_intermediate) {
                super::mjcf_pairs::tag_colliders(&model, b.mjcf_body_id, &mut b.colliders);
            }
        }
        // Merge colliders and mass into owners.
        let mut mass: Vec<MassProperties> = mbodies.iter().map(|b| body_mprops(&b.body)).collect();
        let mut colliders: Vec<Vec<Collider>> = mbodies.iter_mut().map(|b| std::mem::take(&mut b.colliders)).collect();
        for i in 1..n {
            let o = owner[i];
            if o == i {
                continue;
            }
            let r = rel(&world_pose[o], &world_pose[i]);
            let moved: Vec<Collider> = std::mem::take(&mut colliders[i])
                .into_iter()
                .map(|mut c| {
                    let p = r * *c.position();
                    c.set_position(p);
                    c
                })
                .collect();
            colliders[o].extend(moved);
            let m = mass[i].transform_by(&r);
            mass[o] += m;
            mass[i] = MassProperties::default();
        }
        // The hinge/slide joints in file order: our links.
        let mut ref_of: BTreeMap<usize, f32> = BTreeMap::new();
        for d in &qpos_dofs {
            if let Some(j) = d.joint {
                ref_of.insert(j, d.reference);
            }
        }
        let dof_joints: Vec<usize> = (0..mjoints.len()).filter(|j| !fixed_joint(&mjoints[*j])).collect();
        let mut link_of_body: BTreeMap<usize, i32> = BTreeMap::new();
        link_of_body.insert(base, -1);
        if base != 0 {
            // With a free base the worldbody is not part of the robot's chain.
        } else {
            link_of_body.insert(0, -1);
        }
        for (li, j) in dof_joints.iter().enumerate() {
            link_of_body.insert(mjoints[*j].link2, li as i32);
        }
        // Insert the bodies: base, then (free base only) the worldbody's geoms, then links.
        let place = |p: &Pose| pose * *p;
        let mut handle_of: BTreeMap<usize, RigidBodyHandle> = BTreeMap::new();
        let mut colliders_of: BTreeMap<usize, Vec<ColliderHandle>> = BTreeMap::new();
        let order: Vec<usize> = std::iter::once(base).chain(dof_joints.iter().map(|j| mjoints[*j].link2)).collect();
        for &i in &order {
            let ty = if i == 0 || (i == base && fixed_base) { RigidBodyType::Fixed } else { RigidBodyType::Dynamic };
            let mut rb = RigidBodyBuilder::new(ty).can_sleep(false).pose(place(&world_pose[i])).linear_damping(0.0).angular_damping(0.0);
            if mass[i].mass() > 0.0 {
                rb = rb.additional_mass_properties(mass[i]);
            }
            let h = self.physics.insert_body(rb);
            let mut cs = Vec::new();
            for mut c in std::mem::take(&mut colliders[i]) {
                adapt_collider(&mut c);
                cs.push(self.physics.insert_collider(c, Some(h)));
            }
            let set = &self.physics.colliders;
            if let Some(b) = self.physics.bodies.get_mut(h) {
                b.recompute_mass_properties_from_colliders(set);
            }
            handle_of.insert(i, h);
            colliders_of.insert(i, cs);
        }
        let mut world_body = None;
        let mut world_colliders = Vec::new();
        if base != 0 && !colliders[0].is_empty() {
            let h = self.physics.insert_body(RigidBodyBuilder::fixed().pose(place(&world_pose[0])));
            for mut c in std::mem::take(&mut colliders[0]) {
                adapt_collider(&mut c);
                world_colliders.push(self.physics.insert_collider(c, Some(h)));
            }
            world_body = Some(h);
        }
        // A free-base model whose connect or weld names the world, with no world geoms: the
        // world gets a static body for the constraint to hold on to.
        if with_constraints && base != 0 && world_body.is_none() && super::mjcf_equality::uses_world(&model, version9) {
            world_body = Some(self.physics.insert_body(RigidBodyBuilder::fixed().pose(place(&world_pose[0]))));
        }
        // `<exclude>` pairs by the rapier bodies that carry them; their colliders ask the filter.
        let body_of = |name: &str| -> Option<RigidBodyHandle> {
            let mjcf_id = if name == "world" { 0 } else { model.body_id_by_name(name)? };
            let idx = (0..n).find(|i| !mbodies[*i].is_intermediate && mbodies[*i].mjcf_body_id == mjcf_id)?;
            let o = owner[idx];
            handle_of.get(&o).copied().or(if o == 0 { world_body } else { None })
        };
        let mut excluded = Vec::new();
        for e in &model.contact.excludes {
            if let (Some(a), Some(b)) = (body_of(&e.body1), body_of(&e.body2)) {
                if a != b {
                    excluded.push((a, b));
                }
            }
        }
        if parent_filter {
            for (a, b) in parent_pairs_across_spacers(&model, &mbodies, &owner, &dof_joints, &mjoints) {
                if let (Some(&a), Some(&b)) = (handle_of.get(&a), handle_of.get(&b)) {
                    excluded.push((a, b));
                }
            }
        }
        let mut pairs = Vec::new();
        if with_pairs {
            let inserted: Vec<ColliderHandle> = colliders_of.values().flatten().chain(&world_colliders).copied().collect();
            let by_tag = super::mjcf_pairs::take_tags(&mut self.physics.colliders, inserted);
            let notes;
            (pairs, notes) = super::mjcf_pairs::build(&model, &by_tag, &mut self.physics.colliders, &excluded);
            ignored.retain(|s| s != PAIRS_IGNORED);
            ignored.extend(notes);
        }
        for h in excluded.iter().flat_map(|(a, b)| [*a, *b]) {
            let cs: Vec<ColliderHandle> = self.physics.bodies.get(h).map(|b| b.colliders().to_vec()).unwrap_or_default();
            for ch in cs {
                if let Some(c) = self.physics.colliders.get_mut(ch) {
                    c.set_active_hooks(ActiveHooks::FILTER_CONTACT_PAIRS);
                }
            }
        }
        // Joints: the crate's frames, re-parented past merged bodies, `ref` folded in.
        let mut links: Vec<RobotLink> = Vec::new();
        let mut link_masses = Vec::new();
        let mut armatures = Vec::new();
        for (li, &ji) in dof_joints.iter().enumerate() {
            let mj = &mjoints[ji];
            let parent_body = owner[mj.link1];
            let child_body = mj.link2;
            let mut joint = mj.joint;
            let r = rel(&world_pose[parent_body], &world_pose[mj.link1]);
            let reference = ref_of.get(&ji).copied().unwrap_or(0.0);
            let is_slide = joint.locked_axes == JointAxesMask::LOCKED_PRISMATIC_AXES;
            // A ball joint (event version 9 loads; refused before): no axis, no `ref`, no limits.
            let is_ball = joint.locked_axes == JointAxesMask::LOCKED_SPHERICAL_AXES;
            let axis = if is_slide { JointAxis::LinX } else { JointAxis::AngX };
            let shift = if is_slide {
                Pose::from_translation(Vector::new(-reference, 0.0, 0.0))
            } else if is_ball {
                Pose::IDENTITY
            } else {
                Pose::from_rotation(Rotation::from_rotation_x(-reference))
            };
            joint.set_local_frame1(r * joint.local_frame1 * shift);
            let limits = joint.limits(axis).filter(|_| !is_ball).map(|l| [l.min + reference, l.max + reference]);
            if let Some(l) = limits {
                joint.set_limits(axis, l);
            }
            joint.motor_axes = JointAxesMask::empty();
            // MuJoCo excludes contacts between a body and its parent, except the worldbody.
            joint.contacts_enabled = parent_body == 0;
            let (Some(&ph), Some(&ch)) = (handle_of.get(&parent_body), handle_of.get(&child_body)) else { continue };
            self.physics.multibody_joints.insert(ph, ch, joint, true);
            let mjcf_joint = find_joint(&model, mbodies[child_body].mjcf_body_id, mj.name.as_deref());
            let axis_body = match is_ball {
                true => [0.0; 3],
                false => mjcf_joint.map_or([1.0, 0.0, 0.0], |j| rapier3d::glamx::DVec3::from_array(j.axis).normalize().to_array()),
            };
            let kind = match (is_ball, is_slide, limits.is_some()) {
                (true, _, _) => JointKind::Spherical,
                (false, true, _) => JointKind::Prismatic,
                (false, false, true) => JointKind::Revolute,
                (false, false, false) => JointKind::Continuous,
            };
            let origin = rel(&world_pose[parent_body], &world_pose[child_body]);
            let (lower, upper) = limits.map_or((0.0, -1.0), |l| (l[0] as f64, l[1] as f64));
            let parent = link_of_body.get(&parent_body).copied().unwrap_or(-1);
            let name = mj.name.clone().unwrap_or_default();
            let entry = &model.bodies[mbodies[child_body].mjcf_body_id];
            links.push(RobotLink {
                name: entry.body.name.clone().unwrap_or_default(),
                body: ch,
                colliders: colliders_of.get(&child_body).cloned().unwrap_or_default(),
                joint: JointSpec {
                    name,
                    kind,
                    parent,
                    origin_pos: origin.translation.to_array().map(|x| x as f64),
                    origin_rot: origin.rotation.to_array().map(|x| x as f64),
                    axis: axis_body,
                    lower,
                    upper,
                    effort: 0.0,
                    velocity: 0.0,
                    damping: mj.damping_per_dof as f64,
                },
                motor: None,
                motor_torque: 0.0,
                color: None,
                extras: DynamicsExtras::default(),
            });
            link_masses.push((li as u32, mass[child_body].mass()));
            armatures.push(mj.armature_per_dof);
        }
        // Self-contacts on: MuJoCo collides a model's non-adjacent bodies (contype/conaffinity
        // filter them).
        self.configure_multibody_joints(&links, &armatures, true);
        // Bodies → links (a merged body shares its owner's link).
        let mut body_links = Vec::new();
        for (i, b) in mbodies.iter().enumerate().skip(1) {
            if b.is_intermediate {
                continue;
            }
            let link = link_of_body.get(&owner[i]).copied().unwrap_or(-1);
            body_links.push(MjcfBodyLink { name: model.bodies[b.mjcf_body_id].body.name.clone().unwrap_or_default(), link_index: link });
        }
        let base_body = handle_of[&base];
        let base_entry = &model.bodies[mbodies[base].mjcf_body_id];
        let robot = Robot {
            file_path: file_path.to_string(),
            urdf_hash: blob.hash.clone(),
            mesh_hashes: meshes.iter().map(|(k, b)| (k.clone(), b.hash.clone())).collect(),
            name: model.name.clone().unwrap_or_default(),
            fixed_base,
            base_name: if base == 0 { "world".into() } else { base_entry.body.name.clone().unwrap_or_default() },
            base_colliders: colliders_of.get(&base).cloned().unwrap_or_default(),
            links,
        };
        let num_joints = robot.links.len();
        let id = self.tables.next_object_id;
        let mut actuator_infos = Vec::new();
        // A hinge or slide joint by name (actuators, tendons, equality joints and joint sensors
        // act on these; a ball joint is not one).
        let joint_of = |name: &str| robot.links.iter().position(|l| !name.is_empty() && l.joint.name == name && l.joint.kind.movable()).map(|i| i as u32);
        let text = std::str::from_utf8(&blob.bytes).unwrap_or("");
        // Each MJCF body's own (not intermediate) body index, found once: the first one.
        let mut kept_of: Vec<Option<usize>> = vec![None; model.bodies.len()];
        for k in (0..n).rev().filter(|k| !mbodies[*k].is_intermediate) {
            if let Some(slot) = kept_of.get_mut(mbodies[k].mjcf_body_id) {
                *slot = Some(k);
            }
        }
        // An MJCF body's carrier: (its index, its owner's index, the owner's rapier body).
        let carrier = |m: usize| -> Option<(usize, usize, RigidBodyHandle)> {
            let k = kept_of[m]?;
            let o = owner[k];
            let body = handle_of.get(&o).copied().or(if o == 0 { world_body } else { None })?;
            Some((k, o, body))
        };
        if with_constraints {
            // Each MJCF body's rapier body and frame, then the equality constraints on them.
            let frames: Vec<Option<super::mjcf_equality::BodyFrame>> = (0..model.bodies.len())
                .map(|m| {
                    let (k, o, body) = carrier(m)?;
                    Some(super::mjcf_equality::BodyFrame { body, in_body: rel(&world_pose[o], &world_pose[k]), at_qpos0: world_pose[k] })
                })
                .collect();
            let joint_ref = |li: u32| dof_joints.get(li as usize).and_then(|ji| ref_of.get(ji)).copied().unwrap_or(0.0) as f64;
            let at = super::mjcf_equality::Placement { frames: &frames, joint_of: &joint_of, robot: &robot, joint_ref: &joint_ref };
            let (notes, built) = self.build_mjcf_equalities(&model, &at);
            if version9 && (!model.equality.is_empty() || !model.tendons.is_empty()) {
                self.tables.mjcf_elements.insert(id, super::mjcf_equality::Elements::of(&model, &built, &joint_of));
            }
            ignored.retain(|s| s != EQUALITY_IGNORED && s != TENDONS_IGNORED);
            ignored.extend(notes);
            ignored.extend(super::mjcf_equality::tendon_notes(text, version9));
        }
        if with_actuators {
            let tendon_of = |name: &str| super::mjcf_equality::tendon_joints(&model, name, &joint_of);
            let tendons: Option<super::actuators::TendonOf<'_>> = if with_constraints { Some(&tendon_of) } else { None };
            let (mut actuation, notes, transmissions) = super::actuators::build(&model, &actuator_extras, &joint_of, tendons);
            for (k, t) in transmissions {
                self.tables.transmissions.insert((id, k), t);
            }
            ignored.retain(|s| s != ACTUATORS_IGNORED);
            ignored.extend(notes);
            if !actuation.actuators.is_empty() {
                // A keyframe's `ctrl` (one per actuator of the file) starts the controls.
                if keyframe_ctrl.len() == model.actuators.len() {
                    let kept = model.actuators.iter().enumerate().filter(|(k, a)| {
                        let name = a.name.clone().unwrap_or_else(|| format!("#{k}"));
                        actuation.actuators.iter().any(|x| x.name == name)
                    });
                    for (slot, (k, _)) in kept.enumerate() {
                        actuation.ctrl[slot] = keyframe_ctrl[k];
                    }
                }
                actuator_infos = super::actuators::infos(&actuation);
                self.tables.actuation.insert(id, actuation);
            }
            // Sensors (get_sensor_data): each MJCF body's placement, then the model's sensors.
            let placed: Vec<Option<super::sensors::Placed>> = (0..model.bodies.len())
                .map(|m| {
                    let (k, o, body) = carrier(m)?;
                    let link = link_of_body.get(&o).copied().unwrap_or(-1);
                    Some(super::sensors::Placed { body, in_body: rel(&world_pose[o], &world_pose[k]), own: o == k, link })
                })
                .collect();
            let actuator_names: Vec<String> = self.tables.actuation.get(&id).map(|a| a.actuators.iter().map(|x| x.name.clone()).collect()).unwrap_or_default();
            let actuator_of = |name: &str| actuator_names.iter().position(|x| x == name);
            let resolver = super::sensors::Resolver { model: &model, placed: &placed, joint_of: &joint_of, actuator_of: &actuator_of };
            let (mut sensors, notes) = super::sensors::build(text, &resolver, with_constraints);
            // The Newton–Euler pass behind accelerometer/force/torque works in joint space, one
            // number per joint: a robot with a ball joint does not get them (event version 9).
            if let Some((_, ball)) = robot.ball_joint() {
                use super::sensors::SensorType as T;
                let (kept, dropped): (Vec<_>, Vec<_>) = sensors.into_iter().partition(|s| !matches!(s.kind, T::Accelerometer | T::Force | T::Torque));
                sensors = kept;
                ignored.extend(dropped.iter().map(|s| format!("sensor {}: type {} is not computed on a model with a ball joint ({ball})", s.name, s.kind.name())));
            }
            ignored.retain(|s| s != SENSORS_IGNORED);
            ignored.extend(notes);
            ignored.extend(super::actuators::unapplied_attributes(text));
            if !sensors.is_empty() {
                self.tables.mjcf_sensors.insert(id, sensors);
            }
        }
        if !pairs.is_empty() {
            self.tables.contact_pairs.insert(id, pairs);
        }
        self.tables.next_object_id += 1;
        for (link, m) in link_masses.into_iter().filter(|(_, m)| *m > 0.0) {
            self.tables.as_given.link_masses.insert((id, link), m);
        }
        let info = MjcfInfo {
            keyframe: keyframe.map(str::to_string),
            bodies: body_links.clone(),
            ignored: ignored.clone(),
            world_body,
            world_colliders,
            excluded,
        };
        self.tables.objects.insert(
            id,
            Object {
                body: base_body,
                collider: colliders_of.get(&base).and_then(|c| c.first().copied()).unwrap_or_else(ColliderHandle::invalid),
                kind: ObjectKind::Mjcf { robot: Box::new(robot), mjcf: Box::new(info) },
                color: None,
                mass: if base == 0 { 0.0 } else { mass[base].mass() },
                extras: DynamicsExtras::default(),
            },
        );
        // qpos0: each joint at its `ref` (the bodies were placed at the file's pose, which is
        // coordinate `ref` now that `ref` is folded into the joint frames).
        for (li, &ji) in dof_joints.iter().enumerate() {
            let reference = ref_of.get(&ji).copied().unwrap_or(0.0);
            if reference != 0.0 {
                self.reset_joint(id, li as u32, reference, 0.0);
            }
        }
        if let Some(qpos) = keyframe_qpos {
            self.apply_mjcf_qpos(id, pose, &qpos_dofs, &qpos);
        }
        MjcfLoaded {
            landed: None,
            object_id: id,
            file_path: file_path.to_string(),
            position: r32s(pose.translation.to_array()),
            num_joints,
            bodies: body_links,
            ignored,
            actuators: actuator_infos,
        }
    }

    /// Sets the joints from a keyframe's qpos (MuJoCo's layout: a free joint's position and
    /// [w, x, y, z] quaternion, then one value per hinge/slide). A free root goes to the
    /// keyframe's pose within the load frame `pose`.
    fn apply_mjcf_qpos(&mut self, id: u32, pose: Pose, dofs: &[rapier3d_mjcf::MjcfQposDof], qpos: &[f64]) {
        let mut at = 0usize;
        let mut joint = 0u32;
        for d in dofs {
            let w = d.kind.qpos_width();
            match d.kind {
                rapier3d_mjcf::MjcfDofKind::Hinge | rapier3d_mjcf::MjcfDofKind::Slide => {
                    if let Some(q) = qpos.get(at) {
                        self.reset_joint(id, joint, *q as f32, 0.0);
                    }
                    joint += 1;
                }
                rapier3d_mjcf::MjcfDofKind::Ball => {
                    if let Some(q) = qpos.get(at..at + 4) {
                        let rot = Rotation::from_xyzw(q[1] as f32, q[2] as f32, q[3] as f32, q[0] as f32);
                        if rot.length() > 0.0 {
                            self.reset_ball_joint(id, joint, rot.normalize());
                        }
                    }
                    joint += 1;
                }
                rapier3d_mjcf::MjcfDofKind::Free => {
                    if let (Some(q), Some(base)) = (qpos.get(at..at + 7), self.body_handle(id)) {
                        let rot = Rotation::from_xyzw(q[4] as f32, q[5] as f32, q[6] as f32, q[3] as f32);
                        if rot.length() > 0.0 {
                            let local = Pose::from_parts(Vector::new(q[0] as f32, q[1] as f32, q[2] as f32), rot.normalize());
                            self.set_robot_pose(base, pose * local);
                        }
                    }
                }
            }
            at += w;
        }
    }
}

/// MuJoCo's parent filter where a joint cannot carry it: pairs (kept crate bodies) of a body
/// and its parent body, neither the worldbody (MuJoCo keeps contacts with the world), that no
/// joint joins directly — a body with several joints hangs from its parent through the crate's
/// massless spacers, so the joint's own `contacts_enabled = false` only parts it from a spacer.
fn parent_pairs_across_spacers(
    model: &Model,
    mbodies: &[rapier3d_mjcf::MjcfBody],
    owner: &[usize],
    dof_joints: &[usize],
    mjoints: &[rapier3d_mjcf::MjcfJoint],
) -> Vec<(usize, usize)> {
    let kept = |mjcf_id: usize| (0..mbodies.len()).find(|k| !mbodies[*k].is_intermediate && mbodies[*k].mjcf_body_id == mjcf_id);
    let joined = |a: usize, b: usize| dof_joints.iter().any(|j| mjoints[*j].link2 == a && owner[mjoints[*j].link1] == b);
    let mut pairs = Vec::new();
    for (i, b) in mbodies.iter().enumerate().skip(1) {
        if b.is_intermediate {
            continue;
        }
        let Some(parent) = model.bodies[b.mjcf_body_id].parent.filter(|p| *p != 0) else { continue };
        let Some(p) = kept(parent) else { continue };
        let (a, p) = (owner[i], owner[p]);
        if a != p && a != 0 && p != 0 && !joined(a, p) && !pairs.contains(&(a, p)) {
            pairs.push((a, p));
        }
    }
    pairs
}

fn find_joint<'a>(model: &'a Model, body: usize, name: Option<&str>) -> Option<&'a rapier3d_mjcf::mjcf_rs::body::Joint> {
    let joints = &model.bodies.get(body)?.body.joints;
    match name {
        Some(n) => joints.iter().find(|j| j.name.as_deref() == Some(n)),
        None => joints.iter().find(|j| j.name.is_none()),
    }
}

/// How many of a geom's `size` numbers its shape uses (none when sized from a mesh).
fn used_sizes(g: &rapier3d_mjcf::mjcf_rs::body::Geom) -> usize {
    if g.mesh.is_some() {
        return 0;
    }
    match g.type_ {
        GeomType::Sphere => 1,
        GeomType::Capsule | GeomType::Cylinder if g.fromto.is_some() => 1,
        GeomType::Capsule | GeomType::Cylinder => 2,
        GeomType::Box | GeomType::Ellipsoid => 3,
        _ => 0,
    }
}

/// Refuses a body whose position, or a geom whose position or size, is not a finite number
/// within [`crate::limits::MAX_EXTENT_M`] (a size must also be > 0): the engine panics on such
/// values at load (a negative cylinder) or at every later step (a body at 1e400).
fn bounded_body(body: &rapier3d_mjcf::mjcf_rs::body::Body, name: &str) -> Result<(), Refusal> {
    let bound = crate::limits::MAX_EXTENT_M;
    let within = |x: f64| x.abs() <= bound;
    if !body.pose.translation.to_array().into_iter().all(within) {
        return Err(format!("body {name} has pos {:?}, not finite numbers within {bound} m", body.pose.translation.to_array()));
    }
    for (i, g) in body.geoms.iter().enumerate() {
        let geom = g.name.clone().unwrap_or_else(|| format!("#{i} of body {name}"));
        let used = used_sizes(g);
        if !g.size[..used].iter().all(|&x| x > 0.0 && within(x)) {
            return Err(format!("geom {geom} has size {:?}, not numbers > 0 and within {bound} m", &g.size[..used]));
        }
        let at = g.pose.translation.to_array();
        if !at.into_iter().chain(g.fromto.into_iter().flatten()).all(within) {
            return Err(format!("geom {geom} has a position not finite or beyond {bound} m"));
        }
    }
    Ok(())
}
