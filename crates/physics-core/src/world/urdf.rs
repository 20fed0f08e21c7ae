//! URDF text and mesh bytes → a robot model in PyBullet's numbering. Pure: no files, no rapier
//! sets; the adapter reads the files, `Command::validate` builds the model to refuse bad input,
//! and `World::apply` builds it again (the same bytes give the same model) to insert it.
//!
//! PyBullet numbers joints depth-first in pre-order from the root link, children in the order
//! their joints appear in the file, fixed joints included; link i is the child of joint i and
//! −1 is the base. `RobotModel::links[0]` is the base, `links[i + 1]` is link i.

use std::collections::{BTreeMap, BTreeSet};

use rapier3d::glamx::{DQuat, DVec3, EulerRot};
use serde::{Deserialize, Serialize};

use crate::value::Refusal;

/// Mass given to a non-root link whose `<inertial>` says 0 kg: rapier cannot move a massless
/// link of an articulation. Small enough not to change a real robot's dynamics. (A link with
/// no `<inertial>` at all gets PyBullet's 1 kg instead.)
pub const MASSLESS_LINK_MASS: f64 = 1.0e-3;
/// Inertia (kg·m², each principal axis) given with `MASSLESS_LINK_MASS`.
pub const MASSLESS_LINK_INERTIA: f64 = 1.0e-6;

/// A URDF joint type this server simulates.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JointKind {
    /// Rotation about the axis, within limits.
    Revolute,
    /// Rotation about the axis, unbounded (limits in its `<limit>` are reported, not enforced).
    Continuous,
    /// Translation along the axis, within limits.
    Prismatic,
    /// No motion (still numbered, as in PyBullet).
    Fixed,
    /// Free rotation about a point: an MJCF ball joint (event version 9), one joint index whose
    /// state is a quaternion and an angular velocity (PyBullet's `getJointStateMultiDof`).
    Spherical,
}

impl JointKind {
    /// The name get_joint_info reports.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
            JointKind::Fixed => "fixed",
            JointKind::Spherical => "spherical",
        }
    }

    /// Whether the joint has one scalar degree of freedom (IK, motors, trajectories, resets and
    /// the joint-space dynamics act on these; a spherical joint has three and is refused there).
    pub fn movable(self) -> bool {
        matches!(self, JointKind::Revolute | JointKind::Continuous | JointKind::Prismatic)
    }
}

/// A joint as written in the URDF, with its place in PyBullet's numbering.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct JointSpec {
    /// The joint's name.
    pub name: String,
    /// Its type.
    pub kind: JointKind,
    /// The parent link's index (−1 = the base).
    pub parent: i32,
    /// Joint frame position in the parent link frame.
    pub origin_pos: [f64; 3],
    /// Joint frame orientation in the parent link frame, [x, y, z, w].
    pub origin_rot: [f64; 4],
    /// Unit axis in the joint frame.
    pub axis: [f64; 3],
    /// Lower limit (rad or m). PyBullet's "none" is lower 0 with upper −1: fixed joints, and
    /// joints whose `<limit>` lacks the attribute (for robots loaded by an old event, the rule
    /// of its era — see `UrdfRules`).
    pub lower: f64,
    /// Upper limit.
    pub upper: f64,
    /// URDF effort limit (N·m or N); 0 when not given.
    pub effort: f64,
    /// URDF velocity limit; 0 when not given.
    pub velocity: f64,
    /// URDF `<dynamics damping>`.
    pub damping: f64,
}

impl JointSpec {
    /// Whether lower/upper bound the motion (revolute and prismatic with lower ≤ upper). A
    /// continuous joint's limits are reported but never enforced, as in PyBullet (a velocity
    /// motor drives r2d2's head_swivel past its upper limit 0 there).
    pub fn limited(&self) -> bool {
        matches!(self.kind, JointKind::Revolute | JointKind::Prismatic) && self.lower <= self.upper
    }
}

/// A collision geometry in its link frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Geom {
    /// Box by half-extents.
    Box([f32; 3]),
    /// Sphere by radius.
    Sphere(f32),
    /// Cylinder along local z: radius, full length.
    Cylinder(f32, f32),
    /// Capsule along local z: radius, cylindrical length.
    Capsule(f32, f32),
    /// A mesh, collided as its convex hull (as PyBullet does for URDF meshes by default).
    Hull(Vec<[f32; 3]>),
}

