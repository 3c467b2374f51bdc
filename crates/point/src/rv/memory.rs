//! Memory accounting: the budget is split once into fixed parts (visible set, batch ring, bin
//! queues) and one shared occluder pool that bins draw from as their occluders grow.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, sections 6.1 (bounded queues and triangle buffer) and 6.3.1 (a global pool of occluder
//! triangle batches that bins allocate from only when needed, so empty bins cost nothing).
//!
//! The pool counts *capacity* bytes of the occluder vectors, reserved before a vector grows and
//! released after the old buffer is freed, so the accounted figure is an upper bound of the
//! real heap use at every instant, including the moment of a reallocation.

use std::sync::atomic::{AtomicUsize, Ordering};

/// A byte pool with a hard limit and a high-water mark.
#[derive(Debug)]
pub(crate) struct Pool {
    limit: usize,
    used: AtomicUsize,
    peak: AtomicUsize,
}

impl Pool {
    /// A pool of `limit` bytes.
    pub(crate) fn new(limit: usize) -> Self {
        Self {
            limit,
            used: AtomicUsize::new(0),
            peak: AtomicUsize::new(0),
        }
    }

    /// Takes `bytes` from the pool; false (and nothing taken) when that would pass the limit.
    pub(crate) fn try_take(&self, bytes: usize) -> bool {
        let mut cur = self.used.load(Ordering::Relaxed);
        loop {
            let Some(next) = cur.checked_add(bytes).filter(|&n| n <= self.limit) else {
                return false;
            };
            match self
                .used
                .compare_exchange_weak(cur, next, Ordering::Relaxed, Ordering::Relaxed)
            {
                Ok(_) => {
                    self.peak.fetch_max(next, Ordering::Relaxed);
                    return true;
                }
                Err(actual) => cur = actual,
            }
        }
    }

    /// Returns `bytes` to the pool.
    pub(crate) fn give(&self, bytes: usize) {
        let prev = self.used.fetch_sub(bytes, Ordering::Relaxed);
        debug_assert!(prev >= bytes, "pool underflow");
    }

    /// The most bytes ever taken at once.
    pub(crate) fn peak(&self) -> usize {
        self.peak.load(Ordering::Relaxed)
    }
}

/// Makes room for `extra` more elements in `v`, taking the new capacity's bytes from `pool`
/// first (growth by half the capacity, at least 8 elements, falling back to the exact need).
/// False, with `v` unchanged, when the pool cannot give the bytes.
pub(crate) fn reserve_from<T>(v: &mut Vec<T>, extra: usize, pool: &Pool) -> bool {
    let need = v.len() + extra;
    let cap = v.capacity();
    if need <= cap {
        return true;
    }
    let size = std::mem::size_of::<T>();
    let candidates = [need.max(cap + cap / 2).max(8), need];
    for new_cap in candidates {
        if pool.try_take(new_cap * size) {
            v.reserve_exact(new_cap - v.len());
            // reserve_exact may round up; account what was really allocated.
            let got = v.capacity();
            if got > new_cap && !pool.try_take((got - new_cap) * size) {
                // Over-allocation we cannot account: give it all back.
                v.shrink_to(cap);
                pool.give(new_cap * size);
                return false;
            }
            pool.give(cap * size);
            return true;
        }
    }
    false
}

/// Returns the bytes of `v`'s capacity to `pool` and frees it.
pub(crate) fn release_to<T>(v: &mut Vec<T>, pool: &Pool) {
    pool.give(v.capacity() * std::mem::size_of::<T>());
    *v = Vec::new();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_pool_refuses() {
        let p = Pool::new(0);
        assert!(!p.try_take(1));
        assert!(p.try_take(0));
    }

    #[test]
    fn reserve_accounts_capacity() {
        let p = Pool::new(1024);
        let mut v: Vec<u64> = Vec::new();
        assert!(reserve_from(&mut v, 3, &p));
        assert!(v.capacity() >= 3);
        assert_eq!(p.used.load(Ordering::Relaxed), v.capacity() * 8);
        release_to(&mut v, &p);
        assert_eq!(p.used.load(Ordering::Relaxed), 0);
    }

    #[test]
    fn reserve_fails_past_limit() {
        let p = Pool::new(64);
        let mut v: Vec<u64> = Vec::new();
        assert!(!reserve_from(&mut v, 100, &p));
        assert_eq!(v.capacity(), 0);
    }
}
