//! get_camera_image: a small CPU rasteriser (no GPU, no display).
//!
//! Every collider is triangulated (parry's own meshes for balls, cylinders, capsules, boxes
//! and convex hulls), transformed by the caller's view and projection matrices (column-major,
//! OpenGL conventions, as PyBullet's), clipped against the near plane in clip space, and
//! filled with a depth test. Depth is interpolated perspective-correctly and reported in
//! metres along the viewing axis (not Bullet's non-linear [0, 1] buffer). Faces are flat
//! shaded: the object's colour times ambient plus one directional light. Back faces of the
//! (convex) shapes are culled. Segmentation holds the object id per pixel, −1 for background.

use rapier3d::parry::shape::{Shape, TypedShape};
use rapier3d::prelude::Vector;

use super::camera::Mat4;
use super::capture::Scene;
use crate::world::World;

/// Background colour (PyBullet's TinyRenderer clears to white).
const BACKGROUND: [u8; 3] = [255, 255, 255];
/// Colour of objects that were given none.
const DEFAULT_COLOR: [f32; 3] = [0.8, 0.8, 0.8];
/// Light coming from this (world) direction, normalised at use.
const LIGHT_FROM: [f32; 3] = [0.35, 0.45, 1.0];
/// Share of the colour every lit or unlit face gets.
const AMBIENT: f32 = 0.35;

/// What a render produces, row-major from the top-left pixel.
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGB bytes, 3 per pixel.
    pub rgb: Vec<u8>,
    /// Metres along the view axis; `f32::INFINITY` where nothing was drawn.
    pub depth: Vec<f32>,
    /// Object id per pixel, −1 where nothing was drawn.
    pub segmentation: Vec<i64>,
}

impl Frame {
    /// The far plane of a standard perspective matrix (background depth), if it is one.
    pub fn far_plane(proj: &Mat4) -> Option<f64> {
        let far = proj[14] / (proj[10] + 1.0);
        (far.is_finite() && far > 0.0).then_some(far)
    }

    /// The image as PNG bytes.
    pub fn png(&self) -> Result<Vec<u8>, String> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        // fdeflate's PNG-tuned level: several times faster than the default, and flat-shaded
        // renders still compress to a few tens of KB.
        enc.set_compression(png::Compression::Fast);
        let mut writer = enc.write_header().map_err(|e| format!("PNG encoding failed: {e}"))?;
        writer.write_image_data(&self.rgb).map_err(|e| format!("PNG encoding failed: {e}"))?;
        writer.finish().map_err(|e| format!("PNG encoding failed: {e}"))?;
        Ok(out)
    }
}

/// A shape's triangles in its local frame.
fn triangulate(shape: &dyn Shape) -> (Vec<Vector>, Vec<[u32; 3]>) {
    match shape.as_typed_shape() {
        TypedShape::Cuboid(s) => s.to_trimesh(),
        TypedShape::Ball(s) => s.to_trimesh(20, 10),
        TypedShape::Cylinder(s) => s.to_trimesh(24),
        TypedShape::Capsule(s) => s.to_trimesh(20, 6),
        TypedShape::ConvexPolyhedron(s) => s.to_trimesh(),
        TypedShape::TriMesh(s) => (s.vertices().to_vec(), s.indices().to_vec()),
        // Anything else is drawn as its bounding box.
        _ => {
            let aabb = shape.compute_local_aabb();
            let half = (aabb.maxs - aabb.mins) * 0.5;
            let (mut v, i) = rapier3d::parry::shape::Cuboid::new(half).to_trimesh();
            let center = (aabb.maxs + aabb.mins) * 0.5;
            v.iter_mut().for_each(|p| *p += center);
            (v, i)
        }
    }
}

/// A vertex in clip space with its view-axis depth.
#[derive(Clone, Copy)]
struct ClipVertex {
    clip: [f32; 4],
    depth: f32,
}

fn lerp(a: ClipVertex, b: ClipVertex, t: f32) -> ClipVertex {
    let mut clip = [0.0; 4];
    for (k, c) in clip.iter_mut().enumerate() {
        *c = a.clip[k] + (b.clip[k] - a.clip[k]) * t;
    }
    ClipVertex { clip, depth: a.depth + (b.depth - a.depth) * t }
}

