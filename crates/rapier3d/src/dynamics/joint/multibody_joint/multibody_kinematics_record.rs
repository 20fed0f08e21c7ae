//! physics-mcp patch 4 (PATCHES.md): a step's opening forward kinematics, skipped when it
//! would change nothing.
//!
//! Every step starts by running each multibody's forward kinematics with the root pose read
//! back from the root's body (`forward_kinematics_for(bodies, true, ..)`), then writing the
//! link poses and world mass properties to the links' bodies
//! (`update_rigid_bodies_internal(bodies, true, false, false)`) — rapier's
//! "TODO: do this only on user-change". When nothing changed since the forward kinematics of
//! the previous step's last substep, that recomputes, from the same inputs and by the same
//! arithmetic, what is already there. This module decides "nothing changed" by comparing,
//! bit for bit, everything that pass reads with what the last pipeline forward kinematics
//! read (a record kept beside the multibody, never serialized):
//!
//! - per link: its body's handle, its parent and first degree of freedom (the topology), its
//!   joint's coordinates, rotation, frames, locked axes and kinematic flag, and its body's
//!   type, locked axes and local mass properties (the centres of mass place the links' shifts;
//!   the masses decide the tree path's eligibility and, with the type, the world mass
//!   properties);
//! - the path (`MultibodyDynamics`) the jacobians were computed for;
//!
//! and by checking that the pass's writes would be no-ops: every link's body already sits at
//! the link's pose (`position` and `next_position`, bit for bit: this catches CCD clamping,
//! the quarantine, and a body moved by the user), the root joint already holds what it would
//! read back from the root's body (free root: its translation coordinates and rotation; fixed
//! root: its first frame; and the root body's dynamic-ness is the multibody's), and no link's
//! body carries a user change of its pose, type, colliders, mass properties or enabled state
//! (a conservative extra: these would show in the comparison anyway).
//!
//! A comparison rather than a "changed by the user" flag, so no mutation path can be missed:
//! whoever changes a joint coordinate, a frame, a mass or a pose — rapier's setters, a
//! `&mut Multibody` from the set, an IK write, a restored or forked world — changes an input
//! the comparison sees. A multibody whose record is empty (new, restructured, deserialized)
//! always runs the pass.

use super::Multibody;
use super::MultibodyLink;
use crate::alloc_prelude::*;
use crate::dynamics::{
    JointAxesMask, LockedAxes, MultibodyDynamics, RigidBody, RigidBodyChanges, RigidBodyHandle,
    RigidBodySet, RigidBodyType,
};
use crate::math::{Pose, Real};

/// The floating-point inputs of one link: coordinates (6), joint rotation (4), the two joint
/// frames (7 each), the body's local centre of mass (3), inverse mass (1), inverse principal
/// inertia (3) and principal inertia frame (4).
const FLOATS: usize = 35;

/// What the last pipeline forward kinematics of a multibody read (see the module doc).
#[derive(Clone, Debug, Default)]
pub(crate) struct KinematicsRecord {
    /// The path its jacobians were computed for; `None`: no valid record.
    dynamics: Option<MultibodyDynamics>,
    links: Vec<LinkInputs>,
}

/// One link's inputs to forward kinematics and to its body's world mass properties.
#[derive(Copy, Clone, Debug, PartialEq)]
struct LinkInputs {
    rigid_body: RigidBodyHandle,
    parent_internal_id: usize,
    assembly_id: usize,
    locked_axes: JointAxesMask,
    kinematic: bool,
    body_type: RigidBodyType,
    body_locked_axes: LockedAxes,
    /// Every floating-point input as its bits (so `-0.0` differs from `0.0`, and a NaN from
    /// another NaN only by payload).
    bits: [u64; FLOATS],
}

#[inline]
fn bits(x: Real) -> u64 {
    u64::from(x.to_bits())
}

#[inline]
fn pose_floats(p: &Pose) -> [Real; 7] {
    let r = p.rotation.to_array();
    let t = p.translation.to_array();
    [r[0], r[1], r[2], r[3], t[0], t[1], t[2]]
}

/// Whether two poses hold the same bits.
#[inline]
fn same_pose(a: &Pose, b: &Pose) -> bool {
    let (a, b) = (pose_floats(a), pose_floats(b));
    a.iter().zip(b.iter()).all(|(x, y)| bits(*x) == bits(*y))
}

