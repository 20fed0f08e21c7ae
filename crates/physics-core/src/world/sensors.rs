//! MuJoCo sensors of an MJCF robot (get_sensor_data, MuJoCo's `sensordata` by name): the
//! model's `<sensor>`s resolved at load to what they read in our world — a joint, an
//! actuator, a frame fixed on a rapier body (a site, a body's frame or inertial frame, a geom),
//! a subtree's bodies, a link's joint wrench — and evaluated only when read, from the state the
//! engine holds (docs/tools.md "MJCF models" says how each is computed and where it differs).
//!
//! A read: nothing here changes the world. Only loads recorded with `actuators` (event version
//! 7) keep sensors; the table is hashed and snapshotted only when it holds some.

use rapier3d::glamx::{DQuat, DVec3};
use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::Model;
use serde::{Deserialize, Serialize};

use super::World;
use crate::outputs::{SensorData, SensorReading};
use crate::value::Refusal;

/// The sensor types computed (MuJoCo's element names).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SensorType {
    /// `jointpos`: a hinge/slide coordinate.
    Jointpos,
    /// `jointvel`: its velocity.
    Jointvel,
    /// `actuatorfrc`: the actuator's scalar force (before its gear).
    Actuatorfrc,
    /// `framepos`: a frame's world position.
    Framepos,
    /// `framequat`: its world orientation, [w, x, y, z].
    Framequat,
    /// `framelinvel`: the world velocity of its origin.
    Framelinvel,
    /// `frameangvel`: its world angular velocity.
    Frameangvel,
    /// `gyro`: a site's angular velocity in the site frame.
    Gyro,
    /// `velocimeter`: a site's linear velocity in the site frame.
    Velocimeter,
    /// `accelerometer`: a site's linear acceleration less gravity, site frame.
    Accelerometer,
    /// `subtreecom`: the centre of mass of a body's subtree.
    Subtreecom,
    /// `force`: the force the parent body exerts on a site's body, site frame.
    Force,
    /// `torque`: the matching moment about the site.
    Torque,
    /// `touch`: the sum of the normal forces of the contacts inside a site's volume (loads of
    /// event version 8 on).
    Touch,
}

impl SensorType {
    fn parse(tag: &str) -> Option<SensorType> {
        Some(match tag {
            "jointpos" => SensorType::Jointpos,
            "jointvel" => SensorType::Jointvel,
            "actuatorfrc" => SensorType::Actuatorfrc,
            "framepos" => SensorType::Framepos,
            "framequat" => SensorType::Framequat,
            "framelinvel" => SensorType::Framelinvel,
            "frameangvel" => SensorType::Frameangvel,
            "gyro" => SensorType::Gyro,
            "velocimeter" => SensorType::Velocimeter,
            "accelerometer" => SensorType::Accelerometer,
            "subtreecom" => SensorType::Subtreecom,
            "force" => SensorType::Force,
            "torque" => SensorType::Torque,
            "touch" => SensorType::Touch,
            _ => return None,
        })
    }

    /// The MJCF element name.
    pub fn name(self) -> &'static str {
        match self {
            SensorType::Jointpos => "jointpos",
            SensorType::Jointvel => "jointvel",
            SensorType::Actuatorfrc => "actuatorfrc",
            SensorType::Framepos => "framepos",
            SensorType::Framequat => "framequat",
            SensorType::Framelinvel => "framelinvel",
            SensorType::Frameangvel => "frameangvel",
            SensorType::Gyro => "gyro",
            SensorType::Velocimeter => "velocimeter",
            SensorType::Accelerometer => "accelerometer",
            SensorType::Subtreecom => "subtreecom",
            SensorType::Force => "force",
            SensorType::Torque => "torque",
            SensorType::Touch => "touch",
        }
    }
}

