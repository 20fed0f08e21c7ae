//! MuJoCo actuators of an MJCF robot, simulated with MuJoCo's meaning (docs/tools.md "MJCF
//! models"): each step, an actuator on a hinge or slide joint applies
//! `gear · clamp(gain · input + bias, forcerange)` to its joint, where `input` is the control
//! (clamped to `ctrlrange`) or, for an integrator (`intvelocity`), the activation, and gain and
//! bias are MuJoCo's affine terms in the actuator length `gear·q` and velocity `gear·q̇`. The
//! control is held until set_actuator_controls changes it, as `data.ctrl` is.
//!
//! Acts above the engine (a joint effort before each step, like a TORQUE_CONTROL motor), so it
//! steps the same way under every engine rule. Only loads recorded with `actuators` build any
//! (event version 7); the table is hashed and snapshotted only when it holds some, so every
//! world without one hashes and snapshots as before.

use std::collections::BTreeMap;

use rapier3d_mjcf::mjcf_rs::extras::{Actuator as MjcfActuator, ActuatorKind};
use rapier3d_mjcf::mjcf_rs::Model;
use serde::{Deserialize, Serialize};

use super::World;
use crate::command::ActuatorControls;
use crate::outputs::ActuatorInfo;
use crate::value::Refusal;

/// MuJoCo's actuator shortcuts, as the file wrote them (what load_mjcf reports).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ActuatorType {
    /// `<motor>`: force = ctrl.
    Motor,
    /// `<position>`: force = kp·(ctrl − q) − kv·q̇.
    Position,
    /// `<velocity>`: force = kv·(ctrl − q̇).
    Velocity,
    /// `<intvelocity>`: an integrator of ctrl, held by a position servo.
    Intvelocity,
    /// `<damper>`: force = −kv·ctrl·q̇.
    Damper,
    /// `<general>`: fixed or affine gain, none or affine bias.
    General,
}

impl ActuatorType {
    /// The MJCF element name.
    pub fn name(self) -> &'static str {
        match self {
            ActuatorType::Motor => "motor",
            ActuatorType::Position => "position",
            ActuatorType::Velocity => "velocity",
            ActuatorType::Intvelocity => "intvelocity",
            ActuatorType::Damper => "damper",
            ActuatorType::General => "general",
        }
    }
}

/// One actuator on one joint of the robot, with MuJoCo's parameters resolved.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Actuator {
    /// Its `name` (`#k` when unnamed, k its index among the model's actuators).
    pub name: String,
    /// The shortcut it was written as.
    pub kind: ActuatorType,
    /// The joint index (PyBullet numbering) it drives.
    pub joint: u32,
    /// `gear[0]`: the transmission's moment arm.
    pub gear: f64,
    /// `ctrlrange` when control-limited.
    pub ctrl_range: Option<[f64; 2]>,
    /// `forcerange` when force-limited.
    pub force_range: Option<[f64; 2]>,
    /// `actrange` when activation-limited (integrators).
    pub act_range: Option<[f64; 2]>,
    /// `gainprm[0..3]` (a fixed gain has the last two 0).
    pub gain: [f64; 3],
    /// `biasprm[0..3]` (no bias: all 0).
    pub bias: [f64; 3],
    /// `dyntype="integrator"`: the input is the activation, whose rate is the control.
    pub integrator: bool,
}

impl Actuator {
    /// MuJoCo's `actuator_force`: gain·input + bias at joint position `q` and velocity `v`,
    /// clamped to `forcerange` (before the gear).
    pub fn force(&self, input: f64, q: f64, v: f64) -> f64 {
        let (len, vel) = (self.gear * q, self.gear * v);
        let gain = self.gain[0] + self.gain[1] * len + self.gain[2] * vel;
        let bias = self.bias[0] + self.bias[1] * len + self.bias[2] * vel;
        let f = gain * input + bias;
        match self.force_range {
            Some([lo, hi]) => f.max(lo).min(hi),
            None => f,
        }
    }

    /// The control as MuJoCo applies it (clamped to `ctrlrange` when limited).
    pub fn clamp_ctrl(&self, u: f64) -> f64 {
        match self.ctrl_range {
            Some([lo, hi]) => u.max(lo).min(hi),
            None => u,
        }
    }
}

