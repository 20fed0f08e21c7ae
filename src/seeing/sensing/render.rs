//! get_camera_image: a small CPU rasteriser (no GPU, no display).
//!
//! Every collider is triangulated (parry's own meshes for balls, cylinders, capsules, boxes
//! and convex hulls), transformed by the caller's view and projection matrices (column-major,
//! OpenGL conventions, as PyBullet's), clipped against the near plane in clip space, and
//! filled with a depth test. Depth is interpolated perspective-correctly and reported in
//! metres along the viewing axis (not Bullet's non-linear [0, 1] buffer). Back faces of the
//! (convex) shapes are culled. Segmentation holds the object id per pixel, −1 for background.
//!
//! Colour is decided after that geometry pass, per pixel (`shading`): the object's colour
//! (`seeing::style`) lit by ambient plus one directional key light over the camera's shoulder
//! with shadows (a shadow map from the light), fixed bodies' upward faces with the ground's 1 m checker, a sky gradient behind.
//! What is seen where — depth and segmentation — is the geometry pass's alone.

use rapier3d::parry::shape::{Shape, TypedShape};
use rapier3d::glamx::DMat4;
use rapier3d::prelude::Vector;

use super::camera::Mat4;
use super::capture::Scene;
use super::shading::{self, ShadowMap, Surface};
use crate::seeing::style;
use crate::world::World;

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

/// A shape's triangles in its local frame (the viewer page and the MCAP export draw meshes
/// from the same, so they show what the pictures show).
pub(crate) fn triangulate(shape: &dyn Shape) -> (Vec<Vector>, Vec<[u32; 3]>) {
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

/// The geometry pass's buffers: what is seen at each pixel and how far, and what shading needs.
struct Raster {
    width: u32,
    height: u32,
    depth: Vec<f32>,
    segmentation: Vec<i64>,
    /// Index into `faces` of the face seen at each pixel (where `segmentation` ≥ 0): 4 bytes a
    /// pixel; the point seen is found again from the pixel's ray and the face's plane.
    face: Vec<u32>,
    faces: Vec<Face>,
}

/// A drawn face: its plane and how it is coloured.
#[derive(Clone, Copy)]
struct Face {
    normal: Vector,
    offset: f32,
    surface: Surface,
}

impl Raster {
    /// Fills one clipped triangle (clip-space vertices) with `face` (its position is filled
    /// in per pixel) and `id`.
    fn fill(&mut self, v: [ClipVertex; 3], face: u32, id: i64) {
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
                    self.face[i] = face;
                }
            }
        }
    }

    /// Draws one collider, given as its world-space triangles.
    fn draw(&mut self, part: &Triangulated, view: &[f32; 16], proj: &[f32; 16], eye: Option<Vector>, light: Vector) {
        let world = &part.world;
        if world.is_empty() {
            return;
        }
        let center = world.iter().copied().fold(Vector::ZERO, |a, b| a + b) / world.len() as f32;
        let verts: Vec<ClipVertex> = world
            .iter()
            .map(|p| {
                let e = transform(view, [p.x, p.y, p.z, 1.0]);
                ClipVertex { clip: transform(proj, e), depth: -e[2] }
            })
            .collect();
        let base = style::object_bytes(part.object_id, part.color);
        for t in &part.tris {
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
            let lambert = n.dot(light);
            let surface = Surface { pos: [0.0; 3], lambert, bias_texels: ShadowMap::bias_texels(lambert), up: n.z, base, checker: shading::is_ground_face(part.fixed, n) };
            let face = self.faces.len() as u32;
            self.faces.push(Face { normal: n, offset: n.dot(a), surface });
            let poly = [verts[t[0] as usize], verts[t[1] as usize], verts[t[2] as usize]];
            let poly = clip_polygon(&poly, |v| v.clip[2] + v.clip[3]);
            let poly = clip_polygon(&poly, |v| v.clip[3] - 1e-6);
            for k in 1..poly.len().saturating_sub(1) {
                self.fill([poly[0], poly[k], poly[k + 1]], face, i64::from(part.object_id));
            }
        }
    }
}

/// One collider's triangles in world space, with what drawing it needs.
struct Triangulated {
    object_id: u32,
    color: Option<[f32; 4]>,
    fixed: bool,
    world: Vec<Vector>,
    tris: Vec<[u32; 3]>,
}

impl Triangulated {
    fn of(part: Drawable) -> Triangulated {
        let (local, tris) = triangulate(part.shape);
        let world = local.iter().map(|p| part.pose.transform_point(*p)).collect();
        Triangulated { object_id: part.object_id, color: part.color, fixed: part.fixed, world, tris }
    }

