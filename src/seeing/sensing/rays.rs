//! ray_test and ray_test_batch: the first surface each ray enters.
//!
//! Like Bullet's rayTest, a shape that contains the ray's start is not reported (a sensor
//! inside its own link sees out of it); a zero-length ray hits nothing. `hit_fraction` is the
//! fraction of the way from `ray_from` to `ray_to`.

use rapier3d::prelude::*;
use rayon::iter::{IndexedParallelIterator, IntoParallelRefIterator, ParallelIterator};

use crate::world::scene::Scene;
use crate::outputs::RayHit;
use crate::value::{r32, r32s};
use crate::world::World;

/// Rays below which a batch, or a piece of one, is not split (a thread hop costs more).
const RAYS_PER_THREAD: usize = 512;

/// A miss, as PyBullet reports one.
fn miss() -> RayHit {
    RayHit {
        hit: false,
        object_id: -1,
        link_index: -1,
        hit_fraction: 1.0,
        hit_position: [0.0; 3],
        hit_normal: [0.0; 3],
    }
}

/// The first hit of the ray `from → to`.
pub fn cast(scene: &Scene, from: [f32; 3], to: [f32; 3]) -> RayHit {
    let origin = Vector::from_array(from);
    let dir = Vector::from_array(to) - origin;
    if dir.length_squared() == 0.0 {
        return miss();
    }
    let ray = Ray::new(origin, dir);
    let best = scene.bvh.cast_ray(&ray, 1.0, |leaf, best| {
        let p = scene.parts.get(leaf as usize)?;
        if p.shape.contains_point(&p.pose, origin) {
            return None;
        }
        p.shape.cast_ray(&p.pose, &ray, best, true)
    });
    let Some((leaf, _)) = best else { return miss() };
    let Some(p) = scene.parts.get(leaf as usize) else { return miss() };
    let Some(hit) = p.shape.cast_ray_and_get_normal(&p.pose, &ray, 1.0, true) else {
        return miss();
    };
    RayHit {
        hit: true,
        object_id: i64::from(p.object_id),
        link_index: p.link_index,
        hit_fraction: r32(hit.time_of_impact),
        hit_position: r32s(ray.point_at(hit.time_of_impact).to_array()),
        hit_normal: r32s(hit.normal.to_array()),
    }
}

/// ray_test: one ray against the world as it is now (the tool's whole computation once its
/// parameters are read; the bench times this). The world's scene index is shared by every
/// read until the next change, so consecutive single rays do not rebuild it.
pub fn ray_test(w: &World, from: [f32; 3], to: [f32; 3]) -> RayHit {
    cast(w.scene(), from, to)
}

/// Many rays against one scene index (the world's, see `World::scene`), results in the order given; large
/// batches run on rayon's pool (each ray is independent, so results do not depend on how
/// they are split).
pub fn cast_batch(scene: &Scene, rays: &[([f32; 3], [f32; 3])]) -> Vec<RayHit> {
    if rays.len() <= RAYS_PER_THREAD {
        return rays.iter().map(|(f, t)| cast(scene, *f, *t)).collect();
    }
    rays.par_iter().with_min_len(RAYS_PER_THREAD).map(|(f, t)| cast(scene, *f, *t)).collect()
}