/// One robot's actuators and their held state (hashed and snapshotted).
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq, Default)]
pub struct Actuation {
    /// The actuators in MuJoCo's order.
    pub actuators: Vec<Actuator>,
    /// `data.ctrl`: each actuator's control as set (clamped when it acts).
    pub ctrl: Vec<f64>,
    /// `data.act`: each integrator's activation (0 for the others).
    pub act: Vec<f64>,
    /// Whether each actuator drives its joint: the last call driving a joint wins, so a
    /// set_joint_motor_control on it turns this off until the next set_actuator_controls.
    pub driving: Vec<bool>,
}

/// A fixed tendon driven by an actuator (loads of event version 8): MuJoCo's transmission,
/// length `Σ coef·q` and each joint pushed by `coef·gear·force`. Kept beside the actuator
/// (`Tables::transmissions`), whose `joint` is the tendon's first joint.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct Transmission {
    /// The tendon's name.
    pub tendon: String,
    /// Its joints (joint index) and coefficients, in file order.
    pub joints: Vec<(u32, f64)>,
}

/// Resolves a fixed tendon's name to its joints and coefficients, or why it cannot drive.
pub type TendonOf<'a> = &'a dyn Fn(&str) -> Result<Vec<(u32, f64)>, String>;

/// What the parser gives and the actuator table needs, per `<actuator>` child in file order,
/// read from the text (the parser keeps no `actrange`).
#[derive(Clone, Debug, Default)]
pub struct ActuatorExtras {
    /// `actrange` written on the element.
    pub act_range: Option<[f64; 2]>,
    /// `actlimited` written on the element (None: auto).
    pub act_limited: Option<bool>,
}

/// Every `<actuator>` child's extras in file order (includes are already spliced).
pub fn actuator_extras(xml: &str) -> Vec<ActuatorExtras> {
    let Ok(doc) = roxmltree::Document::parse(xml) else { return Vec::new() };
    doc.descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "actuator")
        .flat_map(|block| block.children().filter(|n| n.is_element() && n.tag_name().name() != "include"))
        .map(|n| {
            let range = n.attribute("actrange").and_then(|v| {
                let xs: Vec<f64> = v.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                (xs.len() == 2).then(|| [xs[0], xs[1]])
            });
            let limited = n.attribute("actlimited").and_then(|v| match v {
                "true" => Some(true),
                "false" => Some(false),
                _ => None,
            });
            ActuatorExtras { act_range: range, act_limited: limited }
        })
        .collect()
}

/// Notes for the actuator-related attributes written in `xml` that are not applied (only loads
/// that simulate actuators list them: older loads' `ignored` stays as recorded).
pub fn unapplied_attributes(xml: &str) -> Vec<String> {
    let Ok(doc) = roxmltree::Document::parse(xml) else { return Vec::new() };
    let mut notes: Vec<String> = Vec::new();
    for n in doc.descendants().filter(|n| n.is_element()) {
        for (a, why) in [
            ("dampratio", "position actuators' damping ratio is not applied (kv is)"),
            ("timeconst", "activation time constants are not applied"),
            ("actearly", "activations act on the next step, not early"),
            ("inheritrange", "ranges are not inherited from the joint"),
            ("actuatorfrcrange", "a joint's total actuator force is not clamped"),
        ] {
            let note = format!("{a} (on <{}>): {why}", n.tag_name().name());
            if n.attribute(a).is_some() && !notes.contains(&note) {
                notes.push(note);
            }
        }
    }
    notes
}

/// The model's actuators on our joints (`joint_of`: a joint name → its index; `tendon_of`, for
/// loads of event version 8: fixed tendons as transmissions), a sentence for each one that is
/// not simulated, and the tendon transmissions by actuator slot.
pub fn build(
    model: &Model,
    extras: &[ActuatorExtras],
    joint_of: &dyn Fn(&str) -> Option<u32>,
    tendon_of: Option<TendonOf<'_>>,
) -> (Actuation, Vec<String>, BTreeMap<u32, Transmission>) {
    let autolimits = model.compiler.autolimits;
    let mut out = Actuation::default();
    let mut ignored = Vec::new();
    let mut transmissions = BTreeMap::new();
    for (k, a) in model.actuators.iter().enumerate() {
        let name = a.name.clone().unwrap_or_else(|| format!("#{k}"));
        match resolve(a, extras.get(k), autolimits, joint_of, tendon_of) {
            Ok((act, tendon)) => {
                if let Some(t) = tendon {
                    transmissions.insert(out.actuators.len() as u32, t);
                }
                out.actuators.push(Actuator { name, ..act });
                out.ctrl.push(0.0);
                out.act.push(0.0);
                out.driving.push(true);
            }
            Err(why) => ignored.push(format!("actuator {name}: {why}")),
        }
    }
    (out, ignored, transmissions)
}

