//! The state hash: blake3 over a versioned canonical encoding of everything `apply` changes.
//!
//! Not the solver caches (the snapshot hash covers those), not the simulation id, the gui flag
//! or any seq — so a fork, a load or a restart of the same state hashes the same. The encoding
//! is postcard of plain arrays of f32 (exact bits) in object-id order. Changing what is encoded
//! means bumping `STATE_HASH_VERSION` and re-recording `replays/`.

use serde::Serialize;

use rapier3d::prelude::{RigidBody, RigidBodyHandle};

use super::{DynamicsExtras, Object, ObjectKind, Robot, Viewer, World};

/// Version prefix of the canonical encoding.
pub const STATE_HASH_VERSION: &str = "physics-mcp/state/v1";

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

pub(super) fn state_hash(w: &World) -> String {
    let bodies = w
        .tables
        .objects
        .iter()
        .filter(|(_, obj)| matches!(obj.kind, ObjectKind::Primitive { .. }))
        .filter_map(|(id, obj)| {
            let b = w.physics.bodies.get(obj.body)?;
            let c = w.physics.colliders.get(obj.collider)?;
            Some(BodyView {
                id: *id,
                kind: &obj.kind,
                color: obj.color,
                mass_requested: obj.mass,
                extras: &obj.extras,
                dynamic: dynamic(b),
                friction: c.friction(),
                restitution: c.restitution(),
            })
        })
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
    blake3::hash(&bytes).to_hex().to_string()
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
