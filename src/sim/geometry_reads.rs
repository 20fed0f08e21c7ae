//! get_aabb and get_overlapping_objects (PyBullet's getAABB, getOverlappingObjects): boxes
//! around the collision shapes where they are now (`World::scene`). Shared by the MCP adapters
//! and `replay`.

use rapier3d::parry::bounding_volume::{Aabb as ParryAabb, BoundingVolume};

use super::reads::ReadContext;
use crate::command::object_not_found;
use crate::outputs::{Aabb, Overlapping, PartRef};
use crate::params::{AabbQuery, OverlapQuery};
use crate::value::{r32s, Refusal};

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