/// One parsed actuator → ours, or why it is not simulated.
fn resolve(
    a: &MjcfActuator,
    extras: Option<&ActuatorExtras>,
    autolimits: bool,
    joint_of: &dyn Fn(&str) -> Option<u32>,
    tendon_of: Option<TendonOf<'_>>,
) -> Result<(Actuator, Option<Transmission>), String> {
    let mut tendon = None;
    let joint = match (&a.joint, &a.tendon, &a.site, &a.body) {
        (Some(j), ..) => joint_of(j).ok_or_else(|| format!("joint {j} is not a hinge or slide joint of the model; not simulated"))?,
        (None, Some(t), ..) => match tendon_of {
            Some(of) => {
                let joints = of(t).map_err(|why| format!("{why}; not simulated"))?;
                let first = joints[0].0;
                tendon = Some(Transmission { tendon: t.clone(), joints });
                first
            }
            None => return Err(format!("tendon {t} transmissions are not simulated")),
        },
        (None, None, Some(s), _) => return Err(format!("site {s} transmissions are not simulated")),
        (None, None, None, Some(b)) => return Err(format!("body {b} (adhesion) transmissions are not simulated")),
        _ => return Err("it has no transmission".into()),
    };
    let p = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(0.0);
    let ctrl_limited = a.ctrl_limited.resolve(autolimits, a.ctrl_range.is_some());
    let force_limited = a.force_limited.resolve(autolimits, a.force_range.is_some());
    let act_range = extras.and_then(|e| e.act_range);
    let act_limited = extras.and_then(|e| e.act_limited).unwrap_or(autolimits && act_range.is_some());
    let (kind, gain, bias, integrator) = match a.kind {
        ActuatorKind::Motor => (ActuatorType::Motor, [1.0, 0.0, 0.0], [0.0; 3], false),
        ActuatorKind::Position => {
            let (kp, kv) = (a.kp.unwrap_or(1.0), a.kv.unwrap_or(0.0));
            (ActuatorType::Position, [kp, 0.0, 0.0], [0.0, -kp, -kv], false)
        }
        ActuatorKind::Velocity => {
            let kv = a.kv.unwrap_or(1.0);
            (ActuatorType::Velocity, [kv, 0.0, 0.0], [0.0, 0.0, -kv], false)
        }
        ActuatorKind::IntVelocity => {
            let (kp, kv) = (a.kp.unwrap_or(1.0), a.kv.unwrap_or(0.0));
            (ActuatorType::Intvelocity, [kp, 0.0, 0.0], [0.0, -kp, -kv], true)
        }
        ActuatorKind::Damper => {
            let kv = a.kv.unwrap_or(0.0);
            (ActuatorType::Damper, [0.0, 0.0, -kv], [0.0; 3], false)
        }
        ActuatorKind::General => {
            let gain = match a.gain_type.as_deref().unwrap_or("fixed") {
                "fixed" => [if a.gainprm.is_empty() { 1.0 } else { p(&a.gainprm, 0) }, 0.0, 0.0],
                "affine" => [p(&a.gainprm, 0), p(&a.gainprm, 1), p(&a.gainprm, 2)],
                other => return Err(format!("gaintype {other} is not simulated")),
            };
            let bias = match a.bias_type.as_deref().unwrap_or("none") {
                "none" => [0.0; 3],
                "affine" => [p(&a.biasprm, 0), p(&a.biasprm, 1), p(&a.biasprm, 2)],
                other => return Err(format!("biastype {other} is not simulated")),
            };
            let integrator = match a.dyn_type.as_deref().unwrap_or("none") {
                "none" => false,
                "integrator" => true,
                other => return Err(format!("dyntype {other} is not simulated")),
            };
            (ActuatorType::General, gain, bias, integrator)
        }
        ActuatorKind::Other => return Err("this actuator type (cylinder, muscle, adhesion, plugin) is not simulated".into()),
    };
    let finite = |xs: &[f64]| xs.iter().all(|x| (*x as f32).is_finite());
    let gear = a.gear[0];
    let ctrl_range = a.ctrl_range.filter(|_| ctrl_limited);
    let force_range = a.force_range.filter(|_| force_limited);
    let ranges_ok = [ctrl_range, force_range, act_range.filter(|_| act_limited)].iter().flatten().all(|r| finite(r) && r[0] <= r[1]);
    if !finite(&gain) || !finite(&bias) || !gear.is_finite() || !ranges_ok {
        return Err("its gear, gains or ranges are not finite f32 numbers (a range must be [low, high])".into());
    }
    let actuator = Actuator {
        name: String::new(),
        kind,
        joint,
        gear,
        ctrl_range,
        force_range,
        act_range: act_range.filter(|_| act_limited),
        gain,
        bias,
        integrator,
    };
    Ok((actuator, tendon))
}

