//! Patch 6's AABB against parry's, bit for bit (`convex_aabb.rs`).

use super::{convex_points_aabb, shape_aabb};
use crate::alloc_prelude::*;
use crate::math::{Pose, Real, Rotation, Vector};
use parry::bounding_volume::Aabb;
use parry::shape::{ConvexPolyhedron, Shape};

fn bits(a: &Aabb) -> [u32; 6] {
    [a.mins.x, a.mins.y, a.mins.z, a.maxs.x, a.maxs.y, a.maxs.z].map(Real::to_bits)
}

fn parry_aabb(pos: &Pose, pts: &[Vector]) -> Aabb {
    parry::bounding_volume::details::point_cloud_aabb_ref(pos, pts)
}

fn same(pos: &Pose, pts: &[Vector]) -> bool {
    let (ours, theirs) = (convex_points_aabb(pos, pts), parry_aabb(pos, pts));
    // NaN bounds: the same bits too (the fallback is parry's function itself).
    bits(&ours) == bits(&theirs)
}

struct Rng(oorandom::Rand32);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(oorandom::Rand32::new(seed))
    }
    fn f(&mut self, lo: Real, hi: Real) -> Real {
        lo + (hi - lo) * self.0.rand_float()
    }
    fn rotation(&mut self) -> Rotation {
        let axis = Vector::new(self.f(-1.0, 1.0), self.f(-1.0, 1.0), self.f(-1.0, 1.0));
        if axis.length() < 1e-3 {
            return Rotation::IDENTITY;
        }
        Rotation::from_axis_angle(axis.normalize(), self.f(-7.0, 7.0))
    }
    fn points(&mut self, n: usize, scale: Real) -> Vec<Vector> {
        (0..n).map(|_| Vector::new(self.f(-scale, scale), self.f(-scale, scale), self.f(-scale, scale))).collect()
    }
}

#[test]
fn convex_aabb_equals_parry_on_random_clouds_and_poses() {
    let mut rng = Rng::new(5);
    let (mut checked, mut fast) = (0, 0);
    for case in 0..4000 {
        let n = 1 + (case % 70);
        let scale = [0.01, 0.3, 2.0, 150.0][case % 4];
        let pts = rng.points(n, scale);
        let pos = Pose::from_parts(Vector::new(rng.f(-3.0, 3.0), rng.f(-3.0, 3.0), rng.f(-3.0, 3.0)), rng.rotation());
        assert!(same(&pos, &pts), "case {case}: {pos:?}");
        checked += 1;
        #[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "enhanced-determinism"))]
        if n >= 8 {
            // Both kernels, whichever the CPU would be given: the same extremes, and an answer
            // (not the fallback).
            let sse2 = unsafe { super::lanes::rotated_extremes_sse2(&pos, &pts) };
            if std::is_x86_feature_detected!("avx") {
                let avx = unsafe { super::lanes::rotated_extremes_avx(&pos, &pts) };
                assert_eq!(sse2.map(|(a, b)| (a.map(Real::to_bits), b.map(Real::to_bits))), avx.map(|(a, b)| (a.map(Real::to_bits), b.map(Real::to_bits))), "case {case}");
            }
            fast += usize::from(sse2.is_some());
        }
    }
    assert_eq!(checked, 4000);
    // The four-lane kernel, not the fallback, answered (all but clouds under 8 points).
    #[cfg(all(target_arch = "x86_64", target_feature = "sse2", feature = "f32", feature = "enhanced-determinism"))]
    assert_eq!(fast, (0..4000).filter(|c| 1 + c % 70 >= 8).count());
}

#[test]
fn convex_aabb_equals_parry_on_hulls_at_the_origin_and_on_zero_extremes() {
    // A hull centred on the origin with vertices on the axes: rotated by identity or quarter
    // turns, extremes are exact zeros of either sign (the fallback's case), and the translation
    // is ±0 or exactly cancels a vertex.
    let mut pts = vec![
        Vector::new(0.0, 0.0, 0.0),
        Vector::new(-0.0, 1.0, 0.0),
        Vector::new(1.0, -0.0, 0.0),
        Vector::new(0.0, 0.0, 1.0),
        Vector::new(1.0, 1.0, -0.0),
        Vector::new(0.0, 1.0, 1.0),
        Vector::new(1.0, 0.0, 1.0),
        Vector::new(1.0, 1.0, 1.0),
        Vector::new(0.5, 0.5, 0.5),
    ];
    let turns = [
        Rotation::IDENTITY,
        Rotation::from_xyzw(-0.0, 0.0, 0.0, 1.0),
        Rotation::from_axis_angle(Vector::Z, core::f32::consts::FRAC_PI_2 as Real),
        Rotation::from_axis_angle(Vector::X, core::f32::consts::PI as Real),
        Rotation::from_xyzw(0.0, 0.0, 1.0, 0.0),
    ];
    for extra in 0..6 {
        for rot in turns {
            for t in [Vector::ZERO, Vector::new(-0.0, -0.0, -0.0), Vector::new(-1.0, -0.5, 1.0), Vector::new(1e-30, -1e30, 3.0)] {
                let pos = Pose::from_parts(t, rot);
                assert!(same(&pos, &pts), "{pos:?} with {} points", pts.len());
            }
        }
        pts.push(Vector::new(-0.25 * extra as Real, 0.125, -0.0));
    }
}

