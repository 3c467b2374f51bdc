//! GVS++'s schedule by yield, under a budget and to convergence: each batch of rays goes to the
//! kind of ray (random, coarse border sampling, its refinement, reverse or neighbour sampling)
//! whose recent batches found the most new triangles per ray. Without a budget the bake ends
//! when the termination rule holds (fewer than `T` new triangles over the batches of the last
//! [`TERMINATION_WINDOW`] rays, the paper's rule at its round size) while nothing is waiting
//! for exploration.
//!
//! Ours, not the paper's: Koch and Wimmer (GVS++ 2021, section 4.4) drain the exploration queue
//! after every round of 10^7 random rays and reverse-sample each discontinuity as soon as border
//! sampling finds it. That order suits a GPU that casts a round in milliseconds, not a CPU budget
//! of a few million rays. On a munich cell above the roofs, one million rays in rounds that grew
//! from 16k random rays (the previous schedule) went 34 % to random rays (1,832 new triangles),
//! 9 % to border sampling (1,814, i.e. 47 rays per triangle) and 57 % to reverse sampling (435,
//! 1,320 rays per triangle); the bake equalled RAND. Here discontinuities wait in their own
//! queue, every batch of [`YIELD_BATCH`] rays goes to the kind with the best yield — an
//! exponential average of new triangles per ray over that kind's own batches — and a kind that
//! has cast less than [`FLOOR_SHARE`] of the rays so far goes next while it has work, so no
//! estimate goes stale and random rays keep finding what no neighbour leads to. The same cell
//! then found 8,302 triangles (1,395 random, 6,822 border, 85 reverse) and its error fell from
//! 216 to 3.4 px per view (docs/BENCHMARKS.md has the measurements on every shared scene).
//!
//! Border sampling runs in two passes here. The paper's 20 samples per border edge are many for
//! a triangle a few pixels wide: on the dragon's cells, whose 14,000 visible triangles are each a
//! few pixels from the cell, a million rays explored only part of the queue at 69 rays per
//! triangle (2.8x better than RAND). The first pass casts the 9 border vertices and edge samples
//! `ABS_ANGLE_STEP` (3 mrad) apart as seen from the discovery's origin (1 to 20 per edge); a
//! triangle that got fewer than 20 somewhere joins a refinement queue, whose batches (a fourth
//! kind) cast the paper's edge samples when their yield is the best. At 1M rays the dragon's
//! cells are then 18x better than RAND.
//!
//! A fifth kind, neighbour sampling (`neighbours.rs`), aims from spread origins at the corners
//! of triangles that touch a found one and are not found yet: slivers that border sampling
//! passes by. On fan at 7M rays it took the six cells' missed pixels from 5 to 1.
//!
//! Bakes to convergence used the paper's rounds until the eighteenth session: the rule needs
//! no rounds, only the rays and new triangles of recent batches. By yield, on 36 cells of six
//! scenes (`bench pvs`, docs/BENCHMARKS.md), converged sets had fewer error pixels on 9 cells
//! and more on 1 (etoile: 5 pixels in 600 views against 1), the same on 26 (most without any
//! error), with fewer rays on five of the six scenes (10 to 20 M a cell against 20 to 26 M; 40 M
//! against 33 M on the open generated city, where the rounds stopped early).
//!
//! [`TERMINATION_WINDOW`]: super::TERMINATION_WINDOW

use glam::Vec3;
use sightline_core::{Hit, Ray};

use crate::guided::Phase;
use crate::rays::{cast, discover};
use crate::sampler::{CellContext, ConvergencePoint, Tally};

use super::cell::{fitting, GvsppCell};
use super::neighbours::NeighbourSampling;
use super::params::YIELD_BATCH;

/// The kinds of GVS++ rays a batch can be.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Random rays (4.1).
    Random = 0,
    /// Coarse adaptive border sampling of queued triangles (4.2, edge samples
    /// `ABS_ANGLE_STEP` apart).
    Border = 1,
    /// Reverse sampling of waiting discontinuities (4.3).
    Reverse = 2,
    /// The rest of the paper's edge samples of coarsely sampled triangles (4.2).
    Refine = 3,
    /// Rays at the corners of found triangles' unfound neighbours (ours: `neighbours.rs`).
    Neighbour = 4,
}

impl Kind {
    /// The phase a kind's finds are credited to.
    pub(crate) fn phase(self) -> Phase {
        match self {
            Kind::Random => Phase::Random,
            Kind::Border | Kind::Refine => Phase::Abs,
            Kind::Reverse => Phase::Rs,
            Kind::Neighbour => Phase::Adjacent,
        }
    }

    /// Every kind, in the order of their values (the index of their counters).
    pub(crate) const ALL: [Kind; 5] = [
        Kind::Random,
        Kind::Border,
        Kind::Reverse,
        Kind::Refine,
        Kind::Neighbour,
    ];
}

/// Each kind casts at least this share of the rays while it has work.
pub(crate) const FLOOR_SHARE: f64 = 0.1;

