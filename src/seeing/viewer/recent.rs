//! A small process-wide cache of the most recently used values by key, bounded in entries and
//! in bytes, so that what the viewer keeps (past moments, timelines, the last moment shown,
//! inspections, clips and refusals) cannot grow with the number of simulations a long-running
//! server has seen or with the length of their chains: the least recently used entry goes
//! first, and an entry larger than the whole budget is not kept. Entries of a destroyed
//! simulation are dropped at once (`forget`).

use std::collections::VecDeque;
use std::sync::Mutex;

/// What one entry costs besides the bytes its owner reports (the key, the slot, the `Arc`).
pub const ENTRY_OVERHEAD: usize = 128;

/// At most `max_entries` values and `max_bytes` bytes by key, most recently used last.
pub struct Recent<K, V> {
    max_entries: usize,
    max_bytes: usize,
    items: Mutex<Kept<K, V>>,
}

struct Kept<K, V> {
    /// (key, value, bytes), least recently used first.
    entries: VecDeque<(K, V, usize)>,
    bytes: usize,
}

impl<K: PartialEq, V: Clone> Recent<K, V> {
    /// An empty cache of at most `max_entries` entries and `max_bytes` bytes.
    pub const fn new(max_entries: usize, max_bytes: usize) -> Self {
        Recent { max_entries, max_bytes, items: Mutex::new(Kept { entries: VecDeque::new(), bytes: 0 }) }
    }

    fn kept(&self) -> std::sync::MutexGuard<'_, Kept<K, V>> {
        self.items.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The value under `key`, if still kept (it becomes the most recently used).
    pub fn get(&self, key: &K) -> Option<V> {
        let mut kept = self.kept();
        let at = kept.entries.iter().position(|(k, _, _)| k == key)?;
        let entry = kept.entries.remove(at)?;
        let value = entry.1.clone();
        kept.entries.push_back(entry);
        Some(value)
    }

    /// Keeps `value` under `key` (replacing an older one) as `bytes` bytes, dropping the least
    /// recently used entries until it fits; a value larger than the whole budget is not kept.
    pub fn put(&self, key: K, value: V, bytes: usize) {
        let bytes = bytes.saturating_add(ENTRY_OVERHEAD);
        let mut kept = self.kept();
        if let Some(at) = kept.entries.iter().position(|(k, _, _)| *k == key) {
            if let Some((_, _, b)) = kept.entries.remove(at) {
                kept.bytes -= b;
            }
        }
        if bytes > self.max_bytes {
            return;
        }
        while !kept.entries.is_empty() && (kept.entries.len() >= self.max_entries.max(1) || kept.bytes + bytes > self.max_bytes) {
            if let Some((_, _, b)) = kept.entries.pop_front() {
                kept.bytes -= b;
            }
        }
        kept.bytes += bytes;
        kept.entries.push_back((key, value, bytes));
    }

    /// Drops every entry whose key `doomed` says (a destroyed simulation's).
    pub fn forget(&self, doomed: impl Fn(&K) -> bool) {
        let mut kept = self.kept();
        let mut freed = 0;
        kept.entries.retain(|(k, _, b)| {
            let drop = doomed(k);
            if drop {
                freed += b;
            }
            !drop
        });
        kept.bytes -= freed;
    }

    /// Entries kept now whose key `which` says (a simulation's, for `ask::kept_of`).
    pub fn count(&self, which: impl Fn(&K) -> bool) -> usize {
        self.kept().entries.iter().filter(|(k, _, _)| which(k)).count()
    }

    /// Bytes kept now (entries' reported bytes and their overhead).
    pub fn bytes(&self) -> usize {
        self.kept().bytes
    }

    /// Entries kept now.
    pub fn len(&self) -> usize {
        self.kept().entries.len()
    }

    /// Whether nothing is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A cache key that names the simulation its entry belongs to (the whole key, or its first
/// part), so a simulation's entries can be dropped and counted through one list of caches.
pub trait OfSimulation {
    /// The simulation's id.
    fn simulation(&self) -> &str;
}

impl OfSimulation for String {
    fn simulation(&self) -> &str {
        self
    }
}

impl<A, B> OfSimulation for (String, A, B) {
    fn simulation(&self) -> &str {
        &self.0
    }
}

/// A cache whose entries belong to simulations: what the viewer's modules list once, so that
/// `forget` (a destroyed simulation) and `kept_of` (its test) cannot disagree on the caches.
pub trait SimulationCache: Sync {
    /// Drops simulation `id`'s entries.
    fn forget_simulation(&self, id: &str);
    /// How many entries of simulation `id` are kept.
    fn count_simulation(&self, id: &str) -> usize;
}

impl<K: PartialEq + OfSimulation + Send, V: Clone + Send> SimulationCache for Recent<K, V> {
    fn forget_simulation(&self, id: &str) {
        self.forget(|k| k.simulation() == id);
    }

    fn count_simulation(&self, id: &str) -> usize {
        self.count(|k| k.simulation() == id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_most_recently_used_and_replaces_by_key() {
        let r: Recent<u32, &str> = Recent::new(2, usize::MAX);
        r.put(1, "a", 0);
        r.put(2, "b", 0);
        r.put(1, "c", 0);
        r.put(3, "d", 0);
        assert_eq!((r.get(&1), r.get(&2), r.get(&3)), (Some("c"), None, Some("d")));
        // Using 1 makes 3 the least recently used.
        r.get(&1);
        r.put(4, "e", 0);
        assert_eq!((r.get(&1), r.get(&3), r.get(&4)), (Some("c"), None, Some("e")));
    }

    #[test]
    fn bytes_are_bounded_and_an_oversized_value_is_not_kept() {
        let r: Recent<u32, u32> = Recent::new(100, 3 * (1000 + ENTRY_OVERHEAD));
        for k in 0..10 {
            r.put(k, k, 1000);
            assert!(r.bytes() <= 3 * (1000 + ENTRY_OVERHEAD));
        }
        assert_eq!(r.len(), 3);
        assert_eq!((r.get(&9), r.get(&6)), (Some(9), None));
        r.put(99, 99, 10_000);
        assert_eq!((r.get(&99), r.len()), (None, 3));
        assert_eq!(r.count(|k| *k >= 8), 2);
        r.forget(|k| *k >= 8);
        assert_eq!((r.len(), r.bytes(), r.count(|k| *k >= 8)), (1, 1000 + ENTRY_OVERHEAD, 0));
    }
}
