//! Per-mission state bounded by count and bytes, the least recently used evicted first: a peer
//! that makes a service hold state for ever more missions (plans, publishers) cannot grow it
//! without bound.

use std::collections::HashMap;

use bridge::MissionId;

/// Most plans a process holds (its [`PlanCache`](super::PlanCache), in memory and in its
/// state directory); the least recently used is evicted first.
pub const MAX_HELD_PLANS: usize = 128;

/// Most bytes of plans (encoded) a process holds; at least one plan of the largest size
/// accepted ([`MAX_PLAN_BYTES`](crate::protocol::MAX_PLAN_BYTES)) fits.
pub const MAX_HELD_PLAN_BYTES: usize = 256 << 20;

/// Most per-mission publishers a service keeps (each a Zenoh declaration); the least recently
/// used is undeclared first and made again when its mission is published again.
pub const MAX_MISSION_PUBLISHERS: usize = 64;

const _: () = assert!(MAX_HELD_PLAN_BYTES >= crate::protocol::MAX_PLAN_BYTES);

struct Entry<V> {
    value: V,
    bytes: usize,
    used: u64,
}

/// Values per mission, at most `max_count` of them and `max_bytes` bytes together (the bytes
/// of each are given when it is inserted); inserting beyond either evicts the least recently
/// used (inserted or got) first.
///
/// Our own because the `lru` crate bounds by count only, not by a weight per entry; eviction
/// scans for the oldest tick, O(n) over at most [`MAX_HELD_PLANS`]-sized sets.
pub struct Lru<V> {
    entries: HashMap<MissionId, Entry<V>>,
    tick: u64,
    bytes: usize,
    max_count: usize,
    max_bytes: usize,
}

impl<V> Lru<V> {
    /// An empty set bounded by `max_count` values (at least 1) and `max_bytes` bytes.
    pub fn new(max_count: usize, max_bytes: usize) -> Self {
        Lru {
            entries: HashMap::new(),
            tick: 0,
            bytes: 0,
            max_count: max_count.max(1),
            max_bytes,
        }
    }

    /// Bounded by count only.
    pub fn with_count(max_count: usize) -> Self {
        Lru::new(max_count, usize::MAX)
    }

    fn next_tick(&mut self) -> u64 {
        self.tick += 1;
        self.tick
    }

    /// Inserts (or replaces) `id`'s value of `bytes` bytes, the most recently used; returns
    /// the ids evicted to keep within the bounds. A value larger than `max_bytes` by itself is
    /// not held (its id is returned as evicted, with any value it replaced).
    pub fn insert(&mut self, id: MissionId, value: V, bytes: usize) -> Vec<MissionId> {
        let mut evicted = Vec::new();
        if let Some(old) = self.entries.remove(&id) {
            self.bytes -= old.bytes;
        }
        if bytes > self.max_bytes {
            evicted.push(id);
            return evicted;
        }
        while !self.entries.is_empty()
            && (self.entries.len() + 1 > self.max_count || self.bytes + bytes > self.max_bytes)
        {
            let Some(oldest) = self
                .entries
                .iter()
                .min_by_key(|(_, e)| e.used)
                .map(|(k, _)| *k)
            else {
                break;
            };
            if let Some(e) = self.entries.remove(&oldest) {
                self.bytes -= e.bytes;
            }
            evicted.push(oldest);
        }
        let used = self.next_tick();
        self.entries.insert(id, Entry { value, bytes, used });
        self.bytes += bytes;
        evicted
    }

    /// `id`'s value, now the most recently used.
    pub fn get(&mut self, id: MissionId) -> Option<&mut V> {
        let used = self.next_tick();
        self.entries.get_mut(&id).map(|e| {
            e.used = used;
            &mut e.value
        })
    }

    /// `id`'s value, its use not noted.
    pub fn peek(&self, id: MissionId) -> Option<&V> {
        self.entries.get(&id).map(|e| &e.value)
    }

    /// Removes `id`'s value.
    pub fn remove(&mut self, id: MissionId) -> Option<V> {
        let e = self.entries.remove(&id)?;
        self.bytes -= e.bytes;
        Some(e.value)
    }

    /// Every value held, in no order.
    pub fn values(&self) -> impl Iterator<Item = &V> {
        self.entries.values().map(|e| &e.value)
    }

    /// How many values are held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether none is held.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The bytes of the values held.
    pub fn bytes(&self) -> usize {
        self.bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(n: u64) -> MissionId {
        MissionId(n)
    }

    #[test]
    fn the_least_recently_used_goes_first_by_count() {
        let mut l = Lru::with_count(3);
        for n in 1..=3 {
            assert!(l.insert(id(n), n, 0).is_empty());
        }
        // 1 used again: 2 is now the least recently used
        assert_eq!(l.get(id(1)).copied(), Some(1));
        assert_eq!(l.insert(id(4), 4, 0), [id(2)]);
        assert_eq!(l.len(), 3);
        assert!(l.peek(id(2)).is_none());
        // peek does not count as a use: 3 goes next
        assert_eq!(l.peek(id(3)), Some(&3));
        assert_eq!(l.insert(id(5), 5, 0), [id(3)]);
        // replacing keeps the count
        assert!(l.insert(id(5), 50, 0).is_empty());
        assert_eq!(l.peek(id(5)), Some(&50));
        assert_eq!(l.len(), 3);
    }

    #[test]
    fn bytes_are_bounded_and_counted() {
        let mut l = Lru::new(100, 10);
        assert!(l.insert(id(1), (), 4).is_empty());
        assert!(l.insert(id(2), (), 4).is_empty());
        assert_eq!(l.bytes(), 8);
        // 5 more: 1 goes (least recent), 2 stays
        assert_eq!(l.insert(id(3), (), 5), [id(1)]);
        assert_eq!(l.bytes(), 9);
        // 10 alone: everything else goes
        let mut gone = l.insert(id(4), (), 10);
        gone.sort_by_key(|m| m.0);
        assert_eq!(gone, [id(2), id(3)]);
        assert_eq!((l.len(), l.bytes()), (1, 10));
        // larger than the bound by itself: not held, nothing else evicted
        assert_eq!(l.insert(id(5), (), 11), [id(5)]);
        assert_eq!((l.len(), l.bytes()), (1, 10));
        // a replacement frees the old bytes first
        assert!(l.insert(id(4), (), 3).is_empty());
        assert_eq!(l.bytes(), 3);
        assert_eq!(l.remove(id(4)), Some(()));
        assert_eq!((l.len(), l.bytes()), (0, 0));
    }

    /// A flood of distinct missions never holds more than the bounds.
    #[test]
    fn a_flood_stays_within_the_bounds() {
        let mut l = Lru::new(MAX_HELD_PLANS, 1 << 20);
        let mut evicted = 0;
        for n in 0..10_000u64 {
            evicted += l.insert(id(n), n, 1 + (n as usize * 7919) % 20_000).len();
            assert!(l.len() <= MAX_HELD_PLANS && l.bytes() <= 1 << 20);
        }
        assert_eq!(evicted + l.len(), 10_000);
        // the most recent is held
        assert_eq!(l.peek(id(9_999)), Some(&9_999));
    }
}