/// A frame fixed on one rapier body: the pose it reads.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct BodyFrame {
    /// The body carrying it.
    pub body: RigidBodyHandle,
    /// Its position in that body's frame.
    pub pos: [f64; 3],
    /// Its orientation in that body's frame, [x, y, z, w].
    pub rot: [f64; 4],
    /// MuJoCo's `body` object: the body's inertial frame (centre of mass, principal axes),
    /// read off the rapier body, rather than `pos`/`rot`.
    pub inertial: bool,
}

/// What one sensor reads.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub enum SensorSource {
    /// A joint by index.
    Joint(u32),
    /// An actuator by its index in the robot's actuation table.
    Actuator(usize),
    /// A frame.
    Frame(BodyFrame),
    /// The bodies of a subtree (their masses and centres).
    Subtree(Vec<RigidBodyHandle>),
    /// A site on the child link of joint `link`: the wrench through that joint.
    Wrench {
        /// The link (its joint carries the body's whole subtree).
        link: u32,
        /// The site.
        site: BodyFrame,
    },
    /// A site's volume: the contacts of its rapier body inside it.
    Volume {
        /// The site's frame.
        site: BodyFrame,
        /// Its shape and size.
        shape: SiteVolume,
    },
}

/// A site's volume as MuJoCo sizes it (half sizes, m).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub enum SiteVolume {
    /// Radius.
    Sphere(f64),
    /// Radius, half length along z.
    Capsule(f64, f64),
    /// Semi-axes.
    Ellipsoid([f64; 3]),
    /// Radius, half height along z.
    Cylinder(f64, f64),
    /// Half extents.
    Box([f64; 3]),
}

impl SiteVolume {
    fn of(site: &rapier3d_mjcf::mjcf_rs::body::Site) -> SiteVolume {
        use rapier3d_mjcf::mjcf_rs::body::SiteType;
        let s = site.size;
        match site.type_ {
            SiteType::Sphere => SiteVolume::Sphere(s[0]),
            SiteType::Capsule => SiteVolume::Capsule(s[0], s[1]),
            SiteType::Ellipsoid => SiteVolume::Ellipsoid(s),
            SiteType::Cylinder => SiteVolume::Cylinder(s[0], s[1]),
            SiteType::Box => SiteVolume::Box(s),
        }
    }

    /// Whether point `p` (in the site's frame) is inside.
    fn contains(&self, p: DVec3) -> bool {
        match *self {
            SiteVolume::Sphere(r) => p.length() <= r,
            SiteVolume::Capsule(r, h) => DVec3::new(p.x, p.y, p.z.clamp(-h, h)).distance(p) <= r,
            SiteVolume::Ellipsoid(a) => (p / DVec3::from_array(a)).length_squared() <= 1.0,
            SiteVolume::Cylinder(r, h) => p.z.abs() <= h && (p.x * p.x + p.y * p.y).sqrt() <= r,
            SiteVolume::Box(b) => p.x.abs() <= b[0] && p.y.abs() <= b[1] && p.z.abs() <= b[2],
        }
    }
}

/// One kept sensor.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Sensor {
    /// Its `name` (`#k` when unnamed, k its index among the model's sensors).
    pub name: String,
    /// Its type.
    pub kind: SensorType,
    /// What it reads.
    pub source: SensorSource,
}

/// Where an MJCF body ended up: the rapier body carrying its frame, and the frame there.
#[derive(Clone, Copy, Debug)]
pub struct Placed {
    /// The rapier body (its own, or the one it was merged into).
    pub body: RigidBodyHandle,
    /// The MJCF body's frame in that rapier body's frame.
    pub in_body: Pose,
    /// Whether the rapier body is its own (not merged into its parent's).
    pub own: bool,
    /// The link of that rapier body (−1: the base).
    pub link: i32,
}

/// The insert's facts the sensors are resolved against.
pub struct Resolver<'a> {
    /// The parsed model.
    pub model: &'a Model,
    /// Each MJCF body id's placement (None: not built, e.g. the worldbody beside a free root
    /// with no geoms).
    pub placed: &'a [Option<Placed>],
    /// A joint name → its index.
    pub joint_of: &'a dyn Fn(&str) -> Option<u32>,
    /// An actuator name → its index among those simulated.
    pub actuator_of: &'a dyn Fn(&str) -> Option<usize>,
}

