//! physics-mcp patch 6: the world AABB of a convex polyhedron, bit-identical to parry's
//! `ConvexPolyhedron::compute_aabb` and about two (SSE2) to four (AVX) times cheaper.
//!
//! A collider's AABB is recomputed every step for every moving collider. For a convex hull that
//! is parry's `point_cloud_aabb`: every vertex transformed by the pose (`q * p + t`), then a
//! running component-wise min and max. A robot whose links are hulls of their meshes
//! (pybullet_data's KUKA: 8 hulls of a few hundred vertices each) spent 30% of its step there.
//!
//! Here, on x86_64, the same per-vertex arithmetic runs on four vertices at once in SSE2
//! registers, or eight in AVX ones where the CPU has them (each lane performs exactly the
//! scalar operations glam's scalar-math `Quat * Vec3` performs, in the same order, with no
//! fused multiply-add, so every rotated vertex has the same bits), the translation is added
//! once at the end instead of per vertex, and the lanes' extremes are combined at the end.
//! Why the result is the same, bit for bit:
//! - **Translation once.** Rounding is monotonic: `a ≤ b` implies `fl(a + t) ≤ fl(b + t)`, so
//!   the extreme of `fl(r + t)` over the vertices is `fl(extreme(r) + t)`. The one way two sums
//!   compare equal yet differ in bits is a signed zero, which a sum with `t ≠ ±0` never yields as
//!   `-0` (round to nearest gives `+0` for `x + (-x)`), and `t = ±0` leaves `r` as it is but for
//!   `-0 + +0`, covered by the zero rule below.
//! - **Lanes.** A min over non-NaN floats is one value whichever order it is taken in; values
//!   that compare equal are the same bits except `+0`/`-0`. So whenever an extreme is zero, or
//!   any rotated coordinate is NaN (parry's sequential select lets a NaN reset the running value,
//!   which an order change would not reproduce), the sequential function computes the result.
//!
//! `convex_aabb_tests` checks bit equality against parry's function on random hulls and poses,
//! including zero extremes, a lattice of signed zeros where the lanes alone would pick the
//! other zero, identity poses at the origin and NaN poses, and the two kernels against each
//! other.

use crate::math::{Pose, Vector};
use parry::bounding_volume::Aabb;
use parry::shape::Shape;

/// The fewest vertices transformed side by side (one SSE register of `f32`; AVX does 8).
const LANES: usize = 4;

/// The world AABB of `shape` at `pos`: [`convex_points_aabb`] for a convex polyhedron, parry's
/// own `compute_aabb` for every other shape. The same bits either way.
#[inline]
pub(crate) fn shape_aabb(shape: &dyn Shape, pos: &Pose) -> Aabb {
    match shape.as_convex_polyhedron() {
        Some(hull) => convex_points_aabb(pos, hull.points()),
        None => shape.compute_aabb(pos),
    }
}

/// The AABB of `pts` transformed by `pos`: the same bits as
/// `parry::bounding_volume::details::point_cloud_aabb_ref(pos, pts)` (module doc). On x86_64,
/// AVX (where the CPU has it, detected at run time) does eight vertices at once, else SSE2 (the
/// architecture's baseline) four; both give the same bits. Elsewhere this is parry's function,
/// and so it is without `enhanced-determinism`: only that feature builds glam with
/// `scalar-math`, whose rotation the kernels copy (glam's SIMD rotation, with FMA where the
/// target has it, rounds differently).
pub(crate) fn convex_points_aabb(pos: &Pose, pts: &[Vector]) -> Aabb {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "dim3", feature = "enhanced-determinism"))]
    if pts.len() >= 2 * LANES {
        #[cfg(feature = "std")]
        let avx = std::is_x86_feature_detected!("avx");
        #[cfg(not(feature = "std"))]
        let avx = false;
        let extremes = if avx {
            // SAFETY: AVX was detected above; the slice has at least 8 points.
            unsafe { lanes::rotated_extremes_avx(pos, pts) }
        } else {
            // SAFETY: SSE2 is part of the x86_64 baseline; the slice has at least 8 points.
            unsafe { lanes::rotated_extremes_sse2(pos, pts) }
        };
        if let Some((lo, hi)) = extremes {
            let t = pos.translation;
            return Aabb::new(
                Vector::new(lo[0] + t.x, lo[1] + t.y, lo[2] + t.z),
                Vector::new(hi[0] + t.x, hi[1] + t.y, hi[2] + t.z),
            );
        }
    }
    parry::bounding_volume::details::point_cloud_aabb_ref(pos, pts)
}

