//! An MJCF model's `<equality>` constraints and fixed tendons, built for loads of event version
//! 8 (`Command::LoadMjcf::constraints`), with MuJoCo's meaning (docs/tools.md "MJCF models"):
//!
//! - `<joint joint1 joint2 polycoef>` with a linear polynomial: `q2 − ref2 = p0 + p1·(q1 − ref1)`,
//!   a DoF coupling of the robot's multibody (rapier's `MultibodyDofCoupling`, a rigid
//!   velocity-level equality solved with the joints; MuJoCo's is soft, `solref`).
//! - `<connect body1 body2 anchor>`: the point `anchor` of body1 and the point of body2 that
//!   coincided with it at qpos0 stay together (an impulse joint locking the three translations).
//! - `<weld body1 body2 relpose>`: body2's pose relative to body1 is held at `relpose` (its
//!   qpos0 relative pose when the quaternion is zero, MuJoCo's default) — an impulse joint
//!   locking all six axes. `anchor` and `torquescale` only weigh MuJoCo's soft constraint
//!   error; a rigid weld has none.
//! - `<tendon><fixed>`: a transmission only — an actuator on it acts on each joint with
//!   `coef·gear·force` at length `Σ coef·q` (`actuators::Transmission`); its own range,
//!   stiffness and damping are not simulated.
//!
//! Everything else of these elements is listed in `ignored` with the reason. Rapier's joint
//! sets (impulse joints, multibodies with their couplings) are snapshotted whole, so nothing
//! here keeps state of its own.

use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::equality::Equality;
use rapier3d_mjcf::mjcf_rs::Model;

use serde::{Deserialize, Serialize};

use super::robot::Robot;
use crate::outputs::ModelElement;
use super::urdf::JointKind;
use super::World;

/// The largest `polycoef[1]` (ratio of two joints' motions) built: real couplings are gear
/// ratios near 1; beyond this the f32 solver has nothing finite to work with.
const MAX_COUPLING_RATIO: f64 = 1e3;

/// Where an MJCF body is in the world we built: its rapier body (the owner it was merged into)
/// and its frame in that body's frame, and its pose at qpos0 in the model's own frame.
#[derive(Clone, Copy, Debug)]
pub struct BodyFrame {
    /// The rapier body carrying it.
    pub body: RigidBodyHandle,
    /// Its frame in that body's frame.
    pub in_body: Pose,
    /// Its pose at qpos0 (the file's pose, `ref` folded in) in the model's frame.
    pub at_qpos0: Pose,
}

/// What the builder needs of the model as inserted.
pub struct Placement<'a> {
    /// Each MJCF body id's frame (None: not built, e.g. the world of a free-base model with no
    /// world geoms).
    pub frames: &'a [Option<BodyFrame>],
    /// A hinge or slide joint's name → its joint index.
    pub joint_of: &'a dyn Fn(&str) -> Option<u32>,
    /// The robot (joint index → its link's body and kind).
    pub robot: &'a Robot,
    /// A joint index → its `ref` (rad or m; 0 when none).
    pub joint_ref: &'a dyn Fn(u32) -> f64,
}

/// A fixed tendon as an actuator transmission: its joints and their coefficients.
pub fn tendon_joints(model: &Model, name: &str, joint_of: &dyn Fn(&str) -> Option<u32>) -> Result<Vec<(u32, f64)>, String> {
    let t = model.tendons.iter().find(|t| t.name.as_deref() == Some(name)).ok_or_else(|| format!("tendon {name} is not a fixed tendon of the model"))?;
    let terms: Vec<(u32, f64)> = t
        .joints
        .iter()
        .map(|term| joint_of(&term.joint).map(|j| (j, term.coef)).ok_or_else(|| format!("tendon {name}'s joint {} is not a hinge or slide joint", term.joint)))
        .collect::<Result<_, _>>()?;
    if terms.is_empty() || terms.iter().any(|(_, c)| !(*c as f32).is_finite()) {
        return Err(format!("tendon {name} has no joints or a coefficient that is not a finite f32 number"));
    }
    Ok(terms)
}

/// The tendon attributes a fixed tendon does not simulate.
const TENDON_ATTRIBUTES: [&str; 7] = ["range", "limited", "stiffness", "damping", "springlength", "frictionloss", "armature"];