/// One `<sensor>` child as written (the parser keeps no `actuator` attribute).
struct Written {
    tag: String,
    name: Option<String>,
    attr: std::collections::BTreeMap<String, String>,
}

fn written(xml: &str) -> Vec<Written> {
    let Ok(doc) = roxmltree::Document::parse(xml) else { return Vec::new() };
    doc.descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "sensor")
        .flat_map(|block| block.children().filter(|n| n.is_element() && n.tag_name().name() != "include"))
        .map(|n| Written {
            tag: n.tag_name().name().to_string(),
            name: n.attribute("name").map(str::to_string),
            attr: n.attributes().map(|a| (a.name().to_string(), a.value().to_string())).collect(),
        })
        .collect()
}

/// The model's sensors (from its text, includes spliced) resolved in our world, and a
/// sentence for each one that is not computed (`touch` only for loads of event version 8 on).
pub fn build(xml: &str, r: &Resolver, touch: bool) -> (Vec<Sensor>, Vec<String>) {
    let mut kept = Vec::new();
    let mut ignored = Vec::new();
    for (k, w) in written(xml).into_iter().enumerate() {
        let name = w.name.clone().unwrap_or_else(|| format!("#{k}"));
        let resolved = SensorType::parse(&w.tag)
            .filter(|kind| touch || *kind != SensorType::Touch)
            .ok_or_else(|| format!("type {} is not computed", w.tag))
            .and_then(|kind| resolve(kind, &w, r).map(|source| Sensor { name: name.clone(), kind, source }));
        match resolved {
            Ok(s) => kept.push(s),
            Err(why) => ignored.push(format!("sensor {name}: {why}")),
        }
    }
    (kept, ignored)
}

fn pose_parts(p: &Pose) -> ([f64; 3], [f64; 4]) {
    (p.translation.to_array().map(f64::from), p.rotation.to_array().map(f64::from))
}