impl LinkInputs {
    fn of(link: &MultibodyLink, rb: &RigidBody) -> Self {
        let joint = &link.joint;
        let mp = &rb.mprops.local_mprops;
        let mut out = [0u64; FLOATS];
        let mut k = 0;
        let mut push = |x: Real| {
            out[k] = bits(x);
            k += 1;
        };
        joint.coords.iter().for_each(|x| push(*x));
        joint.joint_rot.to_array().into_iter().for_each(&mut push);
        pose_floats(&joint.data.local_frame1).into_iter().for_each(&mut push);
        pose_floats(&joint.data.local_frame2).into_iter().for_each(&mut push);
        mp.local_com.to_array().into_iter().for_each(&mut push);
        push(mp.inv_mass);
        mp.inv_principal_inertia.to_array().into_iter().for_each(&mut push);
        mp.principal_inertia_local_frame.to_array().into_iter().for_each(&mut push);
        LinkInputs {
            rigid_body: link.rigid_body,
            parent_internal_id: link.parent_internal_id,
            assembly_id: link.assembly_id,
            locked_axes: joint.data.locked_axes,
            kinematic: joint.kinematic,
            body_type: rb.body_type,
            body_locked_axes: rb.mprops.flags,
            bits: out,
        }
    }
}

/// A body's user changes that the opening pass must see (the others — being in the modified
/// set, a wake-up, a dominance change — do not touch what it reads or writes).
fn pass_relevant(changes: RigidBodyChanges) -> bool {
    changes.intersects(
        RigidBodyChanges::POSITION
            | RigidBodyChanges::COLLIDERS
            | RigidBodyChanges::TYPE
            | RigidBodyChanges::LOCAL_MASS_PROPERTIES
            | RigidBodyChanges::ENABLED_OR_DISABLED,
    )
}

impl Multibody {
    /// Remembers what this multibody's forward kinematics under `dynamics` just read, so the
    /// next step's opening pass can tell whether it would recompute the same bits. Called by
    /// the pipeline after its own forward kinematics only (the last substep's and the opening
    /// pass's), never by a public method: a caller holding `&mut Multibody` may change
    /// coordinates after its own forward kinematics.
    pub(crate) fn record_kinematics_inputs(
        &mut self,
        bodies: &RigidBodySet,
        dynamics: MultibodyDynamics,
    ) {
        let record = &mut self.kinematics_record;
        record.dynamics = None;
        record.links.clear();
        for link in self.links.iter() {
            let Some(rb) = bodies.get(link.rigid_body) else {
                record.links.clear();
                return;
            };
            record.links.push(LinkInputs::of(link, rb));
        }
        record.dynamics = Some(dynamics);
    }

    /// Whether the step's opening pass (`forward_kinematics_for(bodies, true, dynamics)`, then
    /// `update_rigid_bodies_internal(bodies, true, false, false)`) would leave this multibody
    /// and its links' bodies exactly as they are (see the module doc for what is compared).
    pub(crate) fn kinematics_unchanged(
        &self,
        bodies: &RigidBodySet,
        dynamics: MultibodyDynamics,
    ) -> bool {
        let record = &self.kinematics_record;
        if record.dynamics != Some(dynamics)
            || record.links.len() != self.links.len()
            || self.links.is_empty()
        {
            return false;
        }

        // What `update_root_type(bodies, true)` would do: nothing when the root body's type
        // still matches and the root joint already holds the body's pose.
        let root = &self.links[0];
        let Some(root_rb) = bodies.get(root.rigid_body) else {
            return false;
        };
        if root_rb.is_dynamic() != self.root_is_dynamic {
            return false;
        }
        let body_pose = &root_rb.pos.position;
        let joint = &root.joint;
        let root_holds_body_pose = if joint.data.locked_axes.is_empty() {
            let t = body_pose.translation.to_array();
            (0..3).all(|i| bits(joint.coords[i]) == bits(t[i]))
                && joint
                    .joint_rot
                    .to_array()
                    .iter()
                    .zip(body_pose.rotation.to_array().iter())
                    .all(|(x, y)| bits(*x) == bits(*y))
        } else {
            same_pose(&joint.data.local_frame1, body_pose)
        };
        if !root_holds_body_pose {
            return false;
        }

        for (link, recorded) in self.links.iter().zip(record.links.iter()) {
            let Some(rb) = bodies.get(link.rigid_body) else {
                return false;
            };
            if pass_relevant(rb.changes)
                || !same_pose(&rb.pos.position, &link.local_to_world)
                || !same_pose(&rb.pos.next_position, &link.local_to_world)
                || LinkInputs::of(link, rb) != *recorded
            {
                return false;
            }
        }
        true
    }

    /// Forgets the record, so the next step's opening pass runs: while the skip is switched off
    /// (`set_skip_unchanged_multibody_kinematics(false)`, so that a record of an older state
    /// cannot be compared with after it is switched back on), and in tests comparing a world with
    /// one whose pass always runs.
    pub(crate) fn forget_kinematics_record(&mut self) {
        self.kinematics_record = KinematicsRecord::default();
    }
}