/// The lane kernels of [`convex_points_aabb`]: one body, instantiated for SSE2 (4 lanes) and
/// AVX (8 lanes; its 128-bit instructions are SSE's, VEX-encoded, the same operations).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "dim3", feature = "enhanced-determinism"))]
mod lanes {
    use crate::math::{Pose, Real, Vector};
    use core::arch::x86_64::*;

    // The loads below read a `Vector` as three packed `f32`s.
    const _: () = assert!(core::mem::size_of::<Vector>() == 3 * core::mem::size_of::<f32>());

    /// `_MM_SHUFFLE(d, c, b, a)`: lanes `[x[a], x[b], y[c], y[d]]` of `_mm_shuffle_ps(x, y, ·)`.
    const fn pick(a: i32, b: i32, c: i32, d: i32) -> i32 {
        (d << 6) | (c << 4) | (b << 2) | a
    }

    /// Four consecutive `Vector`s from `pts[start..]` (12-byte `#[repr(C)]` x, y, z) as three
    /// loads, transposed into x, y and z registers: a = [x0 y0 z0 x1], b = [y1 z1 x2 y2],
    /// c = [z2 x3 y3 z3].
    #[inline(always)]
    fn four(pts: &[Vector], start: usize) -> (__m128, __m128, __m128) {
        let p = pts[start..start + 4].as_ptr() as *const f32;
        // SAFETY: the slice above holds 4 × 3 = 12 `f32`s from `p`; unaligned loads (SSE2,
        // the x86_64 baseline).
        unsafe {
            let (a, b, c) = (_mm_loadu_ps(p), _mm_loadu_ps(p.add(4)), _mm_loadu_ps(p.add(8)));
            let x = _mm_shuffle_ps::<{ pick(0, 3, 0, 2) }>(a, _mm_shuffle_ps::<{ pick(2, 0, 1, 0) }>(b, c));
            let y = _mm_shuffle_ps::<{ pick(0, 2, 0, 2) }>(
                _mm_shuffle_ps::<{ pick(1, 1, 0, 0) }>(a, b),
                _mm_shuffle_ps::<{ pick(3, 3, 2, 2) }>(b, c),
            );
            let z = _mm_shuffle_ps::<{ pick(0, 2, 0, 2) }>(
                _mm_shuffle_ps::<{ pick(2, 2, 1, 1) }>(a, b),
                _mm_shuffle_ps::<{ pick(0, 0, 3, 3) }>(c, c),
            );
            (x, y, z)
        }
    }

