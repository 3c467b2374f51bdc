//! Which occluders have a given silhouette edge: a hash multimap from an undirected screen edge
//! to occluder slots, so that a new occluder triangle finds the occluders it shares an edge with
//! in three look-ups instead of a scan.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 ("adding visible triangle to occluders": a triangle joins the occluders it
//! shares an edge with). The thesis searches each occluder's silhouette half-edges on the GPU;
//! ours, beyond it: near a street's vanishing point a bin holds hundreds of occluders whose
//! rectangles overlap, and the search visited some sixty of them per triangle (measured in
//! `docs/BENCHMARKS.md`). Edges are matched by exact equality of their screen coordinates
//! (shared corners project bit-identically), which is what makes hashing them exact.
//!
//! Open addressing with linear probing and backward-shift deletion, at most half full. The
//! table's memory comes from the occluder pool; when the pool cannot give it, the caller turns
//! the whole index off (the bin then scans linearly, with the same results).

use glam::DVec2;
use sightline_core::random::mix64;

use super::memory::{release_to, reserve_from, Pool};
use super::occluder::Edge;

/// Slot value of an empty table entry.
const EMPTY: u32 = u32::MAX;

/// An undirected edge as bits: its two corners in a fixed order, `-0.0` folded into `0.0`.
type Key = [u64; 4];

#[derive(Clone, Copy, Debug)]
struct Entry {
    key: Key,
    slot: u32,
    /// The key's hash (low bits): deletion and growth move entries without rehashing keys.
    hash: u32,
}

const VACANT: Entry = Entry {
    key: [0; 4],
    slot: EMPTY,
    hash: 0,
};

/// The multimap (see the module documentation). An occluder with the same edge twice (a
/// non-manifold patch) is listed twice, so the map mirrors its edge lists exactly.
#[derive(Debug, Default)]
pub(crate) struct EdgeMap {
    table: Vec<Entry>,
    len: usize,
}

fn key_of(e: &Edge) -> Key {
    // Adding zero turns -0.0 into 0.0, the only two equal values with different bits (screen
    // coordinates of occluder triangles are finite).
    let bits = |p: DVec2| [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits()];
    let first = (e.a.x, e.a.y) <= (e.b.x, e.b.y);
    let (p, q) = if first { (e.a, e.b) } else { (e.b, e.a) };
    let (p, q) = (bits(p), bits(q));
    [p[0], p[1], q[0], q[1]]
}

fn hash(k: &Key) -> u64 {
    // The words rotated apart and combined, then SplitMix64's mix: screen coordinates differ
    // mostly in low mantissa bits, which the table index (the low bits) must see.
    mix64(k[0] ^ k[1].rotate_left(16) ^ k[2].rotate_left(32) ^ k[3].rotate_left(48))
}

impl EdgeMap {
    fn mask(&self) -> usize {
        self.table.len() - 1
    }

    /// Home position of a stored entry (tables never exceed 2^32 entries: the pool is far
    /// smaller).
    fn home_of(&self, e: &Entry) -> usize {
        e.hash as usize & self.mask()
    }

    /// Lists `slot` under edge `e`; false when the pool cannot give the memory (the map is
    /// then unchanged).
    pub(crate) fn insert(&mut self, e: &Edge, slot: u32, pool: &Pool) -> bool {
        if (self.len + 1) * 2 > self.table.len() && !self.grow(pool) {
            return false;
        }
        let key = key_of(e);
        let h = hash(&key);
        let mut i = h as usize & self.mask();
        while self.table[i].slot != EMPTY {
            i = (i + 1) & self.mask();
        }
        self.table[i] = Entry {
            key,
            slot,
            hash: h as u32,
        };
        self.len += 1;
        true
    }

    /// Doubles the table (at least 16 entries) and re-inserts everything.
    fn grow(&mut self, pool: &Pool) -> bool {
        let size = (self.table.len() * 2).max(16);
        let mut bigger = Vec::new();
        if !reserve_from(&mut bigger, size, pool) {
            return false;
        }
        bigger.resize(size, VACANT);
        let old = std::mem::replace(&mut self.table, bigger);
        for entry in old.iter().filter(|e| e.slot != EMPTY) {
            let mut i = self.home_of(entry);
            while self.table[i].slot != EMPTY {
                i = (i + 1) & self.mask();
            }
            self.table[i] = *entry;
        }
        let mut old = old;
        release_to(&mut old, pool);
        true
    }

    /// Position of one entry of `slot` under `key`.
    fn find(&self, key: &Key, slot: u32) -> Option<usize> {
        if self.table.is_empty() {
            return None;
        }
        let h = hash(key);
        let mut i = h as usize & self.mask();
        loop {
            let entry = &self.table[i];
            if entry.slot == EMPTY {
                return None;
            }
            if entry.slot == slot && entry.hash == h as u32 && entry.key == *key {
                return Some(i);
            }
            i = (i + 1) & self.mask();
        }
    }