/// Sutherland–Hodgman against one plane `f(v) ≥ 0`.
fn clip_polygon(poly: &[ClipVertex], f: impl Fn(&ClipVertex) -> f32) -> Vec<ClipVertex> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (fa, fb) = (f(&a), f(&b));
        if fa >= 0.0 {
            out.push(a);
        }
        if (fa >= 0.0) != (fb >= 0.0) {
            out.push(lerp(a, b, fa / (fa - fb)));
        }
    }
    out
}

fn transform(m: &[f32; 16], p: [f32; 4]) -> [f32; 4] {
    let mut r = [0.0; 4];
    for (row, out) in r.iter_mut().enumerate() {
        *out = m[row] * p[0] + m[4 + row] * p[1] + m[8 + row] * p[2] + m[12 + row] * p[3];
    }
    r
}

fn to_f32(m: &Mat4) -> [f32; 16] {
    let mut out = [0.0; 16];
    for (o, v) in out.iter_mut().zip(m) {
        *o = *v as f32;
    }
    out
}

/// The camera's world position from a view matrix (rigid: eye = −Rᵀ·t).
fn eye_position(view: &[f32; 16]) -> Vector {
    let t = [view[12], view[13], view[14]];
    Vector::new(
        -(view[0] * t[0] + view[1] * t[1] + view[2] * t[2]),
        -(view[4] * t[0] + view[5] * t[1] + view[6] * t[2]),
        -(view[8] * t[0] + view[9] * t[1] + view[10] * t[2]),
    )
}