/// load_mjcf's compact view of the actuators.
pub fn infos(a: &Actuation) -> Vec<ActuatorInfo> {
    a.actuators
        .iter()
        .map(|x| ActuatorInfo {
            name: x.name.clone(),
            r#type: x.kind.name().to_string(),
            joint_index: x.joint,
            ctrlrange: x.ctrl_range,
            forcerange: x.force_range,
        })
        .collect()
}

impl World {
    /// The actuators of object `id` (None: it has none).
    pub fn actuation(&self, id: u32) -> Option<&Actuation> {
        self.tables.actuation.get(&id)
    }

    /// Checks set_actuator_controls against the robot: it has actuators, the names exist and
    /// a list gives one control per actuator.
    pub fn check_actuator_controls(&self, id: u32, controls: &ActuatorControls) -> Result<(), Refusal> {
        let a = self.actuation(id).ok_or_else(|| format!("object_id {id} has no actuators (only MJCF models loaded with them do)"))?;
        match controls {
            ActuatorControls::InOrder(us) if us.len() != a.actuators.len() => Err(format!(
                "controls has {} values; object {id} has {} actuators (give one per actuator, or an object by name)",
                us.len(),
                a.actuators.len()
            )),
            ActuatorControls::InOrder(_) => Ok(()),
            ActuatorControls::ByName(by) => {
                if by.is_empty() {
                    return Err("controls must name at least one actuator".into());
                }
                match by.keys().find(|n| !a.actuators.iter().any(|x| &x.name == *n)) {
                    Some(n) => {
                        let names: Vec<&str> = a.actuators.iter().map(|x| x.name.as_str()).collect();
                        Err(format!("controls names no actuator {n:?} of object {id}; its actuators are {}", crate::limits::some_names(&names)))
                    }
                    None => Ok(()),
                }
            }
        }
    }

    /// set_actuator_controls: holds the controls, and each actuator set drives its joint again
    /// (the joint's motor of set_joint_motor_control, if any, is removed: the last call wins).
    pub(super) fn set_actuator_controls(&mut self, id: u32, controls: &ActuatorControls) -> String {
        let Some(a) = self.tables.actuation.get_mut(&id) else { return String::new() };
        let set: BTreeMap<usize, f64> = match controls {
            ActuatorControls::InOrder(us) => us.iter().copied().enumerate().collect(),
            ActuatorControls::ByName(by) => by
                .iter()
                .filter_map(|(n, u)| a.actuators.iter().position(|x| &x.name == n).map(|k| (k, *u)))
                .collect(),
        };
        let mut joints = Vec::new();
        for (&k, &u) in &set {
            a.ctrl[k] = u;
            a.driving[k] = true;
            match self.tables.transmissions.get(&(id, k as u32)) {
                Some(t) => joints.extend(t.joints.iter().map(|(j, _)| *j)),
                None => joints.push(a.actuators[k].joint),
            }
        }
        for j in joints {
            self.remove_motor(id, j);
        }
        let shown: Vec<f64> = self.tables.actuation.get(&id).map(|a| a.ctrl.clone()).unwrap_or_default();
        format!("Controls of object {id} set: {shown:?}")
    }

    /// set_joint_motor_control on joint `joint` of `id`: its actuators stop driving it.
    pub(super) fn release_actuators(&mut self, id: u32, joint: u32) {
        let transmissions = &self.tables.transmissions;
        if let Some(a) = self.tables.actuation.get_mut(&id) {
            for (k, x) in a.actuators.iter().enumerate() {
                let via_tendon = transmissions.get(&(id, k as u32)).is_some_and(|t| t.joints.iter().any(|(j, _)| *j == joint));
                if x.joint == joint || via_tendon {
                    a.driving[k] = false;
                }
            }
        }
    }

