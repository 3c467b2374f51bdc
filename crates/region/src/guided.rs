//! The skeleton of guided visibility sampling that GVS and GVS++ share: the exploration queue of
//! newly found triangles, the count of triangles each phase found, and the termination rule
//! that ends the rounds.
//!
//! Based on: Wonka, Wimmer, Zhou, Maierhofer, Hesina, Reshetov. Guided Visibility Sampling.
//! ACM TOG 25(3), 2006 (rounds of random sampling; each newly found triangle is explored around
//! the ray that found it; sampling stops after a round that found fewer new triangles than a
//! threshold), and Koch, Wimmer. Guided Visibility Sampling++. 2021, section 4.4 (the queue and
//! the termination rule of GVS++).
//!
//! Its drivers: `gvs.rs` (GVS, one cell), `gvspp/sampler.rs` (GVS++, one cell) and
//! `ray_sharing/` (GVS++ for many cells at once); the per-cell GVS++ state built on it is
//! `gvspp/cell.rs`.

use std::collections::VecDeque;

use crate::rays::Discovery;

/// Newly found triangles waiting for exploration, first in first out, each with the ray that
/// found it.
#[derive(Debug, Default)]
pub(crate) struct ExploreQueue {
    items: Vec<Discovery>,
    /// Index of the next triangle to explore.
    head: usize,
}

impl ExploreQueue {
    /// True when every queued triangle has been taken.
    pub fn is_empty(&self) -> bool {
        self.head == self.items.len()
    }

    /// Queues `discovery`.
    pub fn push(&mut self, discovery: Discovery) {
        self.items.push(discovery);
    }

    /// Queues `discoveries`, in order.
    pub fn extend(&mut self, discoveries: impl IntoIterator<Item = Discovery>) {
        self.items.extend(discoveries);
    }

    /// Takes the next `n` triangles (fewer when fewer wait).
    pub fn take(&mut self, n: usize) -> Vec<Discovery> {
        let end = (self.head + n).min(self.items.len());
        let chunk = self.items[self.head..end].to_vec();
        self.head = end;
        if self.is_empty() {
            // Nothing before `head` is read again: free it.
            self.items.clear();
            self.head = 0;
        }
        chunk
    }
}

/// The phase whose ray first found a triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Random sampling (GVS++ section 4.1).
    Random,
    /// Adaptive border sampling (4.2).
    Abs,
    /// Reverse sampling (4.3).
    Rs,
    /// Another cell's ray (ray sharing).
    Shared,
    /// Neighbour sampling (ours, GVS++ under a budget: `gvspp/neighbours.rs`).
    Adjacent,
}

/// Triangles first found by each phase, in total and in the round under way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Found {
    /// By random rays.
    pub random: usize,
    /// By adaptive border sampling.
    pub abs: usize,
    /// By reverse sampling.
    pub rs: usize,
    /// By other cells' rays.
    pub shared: usize,
    /// By neighbour sampling.
    pub adjacent: usize,
    /// By any phase since the round began.
    pub this_round: usize,
}

impl Found {
    /// Credits `n` newly found triangles to `phase`.
    pub fn credit(&mut self, phase: Phase, n: usize) {
        match phase {
            Phase::Random => self.random += n,
            Phase::Abs => self.abs += n,
            Phase::Rs => self.rs += n,
            Phase::Shared => self.shared += n,
            Phase::Adjacent => self.adjacent += n,
        }
        self.this_round += n;
    }

    /// The new triangles of the round under way; starts the next round's count.
    pub fn end_round(&mut self) -> usize {
        std::mem::take(&mut self.this_round)
    }

    /// The `found_by` of a cell's result: "random", "abs", "rs", and "adjacent" where
    /// neighbour sampling found some.
    pub fn found_by(&self) -> Vec<(&'static str, usize)> {
        let mut list = vec![("random", self.random), ("abs", self.abs), ("rs", self.rs)];
        if self.adjacent > 0 {
            list.push(("adjacent", self.adjacent));
        }
        list
    }