/// One collision shape of a link.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// Position in the link frame.
    pub pos: [f32; 3],
    /// Orientation in the link frame, [x, y, z, w].
    pub rot: [f32; 4],
    /// The shape.
    pub geom: Geom,
}

/// A link: inertial, collision shapes, color, and the joint that attaches it.
#[derive(Clone, Debug, PartialEq)]
pub struct LinkModel {
    /// The link's name.
    pub name: String,
    /// Mass in kg (0 on the base means a static base, as in PyBullet).
    pub mass: f64,
    /// Centre of mass in the link frame.
    pub com: [f64; 3],
    /// Inertia tensor about the centre of mass, in the link frame (symmetric).
    pub inertia: [[f64; 3]; 3],
    /// Collision shapes.
    pub parts: Vec<Part>,
    /// The first visual's material color, if any.
    pub color: Option<[f32; 4]>,
    /// The joint to its parent (None for the base).
    pub joint: Option<JointSpec>,
}

/// A robot ready to insert: the base and its links in PyBullet order.
#[derive(Clone, Debug, PartialEq)]
pub struct RobotModel {
    /// The `<robot name>`.
    pub name: String,
    /// `links[0]` is the base; `links[i + 1]` is PyBullet link i.
    pub links: Vec<LinkModel>,
}

impl RobotModel {
    /// Every moving joint's axis normalised to a direction (see `robot::axis_refusal`; the
    /// axes are stored normalised, so an axis that overflowed is zero here).
    pub fn joints_usable(&self) -> Result<(), Refusal> {
        let mut moving = self.links.iter().filter_map(|l| l.joint.as_ref()).filter(|j| j.kind.movable());
        moving.try_for_each(|j| super::robot::axis_refusal(&j.name, j.axis))
    }
}

/// Quaternion [x, y, z, w] of a URDF fixed-axis roll-pitch-yaw: Rz(yaw)·Ry(pitch)·Rx(roll).
pub fn rpy_quat(rpy: [f64; 3]) -> [f64; 4] {
    DQuat::from_euler(EulerRot::ZYX, rpy[2], rpy[1], rpy[0]).to_array()
}

fn f32s<const N: usize>(a: [f64; N]) -> [f32; N] {
    a.map(|x| x as f32)
}

/// The mesh file names a URDF refers to (as written), for the adapter to resolve and read.
pub fn mesh_names(urdf: &str) -> Result<Vec<String>, Refusal> {
    let robot = parse(urdf)?;
    let mut names: Vec<String> = robot
        .links
        .iter()
        .flat_map(|l| l.collision.iter().map(|c| &c.geometry))
        .filter_map(|g| match g {
            urdf_rs::Geometry::Mesh { filename, .. } => Some(filename.clone()),
            _ => None,
        })
        .collect();
    names.sort();
    names.dedup();
    Ok(names)
}

fn parse(urdf: &str) -> Result<urdf_rs::Robot, Refusal> {
    super::xml_guard::check(urdf, "file_path")?;
    // A file urdf-rs reads is read as it always was; only one it refuses is read again the
    // way PyBullet does (`pybullet_tolerated`), so every load accepted before reads the same.
    urdf_rs::read_from_string(urdf)
        .or_else(|first| match pybullet_tolerated(urdf) {
            Some(tolerated) => urdf_rs::read_from_string(&tolerated).map_err(|_| first),
            None => Err(first),
        })
        .map_err(|e| {
            let msg = e.to_string();
            let first = msg.lines().next().unwrap_or("").trim();
            format!("file_path is not a valid URDF: {first}")
        })
}

