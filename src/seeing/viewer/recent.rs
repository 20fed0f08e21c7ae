//! A small process-wide cache of the most recently used values by key, bounded so that what
//! the viewer keeps (past moments, timelines, the last moment shown) cannot grow with the
//! number of simulations a long-running server has seen: the oldest entry goes first.

use std::collections::VecDeque;
use std::sync::Mutex;

/// At most `cap` values by key, most recently used last.
pub struct Recent<K, V> {
    cap: usize,
    items: Mutex<VecDeque<(K, V)>>,
}

impl<K: PartialEq, V: Clone> Recent<K, V> {
    /// An empty cache of at most `cap` entries.
    pub const fn new(cap: usize) -> Self {
        Recent { cap, items: Mutex::new(VecDeque::new()) }
    }

    /// The value under `key`, if still kept.
    pub fn get(&self, key: &K) -> Option<V> {
        let items = self.items.lock().unwrap_or_else(|p| p.into_inner());
        items.iter().find(|(k, _)| k == key).map(|(_, v)| v.clone())
    }

    /// Keeps `value` under `key` (replacing an older one), dropping the oldest entry when full.
    pub fn put(&self, key: K, value: V) {
        let mut items = self.items.lock().unwrap_or_else(|p| p.into_inner());
        items.retain(|(k, _)| *k != key);
        while items.len() >= self.cap.max(1) {
            items.pop_front();
        }
        items.push_back((key, value));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_newest_and_replaces_by_key() {
        let r: Recent<u32, &str> = Recent::new(2);
        r.put(1, "a");
        r.put(2, "b");
        r.put(1, "c");
        r.put(3, "d");
        assert_eq!((r.get(&1), r.get(&2), r.get(&3)), (Some("c"), None, Some("d")));
    }
}
