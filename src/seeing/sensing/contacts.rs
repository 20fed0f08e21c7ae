//! get_all_collisions and get_collisions_for_pair: the contact points of the last step, from
//! rapier's narrow phase, in PyBullet's form (normal from B to A, normal force = the solver's
//! normal impulse over the step's dt).

use std::collections::HashMap;

use rapier3d::prelude::*;

use crate::outputs::Contact;
use crate::value::{r32, r32s};
use crate::world::World;

/// Every contact point, ordered by (object_a, object_b, link_a, link_b) with object_a ≤
/// object_b; when `pair` is given, only contacts between those two objects, with A = the
/// first of the pair.
pub fn contacts(w: &World, pair: Option<(u32, u32)>) -> Vec<Contact> {
    let owner: HashMap<ColliderHandle, (u32, i64)> =
        w.scene().parts.iter().map(|p| (p.collider, (p.object_id, p.link_index))).collect();
    let physics = w.physics();
    let dt = physics.integration_parameters.dt;
    let mut out = Vec::new();
    for cp in physics.contact_pairs() {
        let (Some(&o1), Some(&o2)) = (owner.get(&cp.collider1), owner.get(&cp.collider2)) else {
            continue;
        };
        let (Some(c1), Some(c2)) = (physics.colliders.get(cp.collider1), physics.colliders.get(cp.collider2)) else {
            continue;
        };
        // A is collider 1 unless the order asked for (or id order) says otherwise.
        let swap = match pair {
            Some((a, b)) => {
                if (o1.0, o2.0) == (a, b) {
                    false
                } else if (o1.0, o2.0) == (b, a) {
                    true
                } else {
                    continue;
                }
            }
            None => (o1.0, o1.1) > (o2.0, o2.1),
        };
        // rapier keeps a resting contact's anchors where they were found while the bodies
        // creep (spatial coherence), so a box that slid 16 mm after landing still reported the
        // ground's anchors of the landing. The points are reported where the shapes touch now:
        // a fresh manifold for the current poses, matched to rapier's points by feature.
        let fresh = fresh_manifolds(c1, c2, physics.integration_parameters.prediction_distance());
        for m in cp.manifolds() {
            // The same sub-shapes' fresh manifold (feature ids are per sub-shape).
            let now_m = fresh.iter().find(|f| (f.subshape1, f.subshape2) == (m.subshape1, m.subshape2));
            for p in &m.points {
                let now = now_m.and_then(|f| f.points.iter().find(|q| (q.fid1, q.fid2) == (p.fid1, p.fid2)).map(|q| (f, q)));
                let (local_n1, local_p1, local_p2, dist) = match now {
                    Some((f, q)) => (f.local_n1, q.local_p1, q.local_p2, q.dist),
                    None => (m.local_n1, p.local_p1, p.local_p2, p.dist),
                };
                // The manifold normal points from collider 1 towards collider 2.
                let n12 = c1.position().transform_vector(local_n1);
                let on1 = c1.position().transform_point(local_p1);
                let on2 = c2.position().transform_point(local_p2);
                let force = (p.data.impulse / dt).max(0.0);
                let (a, b, on_a, on_b, normal_b_to_a) =
                    if swap { (o2, o1, on2, on1, n12) } else { (o1, o2, on1, on2, -n12) };
                out.push(Contact {
                    object_a: a.0,
                    object_b: b.0,
                    link_index_a: a.1,
                    link_index_b: b.1,
                    position_on_a: r32s(on_a.to_array()),
                    position_on_b: r32s(on_b.to_array()),
                    contact_normal: r32s(normal_b_to_a.to_array()),
                    contact_distance: r32(dist),
                    normal_force: r32(force),
                });
            }
        }
    }
    out.sort_by_key(|c| (c.object_a, c.object_b, c.link_index_a, c.link_index_b));
    out
}

/// The two colliders' contact manifolds computed afresh for their current poses.
fn fresh_manifolds(c1: &Collider, c2: &Collider, prediction: f32) -> Vec<rapier3d::parry::query::ContactManifold<(), ()>> {
    use rapier3d::parry::query::{DefaultQueryDispatcher, PersistentQueryDispatcher};
    let pos12 = c1.position().inv_mul(c2.position());
    let mut out = Vec::new();
    let _ = DefaultQueryDispatcher.contact_manifolds(&pos12, c1.shape(), c2.shape(), prediction, &mut out, &mut None);
    out
}