fn resolve(kind: SensorType, w: &Written, r: &Resolver) -> Result<SensorSource, String> {
    let attr = |n: &str| w.attr.get(n).map(String::as_str);
    let need = |n: &str| attr(n).ok_or_else(|| format!("it names no {n}"));
    let body_id = |name: &str| -> Result<usize, String> {
        if name == "world" {
            return Ok(0);
        }
        r.model.body_id_by_name(name).ok_or_else(|| format!("body {name} is not in the model"))
    };
    let placed = |b: usize| r.placed.get(b).copied().flatten().ok_or_else(|| "its body is the worldbody beside a free base, which carries no frame".to_string());
    let site_of = |name: &str| -> Result<(Placed, Pose, SiteVolume), String> {
        for (b, entry) in r.model.bodies.iter().enumerate() {
            if let Some(s) = entry.body.sites.iter().find(|s| s.name.as_deref() == Some(name)) {
                let p = placed(b)?;
                return Ok((p, p.in_body * Pose::from(s.pose), SiteVolume::of(s)));
            }
        }
        Err(format!("site {name} is not in the model"))
    };
    let site = |name: &str| site_of(name).map(|(p, at, _)| (p, at));
    let frame = |p: Placed, at: Pose, inertial: bool| {
        let (pos, rot) = pose_parts(&at);
        BodyFrame { body: p.body, pos, rot, inertial }
    };
    match kind {
        SensorType::Jointpos | SensorType::Jointvel => {
            let j = need("joint")?;
            (r.joint_of)(j).map(SensorSource::Joint).ok_or_else(|| format!("joint {j} is not a hinge or slide joint of the model"))
        }
        SensorType::Actuatorfrc => {
            let a = need("actuator")?;
            (r.actuator_of)(a).map(SensorSource::Actuator).ok_or_else(|| format!("actuator {a} is not simulated"))
        }
        SensorType::Framepos | SensorType::Framequat | SensorType::Framelinvel | SensorType::Frameangvel => {
            if attr("reftype").is_some() || attr("refname").is_some() {
                return Err("frames relative to a reference frame (reftype/refname) are not computed".into());
            }
            let (objtype, objname) = (need("objtype")?, need("objname")?);
            match objtype {
                "site" => site(objname).map(|(p, at)| SensorSource::Frame(frame(p, at, false))),
                "xbody" => {
                    let p = placed(body_id(objname)?)?;
                    Ok(SensorSource::Frame(frame(p, p.in_body, false)))
                }
                "body" => {
                    let p = placed(body_id(objname)?)?;
                    if !p.own {
                        return Err(format!("body {objname} is welded into its parent's rigid body, whose inertial frame it does not have alone"));
                    }
                    Ok(SensorSource::Frame(frame(p, p.in_body, true)))
                }
                "geom" => {
                    for (b, entry) in r.model.bodies.iter().enumerate() {
                        if let Some(g) = entry.body.geoms.iter().find(|g| g.name.as_deref() == Some(objname)) {
                            let p = placed(b)?;
                            return Ok(SensorSource::Frame(frame(p, p.in_body * Pose::from(g.pose), false)));
                        }
                    }
                    Err(format!("geom {objname} is not in the model"))
                }
                other => Err(format!("objtype {other} is not computed (site, xbody, body and geom are)")),
            }
        }
        SensorType::Gyro | SensorType::Velocimeter | SensorType::Accelerometer => {
            site(need("site")?).map(|(p, at)| SensorSource::Frame(frame(p, at, false)))
        }
        SensorType::Force | SensorType::Torque => {
            let (p, at) = site(need("site")?)?;
            if !p.own || p.link < 0 {
                return Err("its site's body hangs from no joint of its own (the base, or welded to its parent)".into());
            }
            Ok(SensorSource::Wrench { link: p.link as u32, site: frame(p, at, false) })
        }
        SensorType::Subtreecom => {
            let b = body_id(need("body")?)?;
            subtree(r, b).map(SensorSource::Subtree)
        }
        SensorType::Touch => {
            let (p, at, shape) = site_of(need("site")?)?;
            Ok(SensorSource::Volume { site: frame(p, at, false), shape })
        }
    }
}

/// The rapier bodies of MJCF body `root`'s subtree (every own body at or below it; the
/// worldbody's, massless in MuJoCo, left out).
fn subtree(r: &Resolver, root: usize) -> Result<Vec<RigidBodyHandle>, String> {
    if root != 0 && !r.placed.get(root).copied().flatten().is_some_and(|p| p.own) {
        return Err("its body is welded into its parent's rigid body, so its subtree's mass is not separate".into());
    }
    let below = |mut b: usize| loop {
        if b == root {
            return true;
        }
        match r.model.bodies.get(b).and_then(|e| e.parent) {
            Some(p) if p != b => b = p,
            _ => return false,
        }
    };
    let mut out: Vec<RigidBodyHandle> = Vec::new();
    for b in 1..r.model.bodies.len() {
        if let Some(p) = r.placed.get(b).copied().flatten().filter(|p| p.own && below(b)) {
            if !out.contains(&p.body) {
                out.push(p.body);
            }
        }
    }
    Ok(out)
}