/// The URDF text as PyBullet's parser reads it, where that differs from urdf-rs's reading in
/// two ways that pybullet_data's own files rely on: an element inside `<geometry>` after its
/// shape is ignored (racecar.urdf has a `<material>` there), and an `<origin>` `xyz` or `rpy`
/// that is not three numbers is read as PyBullet's `parseVector3` reads it (`pybullet_vector3`;
/// husky.urdf has xacro leftovers, `xyz="$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)"`, which
/// pybullet 3.2.7 reads as 0 0 0.19). None when neither occurs (or the text is not XML).
fn pybullet_tolerated(urdf: &str) -> Option<String> {
    let doc = roxmltree::Document::parse(urdf).ok()?;
    // (range of the text, what replaces it)
    let mut edits: Vec<(std::ops::Range<usize>, String)> = Vec::new();
    for node in doc.descendants().filter(|n| n.is_element()) {
        match node.tag_name().name() {
            "geometry" => edits.extend(node.children().filter(|c| c.is_element()).skip(1).map(|c| (c.range(), String::new()))),
            "origin" => {
                let three_numbers = |v: &str| {
                    let parts: Vec<&str> = v.split_whitespace().collect();
                    parts.len() == 3 && parts.iter().all(|p| p.parse::<f64>().is_ok())
                };
                for a in node.attributes().filter(|a| matches!(a.name(), "xyz" | "rpy") && !three_numbers(a.value())) {
                    let replacement = match pybullet_vector3(a.value()) {
                        Some([x, y, z]) => format!("{}=\"{x:?} {y:?} {z:?}\"", a.name()),
                        None => String::new(),
                    };
                    edits.push((a.range(), replacement));
                }
            }
            _ => {}
        }
    }
    if edits.is_empty() {
        return None;
    }
    edits.sort_by_key(|(r, _)| r.start);
    let mut out = String::with_capacity(urdf.len());
    let mut at = 0;
    for (r, replacement) in edits {
        if r.start >= at {
            out.push_str(&urdf[at..r.start]);
            out.push_str(&replacement);
            at = r.end;
        }
    }
    out.push_str(&urdf[at..]);
    Some(out)
}

/// A vector as bullet3's URDF parser (`parseVector3`) reads it: the value split at spaces,
/// each piece read as C's `atof` (its longest leading number, else 0), the first three kept;
/// None (the attribute left out: 0 0 0) when there are fewer than three pieces.
fn pybullet_vector3(value: &str) -> Option<[f64; 3]> {
    let atof = |piece: &str| {
        let numeric = piece.find(|c: char| !(c.is_ascii_digit() || matches!(c, '+' | '-' | '.' | 'e' | 'E'))).unwrap_or(piece.len());
        (1..=numeric).rev().find_map(|n| piece[..n].parse::<f64>().ok().filter(|x| x.is_finite())).unwrap_or(0.0)
    };
    let pieces: Vec<f64> = value.split(' ').filter(|p| !p.is_empty()).map(atof).collect();
    (pieces.len() >= 3).then(|| [pieces[0], pieces[1], pieces[2]])
}

/// How a URDF is read where the rules changed over releases. Each flag is the load_urdf event's
/// own: events recorded before a flag existed fold with it false, to the robot they always did
/// (limits and masses are hashed state).
///
/// `continuous`, `revolute_prismatic`: which joints read `lower`/`upper` attribute by
/// attribute from their `<limit>`, as PyBullet's parser does: each on its own, a missing lower
/// as 0 and a missing upper as −1 — so a limit with only effort/velocity, or only a lower above
/// −1, leaves lower > upper: no limit, reported as such and not enforced. False: continuous
/// joints at 0 / −1 always, revolute and prismatic joints at urdf-rs's reading, which takes a
/// missing attribute as 0 (so effort/velocity alone locked the joint).
///
/// `pybullet_inertials`: which links have an inertial is read as PyBullet 3.2.7 reads it. The
/// scans of which links have an `<inertial>` (and which `<limit>` attributes are written) start
/// after the XML declaration: pybullet_data's objects declare `<?xml version="0.0" ?>`, which
/// the scanning XML reader refuses, so it found no `<inertial>` and every link got the 1 kg
/// stand-in (cube_small.urdf weighed 1 kg, not 0.1); a file whose declaration the reader
/// accepts scans the same either way. And a link named `world` without one has PyBullet's
/// mass 0 instead of the stand-in (a root `world` link is static: table_square.urdf's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UrdfRules {
    /// Continuous joints (their limits are reported, never enforced).
    pub continuous: bool,
    /// Revolute and prismatic joints (enforced when lower ≤ upper).
    pub revolute_prismatic: bool,
    /// Inertials found past the XML declaration; a `world` link without one has mass 0.
    pub pybullet_inertials: bool,
}