/// Notes for what a fixed tendon carries beyond its transmission (not simulated); with
/// `defaults` (loads of event version 9) also what `<default>` classes set for tendons, which
/// a fixed tendon of the class inherits.
pub fn tendon_notes(xml: &str, defaults: bool) -> Vec<String> {
    let Ok(doc) = roxmltree::Document::parse(xml) else { return Vec::new() };
    let mut notes = Vec::new();
    let element = |n: &roxmltree::Node, tag: &str| n.is_element() && n.tag_name().name() == tag;
    if defaults && doc.descendants().any(|n| element(&n, "fixed")) {
        for n in doc.descendants().filter(|n| element(n, "tendon") && n.parent().is_some_and(|p| element(&p, "default"))) {
            let class = n.parent().and_then(|p| p.attribute("class")).unwrap_or("main");
            let set: Vec<&str> = TENDON_ATTRIBUTES.into_iter().filter(|a| n.attribute(*a).is_some()).collect();
            if !set.is_empty() {
                notes.push(format!("<default class=\"{class}\"><tendon>: {} not simulated (a fixed tendon acts only as an actuator's transmission)", set.join(", ")));
            }
        }
    }
    for (k, n) in doc.descendants().filter(|n| n.is_element() && n.tag_name().name() == "fixed").enumerate() {
        let name = n.attribute("name").map_or_else(|| format!("#{k}"), str::to_string);
        let set: Vec<&str> = TENDON_ATTRIBUTES.into_iter().filter(|a| n.attribute(*a).is_some()).collect();
        if !set.is_empty() {
            notes.push(format!("tendon {name}: {} not simulated (a fixed tendon acts only as an actuator's transmission)", set.join(", ")));
        }
    }
    if doc.descendants().any(|n| n.is_element() && n.tag_name().name() == "tendon" && n.children().any(|c| c.is_element() && c.tag_name().name() != "fixed")) {
        notes.push("<tendon>: only fixed tendons are simulated".into());
    }
    notes
}

/// Whether a `<connect>` or `<weld>` of the model names the world (body2 omitted or `world`);
/// with `only_built` (loads of event version 9) only one that can be built — active and in the
/// body form — counts, so a model whose world constraint is not built gets no world body.
pub fn uses_world(model: &Model, only_built: bool) -> bool {
    let counts = |common: &rapier3d_mjcf::mjcf_rs::equality::EqualityCommon, body1: &str| !only_built || (common.active && !body1.is_empty());
    model.equality.iter().any(|e| match e {
        Equality::Connect(c) => (c.body2.as_deref().is_none_or(|b| b == "world") || c.body1 == "world") && counts(&c.common, &c.body1),
        Equality::Weld(w) => (w.body2.as_deref().is_none_or(|b| b == "world") || w.body1 == "world") && counts(&w.common, &w.body1),
        _ => false,
    })
}

/// A connect's or weld's two bodies (body2 omitted: the world), or why it is not built.
fn endpoints(
    common: &rapier3d_mjcf::mjcf_rs::equality::EqualityCommon,
    body1: &str,
    body2: Option<&str>,
    frame_of: &dyn Fn(&str) -> Result<BodyFrame, String>,
) -> Result<(BodyFrame, BodyFrame), String> {
    if !common.active {
        return Err("inactive (active=\"false\")".into());
    }
    if body1.is_empty() {
        return Err("the site1/site2 form is not supported (name body1 and body2)".into());
    }
    Ok((frame_of(body1)?, frame_of(body2.unwrap_or("world"))?))
}

/// An equality's name for notes (`#k` when unnamed).
fn label(name: &Option<String>, k: usize) -> String {
    name.clone().unwrap_or_else(|| format!("#{k}"))
}

/// An MJCF model's equality constraints and fixed tendons as listed (get_simulation_info,
/// get_joint_info), loads of event version 9.
#[derive(Serialize, Deserialize, Clone, Debug, Default, PartialEq)]
pub struct Elements {
    /// The equality constraints in file order.
    pub equality: Vec<ModelElement>,
    /// The fixed tendons in file order.
    pub tendons: Vec<ModelElement>,
}

impl Elements {
    /// The names of `list`'s elements that name joint `joint` (get_joint_info).
    pub fn naming(&self, list: &[ModelElement], joint: usize) -> Vec<String> {
        list.iter().filter(|e| e.joints.contains(&(joint as u32))).map(|e| e.name.clone()).collect()
    }