    /// [`Found::found_by`] and "shared".
    pub fn found_by_with_shared(&self) -> Vec<(&'static str, usize)> {
        let mut list = self.found_by();
        list.push(("shared", self.shared));
        list
    }
}

/// The termination rule, applied after every round: the most recent rounds that together cast
/// at least `window` rays found fewer than `threshold` new triangles. With a `window` of 0 the
/// last round alone counts (GVS's rule; GVS++'s too, for rounds of the paper's size).
#[derive(Debug)]
pub(crate) struct Termination {
    threshold: usize,
    window: u64,
    /// (rays, new triangles) of the recent rounds, newest last.
    recent: VecDeque<(u64, usize)>,
}

impl Termination {
    /// The rule over the rounds of the last `window` rays.
    pub fn over_window(threshold: usize, window: u64) -> Self {
        Self {
            threshold,
            window,
            recent: VecDeque::new(),
        }
    }

    /// The rule over the last round alone.
    pub fn per_round(threshold: usize) -> Self {
        Self::over_window(threshold, 0)
    }

    /// Records a round that cast `rays` rays and found `new` triangles; true when the rule
    /// holds.
    pub fn round_done(&mut self, rays: u64, new: usize) -> bool {
        self.recent.push_back((rays, new));
        while self.recent.len() > 1
            && self.recent.iter().skip(1).map(|r| r.0).sum::<u64>() >= self.window
        {
            self.recent.pop_front();
        }
        let window_rays: u64 = self.recent.iter().map(|r| r.0).sum();
        let window_new: usize = self.recent.iter().map(|r| r.1).sum();
        window_rays >= self.window && window_new < self.threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn discovery(triangle: u32) -> Discovery {
        Discovery {
            triangle,
            origin: Vec3::ZERO,
            hit_point: Vec3::X,
        }
    }

    #[test]
    fn queue_takes_in_order_and_empties() {
        let mut queue = ExploreQueue::default();
        assert!(queue.is_empty());
        assert!(queue.take(4).is_empty());
        queue.extend((0..5).map(discovery));
        let first: Vec<u32> = queue.take(3).iter().map(|d| d.triangle).collect();
        assert_eq!(first, [0, 1, 2]);
        queue.push(discovery(7));
        let rest: Vec<u32> = queue.take(10).iter().map(|d| d.triangle).collect();
        assert_eq!(rest, [3, 4, 7]);
        assert!(queue.is_empty());
    }

    #[test]
    fn found_counts_rounds_and_phases() {
        let mut found = Found::default();
        found.credit(Phase::Random, 5);
        found.credit(Phase::Shared, 2);
        assert_eq!(found.end_round(), 7);
        found.credit(Phase::Rs, 1);
        assert_eq!(found.end_round(), 1);
        assert_eq!(found.end_round(), 0);
        assert_eq!(
            found.found_by_with_shared(),
            [("random", 5), ("abs", 0), ("rs", 1), ("shared", 2)]
        );
    }

    #[test]
    fn per_round_rule_looks_at_the_last_round() {
        let mut rule = Termination::per_round(10);
        assert!(!rule.round_done(100, 10));
        assert!(rule.round_done(0, 9));
        assert!(!rule.round_done(100, 11));
    }

    #[test]
    fn window_rule_waits_for_enough_rays() {
        let mut rule = Termination::over_window(10, 1000);
        assert!(!rule.round_done(600, 0));
        // 600 + 600 rays with 4 new: the window is full and found fewer than 10.
        assert!(rule.round_done(600, 4));
        // The oldest round leaves the window once the newer ones alone cover it.
        assert!(!rule.round_done(600, 20));
        assert!(!rule.round_done(600, 0));
        assert!(rule.round_done(1000, 9));
    }
}
