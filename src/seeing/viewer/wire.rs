//! What the browser viewer is sent (docs/tools.md "Visualization"): a scene once per change —
//! each collider's shape, colour and object — and then only poses, seven f32 per collider in
//! base64, so a frame costs bytes, not server rendering. Both are read off a captured `Scene`
//! (the present world, a running step's published moment or a re-simulated past state alike),
//! so the page draws exactly what the camera tools would.
//!
//! A scene's `key` names its contents (objects, links, shapes, colours): the page rebuilds its
//! meshes only when a frame carries a key it has not seen.

use base64::Engine;
use rapier3d::parry::shape::TypedShape;
use serde::Serialize;

use crate::seeing::sensing::capture::{Posed, Scene};
use crate::seeing::sensing::render::triangulate;
use crate::seeing::style::object_rgba;
use crate::value::{r32, r32s};

/// A collider's shape as the page builds it: primitives by their sizes (three.js draws them
/// smooth), anything else as the triangles the CPU renderer draws (the world makes no
/// half-spaces: MJCF planes are boxes, `world::mjcf`).
#[derive(Serialize, Debug, Clone, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ShapeJson {
    /// A box by its half extents (m).
    Box {
        /// Half extents x, y, z.
        half: [f64; 3],
    },
    /// A sphere.
    Sphere {
        /// Radius (m).
        r: f64,
    },
    /// A cylinder along its local y axis (rapier's convention).
    Cylinder {
        /// Half height (m).
        hh: f64,
        /// Radius (m).
        r: f64,
    },
    /// A capsule: the segment a–b swept by radius r.
    Capsule {
        /// Segment start (local).
        a: [f64; 3],
        /// Segment end (local).
        b: [f64; 3],
        /// Radius (m).
        r: f64,
    },
    /// Triangles: vertices as little-endian f32 x, y, z and indices as little-endian u32, each
    /// base64.
    Mesh {
        /// Vertices, base64 of f32 LE.
        v: String,
        /// Triangle indices, base64 of u32 LE.
        i: String,
    },
}

/// One collider of the scene.
#[derive(Serialize, Debug, Clone)]
pub struct PartJson {
    /// The object.
    pub object_id: u32,
    /// Its link (−1: a primitive or a robot's base).
    pub link_index: i64,
    /// RGBA as the pictures draw it (the object's own colour, else its palette colour).
    pub color: [f64; 4],
    /// Whether it never moves (ground, fixed furniture).
    pub fixed: bool,
    /// Its shape.
    pub shape: ShapeJson,
}

/// A scene: what the page builds meshes from.
#[derive(Serialize, Debug, Clone)]
pub struct SceneJson {
    /// Names these contents; frames carry it.
    pub key: String,
    /// Every collider, in the order frames list their poses.
    pub parts: Vec<PartJson>,
}

fn b64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// A shape as the page builds it.
fn shape_json(p: &Posed) -> ShapeJson {
    match p.shape.as_typed_shape() {
        TypedShape::Cuboid(s) => ShapeJson::Box { half: r32s(s.half_extents.to_array()) },
        TypedShape::Ball(s) => ShapeJson::Sphere { r: r32(s.radius) },
        TypedShape::Cylinder(s) => ShapeJson::Cylinder { hh: r32(s.half_height), r: r32(s.radius) },
        TypedShape::Capsule(s) => ShapeJson::Capsule { a: r32s(s.segment.a.to_array()), b: r32s(s.segment.b.to_array()), r: r32(s.radius) },
        _ => {
            let (vertices, triangles) = triangulate(&*p.shape);
            let v: Vec<u8> = vertices.iter().flat_map(|p| p.to_array()).flat_map(f32::to_le_bytes).collect();
            let i: Vec<u8> = triangles.iter().flatten().flat_map(|i| i.to_le_bytes()).collect();
            ShapeJson::Mesh { v: b64(&v), i: b64(&i) }
        }
    }
}