/// Weight of a batch's yield in its kind's running estimate.
const SMOOTHING: f64 = 0.3;

/// The yield estimates and ray counts of the kinds.
#[derive(Clone, Debug, Default)]
pub(crate) struct YieldScheduler {
    rays: [u64; 5],
    /// Estimated new triangles per ray; `None` before the kind's first batch.
    estimate: [Option<f64>; 5],
}

impl YieldScheduler {
    /// The kind the next batch casts, among those with work (`has_work[kind as usize]`):
    /// an untried kind first, then one below its floor share, then the best estimate (the
    /// first of equals); `None` when no kind has work.
    pub fn choose(&self, has_work: [bool; 5]) -> Option<Kind> {
        let total: u64 = self.rays.iter().sum();
        let ready = || Kind::ALL.into_iter().filter(|k| has_work[*k as usize]);
        ready()
            .find(|k| self.estimate[*k as usize].is_none())
            .or_else(|| {
                ready().find(|k| (self.rays[*k as usize] as f64) < FLOOR_SHARE * total as f64)
            })
            .or_else(|| {
                ready().fold(None, |best: Option<Kind>, k| match best {
                    Some(b) if self.yield_of(b) >= self.yield_of(k) => Some(b),
                    _ => Some(k),
                })
            })
    }

    fn yield_of(&self, kind: Kind) -> f64 {
        self.estimate[kind as usize].unwrap_or(0.0)
    }

    /// Records a batch of `kind` that cast `rays` rays and found `new` triangles (a batch of
    /// no rays, e.g. reverse sampling whose origins were all hidden, changes nothing).
    pub fn record(&mut self, kind: Kind, rays: usize, new: usize) {
        if rays == 0 {
            return;
        }
        let k = kind as usize;
        self.rays[k] += rays as u64;
        let y = new as f64 / rays as f64;
        self.estimate[k] = Some(match self.estimate[k] {
            None => y,
            Some(e) => e + SMOOTHING * (y - e),
        });
    }
}

/// Samples `cell` batch by batch until `tally`'s budget is spent, or without a budget until the
/// termination rule holds (or until the cell has no free space for random origins).
/// Deterministic for a seed: the choice depends only on counts. Returns whether the
/// termination rule (over [`TERMINATION_WINDOW`] rays of batches) held at some point while no
/// exploration work was waiting: the cell had converged then, although a budgeted bake goes on
/// until its budget is spent.
///
/// [`TERMINATION_WINDOW`]: super::TERMINATION_WINDOW
pub(crate) fn sample_by_yield(
    ctx: &CellContext<'_>,
    cell: &mut GvsppCell,
    tally: &mut Tally,
    progress: &(dyn Fn(&ConvergencePoint) + Sync),
) -> bool {
    let mut scheduler = YieldScheduler::default();
    let mut rule_held = false;
    while !tally.exhausted() {
        let Some(kind) = scheduler.choose(cell.work()) else {
            break;
        };
        let before = tally.rays;
        let new = if kind == Kind::Random {
            match random_batch(ctx, cell, tally, progress) {
                Some(new) => new,
                None => break,
            }
        } else {
            let is_found = |id: u32| tally.pvs.contains(id);
            let (rays, targets) = guided_batch(ctx, cell, kind, tally.rays_left(), is_found);
            let (hits, new) = cast_and_credit(ctx, cell, tally, &rays, kind.phase(), progress);
            let discontinuities = cell.discontinuities(&rays, &hits, &targets);
            cell.pending.extend(discontinuities);
            new
        };
        scheduler.record(kind, (tally.rays - before) as usize, new);
        rule_held |= cell.batch_done(tally.rays - before, new) && cell.idle();
        // Without a budget the rule ends the bake; under one the budget does (so that
        // comparisons at equal rays are fair).
        if rule_held && tally.budget_unlimited() {
            break;
        }
    }
    rule_held
}

/// One batch of random rays (4.1); the number of new triangles, `None` when the cell has no
/// free space for origins.
fn random_batch(
    ctx: &CellContext<'_>,
    cell: &mut GvsppCell,
    tally: &mut Tally,
    progress: &(dyn Fn(&ConvergencePoint) + Sync),
) -> Option<usize> {
    let new = cell
        .random
        .sample_round(ctx, tally, YIELD_BATCH as u64, progress)?;
    let n = new.len();
    cell.found_new(ctx, Phase::Random, new);
    Some(n)
}

