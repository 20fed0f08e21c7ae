//! Who touches whom, as the agent set it: PyBullet's collision filter group and mask per part
//! (set_collision_filter_group_mask), pairs of parts whose contacts are off
//! (set_collision_filter_pair), and markers — bodies that touch nothing (add_* with
//! `collides: false`; rays and the camera still see them).
//!
//! Markers live in rapier's colliders (collision groups that meet nothing). Group/mask and
//! disabled pairs are a contact-pair filter consulted during the step (`ContactFilter`), beside
//! MJCF's `<exclude>`: PyBullet's rule needs every other part at its default, while rapier's
//! default membership is every group, and changing that would change every world's hash. The
//! table here records what was set, so the state hash covers it (only when anything was:
//! worlds that never used these keep their hashes).
//!
//! PyBullet's test, as measured against pybullet 3.2.7 (`scripts/pybullet_filter_defaults.py`):
//! a pair touches when *either* part's group meets the other's mask (the world's filter mode
//! is `B3_FILTER_GROUPAMASKB_OR_GROUPBMASKA`), dynamic parts default to group 1, mask all, and
//! static parts (fixed: mass 0, a fixed base) to Bullet's StaticFilter, group 2, mask all but 2.
//! The first release tested both ways with every part at group 1, mask all; worlds whose
//! filters it set keep that test (`pybullet_test` false), so their logs fold as recorded.

use std::collections::{BTreeMap, BTreeSet};

use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

use super::World;

/// A part of an object: (object id, link index; −1 = the base).
pub type Part = (u32, i32);

/// What the collision filter tools set (empty unless used).
#[derive(Serialize, Deserialize, Clone, Debug, Default, PartialEq)]
pub struct Filters {
    /// set_collision_filter_group_mask: part → (group, mask).
    pub groups: BTreeMap<Part, (u32, u32)>,
    /// set_collision_filter_pair: pairs whose contacts are forced off (false) or on (true),
    /// whatever their groups and masks, as PyBullet's filter does (smaller part first).
    pub pairs: BTreeMap<(Part, Part), bool>,
    /// Markers: objects made to touch nothing.
    pub markers: BTreeSet<u32>,
    /// Groups and masks are tested as PyBullet tests them (module doc); false only for
    /// worlds filtered by the first release, whose test it keeps.
    pub pybullet_test: bool,
}

/// The filters as snapshot version 4 and the first release's state hash encoded them.
#[derive(Deserialize)]
pub(super) struct FiltersV4 {
    groups: BTreeMap<Part, (u32, u32)>,
    pairs: BTreeMap<(Part, Part), bool>,
    markers: BTreeSet<u32>,
}

impl From<FiltersV4> for Filters {
    fn from(f: FiltersV4) -> Self {
        Filters { groups: f.groups, pairs: f.pairs, markers: f.markers, pybullet_test: false }
    }
}

/// `FiltersV4`'s encoding of today's filters, borrowed (postcard encodes a tuple as the struct).
pub(super) type FiltersV4Ref<'a> = (&'a BTreeMap<Part, (u32, u32)>, &'a BTreeMap<(Part, Part), bool>, &'a BTreeSet<u32>);

impl Filters {
    /// Whether nothing was set (then the state hash and snapshot leave the section out). The
    /// rule counts: a world that used PyBullet's test keeps it in its hash and snapshots even
    /// after every filtered object is removed, so a later fold from a snapshot agrees.
    pub fn is_empty(&self) -> bool {
        self.groups.is_empty() && self.pairs.is_empty() && self.markers.is_empty() && !self.pybullet_test
    }

    /// The first release's view of these filters (without `pybullet_test`).
    pub(super) fn v4(&self) -> FiltersV4Ref<'_> {
        (&self.groups, &self.pairs, &self.markers)
    }

    /// Forgets every entry of a removed object.
    pub(super) fn forget(&mut self, id: u32) {
        self.groups.retain(|(o, _), _| *o != id);
        self.pairs.retain(|(a, b), _| a.0 != id && b.0 != id);
        self.markers.remove(&id);
    }
}

/// PyBullet's default group and mask of a dynamic part nobody filtered.
const DEFAULT_GROUP_MASK: (u32, u32) = (1, u32::MAX);

/// PyBullet's default group and mask of a static part (Bullet's StaticFilter).
const STATIC_GROUP_MASK: (u32, u32) = (2, u32::MAX ^ 2);

/// Whether two parts with these (group, mask) touch: PyBullet's test (either way), or the
/// first release's (both ways).
fn touch((g1, m1): (u32, u32), (g2, m2): (u32, u32), pybullet_test: bool) -> bool {
    match pybullet_test {
        true => g1 & m2 != 0 || g2 & m1 != 0,
        false => g1 & m2 != 0 && g2 & m1 != 0,
    }
}

impl World {
    /// Asks the contact filter about a part's colliders from now on.
    fn filter_contacts_of(&mut self, id: u32, link_index: i32) {
        if let Some((_, colliders)) = self.part(id, link_index) {
            for ch in colliders {
                if let Some(c) = self.physics.colliders.get_mut(ch) {
                    c.set_active_hooks(c.active_hooks() | ActiveHooks::FILTER_CONTACT_PAIRS);
                }
            }
        }
    }

