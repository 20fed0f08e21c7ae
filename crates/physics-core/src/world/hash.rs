//! The state hash: blake3 over a versioned canonical encoding of everything `apply` changes.
//!
//! Not the solver caches (the snapshot hash covers those), not the simulation id, the gui flag
//! or any seq — so a fork, a load or a restart of the same state hashes the same. The encoding
//! is postcard of plain arrays of f32 (exact bits) in object-id order.
//!
//! Two definitions exist, and a world keeps the one its chain began with ([`HashRules`]):
//! - **v1** (simulations created before event version 5): one blake3 over the whole encoding,
//!   so every change re-hashes every object;
//! - **v2** (from event version 5): each object's encoding is a leaf of a Merkle tree over
//!   object ids (`hash_tree`), kept between calls; the hash is blake3 over the world-wide
//!   values (gravity, time, counters, viewer, filters, constraints) and the tree's root. A
//!   change that touches one object ([`touched_by`]) costs the same in a world of 100 objects
//!   as in one of 10,000.
//!
//! Changing what is encoded means a new version beside these, never an edit of them.

use std::sync::{Mutex, MutexGuard};

use serde::Serialize;

use rapier3d::prelude::{RigidBody, RigidBodyHandle};

use super::hash_tree::{Digest, Touched, Tree};
use super::{DynamicsExtras, Object, ObjectKind, Robot, Viewer, World};
use crate::command::Command;

/// Version prefix of the v1 canonical encoding.
pub const STATE_HASH_VERSION: &str = "physics-mcp/state/v1";
/// Version prefix of the v2 encoding (the world-wide values and the objects' Merkle root).
pub const STATE_HASH_V2: &str = "physics-mcp/state/v2";

/// Which definition of the state hash a world's chain records (module doc). Kept with the
/// world (snapshot version 6 means v2), inherited by forks and loads, so every recorded hash
/// of every log keeps verifying.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HashRules {
    /// One blake3 over the whole world.
    V1,
    /// The objects' Merkle tree, updated per touched object.
    V2,
}

/// The v2 digests kept between calls (a cache: neither hashed nor snapshotted).
#[derive(Default)]
pub(super) struct Digests(Mutex<Tree>);

impl Digests {
    /// A copy for `World::duplicate` (the batch's working copy keeps the work done).
    pub(super) fn duplicate(&self) -> Digests {
        Digests(Mutex::new(self.lock().clone()))
    }

    /// Notes what an applied command changed.
    pub(super) fn mark(&mut self, touched: Touched) {
        self.0.get_mut().unwrap_or_else(|poisoned| poisoned.into_inner()).mark(touched);
    }

    /// The tree; after a panic mid-update (a bug) it is rebuilt in full rather than trusted.
    fn lock(&self) -> MutexGuard<'_, Tree> {
        self.0.lock().unwrap_or_else(|poisoned| {
            self.0.clear_poison();
            let mut tree = poisoned.into_inner();
            tree.mark(Touched::All);
            tree
        })
    }
}

/// Which objects `cmd` can change, `next_object_id` being the world's before it is applied
/// (an added object gets that id). Only commands that change one object's own state are
/// narrowed; anything else may move any object and re-hashes all of them.
pub(super) fn touched_by(cmd: &Command, next_object_id: u32) -> Touched {
    match cmd {
        Command::AddBody { .. } => Touched::One(next_object_id),
        Command::SetObjectPose { object_id, .. }
        | Command::ApplyForce { object_id, .. }
        | Command::ApplyTorque { object_id, .. }
        | Command::SetObjectVelocity { object_id, .. }
        | Command::ChangeDynamics { object_id, .. }
        | Command::RemoveObject { object_id }
        | Command::SetJointTrajectory { object_id, .. } => Touched::One(*object_id),
        | Command::SetActuatorControls { object_id, .. } => Touched::One(*object_id),
        Command::SetCamera { .. }
        | Command::SetDebugVisualization { .. }
        | Command::SetTimestep { .. }
        | Command::EnableJointForceTorqueSensor { .. } => Touched::Nothing,
        _ => Touched::All,
    }
}