    /// Eight consecutive `Vector`s as x, y and z registers (two [`four`]s side by side).
    #[target_feature(enable = "avx")]
    fn eight(pts: &[Vector], start: usize) -> (__m256, __m256, __m256) {
        let ((x0, y0, z0), (x1, y1, z1)) = (four(pts, start), four(pts, start + 4));
        let join = |lo: __m128, hi: __m128| _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(lo), hi);
        (join(x0, x1), join(y0, y1), join(z0, z1))
    }

    /// One kernel per instruction set: `$name` over `$n` lanes of `$v`, loading with `$load`.
    macro_rules! kernel {
        ($name:ident, $feature:literal, $v:ty, $n:literal, $load:ident, $set1:ident, $add:ident,
         $sub:ident, $mul:ident, $min:ident, $max:ident, $store:ident) => {
            /// The component-wise minimum and maximum, over `pts`, of each vertex rotated by
            /// `pos`'s rotation exactly as glam's scalar `Quat::mul_vec3` rotates it:
            /// rhs·(w² − b·b) + b·(2 (rhs·b)) + (b × rhs)·2w, term by term in the same order.
            /// None when an extreme is zero or a rotated coordinate NaN: the caller then
            /// computes sequentially (module doc). Needs its instruction set and
            /// `pts.len() >=` its lane count.
            #[target_feature(enable = $feature)]
            pub(super) fn $name(pos: &Pose, pts: &[Vector]) -> Option<([Real; 3], [Real; 3])> {
                assert!(pts.len() >= $n);
                let q = pos.rotation;
                let (w, bx, by, bz) = (q.w, q.x, q.y, q.z);
                let b2 = (bx * bx) + (by * by) + (bz * bz);
                let (s, w2) = ($set1(w * w - b2), $set1(w * 2.0));
                let (bx, by, bz) = ($set1(bx), $set1(by), $set1(bz));
                let (two, zero) = ($set1(2.0), $set1(0.0));
                let mut min = [$set1(Real::INFINITY); 3];
                let mut max = [$set1(Real::NEG_INFINITY); 3];
                let mut nan = zero;
                let mut fold = |(x, y, z): ($v, $v, $v)| {
                    let d2 = $mul($add($add($mul(x, bx), $mul(y, by)), $mul(z, bz)), two);
                    let r = [
                        $add($add($mul(x, s), $mul(bx, d2)), $mul($sub($mul(by, z), $mul(y, bz)), w2)),
                        $add($add($mul(y, s), $mul(by, d2)), $mul($sub($mul(bz, x), $mul(z, bx)), w2)),
                        $add($add($mul(z, s), $mul(bz, d2)), $mul($sub($mul(bx, y), $mul(x, by)), w2)),
                    ];
                    nan = $add(nan, $mul($add($add(r[0], r[1]), r[2]), zero));
                    for k in 0..3 {
                        // `min(m, r)` is `if m < r { m } else { r }` per lane: glam's `Vec3::min`.
                        min[k] = $min(min[k], r[k]);
                        max[k] = $max(max[k], r[k]);
                    }
                };
                let full = pts.len() / $n * $n;
                for start in (0..full).step_by($n) {
                    fold($load(pts, start));
                }
                if full < pts.len() {
                    // The last lanes' worth again: a vertex seen twice changes no extreme.
                    fold($load(pts, pts.len() - $n));
                }
                let lanes = |v: $v| {
                    let mut out = [0.0 as Real; $n];
                    // SAFETY: `out` holds exactly one register's lanes; an unaligned store.
                    unsafe { $store(out.as_mut_ptr(), v) };
                    out
                };
                if lanes(nan).iter().any(|x| *x != 0.0) {
                    return None;
                }
                let (mut lo, mut hi) = ([0.0 as Real; 3], [0.0 as Real; 3]);
                for k in 0..3 {
                    let a = lanes(min[k]).iter().fold(Real::INFINITY, |m, x| if m < *x { m } else { *x });
                    let b = lanes(max[k]).iter().fold(Real::NEG_INFINITY, |m, x| if m > *x { m } else { *x });
                    if a == 0.0 || b == 0.0 {
                        return None;
                    }
                    (lo[k], hi[k]) = (a, b);
                }
                Some((lo, hi))
            }
        };
    }

    kernel!(rotated_extremes_sse2, "sse2", __m128, 4, four, _mm_set1_ps, _mm_add_ps, _mm_sub_ps, _mm_mul_ps, _mm_min_ps, _mm_max_ps, _mm_storeu_ps);
    kernel!(rotated_extremes_avx, "avx", __m256, 8, eight, _mm256_set1_ps, _mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_min_ps, _mm256_max_ps, _mm256_storeu_ps);
}

#[cfg(all(test, feature = "dim3"))]
#[path = "convex_aabb_tests.rs"]
mod convex_aabb_tests;