    /// Unlists one entry of `slot` under edge `e` (either direction); false when there is none.
    pub(crate) fn remove(&mut self, e: &Edge, slot: u32) -> bool {
        let Some(mut hole) = self.find(&key_of(e), slot) else {
            return false;
        };
        // Backward-shift deletion: pull later entries of the probe run into the hole when
        // their home does not lie cyclically in (hole, j].
        let mask = self.mask();
        let mut j = hole;
        loop {
            j = (j + 1) & mask;
            if self.table[j].slot == EMPTY {
                break;
            }
            let home = self.home_of(&self.table[j]);
            let home_in_gap = if hole <= j {
                hole < home && home <= j
            } else {
                hole < home || home <= j
            };
            if !home_in_gap {
                self.table[hole] = self.table[j];
                hole = j;
            }
        }
        self.table[hole] = VACANT;
        self.len -= 1;
        true
    }

    /// Moves one entry under edge `e` from `from` to `to` (an occluder merged into another);
    /// false when there is none.
    pub(crate) fn repoint(&mut self, e: &Edge, from: u32, to: u32) -> bool {
        match self.find(&key_of(e), from) {
            Some(i) => {
                self.table[i].slot = to;
                true
            }
            None => false,
        }
    }

    /// Calls `f` with each slot listed under edge `e` (either direction), once per entry.
    pub(crate) fn for_each_slot(&self, e: &Edge, mut f: impl FnMut(u32)) {
        if self.table.is_empty() {
            return;
        }
        let key = key_of(e);
        let h = hash(&key);
        let mut i = h as usize & self.mask();
        loop {
            let entry = &self.table[i];
            if entry.slot == EMPTY {
                return;
            }
            if entry.hash == h as u32 && entry.key == key {
                f(entry.slot);
            }
            i = (i + 1) & self.mask();
        }
    }

    /// Entries listed.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Returns all memory to `pool`; the map is empty.
    pub(crate) fn release(&mut self, pool: &Pool) {
        release_to(&mut self.table, pool);
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge(a: (f64, f64), b: (f64, f64)) -> Edge {
        Edge {
            a: DVec2::new(a.0, a.1),
            b: DVec2::new(b.0, b.1),
        }
    }

    fn slots(m: &EdgeMap, e: &Edge) -> Vec<u32> {
        let mut v = Vec::new();
        m.for_each_slot(e, |s| v.push(s));
        v.sort_unstable();
        v
    }

    #[test]
    fn finds_edges_in_either_direction_and_signed_zero() {
        let pool = Pool::new(1 << 20);
        let mut m = EdgeMap::default();
        assert!(m.insert(&edge((0.0, 1.0), (2.0, 3.0)), 7, &pool));
        assert_eq!(slots(&m, &edge((2.0, 3.0), (0.0, 1.0))), vec![7]);
        assert_eq!(slots(&m, &edge((-0.0, 1.0), (2.0, 3.0))), vec![7]);
        assert!(slots(&m, &edge((0.0, 1.0), (2.0, 3.5))).is_empty());
    }

    /// Against a plain list of (edge, slot) pairs, through many inserts, removals and
    /// repoints with heavy collisions (few distinct edges) and table growth.
    #[test]
    fn matches_a_list_through_churn() {
        let pool = Pool::new(1 << 24);
        let mut m = EdgeMap::default();
        let mut list: Vec<(Edge, u32)> = Vec::new();
        let mut rng = sightline_core::random::SplitMix64::new(0x1234_5678);
        let mut next = || rng.next_u64();
        let e = |i: u64| edge(((i % 7) as f64, 0.5), (1.0, (i % 5) as f64 * 0.25));
        for _ in 0..20_000 {
            let r = next();
            let (edge_id, slot) = (r % 40, ((r >> 8) % 6) as u32);
            match (r >> 16) % 3 {
                0 | 1 => {
                    assert!(m.insert(&e(edge_id), slot, &pool));
                    list.push((e(edge_id), slot));
                }
                _ => {
                    let had = list
                        .iter()
                        .position(|(f, s)| key_of(f) == key_of(&e(edge_id)) && *s == slot);
                    assert_eq!(m.remove(&e(edge_id), slot), had.is_some());
                    if let Some(k) = had {
                        list.swap_remove(k);
                    }
                }
            }
            if r % 97 == 0 {
                let to = ((r >> 24) % 6) as u32;
                let had = list
                    .iter()
                    .position(|(f, s)| key_of(f) == key_of(&e(edge_id)) && *s == slot);
                assert_eq!(m.repoint(&e(edge_id), slot, to), had.is_some());
                if let Some(k) = had {
                    list[k].1 = to;
                }
            }
        }
        assert_eq!(m.len(), list.len());
        for i in 0..40 {
            let mut want: Vec<u32> = list
                .iter()
                .filter(|(f, _)| key_of(f) == key_of(&e(i)))
                .map(|&(_, s)| s)
                .collect();
            want.sort_unstable();
            assert_eq!(slots(&m, &e(i)), want, "edge {i}");
        }
        m.release(&pool);
        assert!(pool.try_take(1 << 24), "release returned all memory");
    }

    #[test]
    fn an_exhausted_pool_refuses_and_keeps_the_map() {
        let pool = Pool::new(16 * std::mem::size_of::<Entry>());
        let mut m = EdgeMap::default();
        for i in 0..8 {
            assert!(m.insert(&edge((f64::from(i), 0.0), (0.0, 1.0)), i, &pool));
        }
        // The ninth entry needs a table of 32.
        assert!(!m.insert(&edge((9.0, 0.0), (0.0, 1.0)), 9, &pool));
        assert_eq!(slots(&m, &edge((3.0, 0.0), (0.0, 1.0))), vec![3]);
    }
}