/// The dynamic state of one rapier body, as hashed (shared by primitives and robot links;
/// postcard encodes a nested struct exactly as its fields inline, so primitives hash as before).
#[derive(Serialize)]
struct Dynamic {
    body_type: u8,
    translation: [f32; 3],
    rotation: [f32; 4],
    linvel: [f32; 3],
    angvel: [f32; 3],
    mass: f32,
    local_com: [f32; 3],
    principal_inertia: [f32; 3],
    inertia_frame: [f32; 4],
    linear_damping: f32,
    angular_damping: f32,
    user_force: [f32; 3],
    user_torque: [f32; 3],
}

fn dynamic(b: &RigidBody) -> Dynamic {
    let mp = &b.mass_properties().local_mprops;
    Dynamic {
        body_type: b.body_type() as u8,
        translation: b.translation().to_array(),
        rotation: b.rotation().to_array(),
        linvel: b.linvel().to_array(),
        angvel: b.angvel().to_array(),
        mass: b.mass(),
        local_com: mp.local_com.to_array(),
        principal_inertia: mp.principal_inertia().to_array(),
        inertia_frame: mp.principal_inertia_local_frame.to_array(),
        linear_damping: b.linear_damping(),
        angular_damping: b.angular_damping(),
        user_force: b.user_force().to_array(),
        user_torque: b.user_torque().to_array(),
    }
}

#[derive(Serialize)]
struct BodyView<'a> {
    id: u32,
    kind: &'a ObjectKind,
    color: Option<[f32; 4]>,
    mass_requested: f32,
    extras: &'a DynamicsExtras,
    dynamic: Dynamic,
    friction: f32,
    restitution: f32,
}

#[derive(Serialize)]
struct StateView<'a> {
    version: &'static str,
    gravity: [f32; 3],
    timestep: f32,
    time_s: f64,
    steps: u64,
    next_object_id: u32,
    next_constraint_id: u32,
    pending_wrench: Vec<u32>,
    viewer: &'a Viewer,
    bodies: Vec<BodyView<'a>>,
}

/// The postcard encoding of a hash view. The views are derived `Serialize` types of numbers,
/// strings, options, arrays and collections of known length, which postcard always encodes into
/// a `Vec`; so a failure is a bug in a view type, never bad data, and it stops the call with that
/// reason (the call fails and the simulation is rebuilt from its log) instead of hashing an
/// empty buffer, which would make different states hash alike. Returning a `Result` instead
/// would ripple through every caller of `state_hash` for a case these types cannot produce.
fn encode<T: Serialize + ?Sized>(view: &T) -> Vec<u8> {
    postcard::to_stdvec(view).expect("state-hash views are plain known-length data that postcard always encodes")
}

/// The world's state hash under its rules, v2 from the kept tree.
pub(super) fn state_hash(w: &World) -> String {
    match w.hash_rules {
        HashRules::V1 => state_hash_v1(w),
        HashRules::V2 => state_hash_v2(w, &mut w.digests.lock()),
    }
}

/// The same hash computed without the kept tree: what the incremental one must equal.
pub(super) fn state_hash_from_scratch(w: &World) -> String {
    match w.hash_rules {
        HashRules::V1 => state_hash_v1(w),
        HashRules::V2 => state_hash_v2(w, &mut Tree::default()),
    }
}

/// One object as v2 hashes it: its id, kind and the same views v1 encodes.
#[derive(Serialize)]
enum Leaf<'a> {
    Primitive(BodyView<'a>),
    Robot(RobotView<'a>),
    Mjcf(RobotView<'a>, &'a super::mjcf::MjcfInfo, Option<PartView>),
}

/// The v2 leaf of object `id` (None: no such object, or its body is gone).
fn object_leaf(w: &World, id: u32) -> Option<Digest> {
    let obj = w.tables.objects.get(&id)?;
    let leaf = match &obj.kind {
        ObjectKind::Primitive { .. } => Leaf::Primitive(body_view(w, id, obj)?),
        ObjectKind::Robot { robot } => Leaf::Robot(robot_view(w, id, obj, robot)),
        ObjectKind::Mjcf { robot, mjcf } => {
            let world = mjcf.world_body.and_then(|h| part_view(w, h, &mjcf.world_colliders, [0.0; 2]));
            Leaf::Mjcf(robot_view(w, id, obj, robot), mjcf, world)
        }
    };
    Some(*blake3::hash(&encode(&leaf)).as_bytes())
}

/// The world-wide values v2 hashes beside the objects' root.
#[derive(Serialize)]
struct HeaderV2<'a> {
    version: &'static str,
    gravity: [f32; 3],
    timestep: f32,
    time_s: f64,
    steps: u64,
    next_object_id: u32,
    next_constraint_id: u32,
    pending_wrench: &'a std::collections::BTreeSet<u32>,
    viewer: &'a Viewer,
    filters: &'a super::filters::Filters,
    constraints: Vec<super::constraints::ConstraintView<'a>>,
    objects: Digest,
}

