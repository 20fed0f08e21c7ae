//! An MJCF model's `<contact><pair geom1 geom2 friction>`s, built for loads of event version 9
//! (`Command::LoadMjcf::ball_joints_and_pairs`) with MuJoCo's meaning (docs/tools.md "MJCF
//! models"): contacts between the two geoms use the pair's sliding friction (its first
//! `friction` number; 1 when omitted, MuJoCo's pair default) instead of the geoms' combined one.
//!
//! The step applies it in the contact hook (`filters::ContactFilter::modify_solver_contacts`,
//! which rapier asks only for colliders flagged `MODIFY_SOLVER_CONTACTS`), so worlds without a
//! pair step exactly as before. What a pair needs beyond that — contacts between geoms that
//! `contype`/`conaffinity`, an `<exclude>` or the parent filter keep apart, `condim`, `margin`,
//! `gap`, `solref`/`solimp` — is listed in `ignored` with the pair's name.
//!
//! Which collider is which geom: the crate's colliders carry no geom identity, so while the
//! model is inserted each collider holds a tag in its `user_data` (the body and the geom's
//! place among the body's built geoms), read back once the colliders are in the world and reset
//! to 0, so the world snapshots and hashes as if no tag had been there.

use std::collections::BTreeMap;

use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::body::GeomType;
use rapier3d_mjcf::mjcf_rs::Model;
use serde::{Deserialize, Serialize};

/// One built pair: its two colliders and the sliding friction their contacts use.
#[derive(Serialize, Deserialize, Clone, Debug, PartialEq)]
pub struct PairFriction {
    /// geom1's collider.
    pub collider1: ColliderHandle,
    /// geom2's collider.
    pub collider2: ColliderHandle,
    /// The pair's sliding friction coefficient.
    pub friction: f32,
}

/// The tag of geom `geom` (its index in the body's `<geom>` list) of MJCF body `body`: never 0,
/// the untagged value.
fn tag(body: usize, geom: usize) -> u128 {
    (((body as u128) << 32) | geom as u128) + 1
}

/// Whether the crate builds a collider for this geom (the count check in `mjcf::prepare`
/// holds it to this rule).
fn has_collider(g: &rapier3d_mjcf::mjcf_rs::body::Geom) -> bool {
    !(g.contype == 0 && g.conaffinity == 0)
}

/// Tags the colliders of one MJCF body, as the crate built them and `mjcf::plane_colliders`
/// appended the planes: its non-plane geoms with colliders in file order, then its planes.
pub(super) fn tag_colliders(model: &Model, mjcf_body: usize, colliders: &mut [Collider]) {
    let geoms = &model.bodies[mjcf_body].body.geoms;
    let solids = geoms.iter().enumerate().filter(|(_, g)| g.type_ != GeomType::Plane && has_collider(g));
    let planes = geoms.iter().enumerate().filter(|(_, g)| g.type_ == GeomType::Plane && has_collider(g));
    for (c, (k, _)) in colliders.iter_mut().zip(solids.chain(planes)) {
        c.user_data = tag(mjcf_body, k);
    }
}

/// The inserted colliders by tag, each tag reset to 0 (so nothing of it stays in the world).
pub(super) fn take_tags(set: &mut ColliderSet, handles: impl IntoIterator<Item = ColliderHandle>) -> BTreeMap<u128, ColliderHandle> {
    let mut out = BTreeMap::new();
    for h in handles {
        if let Some(c) = set.get_mut(h) {
            if c.user_data != 0 {
                out.insert(c.user_data, h);
                c.user_data = 0;
            }
        }
    }
    out
}

/// The tag of the geom named `name`.
fn geom_tag<'a>(model: &'a Model, name: &str) -> Option<(u128, &'a rapier3d_mjcf::mjcf_rs::body::Geom)> {
    model
        .bodies
        .iter()
        .enumerate()
        .find_map(|(b, e)| e.body.geoms.iter().enumerate().find(|(_, g)| g.name.as_deref() == Some(name)).map(|(k, g)| (tag(b, k), g)))
}

