//! How a rendered pixel gets its colour (the scene style of `seeing::style`, applied): a sky
//! gradient behind everything, the ground's 1 m checker, a directional light with shadows
//! (a shadow map seen from the light) and an ambient term. Only colours are decided here: what
//! is seen where (depth, segmentation) is the rasteriser's, and nothing here changes it.

use rapier3d::prelude::Vector;

/// Light comes from this (world) direction for a camera looking straight down or up, normalised
/// at use: high, from the +x/+y side.
pub const LIGHT_FROM: [f32; 3] = [0.35, 0.45, 1.0];
/// Share of the colour a face gets however it faces the light: `AMBIENT_DOWN` for faces
/// looking down, `AMBIENT_UP` for faces looking up (a sky above, the ground below).
const AMBIENT_DOWN: f32 = 0.28;
const AMBIENT_UP: f32 = 0.42;
/// Share of the colour the light adds to a face that faces it squarely and is not in shadow.
const DIFFUSE: f32 = 0.62;
/// The checker's dark squares, as a share of the light ones.
const CHECKER_DARK: f32 = 0.80;
/// A face this close to horizontal (its normal's z) and fixed gets the ground's checker.
const UPWARD: f32 = 0.7;
/// Sky colours (linear 0–1): at the horizon, straight up, and below the horizon (nothing there).
const HORIZON: [f32; 3] = [0.88, 0.92, 0.97];
const ZENITH: [f32; 3] = [0.42, 0.60, 0.86];
const BELOW: [f32; 3] = [0.78, 0.79, 0.80];
/// Shadow-map texels along its longer side: the image's longer side, within these (the 2×2
/// filter softens what one texel a pixel would show as steps).
const SHADOW_TEXELS: (usize, usize) = (256, 1024);
/// Objects larger than this (m, any side) neither cast shadows nor bound the shadow map: the
/// ground and walls receive shadows, the map stays sharp around what moves.
pub const CASTER_MAX_SIZE: f32 = 40.0;

/// What the rasteriser leaves at a pixel for shading.
#[derive(Clone, Copy, Default)]
pub struct Surface {
    /// World position of the point seen.
    pub pos: [f32; 3],
    /// Cosine between the face's normal and the light (≤ 0: facing away).
    pub lambert: f32,
    /// The shadow test's bias for this face, in shadow-map texels (`ShadowMap::bias_texels`).
    pub bias_texels: f32,
    /// The face normal's z (−1 down … 1 up).
    pub up: f32,
    /// The object's colour (style::object_rgb) as bytes.
    pub base: [u8; 3],
    /// Whether the face is a fixed body's upward face (drawn with the checker).
    pub checker: bool,
}

/// The key light's turn from the camera's side, seen from above (rad, 30°), and its height
/// above the horizon (rad, 55°): over the camera's shoulder, so the faces a camera sees are lit
/// from whichever side it looks (a fixed light left the faces seen from yaw 0 in shade).
const KEY_TURN: f32 = std::f32::consts::FRAC_PI_6;
const KEY_ELEVATION: f32 = 0.9599;

/// The direction light comes from for a camera with this (column-major, rigid) view matrix,
/// unit length: the key light over the camera's shoulder; `LIGHT_FROM` for a camera looking
/// (nearly) straight down or up, whose side is no direction.
pub fn light(view: &[f32; 16]) -> Vector {
    // The camera's +z axis in world coordinates (the view rotation's third row): towards the eye.
    let (x, y) = (view[2], view[6]);
    let side = (x * x + y * y).sqrt();
    if side.is_nan() || side <= 0.2 {
        return Vector::from_array(LIGHT_FROM).normalize();
    }
    let turn = y.atan2(x) + KEY_TURN;
    let (c, s) = (KEY_ELEVATION.cos(), KEY_ELEVATION.sin());
    Vector::new(turn.cos() * c, turn.sin() * c, s).normalize()
}

/// Whether a face with normal `n` of a body that is `fixed` is ground (gets the checker).
pub fn is_ground_face(fixed: bool, n: Vector) -> bool {
    fixed && n.z > UPWARD
}