    /// Whether it casts shadows: anything but the ground and other very large bodies.
    fn casts_shadow(&self) -> bool {
        let (lo, hi) = self.world.iter().fold((Vector::splat(f32::INFINITY), Vector::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        (hi - lo).max_element() <= shading::CASTER_MAX_SIZE
    }
}

/// One collider to draw: the fields of `world::scene::Part` and `capture::Posed` the renderer reads.
struct Drawable<'a> {
    object_id: u32,
    shape: &'a dyn Shape,
    pose: rapier3d::prelude::Pose,
    color: Option<[f32; 4]>,
    fixed: bool,
}

/// Renders the world as it is now.
pub fn render(w: &World, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let parts = w.scene().parts.iter();
    render_parts(parts.map(|p| Drawable { object_id: p.object_id, shape: &*p.shape, pose: p.pose, color: p.color, fixed: p.fixed }), width, height, view, proj)
}

/// Renders a scene captured earlier (`Scene::capture`), e.g. on another thread while the
/// world it came from moves on. Gives the same pixels as `render` on that world.
pub fn render_scene(s: &Scene, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let parts = s.parts.iter().map(|p| Drawable { object_id: p.object_id, shape: p.shape.as_ref(), pose: p.pose, color: p.color, fixed: p.fixed });
    render_parts(parts, width, height, view, proj)
}

fn render_parts<'a>(parts: impl Iterator<Item = Drawable<'a>>, width: u32, height: u32, view: &Mat4, proj: &Mat4) -> Frame {
    let n = width as usize * height as usize;
    let mut raster = Raster { width, height, depth: vec![f32::INFINITY; n], segmentation: vec![-1; n], face: vec![0; n], faces: Vec::new() };
    let (view32, proj32) = (to_f32(view), to_f32(proj));
    // Back faces are culled from the eye's position for perspective projections.
    let eye = (proj32[11] == -1.0 && proj32[15] == 0.0).then(|| eye_position(&view32));
    let light = shading::light(&view32);
    let parts: Vec<Triangulated> = parts.map(Triangulated::of).collect();
    for part in &parts {
        raster.draw(part, &view32, &proj32, eye, light);
    }
    let casters: Vec<(&[Vector], &[[u32; 3]])> = parts.iter().filter(|p| p.casts_shadow()).map(|p| (p.world.as_slice(), p.tris.as_slice())).collect();
    let shadows = ShadowMap::new(&casters, light, width.max(height));
    let rgb = shade_pixels(&raster, shadows.as_ref(), view, proj);
    Frame { width, height, rgb, depth: raster.depth, segmentation: raster.segmentation }
}

/// The colour pass: each seen pixel lit (with shadows when there are casters), the sky
/// behind the rest. The point seen at a pixel is where the pixel's ray meets its face's plane.
fn shade_pixels(r: &Raster, shadows: Option<&ShadowMap>, view: &Mat4, proj: &Mat4) -> Vec<u8> {
    let (w, h) = (r.width as usize, r.height as usize);
    let mut rgb = vec![0u8; 3 * w * h];
    let rays = Rays::new(view, proj);
    for py in 0..h {
        let y = 1.0 - (py as f64 + 0.5) / h as f64 * 2.0;
        let mut row = rays.as_ref().map(|r| r.row(y, w));
        for px in 0..w {
            let i = py * w + px;
            let ray = row.as_mut().map(|r| r.next());
            let c = if r.segmentation[i] >= 0 {
                let face = &r.faces[r.face[i] as usize];
                match ray.and_then(|(near, far)| meet(face, near, far)) {
                    Some(pos) => {
                        let s = Surface { pos, ..face.surface };
                        let lit = match shadows {
                            Some(m) if s.lambert > 0.0 => m.lit(s.pos, s.bias_texels),
                            _ => 1.0,
                        };
                        shading::shade(&s, lit)
                    }
                    // No ray (matrices that do not invert): lit, no checker.
                    None => shading::shade(&Surface { checker: false, ..face.surface }, 1.0),
                }
            } else {
                shading::sky(ray.map_or([0.0, 1.0, 0.0], |(near, far)| (far - near).to_array()))
            };
            rgb[3 * i..3 * i + 3].copy_from_slice(&c);
        }
    }
    rgb
}

/// Where the ray from `near` to `far` meets a face's plane.
fn meet(face: &Face, near: Vector, far: Vector) -> Option<[f32; 3]> {
    let d = far - near;
    let den = face.normal.dot(d);
    if den.abs() < 1e-12 {
        return None;
    }
    let t = (face.offset - face.normal.dot(near)) / den;
    Some((near + d * t).to_array())
}

/// The pixels' view rays in world space, from the inverse of projection × view.
struct Rays {
    inv: [f64; 16],
}

impl Rays {
    /// None when the matrices cannot be inverted.
    fn new(view: &Mat4, proj: &Mat4) -> Option<Rays> {
        let pv = DMat4::from_cols_array(proj) * DMat4::from_cols_array(view);
        let det = pv.determinant();
        let inv = pv.inverse().to_cols_array();
        (det.is_finite() && det != 0.0 && inv.iter().all(|v| v.is_finite())).then_some(Rays { inv })
    }

    /// The rays of one image row at normalised device y, `width` pixels, left to right.
    fn row(&self, y: f64, width: usize) -> RowRays {
        let m = &self.inv;
        let col = |c: usize| [m[4 * c], m[4 * c + 1], m[4 * c + 2], m[4 * c + 3]];
        let (cx, cy, cz, cw) = (col(0), col(1), col(2), col(3));
        let x0 = -1.0 + 1.0 / width as f64;
        let at = |z: f64| [0, 1, 2, 3].map(|k| cx[k] * x0 + cy[k] * y + cz[k] * z + cw[k]);
        let dx = 2.0 / width as f64;
        RowRays { near: at(-1.0), far: at(1.0), step: cx.map(|v| v * dx) }
    }
}

/// The rays of one image row: homogeneous points on the near and far planes, moved by `step`
/// from one pixel to the next (unprojection is linear before the divide).
struct RowRays {
    near: [f64; 4],
    far: [f64; 4],
    step: [f64; 4],
}

impl RowRays {
    /// This pixel's (near, far) points in world space; then moves to the next pixel.
    fn next(&mut self) -> (Vector, Vector) {
        let point = |h: &[f64; 4]| Vector::new((h[0] / h[3]) as f32, (h[1] / h[3]) as f32, (h[2] / h[3]) as f32);
        let out = (point(&self.near), point(&self.far));
        for k in 0..4 {
            self.near[k] += self.step[k];
            self.far[k] += self.step[k];
        }
        out
    }
}
