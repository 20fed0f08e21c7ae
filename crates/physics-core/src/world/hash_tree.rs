//! The objects' part of state hash v2: a Merkle tree over object ids, kept between calls, so a
//! change that touches one object re-hashes that object and the 8 nodes above it instead of
//! every object in the world (under v1, adding the 1,000th box cost 2.5× the 100th).
//!
//! The tree is a radix tree of fan-out 16 over the 32-bit id: a leaf is the blake3 of one
//! object's canonical encoding (`hash::object_leaf`); the node at level `L` (1..=8) and prefix
//! `p` covers the ids whose top `32 − 4L` bits are `p`, and is the blake3 of `L`, `p` and its
//! present children (each as its 4-bit index and digest), in index order. Level 8 has one node,
//! the root. Empty subtrees have no node; an empty world's root is 32 zero bytes. Its shape
//! depends on the ids alone, never on the order changes came in, so the root is a function of
//! the objects' leaves: the incremental and the from-scratch computation agree by construction,
//! and `tests/time_machine/incremental_hash.rs` checks it after every event of every log.
//!
//! The tree is a cache, neither hashed nor snapshotted: a restored world starts it afresh.

use std::collections::{BTreeMap, BTreeSet};

/// A blake3 digest.
pub(super) type Digest = [u8; 32];

/// Bits of the id consumed per level (fan-out 16).
const BITS: u32 = 4;
/// Levels above the leaves: 8 × 4 bits cover a u32 id.
const LEVELS: u32 = 8;

/// What an applied command may have changed among the objects (`hash::touched_by`).
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Touched {
    /// No object (header-only changes: camera, debug drawing, timestep).
    Nothing,
    /// This object only (added, removed, or one body's pose, velocity, wrench or dynamics).
    One(u32),
    /// Possibly any object (a step, a robot load, joints, constraints, filters, …).
    All,
}

/// Which leaves must be recomputed before the root is read.
#[derive(Clone, Debug)]
enum Stale {
    /// Every leaf (a new or restored world, or after a step).
    All,
    /// These ids (their objects may also be gone).
    Ids(BTreeSet<u32>),
}

/// The digests of every object and every non-empty subtree, and what is stale.
#[derive(Clone, Debug)]
pub(super) struct Tree {
    /// `levels[0]` are the leaves by id; `levels[L]` the nodes of level L by prefix.
    levels: Vec<BTreeMap<u32, Digest>>,
    stale: Stale,
}

impl Default for Tree {
    fn default() -> Self {
        Tree { levels: vec![BTreeMap::new(); LEVELS as usize + 1], stale: Stale::All }
    }
}

impl Tree {
    /// Notes what a command changed; nothing is hashed until the root is asked for.
    pub(super) fn mark(&mut self, touched: Touched) {
        match (touched, &mut self.stale) {
            (Touched::Nothing, _) | (_, Stale::All) => {}
            (Touched::All, stale) => *stale = Stale::All,
            (Touched::One(id), Stale::Ids(ids)) => {
                ids.insert(id);
            }
        }
    }

    /// The root after bringing the stale leaves up to date: `ids` lists every object id now
    /// in the world (read only when everything is stale), `leaf` hashes one object (None: it is
    /// gone, or has no body to hash).
    pub(super) fn root(&mut self, ids: impl Iterator<Item = u32>, leaf: impl Fn(u32) -> Option<Digest>) -> Digest {
        let stale = std::mem::replace(&mut self.stale, Stale::Ids(BTreeSet::new()));
        let dirty: BTreeSet<u32> = match stale {
            Stale::All => {
                self.levels.iter_mut().for_each(BTreeMap::clear);
                ids.collect()
            }
            Stale::Ids(ids) => ids,
        };
        for &id in &dirty {
            match leaf(id) {
                Some(d) => self.levels[0].insert(id, d),
                None => self.levels[0].remove(&id),
            };
        }
        let mut prefixes = dirty;
        for level in 1..=LEVELS {
            prefixes = prefixes.into_iter().map(|p| p >> BITS).collect();
            for &p in &prefixes {
                let node = self.node(level, p);
                match node {
                    Some(d) => self.levels[level as usize].insert(p, d),
                    None => self.levels[level as usize].remove(&p),
                };
            }
        }
        self.levels[LEVELS as usize].get(&0).copied().unwrap_or([0; 32])
    }