fn dv(v: rapier3d::glamx::Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn dq(q: rapier3d::glamx::Quat) -> DQuat {
    DQuat::from_xyzw(q.x as f64, q.y as f64, q.z as f64, q.w as f64)
}

/// A frame's world pose, velocity of its origin and angular velocity now.
struct FrameState {
    pos: DVec3,
    rot: DQuat,
    vel: DVec3,
    omega: DVec3,
}

impl World {
    /// The sensors of object `id` (None: it has none).
    pub fn sensors(&self, id: u32) -> Option<&Vec<Sensor>> {
        self.tables.mjcf_sensors.get(&id)
    }

    fn frame_state(&self, f: &BodyFrame) -> Option<FrameState> {
        let b = self.physics.bodies.get(f.body)?;
        let (bp, br) = (dv(b.position().translation), dq(b.position().rotation));
        let (local_pos, local_rot) = if f.inertial {
            let mp = &b.mass_properties().local_mprops;
            (dv(mp.local_com), dq(mp.principal_inertia_local_frame))
        } else {
            (DVec3::from_array(f.pos), DQuat::from_array(f.rot))
        };
        let pos = bp + br * local_pos;
        let omega = dv(b.angvel());
        // The body's linear velocity is its centre of mass's.
        let com = bp + br * dv(b.mass_properties().local_mprops.local_com);
        let vel = dv(b.linvel()) + omega.cross(pos - com);
        Some(FrameState { pos, rot: (br * local_rot).normalize(), vel, omega })
    }

    /// get_sensor_data: every sensor of `id` (or those `names` lists, in the model's order),
    /// MuJoCo's `sensordata` values each.
    pub fn sensor_data(&self, id: u32, names: Option<&[String]>) -> Result<SensorData, Refusal> {
        let sensors = self.sensors(id).ok_or_else(|| format!("object_id {id} has no sensors (only MJCF models loaded with them do)"))?;
        // Looked up by set, not by scanning the sensors for each name: a long `names` against a
        // model of many sensors stays linear-logarithmic.
        let asked: Option<std::collections::BTreeSet<&str>> = names.map(|ns| ns.iter().map(String::as_str).collect());
        if let Some(names) = names {
            let have: std::collections::BTreeSet<&str> = sensors.iter().map(|s| s.name.as_str()).collect();
            if let Some(n) = names.iter().find(|n| !have.contains(n.as_str())) {
                let all: Vec<&str> = sensors.iter().map(|s| s.name.as_str()).collect();
                return Err(format!("names lists no sensor {n:?} of object {id}; its sensors are {}", crate::limits::some_names(&all)));
            }
        }
        let wanted = |s: &Sensor| asked.as_ref().is_none_or(|a| a.contains(s.name.as_str()));
        let forces = self.actuator_forces(id);
        let mut wrenches = None;
        let mut out = Vec::new();
        for s in sensors.iter().filter(|s| wanted(s)) {
            let data = match &s.source {
                SensorSource::Joint(j) => {
                    let link = self.robot(id).and_then(|r| r.links.get(*j as usize));
                    let (q, v) = link.map_or((0.0, 0.0), |l| self.joint_coordinates(l.body, l.joint.kind));
                    vec![if s.kind == SensorType::Jointpos { q as f64 } else { v as f64 }]
                }
                SensorSource::Actuator(k) => vec![forces.get(*k).copied().unwrap_or(0.0)],
                SensorSource::Subtree(bodies) => vec_of(self.subtree_com(bodies)),
                SensorSource::Frame(f) => {
                    let Some(st) = self.frame_state(f) else { continue };
                    match s.kind {
                        SensorType::Framepos => vec_of(st.pos),
                        SensorType::Framequat => vec![st.rot.w, st.rot.x, st.rot.y, st.rot.z],
                        SensorType::Framelinvel => vec_of(st.vel),
                        SensorType::Frameangvel => vec_of(st.omega),
                        SensorType::Gyro => vec_of(st.rot.inverse() * st.omega),
                        SensorType::Velocimeter => vec_of(st.rot.inverse() * st.vel),
                        SensorType::Accelerometer => {
                            let w = wrenches.get_or_insert_with(|| self.quasi_static_wrenches(id));
                            let link = self.link_of_body(id, f.body);
                            let acc = match (w.as_ref(), link) {
                                (Some(w), Some(l)) => w.motion[l].acceleration_at(st.pos),
                                // The base (or a body off the chain): at rest, it feels gravity only.
                                _ => -dv(self.physics.gravity),
                            };
                            vec_of(st.rot.inverse() * acc)
                        }
                        _ => Vec::new(),
                    }
                }
                SensorSource::Wrench { link, site } => {
                    let w = wrenches.get_or_insert_with(|| self.quasi_static_wrenches(id));
                    let (Some(w), Some(st)) = (w.as_ref(), self.frame_state(site)) else { continue };
                    let l = *link as usize;
                    let (Some(f), Some(m)) = (w.force.get(l), w.moment.get(l)) else { continue };
                    // The moment about the joint, moved to the site; both in the site frame.
                    let at_site = *m + (w.motion[l].joint_pos - st.pos).cross(*f);
                    let inv = st.rot.inverse();
                    if s.kind == SensorType::Force { vec_of(inv * *f) } else { vec_of(inv * at_site) }
                }
                SensorSource::Volume { site, shape } => {
                    let Some(st) = self.frame_state(site) else { continue };
                    vec![self.touch(site.body, &st, shape)]
                }
            };
            out.push(SensorReading { name: s.name.clone(), r#type: s.kind.name().to_string(), data });
        }
        Ok(SensorData { sensors: out })
    }

    /// The Newton–Euler pass at the current positions and velocities and zero joint
    /// accelerations (the one behind `joint_reaction_wrench`), with the moments about each joint.
    fn quasi_static_wrenches(&self, id: u32) -> Option<super::dynamics::JointWrenches> {
        let model = self.robot_dynamics(id)?;
        let (q, qd) = self.robot_configuration(id)?;
        Some(model.newton_euler(&q, &qd, &vec![0.0; model.dofs], dv(self.physics.gravity)))
    }

    /// MuJoCo's `touch`: the normal forces (impulse over the step, as get_contact_points
    /// reports them) of every contact of `body`'s colliders whose point — midway between the
    /// two surfaces, as MuJoCo places it — lies inside the site's volume.
    fn touch(&self, body: RigidBodyHandle, site: &FrameState, shape: &SiteVolume) -> f64 {
        let dt = self.physics.integration_parameters.dt as f64;
        let Some(b) = self.physics.bodies.get(body) else { return 0.0 };
        let inv = site.rot.inverse();
        let mut sum = 0.0;
        for &ch in b.colliders() {
            for cp in self.physics.contact_pairs_with(ch) {
                let (Some(c1), Some(c2)) = (self.physics.colliders.get(cp.collider1), self.physics.colliders.get(cp.collider2)) else { continue };
                for m in cp.manifolds() {
                    for p in &m.points {
                        let on1 = dv(c1.position().transform_point(p.local_p1));
                        let on2 = dv(c2.position().transform_point(p.local_p2));
                        let local = inv * ((on1 + on2) * 0.5 - site.pos);
                        if p.data.impulse > 0.0 && shape.contains(local) {
                            sum += p.data.impulse as f64 / dt;
                        }
                    }
                }
            }
        }
        sum
    }

    /// The link of robot `id` whose rapier body is `body`.
    fn link_of_body(&self, id: u32, body: RigidBodyHandle) -> Option<usize> {
        self.robot(id)?.links.iter().position(|l| l.body == body)
    }

    /// The mass-weighted centre of `bodies` (their centres of mass).
    fn subtree_com(&self, bodies: &[RigidBodyHandle]) -> DVec3 {
        let (mut m, mut mc) = (0.0, DVec3::ZERO);
        for b in bodies.iter().filter_map(|h| self.physics.bodies.get(*h)) {
            let mp = &b.mass_properties().local_mprops;
            let c = dv(b.position().translation) + dq(b.position().rotation) * dv(mp.local_com);
            m += mp.mass() as f64;
            mc += mp.mass() as f64 * c;
        }
        if m > 0.0 { mc / m } else { DVec3::ZERO }
    }
}

fn vec_of(v: DVec3) -> Vec<f64> {
    vec![v.x, v.y, v.z]
}