    /// The listing of `model`: each equality constraint with whether it was built (`built[k]`),
    /// each fixed tendon built when an actuator drives it through its joints.
    pub fn of(model: &Model, built: &[bool], joint_of: &dyn Fn(&str) -> Option<u32>) -> Elements {
        let joints = |names: &[Option<&str>]| names.iter().flatten().filter_map(|n| joint_of(n)).collect::<Vec<u32>>();
        let equality = model
            .equality
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let (name, kind, joints) = match e {
                    Equality::Joint(j) => (&j.common.name, "joint", joints(&[Some(&j.joint1), j.joint2.as_deref()])),
                    Equality::Connect(c) => (&c.common.name, "connect", Vec::new()),
                    Equality::Weld(w) => (&w.common.name, "weld", Vec::new()),
                    Equality::Tendon(t) => (&t.common.name, "tendon", Vec::new()),
                };
                ModelElement { name: label(name, k), kind: kind.into(), joints, built: built.get(k).copied().unwrap_or(false) }
            })
            .collect();
        let tendons = model
            .tendons
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let name = label(&t.name, k);
                let driven = model.actuators.iter().any(|a| a.tendon.as_deref() == Some(name.as_str()));
                let built = driven && tendon_joints(model, &name, joint_of).is_ok();
                ModelElement { name, kind: "fixed".into(), joints: joints(&t.joints.iter().map(|j| Some(j.joint.as_str())).collect::<Vec<_>>()), built }
            })
            .collect();
        Elements { equality, tendons }
    }
}

impl World {
    /// Builds the model's equality constraints on the inserted robot; returns a note for each
    /// one not built, and whether each was built.
    pub(super) fn build_mjcf_equalities(&mut self, model: &Model, at: &Placement<'_>) -> (Vec<String>, Vec<bool>) {
        let mut notes = Vec::new();
        let mut built = Vec::new();
        let frame_of = |name: &str| -> Result<BodyFrame, String> {
            let id = if name == "world" { 0 } else { model.body_id_by_name(name).ok_or_else(|| format!("body {name} is not in the model"))? };
            at.frames.get(id).copied().flatten().ok_or_else(|| format!("body {name} has no body of its own in the world"))
        };
        for (k, e) in model.equality.iter().enumerate() {
            let outcome = match e {
                Equality::Joint(j) => {
                    let name = label(&j.common.name, k);
                    if !j.common.active {
                        Err(format!("equality joint {name}: inactive (active=\"false\"); not built"))
                    } else {
                        self.couple_joints(j, at).map_err(|why| format!("equality joint {name}: {why}; not built"))
                    }
                }
                Equality::Connect(c) => {
                    let name = label(&c.common.name, k);
                    let built = (|| {
                        if !c.anchor.iter().all(|x| x.abs() <= crate::limits::MAX_EXTENT_M) {
                            return Err(format!("its anchor is not finite numbers within {} m", crate::limits::MAX_EXTENT_M));
                        }
                        let (b1, b2) = endpoints(&c.common, &c.body1, c.body2.as_deref(), &frame_of)?;
                        let anchor = Vector::new(c.anchor[0] as f32, c.anchor[1] as f32, c.anchor[2] as f32);
                        let in2 = b2.at_qpos0.inverse() * b1.at_qpos0 * Pose::from_translation(anchor);
                        let f1 = b1.in_body * Pose::from_translation(anchor);
                        let f2 = b2.in_body * in2;
                        self.insert_equality_joint(JointAxesMask::LIN_AXES, (b1.body, f1), (b2.body, f2))
                    })();
                    built.map_err(|why| format!("equality connect {name}: {why}; not built"))
                }
                Equality::Weld(w) => {
                    let name = label(&w.common.name, k);
                    let built = (|| {
                        let (b1, b2) = endpoints(&w.common, &w.body1, w.body2.as_deref(), &frame_of)?;
                        // MuJoCo: relpose is body2's pose in body1's frame; a zero quaternion
                        // (the default) means "as at qpos0".
                        let rel = match w.relpose.filter(|r| r.rotation.length() > 0.0) {
                            Some(r) => {
                                let q = r.rotation.normalize();
                                let t = r.translation;
                                Pose::from_parts(
                                    Vector::new(t.x as f32, t.y as f32, t.z as f32),
                                    Rotation::from_xyzw(q.x as f32, q.y as f32, q.z as f32, q.w as f32),
                                )
                            }
                            None => b1.at_qpos0.inverse() * b2.at_qpos0,
                        };
                        if !rel.translation.to_array().iter().all(|x| x.abs() <= crate::limits::MAX_EXTENT_M as f32) {
                            return Err("its relpose is not within the world's extent".into());
                        }
                        self.insert_equality_joint(JointAxesMask::LOCKED_FIXED_AXES, (b1.body, b1.in_body * rel), (b2.body, b2.in_body))
                    })();
                    built.map_err(|why| format!("equality weld {name}: {why}; not built"))
                }
                Equality::Tendon(t) => Err(format!("equality tendon {}: tendon length equalities are not simulated", label(&t.common.name, k))),
            };
            built.push(outcome.is_ok());
            if let Err(note) = outcome {
                notes.push(note);
            }
        }
        (notes, built)
    }