    /// The digest of the node at `level`, prefix `p`, from its children one level down (None
    /// when it has none).
    fn node(&self, level: u32, p: u32) -> Option<Digest> {
        let first = u64::from(p) << BITS;
        let last = (first | ((1 << BITS) - 1)).min(u64::from(u32::MAX));
        let below = &self.levels[level as usize - 1];
        let mut children = below.range(first as u32..=last as u32).peekable();
        children.peek()?;
        let mut h = blake3::Hasher::new();
        h.update(&[level as u8]);
        h.update(&p.to_le_bytes());
        for (child, digest) in children {
            h.update(&[(child & ((1 << BITS) - 1)) as u8]);
            h.update(digest);
        }
        Some(*h.finalize().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leaf_of(objects: &BTreeMap<u32, u8>) -> impl Fn(u32) -> Option<Digest> + '_ {
        |id| objects.get(&id).map(|v| *blake3::hash(&[*v]).as_bytes())
    }

    fn from_scratch(objects: &BTreeMap<u32, u8>) -> Digest {
        Tree::default().root(objects.keys().copied(), leaf_of(objects))
    }

    #[test]
    fn incremental_roots_equal_from_scratch_ones_whatever_the_order_of_changes() {
        let mut objects = BTreeMap::new();
        let mut tree = Tree::default();
        // Adds, edits and removals across the id space, including the extremes.
        let ids = [0u32, 1, 15, 16, 17, 255, 256, 4096, 70_000, u32::MAX - 1, u32::MAX];
        for (i, &id) in ids.iter().enumerate() {
            objects.insert(id, i as u8);
            tree.mark(Touched::One(id));
            assert_eq!(tree.root(objects.keys().copied(), leaf_of(&objects)), from_scratch(&objects));
        }
        for &id in ids.iter().step_by(2) {
            objects.insert(id, 200);
            tree.mark(Touched::One(id));
            assert_eq!(tree.root(objects.keys().copied(), leaf_of(&objects)), from_scratch(&objects));
        }
        for &id in &ids {
            objects.remove(&id);
            tree.mark(Touched::One(id));
            assert_eq!(tree.root(objects.keys().copied(), leaf_of(&objects)), from_scratch(&objects));
        }
        assert_eq!(from_scratch(&objects), [0; 32]);
    }

    #[test]
    fn any_change_to_any_leaf_changes_the_root() {
        let objects: BTreeMap<u32, u8> = (0..300).map(|i| (i, 0)).collect();
        let base = from_scratch(&objects);
        for id in [0, 1, 16, 299] {
            let mut changed = objects.clone();
            changed.insert(id, 1);
            assert_ne!(from_scratch(&changed), base, "leaf {id}");
            let mut gone = objects.clone();
            gone.remove(&id);
            assert_ne!(from_scratch(&gone), base, "without {id}");
        }
        // Moving a leaf to another id changes the root too (ids are part of the shape).
        let mut moved = objects.clone();
        moved.remove(&299);
        moved.insert(300, 0);
        assert_ne!(from_scratch(&moved), base);
    }

    #[test]
    fn a_missed_mark_is_what_the_comparison_with_from_scratch_catches() {
        // The property the integration test relies on: a change the tree was not told of
        // leaves the incremental root wrong, and the from-scratch root shows it.
        let mut objects: BTreeMap<u32, u8> = (0..20).map(|i| (i, 0)).collect();
        let mut tree = Tree::default();
        tree.root(objects.keys().copied(), leaf_of(&objects));
        objects.insert(5, 9);
        assert_ne!(tree.root(objects.keys().copied(), leaf_of(&objects)), from_scratch(&objects));
    }
}