/// Builds the model: checks the tree (one root, known links, no loops, supported joint types),
/// numbers it as PyBullet does, and turns every mesh into a hull from its bytes. `rules`: how
/// joint limits and inertials are read (see `UrdfRules`).
pub fn build(urdf: &str, meshes: &BTreeMap<String, Vec<u8>>, rules: UrdfRules) -> Result<RobotModel, Refusal> {
    let robot = parse(urdf)?;
    if robot.links.is_empty() {
        return Err("file_path is not a valid URDF: it has no links".into());
    }
    crate::limits::check_model_joints(robot.joints.len())?;
    let index: BTreeMap<&str, usize> =
        robot.links.iter().enumerate().map(|(i, l)| (l.name.as_str(), i)).collect();
    if index.len() != robot.links.len() {
        return Err("file_path is not a valid URDF: two links share a name".into());
    }
    let mut parent_joint: Vec<Option<usize>> = vec![None; robot.links.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); robot.links.len()];
    for (j, joint) in robot.joints.iter().enumerate() {
        let unknown = |n: &str| format!("file_path is not a valid URDF: joint {} refers to unknown link {n}", joint.name);
        let p = *index.get(joint.parent.link.as_str()).ok_or_else(|| unknown(&joint.parent.link))?;
        let c = *index.get(joint.child.link.as_str()).ok_or_else(|| unknown(&joint.child.link))?;
        if parent_joint[c].replace(j).is_some() {
            return Err(format!("file_path is not a valid URDF: link {} has two parent joints", joint.child.link));
        }
        children[p].push(j);
    }
    let roots: Vec<usize> = (0..robot.links.len()).filter(|i| parent_joint[*i].is_none()).collect();
    let [root] = roots[..] else {
        return Err(format!(
            "file_path is not a valid URDF: it must have exactly one root link; it has {}",
            roots.len()
        ));
    };
    // Depth-first pre-order; children in file order (pushed reversed onto the stack).
    let mut order: Vec<(usize, i32)> = Vec::new(); // (joint, parent link index in PyBullet numbering)
    let mut stack: Vec<(usize, i32)> = children[root].iter().rev().map(|j| (*j, -1)).collect();
    while let Some((j, parent)) = stack.pop() {
        let me = order.len() as i32;
        order.push((j, parent));
        let child = index[robot.joints[j].child.link.as_str()];
        stack.extend(children[child].iter().rev().map(|c| (*c, me)));
    }
    if order.len() != robot.joints.len() {
        return Err("file_path is not a valid URDF: its joints form a loop".into());
    }
    let materials: BTreeMap<&str, [f32; 4]> = robot
        .materials
        .iter()
        .filter_map(|m| Some((m.name.as_str(), f32s(m.color.as_ref()?.rgba.0))))
        .collect();
    let scanned = if rules.pybullet_inertials { after_xml_declaration(urdf) } else { urdf };
    let inertials = child_attributes(scanned, "link", "inertial");
    let limit_attributes = child_attributes(scanned, "joint", "limit");
    let no_attributes = BTreeSet::new();
    let root_link = &robot.links[root];
    // PyBullet gives a `world` link without an inertial mass 0 (see `UrdfRules`): as if it had
    // urdf-rs's default one, which says 0 kg.
    let has_inertial = |name: &str| inertials.contains_key(name) || (rules.pybullet_inertials && name == "world");
    let mut links = vec![link_model(root_link, None, &materials, meshes, true, has_inertial(&root_link.name))?];
    for (j, parent) in order {
        let joint = &robot.joints[j];
        let by_attribute = match joint.joint_type {
            urdf_rs::JointType::Continuous => rules.continuous,
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic => rules.revolute_prismatic,
            _ => false,
        };
        let given = by_attribute.then(|| limit_attributes.get(&joint.name).unwrap_or(&no_attributes));
        let spec = joint_spec(joint, parent, given)?;
        let child = &robot.links[index[joint.child.link.as_str()]];
        links.push(link_model(child, Some(spec), &materials, meshes, false, has_inertial(&child.name))?);
    }
    Ok(RobotModel { name: robot.name, links })
}