/// The rays of one batch of a guided `kind` (not random), about [`YIELD_BATCH`] of them and
/// no more than `rays_left` allow (to within one item), with the targets of the rays searched
/// for discontinuities (border kinds; empty for the others). Both drivers of the schedule by
/// yield take their batches here: this per-cell sampler and the shared-ray bake.
/// - border sampling (4.2) of the next queued triangles, coarse (see the module docs);
/// - refinement: the rest of the paper's edge samples of the next coarsely sampled triangles;
/// - reverse sampling (4.3) of the oldest waiting discontinuities;
/// - neighbour sampling of the next waiting neighbours that `is_found` does not know.
pub(crate) fn guided_batch(
    ctx: &CellContext<'_>,
    cell: &mut GvsppCell,
    kind: Kind,
    rays_left: u64,
    is_found: impl Fn(u32) -> bool,
) -> (Vec<Ray>, Vec<Option<Vec3>>) {
    match kind {
        Kind::Random => (Vec::new(), Vec::new()),
        Kind::Border => {
            let take = batch_items(cell.abs_rays_per_triangle(), rays_left);
            cell.coarse_abs_rays(ctx, take)
        }
        Kind::Refine => {
            let take = batch_items(cell.abs_rays_per_triangle(), rays_left);
            cell.refine_abs_rays(ctx, take)
        }
        Kind::Reverse => {
            let size = batch_items(cell.rs_rays_per_discontinuity(), rays_left);
            let group: Vec<_> = cell.pending.drain(..size.min(cell.pending.len())).collect();
            (cell.rs_rays(ctx, &group), Vec::new())
        }
        Kind::Neighbour => {
            let take = batch_items(NeighbourSampling::rays_per_triangle(), rays_left);
            let rays =
                (cell.neighbours.as_mut()).map_or_else(Vec::new, |n| n.rays(ctx, take, is_found));
            (rays, Vec::new())
        }
    }
}

/// How many items costing up to `per_item` rays each make about one batch, and no more than
/// `rays_left` allow (at least one, so a batch always makes progress).
fn batch_items(per_item: usize, rays_left: u64) -> usize {
    let per_item = per_item.max(1);
    (YIELD_BATCH / per_item)
        .max(1)
        .min(fitting(rays_left, per_item))
}

/// Casts `rays`, adds what they hit to the PVS, queues and credits the new triangles to
/// `phase`, and counts the batch; returns the hits and the number of new triangles.
fn cast_and_credit(
    ctx: &CellContext<'_>,
    cell: &mut GvsppCell,
    tally: &mut Tally,
    rays: &[Ray],
    phase: Phase,
    progress: &(dyn Fn(&ConvergencePoint) + Sync),
) -> (Vec<Hit>, usize) {
    let hits = cast(ctx.caster, rays);
    let new = discover(&tally.pvs, rays, &hits);
    let n = new.len();
    cell.found_new(ctx, phase, new);
    tally.batch_done(rays.len(), progress);
    (hits, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [bool; 5] = [true, true, true, false, false];

    #[test]
    fn untried_kinds_go_first_then_the_best_yield() {
        let mut s = YieldScheduler::default();
        assert_eq!(s.choose(ALL), Some(Kind::Random));
        s.record(Kind::Random, 1000, 10);
        assert_eq!(s.choose(ALL), Some(Kind::Border));
        // No border work yet: reverse sampling is the untried kind with work.
        assert_eq!(
            s.choose([true, false, true, false, false]),
            Some(Kind::Reverse)
        );
        s.record(Kind::Border, 1000, 50);
        s.record(Kind::Reverse, 1000, 1);
        assert_eq!(s.choose(ALL), Some(Kind::Border));
        assert_eq!(
            s.choose([true, false, true, false, false]),
            Some(Kind::Random)
        );
        assert_eq!(s.choose([false; 5]), None);
        // Refinement work appears: untried, it goes next.
        assert_eq!(
            s.choose([true, true, true, true, false]),
            Some(Kind::Refine)
        );
        s.record(Kind::Refine, 1000, 5);
        // Then neighbour work.
        assert_eq!(s.choose([true; 5]), Some(Kind::Neighbour));
    }

    #[test]
    fn a_kind_below_its_floor_share_goes_next_while_it_has_work() {
        let mut s = YieldScheduler::default();
        s.record(Kind::Random, 1000, 1);
        s.record(Kind::Border, 100_000, 5000);
        s.record(Kind::Reverse, 20_000, 1);
        // Random has 1000 of 121,000 rays (< 10 %), though its yield is below border's.
        assert_eq!(s.choose(ALL), Some(Kind::Random));
        s.record(Kind::Random, 20_000, 0);
        assert_eq!(s.choose(ALL), Some(Kind::Border));
    }

    #[test]
    fn estimates_follow_recent_batches() {
        let mut s = YieldScheduler::default();
        s.record(Kind::Random, 1000, 100);
        s.record(Kind::Border, 1000, 50);
        s.record(Kind::Reverse, 1000, 40);
        assert_eq!(s.choose(ALL), Some(Kind::Random));
        // Random rays stop finding anything: their estimate falls below border sampling's.
        for _ in 0..4 {
            s.record(Kind::Random, 1000, 0);
        }
        assert_eq!(s.choose(ALL), Some(Kind::Border));
        // An empty batch (no rays) leaves the estimates alone.
        s.record(Kind::Border, 0, 0);
        assert_eq!(s.choose(ALL), Some(Kind::Border));
    }
}
