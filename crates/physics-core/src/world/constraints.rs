//! Constraints between objects (create_constraint / remove_constraint): rapier impulse joints
//! with PyBullet's frame conventions, kept in a table by id so they are saved, hashed, undone
//! and removed like everything else.
//!
//! Frames: the joint frame is `parent_frame_*` in the parent's body frame and `child_frame_*`
//! in the child's (world coordinates when the child is the world); the solver keeps the two in
//! coincidence on the locked axes. The free axis of a prismatic or revolute joint is
//! `joint_axis` in the parent's constraint frame. Both frames are turned by the same rotation
//! that takes x to the axis (rapier frees the frame's x axis), which leaves the locked
//! relation "parent frame = child frame" exactly PyBullet's.

use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

use super::World;
use crate::command::{ConstraintSpec, ConstraintType};
use crate::outputs::ConstraintCreated;
use crate::value::r32s;

/// One constraint of the table: what was asked for and the rapier parts that realise it.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct Constraint {
    /// The constraint as created.
    pub spec: ConstraintSpec,
    /// The rapier impulse joint.
    pub joint: ImpulseJointHandle,
    /// A fixed body standing for the world when the child is −1 (removed with the constraint).
    pub anchor: Option<RigidBodyHandle>,
}

impl Constraint {
    /// The constraint as get_simulation_info and saved files show it.
    pub fn describe(&self, id: u32) -> Value {
        let s = &self.spec;
        json!({
            "constraint_id": id,
            "parent_id": s.parent_id,
            "child_id": s.child_id.map_or(-1, i64::from),
            "joint_type": s.joint_type.name(),
            "joint_axis": r32s(s.joint_axis),
            "parent_frame_position": r32s(s.parent_frame_position),
            "child_frame_position": r32s(s.child_frame_position),
            "parent_frame_orientation": r32s(s.parent_frame_orientation),
            "child_frame_orientation": r32s(s.child_frame_orientation),
        })
    }
}

fn locked_axes(t: ConstraintType) -> JointAxesMask {
    match t {
        ConstraintType::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
        ConstraintType::Prismatic => JointAxesMask::LOCKED_PRISMATIC_AXES,
        ConstraintType::Spherical => JointAxesMask::LOCKED_SPHERICAL_AXES,
        ConstraintType::Revolute => JointAxesMask::LOCKED_REVOLUTE_AXES,
    }
}

fn frame(position: [f32; 3], orientation: [f32; 4], align: Rotation) -> Pose {
    let [x, y, z, w] = orientation;
    Pose::from_parts(Vector::from_array(position), Rotation::from_xyzw(x, y, z, w) * align)
}

/// The rapier joint a spec describes (contacts between the two joined bodies are off, as
/// between a robot's own links).
fn joint(spec: &ConstraintSpec) -> GenericJoint {
    let axis = Vector::from_array(spec.joint_axis);
    let align = if axis.length_squared() > 0.0 {
        Rotation::from_rotation_arc(Vector::X, axis.normalize())
    } else {
        Rotation::IDENTITY
    };
    GenericJointBuilder::new(locked_axes(spec.joint_type))
        .local_frame1(frame(spec.parent_frame_position, spec.parent_frame_orientation, align))
        .local_frame2(frame(spec.child_frame_position, spec.child_frame_orientation, align))
        .contacts_enabled(false)
        .build()
}

impl World {
    /// create_constraint: the spec passed `Command::validate` (both objects exist and differ).
    pub(super) fn insert_constraint(&mut self, spec: &ConstraintSpec) -> ConstraintCreated {
        let id = self.tables.next_constraint_id;
        self.tables.next_constraint_id += 1;
        let parent = self.body_handle(spec.parent_id).unwrap_or_else(RigidBodyHandle::invalid);
        let (child, anchor) = match spec.child_id.and_then(|c| self.body_handle(c)) {
            Some(c) => (c, None),
            None => {
                let h = self.physics.insert_body(RigidBodyBuilder::fixed());
                (h, Some(h))
            }
        };
        let handle = self.physics.insert_impulse_joint(parent, child, joint(spec));
        self.tables.constraints.insert(id, Constraint { spec: spec.clone(), joint: handle, anchor });
        ConstraintCreated {
            landed: None,
            message: format!("Constraint {id} ({}) created", spec.joint_type.name()),
            constraint_id: id,
            joint_type: spec.joint_type.name().to_string(),
        }
    }

    /// remove_constraint (and the constraints of a removed object).
    pub(super) fn remove_constraint(&mut self, id: u32) {
        if let Some(c) = self.tables.constraints.remove(&id) {
            self.physics.remove_impulse_joint(c.joint);
            if let Some(a) = c.anchor {
                self.physics.remove_body(a);
            }
        }
    }

    /// Removes every constraint that touches `object` (before the object itself goes).
    pub(super) fn remove_constraints_of(&mut self, object: u32) {
        let ids: Vec<u32> = self
            .tables
            .constraints
            .iter()
            .filter(|(_, c)| c.spec.parent_id == object || c.spec.child_id == Some(object))
            .map(|(id, _)| *id)
            .collect();
        for id in ids {
            self.remove_constraint(id);
        }
    }

    /// Whether a constraint with this id exists (validation refuses removing an unknown one).
    pub fn has_constraint(&self, id: u32) -> bool {
        self.tables.constraints.contains_key(&id)
    }

    /// Number of constraints (validation enforces the constraint limit before creating one).
    pub fn constraint_count(&self) -> usize {
        self.tables.constraints.len()
    }

    /// Every constraint, described, in id order.
    pub fn constraint_summaries(&self) -> Vec<Value> {
        self.tables.constraints.iter().map(|(id, c)| c.describe(*id)).collect()
    }
}

/// A constraint's spec as the state hash encodes it (f32 bits in the spec, and its id).
#[derive(Serialize)]
pub(super) struct ConstraintView<'a> {
    id: u32,
    spec: &'a ConstraintSpec,
}

/// The constraints in id order, for the state hash.
pub(super) fn hash_views(w: &World) -> Vec<ConstraintView<'_>> {
    w.tables.constraints.iter().map(|(id, c)| ConstraintView { id: *id, spec: &c.spec }).collect()
}