    /// Sets a part's collision group and mask, recording it; with `pybullet_test` the world's
    /// groups and masks are tested as PyBullet tests them from now on (module doc).
    pub(super) fn set_collision_filter(&mut self, id: u32, link_index: i32, (group, mask): (u32, u32), pybullet_test: bool) -> String {
        self.filter_contacts_of(id, link_index);
        self.tables.filters.groups.insert((id, link_index), (group, mask));
        self.tables.filters.pybullet_test |= pybullet_test;
        format!("Collision filter of object {id} link {link_index} set: group {group}, mask {mask}")
    }

    /// Forces contacts between two parts off or on, recording it. Their colliders ask the
    /// contact filter of each step.
    pub(super) fn set_collision_pair(&mut self, a: (u32, i32), b: (u32, i32), enable: bool) -> String {
        let pair = if a <= b { (a, b) } else { (b, a) };
        self.tables.filters.pairs.insert(pair, enable);
        for (id, link) in [a, b] {
            self.filter_contacts_of(id, link);
        }
        format!(
            "Contacts between object {} link {} and object {} link {} {}",
            a.0,
            a.1,
            b.0,
            b.1,
            if enable { "on" } else { "off" }
        )
    }

    /// The rigid bodies of the pairs set, with whether they touch, as a contact filter takes them.
    pub(super) fn body_pairs(&self) -> Vec<((RigidBodyHandle, RigidBodyHandle), bool)> {
        self.tables
            .filters
            .pairs
            .iter()
            .filter_map(|((a, b), on)| Some(((self.part(a.0, a.1)?.0, self.part(b.0, b.1)?.0), *on)))
            .collect()
    }
}

/// The contact filter of a step: body pairs whose contacts are forced off or on (MJCF
/// `<exclude>`, then set_collision_filter_pair, which wins) and bodies' groups and masks
/// (set_collision_filter_group_mask), which decide the other pairs. rapier consults it only for
/// pairs where a collider is flagged `FILTER_CONTACT_PAIRS`.
pub struct ContactFilter {
    pairs: BTreeMap<(Raw, Raw), bool>,
    /// MJCF `<contact><pair>` frictions by collider pair, both ways (`mjcf_pairs`).
    frictions: BTreeMap<(Raw, Raw), f32>,
    groups: BTreeMap<Raw, (u32, u32)>,
    pybullet_test: bool,
}

/// A body handle's raw parts (handles are not `Ord`).
type Raw = (u32, u32);

impl ContactFilter {
    /// The pairs of `w`.
    pub(super) fn of(w: &World) -> ContactFilter {
        let mut pairs = BTreeMap::new();
        let excluded = super::mjcf::excluded_body_pairs(w).into_iter().map(|p| (p, false));
        for ((a, b), on) in excluded.chain(w.body_pairs()) {
            pairs.insert((a.into_raw_parts(), b.into_raw_parts()), on);
            pairs.insert((b.into_raw_parts(), a.into_raw_parts()), on);
        }
        let groups = w
            .tables
            .filters
            .groups
            .iter()
            .filter_map(|((id, link), gm)| Some((w.part(*id, *link)?.0.into_raw_parts(), *gm)))
            .collect();
        let frictions = super::mjcf_pairs::frictions(&w.tables.contact_pairs);
        ContactFilter { pairs, frictions, groups, pybullet_test: w.tables.filters.pybullet_test }
    }

    /// No pair, no group and no contact pair friction: the plain step applies.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty() && self.groups.is_empty() && self.frictions.is_empty()
    }
}

impl PhysicsHooks for ContactFilter {
    fn filter_contact_pair(&self, c: &PairFilterContext) -> Option<SolverFlags> {
        let default = |b: Option<RigidBodyHandle>| {
            let dynamic = b.and_then(|b| c.bodies.get(b)).is_some_and(|b| b.is_dynamic());
            match self.pybullet_test && !dynamic {
                true => STATIC_GROUP_MASK,
                false => DEFAULT_GROUP_MASK,
            }
        };
        let of = |b: Option<RigidBodyHandle>| b.and_then(|b| self.groups.get(&b.into_raw_parts()).copied()).unwrap_or_else(|| default(b));
        let forced = match (c.rigid_body1, c.rigid_body2) {
            (Some(a), Some(b)) => self.pairs.get(&(a.into_raw_parts(), b.into_raw_parts())).copied(),
            _ => None,
        };
        forced.unwrap_or_else(|| touch(of(c.rigid_body1), of(c.rigid_body2), self.pybullet_test)).then(SolverFlags::default)
    }

    fn filter_intersection_pair(&self, _: &PairFilterContext) -> bool {
        true
    }

    /// An MJCF contact pair's friction replaces the combined one (rapier asks only for colliders
    /// flagged `MODIFY_SOLVER_CONTACTS`, which only pairs set).
    fn modify_solver_contacts(&self, c: &mut ContactModificationContext) {
        if let Some(f) = self.frictions.get(&(c.collider1.into_raw_parts(), c.collider2.into_raw_parts())) {
            if let ModifiableContacts::Rigid(m) = &mut c.contacts {
                *m.friction = *f;
            }
        }
    }
}