/// Builds the model's pairs on the inserted colliders (`by_tag`), flagging them for the
/// contact hook; returns them and a note for each one (or each attribute) not built.
/// `excluded` are the body pairs whose contacts are off (`<exclude>`, the parent filter).
pub(super) fn build(
    model: &Model,
    by_tag: &BTreeMap<u128, ColliderHandle>,
    colliders: &mut ColliderSet,
    excluded: &[(RigidBodyHandle, RigidBodyHandle)],
) -> (Vec<PairFriction>, Vec<String>) {
    let mut pairs = Vec::new();
    let mut notes = Vec::new();
    for (k, p) in model.contact.pairs.iter().enumerate() {
        let name = p.name.clone().unwrap_or_else(|| format!("#{k}"));
        let built = (|| {
            let find = |g: &str| -> Result<ColliderHandle, String> {
                let (t, geom) = geom_tag(model, g).ok_or_else(|| format!("geom {g} is not in the model"))?;
                match has_collider(geom) {
                    true => by_tag.get(&t).copied().ok_or_else(|| format!("geom {g} has no collider here")),
                    false => Err(format!("geom {g} has contype and conaffinity 0, so it has no collider here")),
                }
            };
            let (h1, h2) = (find(&p.geom1)?, find(&p.geom2)?);
            let (c1, c2) = (colliders.get(h1).ok_or("geom1 has no collider")?, colliders.get(h2).ok_or("geom2 has no collider")?);
            let (b1, b2) = (c1.parent(), c2.parent());
            if b1 == b2 {
                return Err("both geoms are on one rigid body here (merged or the same)".to_string());
            }
            if !c1.collision_groups().test(c2.collision_groups()) {
                return Err("its geoms' contype/conaffinity keep them apart, which a pair overrides in MuJoCo but not here".to_string());
            }
            if let (Some(a), Some(b)) = (b1, b2) {
                if excluded.iter().any(|&(x, y)| (x, y) == (a, b) || (y, x) == (a, b)) {
                    return Err("its bodies' contacts are off (<exclude> or the parent filter), which a pair overrides in MuJoCo but not here".to_string());
                }
            }
            let friction = p.friction.map_or(1.0, |f| f[0]);
            if !(friction.is_finite() && (0.0..=crate::limits::MAX_EXTENT_M).contains(&friction)) {
                return Err(format!("its friction {friction} is not a number >= 0"));
            }
            Ok(PairFriction { collider1: h1, collider2: h2, friction: friction as f32 })
        })();
        match built {
            Ok(pair) => {
                for h in [pair.collider1, pair.collider2] {
                    if let Some(c) = colliders.get_mut(h) {
                        c.set_active_hooks(c.active_hooks() | ActiveHooks::MODIFY_SOLVER_CONTACTS);
                    }
                }
                pairs.push(pair);
                for (attr, set) in [("condim", p.condim.is_some_and(|c| c != 3)), ("margin", p.margin.is_some_and(|m| m != 0.0)), ("gap", p.gap.is_some_and(|g| g != 0.0)), ("class", p.class.is_some())] {
                    if set {
                        notes.push(format!("pair {name} {attr}: not applied (the pair's sliding friction is)"));
                    }
                }
            }
            Err(why) => notes.push(format!("pair {name}: {why}; not built")),
        }
    }
    (pairs, notes)
}

/// A collider handle's raw parts (handles are not `Ord`).
type RawCollider = (u32, u32);

/// Every pair of a world by its colliders' raw handles, both ways, for the step's contact hook.
pub(super) fn frictions(pairs: &BTreeMap<u32, Vec<PairFriction>>) -> BTreeMap<(RawCollider, RawCollider), f32> {
    let mut out = BTreeMap::new();
    for p in pairs.values().flatten() {
        let (a, b) = (p.collider1.into_raw_parts(), p.collider2.into_raw_parts());
        out.insert((a, b), p.friction);
        out.insert((b, a), p.friction);
    }
    out
}
