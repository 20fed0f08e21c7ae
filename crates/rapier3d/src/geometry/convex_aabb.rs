//! physics-mcp patch 6: the world AABB of a convex polyhedron, bit-identical to parry's
//! `ConvexPolyhedron::compute_aabb` and about four times cheaper.
//!
//! A collider's AABB is recomputed every step for every moving collider. For a convex hull that
//! is parry's `point_cloud_aabb`: every vertex transformed by the pose (`q * p + t`), then a
//! running component-wise min and max. A robot whose links are hulls of their meshes (pybullet_data's
//! KUKA: 8 hulls of a few hundred vertices each) spent 30% of its step there.
//!
//! Here, on x86_64, the same per-vertex arithmetic runs on [`LANES`] vertices at once in SSE2
//! registers (each lane performs exactly the scalar operations glam's scalar-math `Quat * Vec3`
//! performs, in the same order, with no fused multiply-add, so every rotated vertex has the same
//! bits), the translation is added once at the end instead of per vertex, and the lanes'
//! extremes are combined at the end. Why the result is the same, bit for bit:
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
//! including zero extremes, identity poses at the origin and NaN poses.

use crate::math::{Pose, Vector};
use parry::bounding_volume::Aabb;
use parry::shape::Shape;

/// How many vertices are transformed side by side (one SSE register of `f32`).
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
/// `parry::bounding_volume::details::point_cloud_aabb_ref(pos, pts)` (module doc). SSE2 (every
/// x86_64 CPU has it) does four vertices at once; elsewhere this is parry's function.
pub(crate) fn convex_points_aabb(pos: &Pose, pts: &[Vector]) -> Aabb {
    let sequential = || parry::bounding_volume::details::point_cloud_aabb_ref(pos, pts);
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "dim3"))]
    if pts.len() >= 2 * LANES {
        // SAFETY: the kernel's only requirement is SSE2, part of the x86_64 baseline.
        if let Some((lo, hi)) = unsafe { sse2::rotated_extremes(pos, pts) } {
            let t = pos.translation;
            return Aabb::new(
                Vector::new(lo[0] + t.x, lo[1] + t.y, lo[2] + t.z),
                Vector::new(hi[0] + t.x, hi[1] + t.y, hi[2] + t.z),
            );
        }
    }
    sequential()
}

/// The four-lane kernel of [`convex_points_aabb`].
#[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "dim3"))]
mod sse2 {
    use super::LANES;
    use crate::math::{Pose, Real, Vector};
    use core::arch::x86_64::*;

    // The loads below read a `Vector` as three packed `f32`s.
    const _: () = assert!(core::mem::size_of::<Vector>() == 3 * core::mem::size_of::<f32>());

    /// `_MM_SHUFFLE(d, c, b, a)`: lanes `[x[a], x[b], y[c], y[d]]` of `_mm_shuffle_ps(x, y, ·)`.
    const fn pick(a: i32, b: i32, c: i32, d: i32) -> i32 {
        (d << 6) | (c << 4) | (b << 2) | a
    }

    /// The component-wise minimum and maximum, over `pts`, of each vertex rotated by `pos`'s
    /// rotation exactly as glam's scalar `Quat::mul_vec3` rotates it: rhs·(w² − b·b) +
    /// b·(2 (rhs·b)) + (b × rhs)·2w, term by term in the same order. None when an extreme is
    /// zero or a rotated coordinate NaN: the caller then computes sequentially (module doc).
    /// Needs SSE2 (part of the x86_64 baseline) and `pts.len() >= LANES` (the caller asks for
    /// `2 * LANES`).
    #[target_feature(enable = "sse2")]
    pub(super) fn rotated_extremes(pos: &Pose, pts: &[Vector]) -> Option<([Real; 3], [Real; 3])> {
        assert!(pts.len() >= LANES);
        let q = pos.rotation;
        let (w, bx, by, bz) = (q.w, q.x, q.y, q.z);
        let b2 = (bx * bx) + (by * by) + (bz * bz);
        let (s, w2) = (_mm_set1_ps(w * w - b2), _mm_set1_ps(w * 2.0));
        let (bx, by, bz) = (_mm_set1_ps(bx), _mm_set1_ps(by), _mm_set1_ps(bz));
        let (two, zero) = (_mm_set1_ps(2.0), _mm_setzero_ps());
        let mut min = [_mm_set1_ps(Real::INFINITY); 3];
        let mut max = [_mm_set1_ps(Real::NEG_INFINITY); 3];
        let mut nan = zero;
        let four = |start: usize| {
            // Four consecutive `Vector`s (12-byte `#[repr(C)]` x, y, z) as three loads, then
            // transposed: a = [x0 y0 z0 x1], b = [y1 z1 x2 y2], c = [z2 x3 y3 z3].
            let p = pts[start..start + LANES].as_ptr() as *const f32;
            // SAFETY: the slice above holds 4 × 3 = 12 `f32`s from `p`; unaligned loads.
            let (a, b, c) = unsafe { (_mm_loadu_ps(p), _mm_loadu_ps(p.add(4)), _mm_loadu_ps(p.add(8))) };
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
        };
        let mut fold = |(x, y, z): (__m128, __m128, __m128)| {
            let (add, sub, mul) = (_mm_add_ps, _mm_sub_ps, _mm_mul_ps);
            let d2 = mul(add(add(mul(x, bx), mul(y, by)), mul(z, bz)), two);
            let r = [
                add(add(mul(x, s), mul(bx, d2)), mul(sub(mul(by, z), mul(y, bz)), w2)),
                add(add(mul(y, s), mul(by, d2)), mul(sub(mul(bz, x), mul(z, bx)), w2)),
                add(add(mul(z, s), mul(bz, d2)), mul(sub(mul(bx, y), mul(x, by)), w2)),
            ];
            nan = add(nan, mul(add(add(r[0], r[1]), r[2]), zero));
            for k in 0..3 {
                // `_mm_min_ps(m, r)` is `if m < r { m } else { r }` per lane: glam's `Vec3::min`.
                min[k] = _mm_min_ps(min[k], r[k]);
                max[k] = _mm_max_ps(max[k], r[k]);
            }
        };
        let full = pts.len() / LANES * LANES;
        for start in (0..full).step_by(LANES) {
            fold(four(start));
        }
        if full < pts.len() {
            // The last four vertices again: a vertex seen twice changes no extreme.
            fold(four(pts.len() - LANES));
        }

        let lanes = |v: __m128| {
            let mut out = [0.0 as Real; LANES];
            // SAFETY: `out` holds LANES = 4 `f32`s; an unaligned store.
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
            out
        };
        if lanes(nan).iter().any(|x| *x != 0.0) {
            return None;
        }
        let (mut lo, mut hi) = ([0.0 as Real; 3], [0.0 as Real; 3]);
        for k in 0..3 {
            let (mins, maxs) = (lanes(min[k]), lanes(max[k]));
            let a = mins.iter().fold(Real::INFINITY, |m, x| if m < *x { m } else { *x });
            let b = maxs.iter().fold(Real::NEG_INFINITY, |m, x| if m > *x { m } else { *x });
            if a == 0.0 || b == 0.0 {
                return None;
            }
            (lo[k], hi[k]) = (a, b);
        }
        Some((lo, hi))
    }
}

#[cfg(all(test, feature = "dim3"))]
#[path = "convex_aabb_tests.rs"]
mod convex_aabb_tests;