/// The colour of a surface point that the light reaches by `lit` (0 in shadow … 1 lit).
pub fn shade(s: &Surface, lit: f32) -> [u8; 3] {
    let ambient = AMBIENT_DOWN + (AMBIENT_UP - AMBIENT_DOWN) * (s.up * 0.5 + 0.5);
    let mut k = ambient + DIFFUSE * s.lambert.max(0.0) * lit;
    if s.checker && (floor(s.pos[0]) + floor(s.pos[1])).rem_euclid(2) == 1 {
        k *= CHECKER_DARK;
    }
    // + 0.5 then truncate: rounding for these non-negative values (`as` saturates at 255).
    s.base.map(|c| (f32::from(c) * k + 0.5) as u8)
}

/// ⌊v⌋ as an integer without a libm call (this runs per pixel; baseline x86-64 has no SSE4.1
/// `roundss`, so `f32::floor` is a function call). NaN gives 0.
fn floor(v: f32) -> i64 {
    // Far beyond any world (and any map): clamped so that sums of two cannot overflow.
    let v = v.clamp(-1e15, 1e15);
    let t = v as i64;
    if (t as f32) > v {
        t - 1
    } else {
        t
    }
}

/// Entries of the sky's table, over the sine of a view ray's elevation from −1 to 1.
const SKY_STEPS: usize = 512;

/// The sky's colours by elevation, computed once (a `powf` per background pixel was a third of
/// a frame's cost).
fn sky_table() -> &'static [[u8; 3]; SKY_STEPS] {
    static TABLE: std::sync::OnceLock<[[u8; 3]; SKY_STEPS]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let e = i as f32 / (SKY_STEPS - 1) as f32 * 2.0 - 1.0;
            let (to, t) = if e >= 0.0 { (ZENITH, e.powf(0.6)) } else { (BELOW, (-e).powf(0.5)) };
            [0, 1, 2].map(|k| ((HORIZON[k] + (to[k] - HORIZON[k]) * t) * 255.0).round() as u8)
        })
    })
}

/// The sky's colour for a view ray going in direction `dir` (any length).
pub fn sky(dir: [f32; 3]) -> [u8; 3] {
    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let e = if n > 0.0 { (dir[2] / n).clamp(-1.0, 1.0) } else { 0.0 };
    sky_table()[((e + 1.0) * 0.5 * (SKY_STEPS - 1) as f32).round() as usize]
}

/// Depths seen from the light, over the region where shadow casters are: orthographic along
/// the light (`light`), each texel holding the height (towards the light) of the nearest caster.
pub struct ShadowMap {
    u: Vector,
    v: Vector,
    l: Vector,
    origin: (f32, f32),
    texel: f32,
    width: usize,
    height: usize,
    top: Vec<f32>,
}

impl ShadowMap {
    /// A map over the given casters' world vertices, sharp enough for an image whose longer
    /// side is `image_side` pixels (None when there are no casters).
    pub fn new(casters: &[(&[Vector], &[[u32; 3]])], l: Vector, image_side: u32) -> Option<ShadowMap> {
        let texels = (image_side as usize).clamp(SHADOW_TEXELS.0, SHADOW_TEXELS.1);
        let u = l.cross(Vector::Z).normalize();
        let v = l.cross(u);
        let (mut u0, mut u1, mut v0, mut v1) = (f32::INFINITY, f32::NEG_INFINITY, f32::INFINITY, f32::NEG_INFINITY);
        for (verts, _) in casters {
            for p in verts.iter() {
                let (a, b) = (p.dot(u), p.dot(v));
                (u0, u1, v0, v1) = (u0.min(a), u1.max(a), v0.min(b), v1.max(b));
            }
        }
        if !(u0.is_finite() && u1.is_finite() && v0.is_finite() && v1.is_finite()) {
            return None;
        }
        let pad = 0.02 * (u1 - u0).max(v1 - v0) + 0.01;
        let (u0, u1, v0, v1) = (u0 - pad, u1 + pad, v0 - pad, v1 + pad);
        let texel = (u1 - u0).max(v1 - v0) / texels as f32;
        let width = (((u1 - u0) / texel).ceil() as usize).clamp(1, texels);
        let height = (((v1 - v0) / texel).ceil() as usize).clamp(1, texels);
        let mut map = ShadowMap { u, v, l, origin: (u0, v0), texel, width, height, top: vec![f32::NEG_INFINITY; width * height] };
        for (verts, tris) in casters {
            let proj: Vec<[f32; 3]> = verts.iter().map(|p| map.texel_of(*p)).collect();
            let center = verts.iter().copied().fold(Vector::ZERO, |a, b| a + b) / verts.len().max(1) as f32;
            for t in tris.iter() {
                let (Some(&a), Some(&b), Some(&c)) = (verts.get(t[0] as usize), verts.get(t[1] as usize), verts.get(t[2] as usize)) else { continue };
                // Convex parts: only the faces towards the light hold the nearest depth.
                let n = (b - a).cross(c - a);
                let outward = if n.dot(a - center) < 0.0 { -n } else { n };
                if outward.dot(l) <= 0.0 {
                    continue;
                }
                map.fill(proj[t[0] as usize], proj[t[1] as usize], proj[t[2] as usize]);
            }
        }
        Some(map)
    }