fn state_hash_v2(w: &World, tree: &mut Tree) -> String {
    let objects = tree.root(w.tables.objects.keys().copied(), |id| object_leaf(w, id));
    let header = HeaderV2 {
        version: STATE_HASH_V2,
        gravity: w.physics.gravity.to_array(),
        timestep: w.physics.integration_parameters.dt,
        time_s: w.tables.time_s,
        steps: w.tables.steps,
        next_object_id: w.tables.next_object_id,
        next_constraint_id: w.tables.next_constraint_id,
        pending_wrench: &w.tables.pending_wrench,
        viewer: &w.tables.viewer,
        filters: &w.tables.filters,
        constraints: super::constraints::hash_views(w),
        objects,
    };
    let mut bytes = encode(&header);
    extend_with_sensors(w, &mut bytes);
    blake3::hash(&bytes).to_hex().to_string()
}

/// A primitive's view (None when its body or collider is gone).
fn body_view<'a>(w: &World, id: u32, obj: &'a Object) -> Option<BodyView<'a>> {
    let b = w.physics.bodies.get(obj.body)?;
    let c = w.physics.colliders.get(obj.collider)?;
    Some(BodyView {
        id,
        kind: &obj.kind,
        color: obj.color,
        mass_requested: obj.mass,
        extras: &obj.extras,
        dynamic: dynamic(b),
        friction: c.friction(),
        restitution: c.restitution(),
    })
}

fn state_hash_v1(w: &World) -> String {
    let bodies = w
        .tables
        .objects
        .iter()
        .filter(|(_, obj)| matches!(obj.kind, ObjectKind::Primitive { .. }))
        .filter_map(|(id, obj)| body_view(w, *id, obj))
        .collect();
    let view = StateView {
        version: STATE_HASH_VERSION,
        gravity: w.physics.gravity.to_array(),
        timestep: w.physics.integration_parameters.dt,
        time_s: w.tables.time_s,
        steps: w.tables.steps,
        next_object_id: w.tables.next_object_id,
        next_constraint_id: w.tables.next_constraint_id,
        pending_wrench: w.tables.pending_wrench.iter().copied().collect(),
        viewer: &w.tables.viewer,
        bodies,
    };
    let mut bytes = encode(&view);
    // Robots are appended only when there are some, so worlds of primitives keep the hashes
    // recorded before robots existed.
    let robots: Vec<RobotView> = w
        .tables
        .objects
        .iter()
        .filter_map(|(id, obj)| match &obj.kind {
            ObjectKind::Robot { robot } => Some(robot_view(w, *id, obj, robot)),
            ObjectKind::Primitive { .. } | ObjectKind::Mjcf { .. } => None,
        })
        .collect();
    if !robots.is_empty() {
        bytes.extend(encode(&robots));
    }
    // MJCF robots likewise, behind their own tag (an encoding of their own: no older state
    // has them, so nothing recorded before changes).
    let mjcf: Vec<(RobotView, &super::mjcf::MjcfInfo, Option<PartView>)> = w
        .tables
        .objects
        .iter()
        .filter_map(|(id, obj)| match &obj.kind {
            ObjectKind::Mjcf { robot, mjcf } => {
                let world = mjcf.world_body.and_then(|h| part_view(w, h, &mjcf.world_colliders, [0.0; 2]));
                Some((robot_view(w, *id, obj, robot), &**mjcf, world))
            }
            _ => None,
        })
        .collect();
    if !mjcf.is_empty() {
        bytes.extend(encode(&("mjcf", mjcf)));
    }
    // The collision filters, pairs and markers likewise, only when the agent set any.
    if !w.tables.filters.is_empty() {
        // The first release's filters hash as they did; PyBullet's test adds its flag.
        match w.tables.filters.pybullet_test {
            false => bytes.extend(encode(&("filters", w.tables.filters.v4()))),
            true => bytes.extend(encode(&("filters", &w.tables.filters))),
        }
    }
    // Constraints likewise, behind a tag so they can never read as robots.
    if !w.tables.constraints.is_empty() {
        let views = super::constraints::hash_views(w);
        bytes.extend(encode(&("constraints", views)));
    }
    extend_with_sensors(w, &mut bytes);
    blake3::hash(&bytes).to_hex().to_string()
}