/// `limit_given`: the attributes the joint's `<limit>` element writes, when its limits are read
/// attribute by attribute (urdf-rs reads a missing `lower`/`upper` as 0, PyBullet as 0 / −1);
/// None keeps the rule of old events (see `UrdfRules`).
fn joint_spec(joint: &urdf_rs::Joint, parent: i32, limit_given: Option<&BTreeSet<String>>) -> Result<JointSpec, Refusal> {
    use urdf_rs::JointType as T;
    let kind = match joint.joint_type {
        T::Revolute => JointKind::Revolute,
        T::Continuous => JointKind::Continuous,
        T::Prismatic => JointKind::Prismatic,
        T::Fixed => JointKind::Fixed,
        ref other => {
            return Err(format!(
                "joint {} has type {other:?}, which is not supported (revolute, continuous, prismatic, fixed)",
                joint.name
            ))
        }
    };
    let axis = DVec3::from_array(joint.axis.xyz.0);
    if kind.movable() && !(axis.is_finite() && axis.length() > 1e-9) {
        return Err(format!("joint {} has a zero or invalid axis", joint.name));
    }
    let axis = if kind.movable() { axis.normalize() } else { DVec3::ZERO };
    let from_file = |attribute: &str, value: f64, none: f64| match limit_given {
        Some(given) if !given.contains(attribute) => none,
        _ => value,
    };
    let (lower, upper) = match (kind, limit_given) {
        (JointKind::Fixed, _) | (JointKind::Continuous, None) => (0.0, -1.0),
        _ => (from_file("lower", joint.limit.lower, 0.0), from_file("upper", joint.limit.upper, -1.0)),
    };
    let all = [lower, upper, joint.limit.effort, joint.limit.velocity]
        .into_iter()
        .chain(joint.origin.xyz.0)
        .chain(joint.origin.rpy.0);
    if all.into_iter().any(|x| !x.is_finite()) {
        return Err(format!("joint {} has a non-finite origin or limit", joint.name));
    }
    if joint.origin.xyz.0.iter().any(|x| x.abs() > crate::limits::MAX_EXTENT_M) {
        return Err(format!("joint {} has an origin farther than {} m", joint.name, crate::limits::MAX_EXTENT_M));
    }
    Ok(JointSpec {
        name: joint.name.clone(),
        kind,
        parent,
        origin_pos: joint.origin.xyz.0,
        origin_rot: rpy_quat(joint.origin.rpy.0),
        axis: axis.to_array(),
        lower,
        upper,
        effort: joint.limit.effort.max(0.0),
        velocity: joint.limit.velocity.max(0.0),
        damping: joint.dynamics.as_ref().map_or(0.0, |d| d.damping.max(0.0)),
    })
}

/// For each `<parent_tag name=…>` element that has a `<child_tag>` directly inside, the names
/// of that child's attributes (the first such child's), by the parent's name. urdf-rs reads a
/// missing element or attribute as zeros, but PyBullet tells them apart: a link without
/// `<inertial>` gets 1 kg, a continuous joint without `lower`/`upper` reports 0 / −1.
/// The text after its `<?xml …?>` declaration, if it starts with one (see `UrdfRules`).
fn after_xml_declaration(urdf: &str) -> &str {
    let start = urdf.trim_start_matches(['\u{feff}', ' ', '\t', '\r', '\n']);
    match start.strip_prefix("<?xml").and_then(|rest| rest.find("?>").map(|end| &rest[end + 2..])) {
        Some(rest) => rest,
        None => urdf,
    }
}