#[test]
fn convex_aabb_equals_parry_where_lanes_would_pick_another_signed_zero() {
    // Found by the review of patch 6: without the zero-extreme fallback, the lanes' minimum of
    // x is +0 where parry's running minimum keeps -0.
    let pts = [
        (0.0, 1.0, 0.0),
        (0.0, -0.0, 0.5),
        (-0.0, 1.0, 1.0),
        (1.0, 0.5, 0.0),
        (0.0, 0.5, 0.5),
        (0.5, 0.5, 1.0),
        (0.0, -0.0, 0.0),
        (1.0, 1.0, 0.5),
        (-0.0, 0.0, -0.0),
        (1.0, -0.0, 0.0),
        (1.0, 0.0, 1.0),
        (1.0, -0.0, 1.0),
    ]
    .map(|(x, y, z)| Vector::new(x, y, z));
    let pos = Pose::from_parts(Vector::new(-0.0, -0.0, -0.0), Rotation::from_xyzw(-0.0, 0.0, 0.0, 1.0));
    assert!(same(&pos, &pts));
    // And a seeded search over such lattices of signed zeros, halves and ones.
    let mut rng = Rng::new(17);
    let coord = |rng: &mut Rng| [0.0, -0.0, 0.5, 1.0][(rng.f(0.0, 4.0) as usize).min(3)];
    for case in 0..3000 {
        let n = 8 + case % 17;
        let pts: Vec<Vector> = (0..n).map(|_| Vector::new(coord(&mut rng), coord(&mut rng), coord(&mut rng))).collect();
        let t = Vector::new(coord(&mut rng) * -1.0, coord(&mut rng), -coord(&mut rng));
        let rot = [Rotation::IDENTITY, Rotation::from_xyzw(-0.0, 0.0, 0.0, 1.0), Rotation::from_xyzw(0.0, -0.0, 0.0, -1.0)][case % 3];
        assert!(same(&Pose::from_parts(t, rot), &pts), "lattice case {case}");
    }
}

#[test]
fn convex_aabb_equals_parry_on_non_finite_poses_and_points() {
    let mut rng = Rng::new(9);
    let pts = rng.points(33, 1.0);
    for pos in [
        Pose::from_parts(Vector::new(Real::NAN, 0.0, 0.0), Rotation::IDENTITY),
        Pose::from_parts(Vector::ZERO, Rotation::from_xyzw(Real::NAN, 0.0, 0.0, 1.0)),
        Pose::from_parts(Vector::new(Real::INFINITY, 0.0, -Real::INFINITY), rng.rotation()),
        Pose::from_parts(Vector::ZERO, Rotation::from_xyzw(0.0, Real::INFINITY, 0.0, 1.0)),
    ] {
        assert!(same(&pos, &pts), "{pos:?}");
    }
    // A NaN or huge vertex in any lane and position, the rest finite.
    for i in [0, 1, 5, 16, 31, 32] {
        for bad in [Real::NAN, Real::INFINITY, 3e38] {
            let mut pts = rng.points(33, 1.0);
            pts[i].y = bad;
            let pos = Pose::from_parts(Vector::new(0.5, 0.5, 0.5), rng.rotation());
            assert!(same(&pos, &pts), "vertex {i} = {bad}");
        }
    }
}

#[test]
fn convex_aabb_serves_hulls_and_leaves_other_shapes_to_parry() {
    let mut rng = Rng::new(11);
    let hull = ConvexPolyhedron::from_convex_hull(&rng.points(200, 0.4)).expect("a hull");
    assert!(hull.points().len() >= 8, "enough vertices for the lanes");
    let ball = parry::shape::Ball::new(0.3);
    for _ in 0..200 {
        let pos = Pose::from_parts(Vector::new(rng.f(-2.0, 2.0), rng.f(-2.0, 2.0), rng.f(0.0, 2.0)), rng.rotation());
        assert_eq!(bits(&shape_aabb(&hull, &pos)), bits(&hull.compute_aabb(&pos)));
        assert_eq!(bits(&shape_aabb(&ball, &pos)), bits(&ball.compute_aabb(&pos)));
    }
}