/// What names a part's contents in the key, cheaply: its object, link, colour, fixedness and
/// shape — by size for primitives, by counts and bounds for meshes (whose triangles are sent
/// only when the key is new).
fn signature(p: &Posed, h: &mut blake3::Hasher) {
    h.update(&p.object_id.to_le_bytes());
    h.update(&p.link_index.to_le_bytes());
    h.update(&[u8::from(p.fixed)]);
    for c in object_rgba(p.object_id, p.color) {
        h.update(&c.to_le_bytes());
    }
    let shape = &*p.shape;
    h.update(&(shape.shape_type() as u32).to_le_bytes());
    let aabb = shape.compute_local_aabb();
    for v in aabb.mins.to_array().into_iter().chain(aabb.maxs.to_array()) {
        h.update(&v.to_le_bytes());
    }
    match shape.as_typed_shape() {
        TypedShape::TriMesh(m) => {
            h.update(&(m.vertices().len() as u64).to_le_bytes());
            h.update(&(m.indices().len() as u64).to_le_bytes());
        }
        TypedShape::ConvexPolyhedron(m) => {
            h.update(&(m.points().len() as u64).to_le_bytes());
        }
        TypedShape::Capsule(c) => {
            for v in c.segment.a.to_array().into_iter().chain(c.segment.b.to_array()) {
                h.update(&v.to_le_bytes());
            }
        }
        _ => {}
    }
}

/// The key of a captured scene's contents (16 hex digits).
pub fn key(s: &Scene) -> String {
    let mut h = blake3::Hasher::new();
    h.update(&(s.parts.len() as u64).to_le_bytes());
    for p in &s.parts {
        signature(p, &mut h);
    }
    h.finalize().to_hex()[..16].to_string()
}

/// The scene the page builds meshes from.
pub fn scene(s: &Scene) -> SceneJson {
    let parts = s
        .parts
        .iter()
        .map(|p| {
            let [r, g, b, a] = object_rgba(p.object_id, p.color);
            PartJson {
                object_id: p.object_id,
                link_index: p.link_index,
                color: [r32(r), r32(g), r32(b), r32(a)],
                fixed: p.fixed,
                shape: shape_json(p),
            }
        })
        .collect();
    SceneJson { key: key(s), parts }
}

/// Every part's world pose, x y z qx qy qz qw as little-endian f32, base64: 28 bytes a part.
pub fn poses(s: &Scene) -> String {
    let mut out = Vec::with_capacity(s.parts.len() * 28);
    for p in &s.parts {
        for v in p.pose.translation.to_array().into_iter().chain(p.pose.rotation.to_array()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    b64(&out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::{Command, Shape};
    use crate::world::World;

    fn world_with(shape: Shape, color: Option<[f32; 4]>) -> World {
        let create = Command::CreateSimulation { simulation_id: "s".into(), gravity: [0.0, 0.0, -9.81], gui: false, name: None, engine_rule: Some(crate::engine::ENGINE_RULE) };
        let (mut w, _) = World::create(&create).unwrap();
        let add = Command::AddBody { shape, position: [0.0, 0.0, 1.0], orientation: [0.0, 0.0, 0.0, 1.0], mass: 1.0, color, collides: true };
        w.apply(&add, &mut |_| true);
        w
    }

    #[test]
    fn poses_are_seven_floats_a_part() {
        let w = world_with(Shape::Box { half_extents: [0.1, 0.2, 0.3] }, None);
        let s = Scene::capture(&w);
        let bytes = base64::engine::general_purpose::STANDARD.decode(poses(&s)).unwrap();
        assert_eq!(bytes.len(), 28);
        let z = f32::from_le_bytes(bytes[8..12].try_into().unwrap());
        assert_eq!(z, 1.0);
        let json = scene(&s);
        assert_eq!(json.parts[0].shape, ShapeJson::Box { half: [0.1, 0.2, 0.3] });
    }

    #[test]
    fn the_key_follows_contents_not_poses() {
        let mut w = world_with(Shape::Sphere { radius: 0.5 }, Some([1.0, 0.0, 0.0, 1.0]));
        let before = key(&Scene::capture(&w));
        w.apply(&Command::step(10), &mut |_| true);
        assert_eq!(key(&Scene::capture(&w)), before, "moving changes no key");
        let other = world_with(Shape::Sphere { radius: 0.5 }, Some([0.0, 1.0, 0.0, 1.0]));
        assert_ne!(key(&Scene::capture(&other)), before, "a colour is part of the key");
        let bigger = world_with(Shape::Sphere { radius: 0.6 }, Some([1.0, 0.0, 0.0, 1.0]));
        assert_ne!(key(&Scene::capture(&bigger)), before, "a size is part of the key");
    }
}
