//! get_aabb, get_overlapping_objects and get_closest_points (PyBullet's getAABB,
//! getOverlappingObjects, getClosestPoints): boxes around, and distances between, the collision
//! shapes where they are now (`World::scene`). Shared by the MCP adapters and `replay`.

use rapier3d::parry::bounding_volume::{Aabb as ParryAabb, BoundingVolume};

use super::reads::ReadContext;
use crate::command::object_not_found;
use crate::outputs::{Aabb, ClosestPoint, ClosestPoints, Overlapping, PartRef};
use crate::params::{AabbQuery, ClosestPointsQuery, OverlapQuery};
use crate::value::{r32, r32s, Refusal};

/// get_aabb: the union of the part's collider boxes.
pub fn aabb(cx: &ReadContext, p: &AabbQuery) -> Result<Aabb, Refusal> {
    let id = p.object_id.0;
    let w = cx.world;
    if !w.has_object(id) {
        return Err(object_not_found(id, w.simulation_id()));
    }
    let link = crate::params::lenient::link_index(p.link_index)?;
    w.check_link(id, link)?;
    let boxes = w.scene().parts.iter().filter(|s| s.object_id == id && s.link_index == link as i64);
    let union = boxes.map(|s| s.shape.compute_aabb(&s.pose)).reduce(|a, b| a.merged(&b));
    let Some(b) = union else {
        return Err(format!("link_index {link} of object {id} has no collision shape, so no box"));
    };
    Ok(Aabb { aabb_min: r32s(b.mins.to_array()), aabb_max: r32s(b.maxs.to_array()) })
}

/// get_overlapping_objects: every part with a collider box overlapping the given box.
pub fn overlapping(cx: &ReadContext, p: &OverlapQuery) -> Result<Overlapping, Refusal> {
    let (lo, hi) = (p.aabb_min.0, p.aabb_max.0);
    if (0..3).any(|k| lo[k] > hi[k]) {
        return Err(format!("aabb_min must not exceed aabb_max on any axis; got {lo:?} and {hi:?}"));
    }
    let query = ParryAabb::new(lo.into(), hi.into());
    let mut seen = std::collections::BTreeSet::new();
    let mut objects: Vec<PartRef> = Vec::new();
    for s in &cx.world.scene().parts {
        if s.shape.compute_aabb(&s.pose).intersects(&query) && seen.insert((s.object_id, s.link_index)) {
            objects.push(PartRef { object_id: s.object_id, link_index: s.link_index });
        }
    }
    Ok(Overlapping { objects })
}

/// get_closest_points: for every pair of collision shapes (a part of A, a part of B, optionally
/// one link each) at most `distance` apart, parry's closest points (`query::contact` with that
/// distance as its prediction: exact for spheres, boxes, capsules and convex hulls; penetration
/// is a negative distance). A pair parry cannot measure is left out (no shape the server builds).
pub fn closest_points(cx: &ReadContext, p: &ClosestPointsQuery) -> Result<ClosestPoints, Refusal> {
    let w = cx.world;
    let (a, b) = (p.body_a.0, p.body_b.0);
    let mut links = [None, None];
    for (k, (id, link, name)) in [(a, p.link_index_a, "link_index_a"), (b, p.link_index_b, "link_index_b")].into_iter().enumerate() {
        if !w.has_object(id) {
            return Err(object_not_found(id, w.simulation_id()));
        }
        if link.is_some() {
            let i = crate::params::lenient::link_index_named(link, name)?;
            w.check_link(id, i).map_err(|e| e.replacen("link_index", name, 1))?;
            links[k] = Some(i as i64);
        }
    }
    let prediction = p.distance.0;
    let of = |id: u32, link: Option<i64>| {
        w.scene().parts.iter().filter(move |s| s.object_id == id && link.is_none_or(|l| s.link_index == l))
    };
    let mut points = Vec::new();
    for sa in of(a, links[0]) {
        for sb in of(b, links[1]) {
            if std::ptr::eq(sa, sb) {
                continue;
            }
            let Ok(Some(c)) = rapier3d::parry::query::contact(&sa.pose, &*sa.shape.0, &sb.pose, &*sb.shape.0, prediction) else {
                continue;
            };
            points.push(ClosestPoint {
                body_a: a,
                body_b: b,
                link_index_a: sa.link_index,
                link_index_b: sb.link_index,
                position_on_a: r32s(c.point1.to_array()),
                position_on_b: r32s(c.point2.to_array()),
                contact_normal_on_b: r32s(c.normal2.to_array()),
                contact_distance: r32(c.dist),
            });
        }
    }
    Ok(ClosestPoints { points })
}
