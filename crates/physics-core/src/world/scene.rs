//! The world as a flat list of posed collision shapes, tagged with the object and link they
//! belong to, with a bounding-volume tree over them: what rays hit and what the camera draws.
//!
//! Built from the bodies' *current* poses (a set_object_pose is seen at once, as PyBullet's
//! rayTest sees a reset pose), not from rapier's broad-phase tree: that one is brought up to
//! date only by a step, from the poses before the solver moved the bodies, so it is stale
//! after any step or pose change. Building this index is most of a single ray's cost, so
//! `World::scene` builds it at most once per state (see there).

use rapier3d::parry::partitioning::{Bvh, BvhBuildStrategy};
use rapier3d::prelude::*;

use super::{ObjectKind, World};

/// One collider, where it is now.
pub struct Part {
    /// The object it belongs to.
    pub object_id: u32,
    /// Its link (−1 = a primitive or a robot's base).
    pub link_index: i64,
    /// The rapier collider (contacts name colliders).
    pub collider: ColliderHandle,
    /// Its shape (shared with the collider: the index owns no borrow of the world).
    pub shape: SharedShape,
    /// Its world pose: the body's current pose times the collider's offset.
    pub pose: Pose,
    /// RGBA from the object or the URDF material, if any.
    pub color: Option<[f32; 4]>,
    /// Whether its body never moves (static, or a collider with no body): ground planes and
    /// fixed furniture, which pictures draw with the ground's checker and leave out of framing.
    pub fixed: bool,
}

/// Every collider of every object, in object-id then link order, with a tree over their
/// current world bounding boxes (leaf i = part i).
pub struct Scene {
    /// The parts, in object-id then link order.
    pub parts: Vec<Part>,
    /// Tree over `parts`' world AABBs.
    pub bvh: Bvh,
}

impl Scene {
    /// Indexes the world as it is now. Readers use `World::scene`, which keeps one per state;
    /// a fresh one is for measuring what that saves (the sensing bench).
    pub fn new(w: &World) -> Self {
        let parts = parts(w);
        let aabbs: Vec<_> = parts.iter().map(|p| p.shape.compute_aabb(&p.pose)).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
        Self { parts, bvh }
    }
}

/// Every collider of every object, in object-id then link order.
fn parts(w: &World) -> Vec<Part> {
    let mut out = Vec::new();
    for (id, obj) in &w.tables.objects {
        let mut push = |link_index: i64, colliders: &[ColliderHandle], color: Option<[f32; 4]>| {
            for &h in colliders {
                let Some(c) = w.physics.colliders.get(h) else { continue };
                let body = c.parent().and_then(|b| w.physics.bodies.get(b));
                let body_pose = body.map_or(*c.position(), |b| *b.position());
                let fixed = body.is_none_or(|b| b.is_fixed());
                let offset = c.position_wrt_parent().copied().unwrap_or(Pose::IDENTITY);
                out.push(Part {
                    object_id: *id,
                    link_index,
                    collider: h,
                    shape: c.shared_shape().clone(),
                    pose: body_pose * offset,
                    color,
                    fixed,
                });
            }
        };
        match &obj.kind {
            ObjectKind::Primitive { .. } => push(-1, &[obj.collider], obj.color),
            ObjectKind::Robot { robot } => {
                push(-1, &robot.base_colliders, obj.color);
                for (i, l) in robot.links.iter().enumerate() {
                    push(i as i64, &l.colliders, l.color.or(obj.color));
                }
            }
            ObjectKind::Mjcf { robot, mjcf } => {
                push(-1, &robot.base_colliders, obj.color);
                push(-1, &mjcf.world_colliders, obj.color);
                for (i, l) in robot.links.iter().enumerate() {
                    push(i as i64, &l.colliders, l.color.or(obj.color));
                }
            }
        }
    }
    out
}
