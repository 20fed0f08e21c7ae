//! A world's drawable state at one moment, detached from the world so frames can be rendered
//! on other threads while the world moves on (animations, live viewer progress). Built from
//! `World::scene` (the same parts, in the same order), so a captured frame has exactly the
//! pixels `render::render` gives on that world.

use rapier3d::prelude::{Pose, SharedShape};

use crate::world::{Viewer, World};

/// One collider as it was when captured, owning (a shared handle to) its shape.
pub struct Posed {
    /// The object it belongs to.
    pub object_id: u32,
    /// Its link (−1: a primitive or a robot's base): the viewer's inspector names it.
    pub link_index: i64,
    /// Its shape (shared with the world it came from; shapes are never changed in place).
    pub shape: SharedShape,
    /// Its world pose when captured.
    pub pose: Pose,
    /// RGBA from the object or the URDF material, if any.
    pub color: Option<[f32; 4]>,
    /// Whether its body never moves (`world::scene::Part::fixed`).
    pub fixed: bool,
}

/// What the camera would draw of a world at one moment.
pub struct Scene {
    /// Every collider, in `World::scene` order.
    pub parts: Vec<Posed>,
    /// The recorded viewer camera (set_camera) at that moment.
    pub camera: Viewer,
    /// Simulated time (s) at that moment.
    pub time: f64,
    /// Steps since creation at that moment.
    pub steps: u64,
}

impl Scene {
    /// Captures the world as it is now (cheap: poses and shape handles, no meshes).
    pub fn capture(w: &World) -> Scene {
        let parts = w
            .scene()
            .parts
            .iter()
            .map(|p| Posed { object_id: p.object_id, link_index: p.link_index, shape: p.shape.clone(), pose: p.pose, color: p.color, fixed: p.fixed })
            .collect();
        Scene { parts, camera: w.viewer().clone(), time: w.current_time(), steps: w.steps() }
    }
}