    /// (column, row, height towards the light) of a world point.
    #[inline]
    fn texel_of(&self, p: Vector) -> [f32; 3] {
        [(p.dot(self.u) - self.origin.0) / self.texel, (p.dot(self.v) - self.origin.1) / self.texel, p.dot(self.l)]
    }

    fn fill(&mut self, a: [f32; 3], b: [f32; 3], c: [f32; 3]) {
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if !area.is_finite() || area.abs() < 1e-12 {
            return;
        }
        let lo = |k: usize| a[k].min(b[k]).min(c[k]).floor().max(0.0) as usize;
        let hi = |k: usize, n: usize| (a[k].max(b[k]).max(c[k]).ceil().max(0.0) as usize).min(n);
        let (x0, x1, y0, y1) = (lo(0), hi(0, self.width), lo(1), hi(1, self.height));
        let inv = 1.0 / area;
        let edge = |p: [f32; 3], q: [f32; 3], x: f32, y: f32| (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0]);
        for y in y0..y1 {
            let cy = y as f32 + 0.5;
            for x in x0..x1 {
                let cx = x as f32 + 0.5;
                let (w0, w1, w2) = (edge(b, c, cx, cy) * inv, edge(c, a, cx, cy) * inv, edge(a, b, cx, cy) * inv);
                // A texel a triangle touches at all counts (a conservative fill keeps thin
                // casters from dropping out between texel centres).
                if w0 < -0.02 || w1 < -0.02 || w2 < -0.02 {
                    continue;
                }
                let h = w0 * a[2] + w1 * b[2] + w2 * c[2];
                let i = y * self.width + x;
                if h > self.top[i] {
                    self.top[i] = h;
                }
            }
        }
    }

    /// The shadow test's bias, in texels, for a face whose normal makes cosine `lambert` with
    /// the light: slope-scaled, since a face lit at a grazing angle needs more not to shadow
    /// itself. Computed once per face.
    pub fn bias_texels(lambert: f32) -> f32 {
        let slope = (1.0 - lambert * lambert).max(0.0).sqrt() / lambert.max(0.05);
        1.5 + 2.0 * slope.min(8.0)
    }

    /// How much light reaches world point `p` on a face with bias `bias_texels`: 0 in shadow …
    /// 1 lit, over the 2×2 texels nearest to it (a softened edge).
    pub fn lit(&self, p: [f32; 3], bias_texels: f32) -> f32 {
        let [x, y, h] = self.texel_of(Vector::from_array(p));
        let h = h + self.texel * bias_texels + 1e-3;
        let (cx, cy) = (floor(x - 0.5), floor(y - 0.5));
        if cx >= 0 && cy >= 0 && ((cx + 1) as usize) < self.width && ((cy + 1) as usize) < self.height {
            // Inside the map (the common case): the two rows' pairs, no bounds to check.
            let i = cy as usize * self.width + cx as usize;
            let (a, b) = (&self.top[i..i + 2], &self.top[i + self.width..i + self.width + 2]);
            let lit = u32::from(a[0] <= h) + u32::from(a[1] <= h) + u32::from(b[0] <= h) + u32::from(b[1] <= h);
            return lit as f32 * 0.25;
        }
        let mut lit = 0u32;
        for (tx, ty) in [(cx, cy), (cx + 1, cy), (cx, cy + 1), (cx + 1, cy + 1)] {
            let outside = tx < 0 || ty < 0 || tx as usize >= self.width || ty as usize >= self.height;
            if outside || self.top[ty as usize * self.width + tx as usize] <= h {
                lit += 1;
            }
        }
        lit as f32 * 0.25
    }
}