    /// A rigid impulse joint between two bodies at their frames (a connect or weld).
    fn insert_equality_joint(&mut self, locked: JointAxesMask, (b1, f1): (RigidBodyHandle, Pose), (b2, f2): (RigidBodyHandle, Pose)) -> Result<(), String> {
        if b1 == b2 {
            return Err("both bodies are one rigid body here (merged or the same)".into());
        }
        let finite = |p: &Pose| p.translation.to_array().iter().chain(p.rotation.to_array().iter()).all(|x| x.is_finite());
        if !finite(&f1) || !finite(&f2) {
            return Err("its anchor is not finite".into());
        }
        let joint = GenericJointBuilder::new(locked).local_frame1(f1).local_frame2(f2).build();
        self.physics.impulse_joints.insert(b1, b2, joint, true);
        Ok(())
    }

    /// `<equality><joint>`: a linear coupling of two hinge/slide joints of one multibody.
    fn couple_joints(&mut self, j: &rapier3d_mjcf::mjcf_rs::equality::EqualityJoint, at: &Placement<'_>) -> Result<(), String> {
        let p = j.polycoef;
        if p[2..].iter().any(|c| *c != 0.0) {
            return Err("polycoef beyond the linear terms (p2..p4) is not simulated".into());
        }
        let Some(joint2) = j.joint2.as_deref() else {
            return Err("the one-joint form (joint2 omitted) is not simulated".into());
        };
        let resolve = |name: &str| (at.joint_of)(name).ok_or_else(|| format!("joint {name} is not a hinge or slide joint of the model"));
        let (i1, i2) = (resolve(&j.joint1)?, resolve(joint2)?);
        // A coupling of ratio 1e30 leaves the solver nothing finite to work with.
        if !(p[0].abs() <= crate::limits::MAX_EXTENT_M && p[1].abs() <= MAX_COUPLING_RATIO) {
            return Err(format!("polycoef's p0 must be within {} and p1 within {MAX_COUPLING_RATIO} in magnitude", crate::limits::MAX_EXTENT_M));
        }
        let link = |i: u32| &at.robot.links[i as usize];
        let (l1, l2) = (link(i1), link(i2));
        // Rapier's coordinate is MuJoCo's qpos (`ref` folded into the joint frame), so
        // q2 = p1·q1 + (p0 + ref2 − p1·ref1).
        let (ref1, ref2) = ((at.joint_ref)(i1), (at.joint_ref)(i2));
        // A `ref` of 3e38 would make the offset (and rapier's q2 − p1·q1) infinite.
        if !(ref1.abs() <= crate::limits::MAX_EXTENT_M && ref2.abs() <= crate::limits::MAX_EXTENT_M) {
            return Err(format!("a coupled joint's ref must be within {} in magnitude", crate::limits::MAX_EXTENT_M));
        }
        let offset = p[0] + ref2 - p[1] * ref1;
        let axis = |kind: JointKind| if kind == JointKind::Prismatic { 0 } else { 3 };
        let mbs = &mut self.physics.multibody_joints;
        let (Some(a), Some(b)) = (mbs.rigid_body_link(l1.body).copied(), mbs.rigid_body_link(l2.body).copied()) else {
            return Err("a coupled joint is not part of the robot's articulation".into());
        };
        if a.multibody != b.multibody {
            return Err("the two joints are in different articulations".into());
        }
        let mb = mbs.get_multibody_mut(a.multibody).ok_or("the robot's articulation is missing")?;
        mb.add_dof_coupling(MultibodyDofCoupling {
            link1: a.id,
            dof1: 0,
            axis1: axis(l1.joint.kind),
            link2: b.id,
            dof2: 0,
            axis2: axis(l2.joint.kind),
            coeff: p[1] as f32,
            offset: offset as f32,
        });
        Ok(())
    }
}
