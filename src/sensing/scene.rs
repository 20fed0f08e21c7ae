//! The world as a flat list of posed collision shapes, tagged with the object and link they
//! belong to: what rays hit and what the camera draws.

use rapier3d::parry::partitioning::{Bvh, BvhBuildStrategy};
use rapier3d::prelude::*;

use crate::world::{ObjectKind, World};

/// One collider, where it is now.
pub struct Part<'a> {
    /// The object it belongs to.
    pub object_id: u32,
    /// Its link (−1 = a primitive or a robot's base).
    pub link_index: i64,
    /// The rapier collider (contacts name colliders).
    pub collider: ColliderHandle,
    /// Its shape.
    pub shape: &'a dyn Shape,
    /// Its world pose: the body's current pose times the collider's offset.
    pub pose: Pose,
    /// RGBA from the object or the URDF material, if any.
    pub color: Option<[f32; 4]>,
}

/// Every collider of every object, in object-id then link order.
pub fn parts(w: &World) -> Vec<Part<'_>> {
    let mut out = Vec::new();
    for (id, obj) in &w.tables.objects {
        let mut push = |link_index: i64, colliders: &[ColliderHandle], color: Option<[f32; 4]>| {
            for &h in colliders {
                let Some(c) = w.physics.colliders.get(h) else { continue };
                let body_pose = c
                    .parent()
                    .and_then(|b| w.physics.bodies.get(b))
                    .map_or(*c.position(), |b| *b.position());
                let offset = c.position_wrt_parent().copied().unwrap_or(Pose::IDENTITY);
                out.push(Part {
                    object_id: *id,
                    link_index,
                    collider: h,
                    shape: c.shape(),
                    pose: body_pose * offset,
                    color,
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
        }
    }
    out
}

/// One collider as it was when captured, owning (a shared handle to) its shape.
pub struct Posed {
    /// The object it belongs to.
    pub object_id: u32,
    /// Its shape (shared with the world it came from; shapes are never changed in place).
    pub shape: SharedShape,
    /// Its world pose when captured.
    pub pose: Pose,
    /// RGBA from the object or the URDF material, if any.
    pub color: Option<[f32; 4]>,
}

/// What the camera would draw of a world at one moment, detached from it so frames can be
/// rendered on other threads while the world moves on (animations, viewer progress).
pub struct Scene {
    /// Every collider, in `parts` order.
    pub parts: Vec<Posed>,
    /// The recorded viewer camera (set_camera) at that moment.
    pub camera: crate::world::Viewer,
}

impl Scene {
    /// Captures the world as it is now (cheap: poses and shape handles, no meshes).
    pub fn capture(w: &World) -> Scene {
        let parts = parts(w)
            .into_iter()
            .filter_map(|p| {
                let shape = w.physics.colliders.get(p.collider)?.shared_shape().clone();
                Some(Posed { object_id: p.object_id, shape, pose: p.pose, color: p.color })
            })
            .collect();
        Scene { parts, camera: w.tables.viewer.clone() }
    }
}

/// The parts with a bounding-volume tree over their current bounding boxes (leaf i = part i).
pub struct Indexed<'a> {
    /// The parts.
    pub parts: Vec<Part<'a>>,
    /// Tree over `parts`' world AABBs.
    pub bvh: Bvh,
}

impl<'a> Indexed<'a> {
    /// Indexes the world as it is now.
    pub fn new(w: &'a World) -> Self {
        let parts = parts(w);
        let aabbs: Vec<_> = parts.iter().map(|p| p.shape.compute_aabb(&p.pose)).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
        Self { parts, bvh }
    }
}