    /// Before a step: every driving actuator's force on its joint, as a joint effort for this
    /// step (cleared after it, as a TORQUE_CONTROL motor's).
    pub(super) fn drive_actuators(&mut self) {
        if self.tables.actuation.is_empty() {
            return;
        }
        let ids: Vec<u32> = self.tables.actuation.keys().copied().collect();
        for id in ids {
            let Some(base) = self.body_handle(id) else { continue };
            let outputs = self.actuator_outputs(id);
            let (Some(a), Some(robot)) = (self.tables.actuation.get(&id), self.robot(id)) else { continue };
            let mut effort: BTreeMap<u32, f64> = BTreeMap::new();
            for (k, (x, out)) in a.actuators.iter().zip(&outputs).enumerate() {
                let Some((joint, force)) = out else { continue };
                match self.tables.transmissions.get(&(id, k as u32)) {
                    // A tendon pushes each of its joints by coef · gear · force.
                    Some(t) => {
                        for (j, coef) in &t.joints {
                            *effort.entry(*j).or_default() += x.gear * coef * force;
                        }
                    }
                    None => *effort.entry(*joint).or_default() += x.gear * force,
                }
            }
            // An effort beyond f32 (a gear of 1e300) would be ±inf in the engine: none is applied.
            // Only the driven joints are copied out of the model (the step loop runs this).
            let pushes: Vec<_> = effort
                .into_iter()
                .filter(|(_, tau)| (*tau as f32).is_finite())
                .map(|(j, tau)| {
                    let link = &robot.links[j as usize];
                    (link.body, robot.link_body(base, link.joint.parent).unwrap_or(base), link.joint.kind, link.joint.axis, tau as f32)
                })
                .collect();
            for (child, parent, kind, axis, tau) in pushes {
                self.apply_joint_effort(child, parent, kind, axis, tau);
            }
            self.tables.pending_wrench.insert(id);
        }
    }

    /// After a step: each driving integrator's activation advances by its control over the
    /// step (MuJoCo's Euler: `act += dt·ctrl`, then clamped to `actrange`).
    pub(super) fn integrate_activations(&mut self) {
        let dt = self.physics.integration_parameters.dt as f64;
        for a in self.tables.actuation.values_mut() {
            for (k, x) in a.actuators.iter().enumerate() {
                if x.integrator && a.driving[k] {
                    let next = a.act[k] + dt * x.clamp_ctrl(a.ctrl[k]);
                    a.act[k] = match x.act_range {
                        Some([lo, hi]) => next.max(lo).min(hi),
                        None => next,
                    };
                }
            }
        }
    }

    /// MuJoCo's `actuator_force` of each actuator of `id` now (0 for one not driving).
    pub fn actuator_forces(&self, id: u32) -> Vec<f64> {
        self.actuator_outputs(id).into_iter().map(|out| out.map_or(0.0, |(_, force)| force)).collect()
    }

    /// Each actuator of `id`'s joint and MuJoCo's `actuator_force` now (before its gear), None
    /// for one not driving: what the step applies and what the reads report, computed once.
    fn actuator_outputs(&self, id: u32) -> Vec<Option<(u32, f64)>> {
        let (Some(a), Some(robot)) = (self.actuation(id), self.robot(id)) else { return Vec::new() };
        a.actuators
            .iter()
            .enumerate()
            .map(|(k, x)| {
                let link = robot.links.get(x.joint as usize).filter(|_| a.driving[k])?;
                let input = if x.integrator { a.act[k] } else { x.clamp_ctrl(a.ctrl[k]) };
                if let Some(t) = self.tables.transmissions.get(&(id, k as u32)) {
                    // A tendon's length and velocity: Σ coef·q, Σ coef·q̇.
                    let (mut len, mut vel) = (0.0, 0.0);
                    for (j, coef) in &t.joints {
                        let l = robot.links.get(*j as usize)?;
                        let (q, v) = self.joint_coordinates(l.body, l.joint.kind);
                        len += coef * q as f64;
                        vel += coef * v as f64;
                    }
                    return Some((x.joint, x.force(input, len, vel)));
                }
                let (q, v) = self.joint_coordinates(link.body, link.joint.kind);
                Some((x.joint, x.force(input, q as f64, v as f64)))
            })
            .collect()
    }
}
