//! A concurrent set of triangle ids: a bitset of atomic words, so many threads can insert with
//! one `fetch_or` each and learn whether they were first — no locks, no hash set.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::TriangleSet;

/// A fixed-capacity concurrent bitset.
#[derive(Debug, Default)]
pub struct AtomicTriangleSet {
    words: Vec<AtomicU64>,
    capacity: usize,
}

impl AtomicTriangleSet {
    /// An empty set for ids `0..capacity`.
    pub fn new(capacity: usize) -> Self {
        Self {
            words: (0..capacity.div_ceil(64))
                .map(|_| AtomicU64::new(0))
                .collect(),
            capacity,
        }
    }

    /// The number of ids the set can hold.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Inserts `id`; true when it was not in the set before (exactly one concurrent inserter of
    /// the same id gets true). Ids past the capacity are ignored and give false.
    pub fn insert(&self, id: u32) -> bool {
        let i = id as usize;
        if i >= self.capacity {
            return false;
        }
        let bit = 1u64 << (i % 64);
        // Relaxed suffices: the set's only invariant is per bit, and readers synchronise
        // through the thread joins of the code that uses it.
        self.words[i / 64].fetch_or(bit, Ordering::Relaxed) & bit == 0
    }

    /// True when `id` is in the set.
    pub fn contains(&self, id: u32) -> bool {
        let i = id as usize;
        i < self.capacity && self.words[i / 64].load(Ordering::Relaxed) & (1u64 << (i % 64)) != 0
    }

    /// Number of ids in the set.
    pub fn count(&self) -> usize {
        self.words
            .iter()
            .map(|w| w.load(Ordering::Relaxed).count_ones() as usize)
            .sum()
    }

    /// A plain copy of the set.
    pub fn to_set(&self) -> TriangleSet {
        let mut set = TriangleSet::with_capacity(self.capacity);
        for (w, word) in self.words.iter().enumerate() {
            let mut bits = word.load(Ordering::Relaxed);
            while bits != 0 {
                let b = bits.trailing_zeros() as usize;
                set.insert(w * 64 + b);
                bits &= bits - 1;
            }
        }
        set
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn empty_set_has_nothing() {
        let s = AtomicTriangleSet::new(0);
        assert_eq!(s.count(), 0);
        assert!(!s.insert(0));
        assert!(!s.contains(0));
    }

    #[test]
    fn exactly_one_concurrent_insert_wins() {
        let s = AtomicTriangleSet::new(1000);
        let wins: usize = (0..8000u32)
            .into_par_iter()
            .filter(|i| s.insert(i % 1000))
            .count();
        assert_eq!(wins, 1000);
        assert_eq!(s.count(), 1000);
        assert_eq!(s.to_set().count_ones(..), 1000);
    }

    #[test]
    fn out_of_range_is_ignored() {
        let s = AtomicTriangleSet::new(10);
        assert!(!s.insert(10));
        assert!(s.insert(9));
        assert!(s.contains(9) && !s.contains(10));
    }
}