/// The joint force/torque sensors that are on and the joint trajectories followed, each behind
/// its own tag, only when there are some (event versions 6 and 7): every state without one hashes as it always did.
fn extend_with_sensors(w: &World, bytes: &mut Vec<u8>) {
    if !w.tables.joint_sensors.is_empty() {
        bytes.extend(encode(&("joint_sensors", &w.tables.joint_sensors)));
    }
    // Joint trajectories likewise (event version 7), only while one is followed.
    if !w.tables.joint_trajectories.is_empty() {
        bytes.extend(encode(&("joint_trajectories", &w.tables.joint_trajectories)));
    }
    // MJCF actuators and their held controls likewise (event version 7).
    if !w.tables.actuation.is_empty() {
        bytes.extend(encode(&("actuation", &w.tables.actuation)));
    }
    // MJCF sensors likewise (event version 7): what a load kept is part of the model.
    if !w.tables.mjcf_sensors.is_empty() {
        bytes.extend(encode(&("mjcf_sensors", &w.tables.mjcf_sensors)));
    }
    // MJCF tendon transmissions likewise (event version 8).
    if !w.tables.transmissions.is_empty() {
        bytes.extend(encode(&("transmissions", &w.tables.transmissions)));
    }
    // MJCF contact pairs likewise (event version 9).
    if !w.tables.contact_pairs.is_empty() {
        bytes.extend(encode(&("contact_pairs", &w.tables.contact_pairs)));
    }
    // MJCF equality constraints and tendons as listed likewise (event version 9).
    if !w.tables.mjcf_elements.is_empty() {
        bytes.extend(encode(&("mjcf_elements", &w.tables.mjcf_elements)));
    }
}

/// One body of a robot: its dynamic state, materials and parent joint coordinates.
#[derive(Serialize)]
struct PartView {
    dynamic: Dynamic,
    frictions: Vec<[f32; 2]>,
    joint: [f32; 2],
}

#[derive(Serialize)]
struct RobotView<'a> {
    id: u32,
    robot: &'a Robot,
    color: Option<[f32; 4]>,
    mass_requested: f32,
    extras: &'a DynamicsExtras,
    parts: Vec<Option<PartView>>,
}

fn part_view(w: &World, h: RigidBodyHandle, colliders: &[rapier3d::prelude::ColliderHandle], joint: [f32; 2]) -> Option<PartView> {
    let b: &RigidBody = w.physics.bodies.get(h)?;
    Some(PartView {
        dynamic: dynamic(b),
        frictions: colliders
            .iter()
            .filter_map(|c| w.physics.colliders.get(*c))
            .map(|c| [c.friction(), c.restitution()])
            .collect(),
        joint,
    })
}

fn robot_view<'a>(w: &World, id: u32, obj: &'a Object, robot: &'a Robot) -> RobotView<'a> {
    let mut parts = vec![part_view(w, obj.body, &robot.base_colliders, [0.0; 2])];
    for l in &robot.links {
        let (q, v) = w.joint_coordinates(l.body, l.joint.kind);
        parts.push(part_view(w, l.body, &l.colliders, [q, v]));
    }
    RobotView {
        id,
        robot,
        color: obj.color,
        mass_requested: obj.mass,
        extras: &obj.extras,
        parts,
    }
}