fn child_attributes(urdf: &str, parent_tag: &str, child_tag: &str) -> BTreeMap<String, BTreeSet<String>> {
    use xml::reader::{EventReader, XmlEvent};
    let mut out = BTreeMap::new();
    let mut parent: Option<String> = None;
    let mut depth = 0usize;
    let mut parent_depth = 0usize;
    for event in EventReader::new(urdf.as_bytes()) {
        match event {
            Ok(XmlEvent::StartElement { name, attributes, .. }) => {
                depth += 1;
                if name.local_name == parent_tag && parent.is_none() {
                    parent = attributes.iter().find(|a| a.name.local_name == "name").map(|a| a.value.clone());
                    parent_depth = depth;
                } else if name.local_name == child_tag && depth == parent_depth + 1 {
                    if let Some(p) = &parent {
                        out.entry(p.clone())
                            .or_insert_with(|| attributes.iter().map(|a| a.name.local_name.clone()).collect());
                    }
                }
            }
            Ok(XmlEvent::EndElement { .. }) => {
                if depth == parent_depth {
                    parent = None;
                }
                depth = depth.saturating_sub(1);
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    out
}

/// PyBullet's stand-in for a missing `<inertial>`: 1 kg at the link origin, with the inertia
/// of the collision shapes scaled to that mass (a 2 mm cube's when there are none).
fn default_inertial(parts: &[Part]) -> [[f64; 3]; 3] {
    let shapes: Vec<rapier3d::prelude::MassProperties> = parts
        .iter()
        .filter_map(|p| {
            let (shape, pose) = part_shape(p)?;
            Some(shape.mass_properties(1.0).transform_by(&pose))
        })
        .collect();
    let total: rapier3d::prelude::MassProperties = shapes.into_iter().sum();
    if total.mass() > 0.0 {
        let m = total.reconstruct_inertia_matrix() * (1.0 / total.mass());
        m.to_cols_array_2d().map(|c| c.map(|x| x as f64))
    } else {
        let i = 1.0 / 12.0 * 2.0 * 0.002 * 0.002;
        [[i, 0.0, 0.0], [0.0, i, 0.0], [0.0, 0.0, i]]
    }
}

/// A part's shape and its pose in the link frame (rapier's cylinders turned from y to z, as
/// URDF cylinders are along z). None only for a hull the model builder would have refused.
pub fn part_shape(p: &Part) -> Option<(rapier3d::prelude::SharedShape, rapier3d::prelude::Pose)> {
    use rapier3d::prelude::{Pose, Rotation, SharedShape, Vector};
    let pose = Pose::from_parts(Vector::from_array(p.pos), Rotation::from_xyzw(p.rot[0], p.rot[1], p.rot[2], p.rot[3]).normalize());
    let y_to_z = Pose::from_rotation(Rotation::from_rotation_x(std::f32::consts::FRAC_PI_2));
    Some(match &p.geom {
        Geom::Box(h) => (SharedShape::cuboid(h[0], h[1], h[2]), pose),
        Geom::Sphere(r) => (SharedShape::ball(*r), pose),
        Geom::Cylinder(r, l) => (SharedShape::cylinder(l / 2.0, *r), pose * y_to_z),
        Geom::Capsule(r, l) => (SharedShape::capsule_z(l / 2.0, *r), pose),
        Geom::Hull(points) => {
            let pts: Vec<Vector> = points.iter().map(|q| Vector::from_array(*q)).collect();
            (SharedShape::convex_hull(&pts)?, pose)
        }
    })
}

fn link_model(
    link: &urdf_rs::Link,
    joint: Option<JointSpec>,
    materials: &BTreeMap<&str, [f32; 4]>,
    meshes: &BTreeMap<String, Vec<u8>>,
    is_root: bool,
    has_inertial: bool,
) -> Result<LinkModel, Refusal> {
    let inertial = &link.inertial;
    let i = &inertial.inertia;
    let mut mass = inertial.mass.value;
    let rot = rapier3d::glamx::DMat3::from_quat(DQuat::from_array(rpy_quat(inertial.origin.rpy.0)));
    let local = rapier3d::glamx::DMat3::from_cols_array(&[i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz]);
    let mut inertia_m = rot * local * rot.transpose();
    if !(mass.is_finite() && mass >= 0.0 && inertia_m.is_finite()) {
        return Err(format!("link {} has a negative or non-finite mass or inertia", link.name));
    }
    if mass == 0.0 && !is_root && has_inertial {
        mass = MASSLESS_LINK_MASS;
        inertia_m = rapier3d::glamx::DMat3::from_diagonal(DVec3::splat(MASSLESS_LINK_INERTIA));
    }
    let mut parts = Vec::new();
    for c in &link.collision {
        if !c.origin.xyz.0.iter().all(|x| x.abs() <= crate::limits::MAX_EXTENT_M) {
            return Err(format!("link {} has a collision origin not finite or farther than {} m", link.name, crate::limits::MAX_EXTENT_M));
        }
        let geom = geometry(&link.name, &c.geometry, meshes)?;
        if let Some(geom) = geom {
            parts.push(Part {
                pos: f32s(c.origin.xyz.0),
                rot: f32s(rpy_quat(c.origin.rpy.0)),
                geom,
            });
        }
    }
    let color = link.visual.iter().find_map(|v| {
        let m = v.material.as_ref()?;
        m.color.as_ref().map(|c| f32s(c.rgba.0)).or_else(|| materials.get(m.name.as_str()).copied())
    });
    let (mass, com, inertia) = if has_inertial {
        (mass, inertial.origin.xyz.0, inertia_m.to_cols_array_2d())
    } else {
        (1.0, [0.0; 3], default_inertial(&parts))
    };
    Ok(LinkModel {
        name: link.name.clone(),
        mass,
        com,
        inertia,
        parts,
        color,
        joint,
    })
}

fn geometry(
    link: &str,
    g: &urdf_rs::Geometry,
    meshes: &BTreeMap<String, Vec<u8>>,
) -> Result<Option<Geom>, Refusal> {
    use urdf_rs::Geometry as G;
    let bound = crate::limits::MAX_EXTENT_M;
    let positive = |x: f64, what: &str| {
        if x > 0.0 && x <= bound {
            Ok(x as f32)
        } else {
            Err(format!("link {link} has a {what} of {x}, not a positive number up to {bound} m"))
        }
    };
    Ok(Some(match g {
        G::Box { size } => {
            if size.0 == [0.0; 3] {
                return Ok(None);
            }
            Geom::Box([
                positive(size.0[0], "box size")? / 2.0,
                positive(size.0[1], "box size")? / 2.0,
                positive(size.0[2], "box size")? / 2.0,
            ])
        }
        G::Sphere { radius } => Geom::Sphere(positive(*radius, "sphere radius")?),
        G::Cylinder { radius, length } => {
            Geom::Cylinder(positive(*radius, "cylinder radius")?, positive(*length, "cylinder length")?)
        }
        G::Capsule { radius, length } => {
            Geom::Capsule(positive(*radius, "capsule radius")?, positive(*length, "capsule length")?)
        }
        G::Mesh { filename, scale } => {
            let bytes = meshes
                .get(filename)
                .ok_or_else(|| format!("mesh {filename} of link {link} was not provided"))?;
            let s = scale.as_ref().map_or([1.0; 3], |s| s.0);
            if s.iter().any(|x| !x.is_finite() || *x == 0.0) {
                return Err(format!("mesh {filename} of link {link} has an invalid scale"));
            }
            let points = mesh_points(filename, bytes)?
                .into_iter()
                .map(|p| [p[0] * s[0] as f32, p[1] * s[1] as f32, p[2] * s[2] as f32])
                .collect::<Vec<_>>();
            let pts: Vec<rapier3d::math::Vector> =
                points.iter().map(|p| rapier3d::math::Vector::from_array(*p)).collect();
            if rapier3d::prelude::SharedShape::convex_hull(&pts).is_none() {
                return Err(format!("mesh {filename} of link {link} has no volume (its convex hull is degenerate)"));
            }
            Geom::Hull(points)
        }
    }))
}

/// The vertices of an STL (binary or ASCII) or OBJ mesh, from its bytes (a URDF mesh collides
/// as their convex hull).
pub fn mesh_points(name: &str, bytes: &[u8]) -> Result<Vec<[f32; 3]>, Refusal> {
    Ok(mesh_triangles(name, bytes)?.0)
}

/// A mesh's vertices and its triangles (vertex indices).
pub type Triangles = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// The vertices and triangles (vertex indices) of an STL (binary or ASCII) or OBJ mesh, from its
/// bytes: URDF and MJCF meshes share this reader (MJCF needs the triangles for MuJoCo's mesh
/// volume and inertia).
pub fn mesh_triangles(name: &str, bytes: &[u8]) -> Result<Triangles, Refusal> {
    let lower = name.to_ascii_lowercase();
    let (points, triangles): Triangles = if lower.ends_with(".stl") {
        let mesh = stl_io::read_stl(&mut std::io::Cursor::new(bytes))
            .map_err(|e| format!("mesh {name} is not a readable STL file: {e}"))?;
        let tris = mesh.faces.iter().map(|f| f.vertices.map(|i| i as u32)).collect();
        (mesh.vertices.iter().map(|v| v.0).collect(), tris)
    } else if lower.ends_with(".obj") {
        let opts = tobj::LoadOptions { triangulate: true, ..Default::default() };
        let (models, _) = tobj::load_obj_buf(&mut std::io::BufReader::new(bytes), &opts, |_| {
            Err(tobj::LoadError::GenericFailure)
        })
        .map_err(|e| format!("mesh {name} is not a readable OBJ file: {e}"))?;
        let mut points = Vec::new();
        let mut tris = Vec::new();
        for m in &models {
            let offset = points.len() as u32;
            points.extend(m.mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
            tris.extend(m.mesh.indices.chunks_exact(3).map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]));
        }
        (points, tris)
    } else {
        return Err(format!("mesh {name} has an unsupported format (STL and OBJ are supported)"));
    };
    if points.is_empty() || points.iter().flatten().any(|x| !x.is_finite()) {
        return Err(format!("mesh {name} has no vertices or non-finite ones"));
    }
    within_extent(name, points.iter().map(|p| p.map(f64::from)))?;
    if triangles.iter().flatten().any(|i| *i as usize >= points.len()) {
        return Err(format!("mesh {name} has a face naming a vertex it does not have"));
    }
    Ok((points, triangles))
}

/// Refuses a mesh with a vertex farther than [`crate::limits::MAX_EXTENT_M`] from its origin
/// (in its own units, and again after scaling): such vertices panic the convex hull.
pub fn within_extent(name: &str, points: impl IntoIterator<Item = [f64; 3]>) -> Result<(), Refusal> {
    let bound = crate::limits::MAX_EXTENT_M;
    match points.into_iter().find(|p| p.iter().any(|x| x.is_nan() || x.abs() > bound)) {
        Some(p) => Err(format!("mesh {name} has a vertex at {p:?}, farther than {bound} from its origin")),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROBOT: &str = r#"<robot name="r"><link name="a"><visual><geometry><box size="1 1 1"/>EXTRA</geometry></visual></link>
<link name="b"/><joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin ORIGIN/></joint></robot>"#;

    fn robot(extra: &str, origin: &str) -> String {
        ROBOT.replace("EXTRA", extra).replace("ORIGIN", origin)
    }

    #[test]
    fn what_pybullet_ignores_is_ignored_and_files_urdf_rs_reads_are_untouched() {
        // A clean file: nothing to tolerate, read by urdf-rs as ever.
        assert_eq!(pybullet_tolerated(&robot("", r#"xyz="1 2 3" rpy="0 0 1""#)), None);
        // A material after the shape, and a xacro leftover: both dropped, the rest kept.
        let quirky = robot(r#"<material name="grey"/>"#, r#"rpy="$(optenv X_RPY 0 -1.5708 3.1416)" xyz="1 2 3""#);
        assert!(urdf_rs::read_from_string(&quirky).is_err(), "urdf-rs alone refuses it");
        let tolerated = pybullet_tolerated(&quirky).unwrap();
        assert!(!tolerated.contains("material") && !tolerated.contains("optenv") && tolerated.contains(r#"xyz="1 2 3""#), "{tolerated}");
        let read = parse(&quirky).unwrap();
        assert_eq!(read.joints[0].origin.xyz.0, [1.0, 2.0, 3.0]);
        assert_eq!(read.joints[0].origin.rpy.0, [0.0, 0.0, 0.0], "the first three pieces read as atof: 0 0 0, as in PyBullet");
        // husky.urdf's IMU: the first three pieces are "$(optenv", "HUSKY_IMU_XYZ", "0.19".
        let husky = robot("", r#"xyz="$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)""#);
        assert_eq!(parse(&husky).unwrap().joints[0].origin.xyz.0, [0.0, 0.0, 0.19]);
        assert_eq!(pybullet_vector3("1.5x -2e1 .25 9"), Some([1.5, -20.0, 0.25]));
        assert_eq!(pybullet_vector3("$(a b)"), None, "fewer than three pieces: left out");
        // Something else wrong still says what urdf-rs said.
        assert!(parse("<robot name=\"r\"><link/></robot>").unwrap_err().starts_with("file_path is not a valid URDF"));
    }

    #[test]
    fn inertials_are_read_as_pybullet_reads_them_under_todays_rule() {
        // pybullet_data's cube_small.urdf, in short: version 0.0, a <contact> before the inertial.
        let cube = r#"<?xml version="0.0" ?><robot name="c"><link name="b"><contact><lateral_friction value="1"/></contact>
<inertial><origin xyz="0 0 0"/><mass value=".1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
<collision><geometry><box size=".05 .05 .05"/></geometry></collision></link></robot>"#;
        let today = UrdfRules { continuous: true, revolute_prismatic: true, pybullet_inertials: true };
        let before = UrdfRules { pybullet_inertials: false, ..today };
        assert_eq!(build(cube, &BTreeMap::new(), today).unwrap().links[0].mass, 0.1);
        assert_eq!(build(cube, &BTreeMap::new(), before).unwrap().links[0].mass, 1.0, "events before the rule fold as they did");
        let plain = cube.replace("0.0\" ?>", "1.0\" ?>");
        assert_eq!(build(&plain, &BTreeMap::new(), before).unwrap().links[0].mass, 0.1, "an accepted declaration scans the same either way");
        // A root link named world without an inertial: static (mass 0) as in PyBullet, 1 kg before.
        let world = r#"<robot name="t"><link name="world"/><link name="top"><inertial><mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
<joint name="j" type="fixed"><parent link="world"/><child link="top"/></joint></robot>"#;
        assert_eq!(build(world, &BTreeMap::new(), today).unwrap().links[0].mass, 0.0);
        assert_eq!(build(world, &BTreeMap::new(), before).unwrap().links[0].mass, 1.0);
    }
}