impl Frame {
    /// Fills one clipped triangle (clip-space vertices) with `color` and `id`.
    fn fill(&mut self, v: [ClipVertex; 3], color: [u8; 3], id: i64) {
        let (w, h) = (self.width as f32, self.height as f32);
        let mut sx = [0.0f32; 3];
        let mut sy = [0.0f32; 3];
        let mut inv_w = [0.0f32; 3];
        let mut zn = [0.0f32; 3];
        for k in 0..3 {
            let c = v[k].clip;
            inv_w[k] = 1.0 / c[3];
            sx[k] = (c[0] * inv_w[k] * 0.5 + 0.5) * w;
            sy[k] = (0.5 - c[1] * inv_w[k] * 0.5) * h;
            zn[k] = c[2] * inv_w[k];
        }
        let area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sy[1] - sy[0]) * (sx[2] - sx[0]);
        if !area.is_finite() || area.abs() < 1e-12 {
            return;
        }
        let x0 = sx.iter().copied().fold(f32::INFINITY, f32::min).floor().max(0.0) as usize;
        let x1 = (sx.iter().copied().fold(f32::NEG_INFINITY, f32::max).ceil().min(w) as usize).min(self.width as usize);
        let y0 = sy.iter().copied().fold(f32::INFINITY, f32::min).floor().max(0.0) as usize;
        let y1 = (sy.iter().copied().fold(f32::NEG_INFINITY, f32::max).ceil().min(h) as usize).min(self.height as usize);
        let inv_area = 1.0 / area;
        let edge = |a: usize, b: usize, px: f32, py: f32| (sx[b] - sx[a]) * (py - sy[a]) - (sy[b] - sy[a]) * (px - sx[a]);
        let stride = self.width as usize;
        for py in y0..y1 {
            let cy = py as f32 + 0.5;
            for px in x0..x1 {
                let cx = px as f32 + 0.5;
                let b0 = edge(1, 2, cx, cy) * inv_area;
                let b1 = edge(2, 0, cx, cy) * inv_area;
                let b2 = edge(0, 1, cx, cy) * inv_area;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let z = b0 * zn[0] + b1 * zn[1] + b2 * zn[2];
                if !(-1.0..=1.0).contains(&z) {
                    continue;
                }
                let q = b0 * inv_w[0] + b1 * inv_w[1] + b2 * inv_w[2];
                let d = (b0 * v[0].depth * inv_w[0] + b1 * v[1].depth * inv_w[1] + b2 * v[2].depth * inv_w[2]) / q;
                let i = py * stride + px;
                if d < self.depth[i] {
                    self.depth[i] = d;
                    self.segmentation[i] = id;
                    self.rgb[3 * i..3 * i + 3].copy_from_slice(&color);
                }
            }
        }
    }

    /// Draws one collider.
    fn draw(&mut self, part: Drawable, view: &[f32; 16], proj: &[f32; 16], eye: Option<Vector>) {
        let (local, tris) = triangulate(part.shape);
        if local.is_empty() {
            return;
        }
        let world: Vec<Vector> = local.iter().map(|p| part.pose.transform_point(*p)).collect();
        let center = world.iter().copied().fold(Vector::ZERO, |a, b| a + b) / world.len() as f32;
        let verts: Vec<ClipVertex> = world
            .iter()
            .map(|p| {
                let e = transform(view, [p.x, p.y, p.z, 1.0]);
                ClipVertex { clip: transform(proj, e), depth: -e[2] }
            })
            .collect();
        let base = part.color.map_or(DEFAULT_COLOR, |c| [c[0], c[1], c[2]]);
        let light = Vector::from_array(LIGHT_FROM).normalize();
        for t in &tris {
            let (Some(&a), Some(&b), Some(&c)) = (world.get(t[0] as usize), world.get(t[1] as usize), world.get(t[2] as usize)) else {
                continue;
            };
            let mut n = (b - a).cross(c - a);
            if n.length_squared() == 0.0 {
                continue;
            }
            n = n.normalize();
            // Convex shapes: the outward normal points away from the centre.
            if n.dot(a - center) < 0.0 {
                n = -n;
            }
            if let Some(eye) = eye {
                if n.dot(a - eye) >= 0.0 {
                    continue;
                }
            }
            let shade = AMBIENT + (1.0 - AMBIENT) * n.dot(light).max(0.0);
            let color = [0, 1, 2].map(|k| (base[k] * shade * 255.0).round().clamp(0.0, 255.0) as u8);
            let poly = [verts[t[0] as usize], verts[t[1] as usize], verts[t[2] as usize]];
            let poly = clip_polygon(&poly, |v| v.clip[2] + v.clip[3]);
            let poly = clip_polygon(&poly, |v| v.clip[3] - 1e-6);
            for k in 1..poly.len().saturating_sub(1) {
                self.fill([poly[0], poly[k], poly[k + 1]], color, i64::from(part.object_id));
            }
        }
    }
}

/// One collider to draw: the fields of `world::scene::Part` and `capture::Posed` the renderer reads.
struct Drawable<'a> {
    object_id: u32,
    shape: &'a dyn Shape,
    pose: rapier3d::prelude::Pose,
    color: Option<[f32; 4]>,
}

/// Renders the world as it is now.
pub fn render(w: &World, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let parts = w.scene().parts.iter();
    render_parts(parts.map(|p| Drawable { object_id: p.object_id, shape: &*p.shape, pose: p.pose, color: p.color }), width, height, view, proj)
}

/// Renders a scene captured earlier (`Scene::capture`), e.g. on another thread while the
/// world it came from moves on. Gives the same pixels as `render` on that world.
pub fn render_scene(s: &Scene, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let parts = s.parts.iter().map(|p| Drawable { object_id: p.object_id, shape: p.shape.as_ref(), pose: p.pose, color: p.color });
    render_parts(parts, width, height, view, proj)
}

fn render_parts<'a>(parts: impl Iterator<Item = Drawable<'a>>, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let n = width as usize * height as usize;
    let mut frame = Frame {
        width,
        height,
        rgb: BACKGROUND.iter().copied().cycle().take(3 * n).collect(),
        depth: vec![f32::INFINITY; n],
        segmentation: vec![-1; n],
    };
    let (view, proj) = (to_f32(view), to_f32(proj));
    // Back faces are culled from the eye's position for perspective projections.
    let eye = (proj[11] == -1.0 && proj[15] == 0.0).then(|| eye_position(&view));
    for part in parts {
        frame.draw(part, &view, &proj, eye);
    }
    frame
}
