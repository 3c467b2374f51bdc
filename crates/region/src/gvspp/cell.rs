//! One view cell's GVS++ state, stepped phase by phase by both drivers: the per-cell sampler
//! (`sampler.rs` and, under a budget, `by_yield.rs`, which cast the cell's rays alone) and the
//! shared-ray bake (`ray_sharing/`, which casts many cells' rays together). The state holds what
//! a cell carries from phase to phase and round to round: its random-ray sequence, its
//! reverse-sampling origins, the exploration queue, the discontinuities waiting for reverse
//! sampling (budgeted bakes only), the count of triangles each phase found and the termination
//! rule. The drivers cast the rays and keep the PVS.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4; the
//! schedule by yield under a budget is ours (see `gvspp/mod.rs`).

use std::collections::VecDeque;

use glam::Vec3;
use sightline_core::{Hit, Ray};

use super::guided_rays::{
    abs_rays, find_discontinuities, Discontinuity, EdgeSamples, ReverseOrigins,
};
use super::neighbours::NeighbourSampling;
use super::params::ABS_ANGLE_STEP;
use super::params::{GvsPlusPlusParams, ABS_CHUNK, EXPLORE_RAYS_PER_TRIANGLE, TERMINATION_WINDOW};
use crate::guided::{ExploreQueue, Found, Phase, Termination};
use crate::rays::{Discovery, RandomRays};
use crate::sampler::CellContext;

/// How a driver runs a cell's rounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rounds {
    /// Rounds of `n_rand` random rays that drain the queue, ended by the termination rule over
    /// the last [`TERMINATION_WINDOW`] rays: the per-cell bake without a budget, or with
    /// `fixed_rounds`.
    Paper,
    /// No rounds: batches of whichever kind of ray yields best, until the budget is spent (the
    /// per-cell bake under a budget, `by_yield.rs`).
    ByYield,
    /// Rounds of `n_rand` random rays that drain the queue, ended when one round alone found
    /// fewer than `T` new triangles: the shared-ray bake.
    PaperPerRound,
}

/// One cell's GVS++ state (see the module docs).
pub(crate) struct GvsppCell {
    /// The cell's random rays (4.1); each round continues the sequence.
    pub random: RandomRays,
    reverse: ReverseOrigins,
    /// Groups of discontinuities reverse-sampled so far: each group takes a fresh stretch of
    /// the Halton sequence of surface origins.
    rs_groups: u64,
    /// Triangles waiting for ABS and RS (4.4's queue).
    pub queue: ExploreQueue,
    /// Triangles whose coarse border sampling left out some of the paper's edge samples,
    /// waiting for the rest (scheduled by yield only).
    pub refine: ExploreQueue,
    /// Discontinuities waiting for reverse sampling (scheduled by yield only: the paper's
    /// rounds reverse-sample them as soon as border sampling finds them).
    pub pending: VecDeque<Discontinuity>,
    /// Neighbours of found triangles waiting to be aimed at (scheduled by yield only).
    pub neighbours: Option<NeighbourSampling>,
    /// Triangles found by each phase.
    pub found: Found,
    termination: Termination,
    n_rand: u64,
    n_abs_edge: u32,
    /// Border offset `Δ_ABS` in scene units.
    delta_abs: f32,
    /// Discontinuity threshold `Δ` in scene units.
    delta: f32,
    /// Whether edge samples are searched for discontinuities too
    /// ([`GvsPlusPlusParams::edge_discontinuities`]).
    edge_discontinuities: bool,
}

impl GvsppCell {
    /// The state of `ctx.cell` before its first round.
    pub fn new(ctx: &CellContext<'_>, p: &GvsPlusPlusParams, rounds: Rounds) -> Self {
        let diagonal = ctx.scene.bounds().diagonal().max(f32::MIN_POSITIVE);
        let termination = match rounds {
            Rounds::PaperPerRound => Termination::per_round(p.termination_threshold),
            _ => Termination::over_window(p.termination_threshold, TERMINATION_WINDOW),
        };
        Self {
            random: RandomRays::new(ctx.cell, ctx.scene, ctx.seed),
            reverse: ReverseOrigins::new(ctx, p.n_rs_edge, p.n_rs_area),
            rs_groups: 0,
            queue: ExploreQueue::default(),
            refine: ExploreQueue::default(),
            pending: VecDeque::new(),
            neighbours: (rounds == Rounds::ByYield).then(|| NeighbourSampling::new(ctx)),
            found: Found::default(),
            termination,
            n_rand: p.n_rand,
            n_abs_edge: p.n_abs_edge,
            delta_abs: p.delta_abs * diagonal,
            delta: p.delta_discontinuity * diagonal,
            edge_discontinuities: p.edge_discontinuities,
        }
    }

    /// Random rays a round casts (`n_rand`).
    pub fn round_size(&self) -> u64 {
        self.n_rand
    }

    /// Credits the triangles `phase` found to it and queues them for exploration (and, under
    /// a budget, their neighbours for neighbour sampling).
    pub fn found_new(&mut self, ctx: &CellContext<'_>, phase: Phase, new: Vec<Discovery>) {
        self.found.credit(phase, new.len());
        if let Some(n) = &mut self.neighbours {
            n.found(ctx, new.iter().map(|d| d.triangle));
        }
        self.queue.extend(new);
    }

    /// How many queued triangles the next exploration step of a round takes with `rays_left`
    /// rays left in the budget (`u64::MAX` without a ray limit): a whole [`ABS_CHUNK`], or no
    /// more than the rays left can explore, so a small budget is kept to within one
    /// triangle's step.
    pub fn explore_take(&self, rays_left: u64) -> usize {
        ABS_CHUNK.min(fitting(rays_left, EXPLORE_RAYS_PER_TRIANGLE as usize))
    }

    /// Takes up to `n` triangles off the queue and returns their ABS rays (4.2) with, for each
    /// ray searched for a discontinuity (at a border vertex, and with edge discontinuities at
    /// every sample), its target.
    pub fn abs_rays(&mut self, ctx: &CellContext<'_>, n: usize) -> (Vec<Ray>, Vec<Option<Vec3>>) {
        let chunk = self.queue.take(n);
        let (rays, targets, _) = abs_rays(
            ctx,
            &chunk,
            self.delta_abs,
            EdgeSamples::Fixed(self.n_abs_edge),
            self.edge_discontinuities,
        );
        (rays, targets)
    }

    /// Takes up to `n` triangles off the queue and returns their coarse ABS rays (the border
    /// vertices, and edge samples [`ABS_ANGLE_STEP`] apart as seen from the discovery's origin)
    /// with the targets of the rays searched for discontinuities (as [`GvsppCell::abs_rays`]);
    /// triangles that got fewer edge samples than `n_abs_edge` join [`GvsppCell::refine`].
    pub fn coarse_abs_rays(
        &mut self,
        ctx: &CellContext<'_>,
        n: usize,
    ) -> (Vec<Ray>, Vec<Option<Vec3>>) {
        let chunk = self.queue.take(n);
        let samples = EdgeSamples::Coarse {
            n: self.n_abs_edge,
            step: ABS_ANGLE_STEP,
        };
        let (rays, targets, partial) = abs_rays(
            ctx,
            &chunk,
            self.delta_abs,
            samples,
            self.edge_discontinuities,
        );
        self.refine.extend(
            chunk
                .iter()
                .zip(partial)
                .filter(|(_, p)| *p)
                .map(|(d, _)| *d),
        );
        (rays, targets)
    }

    /// Takes up to `n` triangles off [`GvsppCell::refine`] and returns the paper's edge samples
    /// of their border (no vertices: the coarse pass cast those), with their targets where
    /// edge samples are searched for discontinuities.
    pub fn refine_abs_rays(
        &mut self,
        ctx: &CellContext<'_>,
        n: usize,
    ) -> (Vec<Ray>, Vec<Option<Vec3>>) {
        let chunk = self.refine.take(n);
        let samples = EdgeSamples::EdgesOnly(self.n_abs_edge);
        let (rays, targets, _) = abs_rays(
            ctx,
            &chunk,
            self.delta_abs,
            samples,
            self.edge_discontinuities,
        );
        (rays, targets)
    }

    /// The discontinuities (4.3) of ABS rays `rays` aimed at `targets`, which hit `hits`.
    pub fn discontinuities(
        &self,
        rays: &[Ray],
        hits: &[Hit],
        targets: &[Option<Vec3>],
    ) -> Vec<Discontinuity> {
        find_discontinuities(rays, hits, targets, self.delta)
    }

    /// ABS rays per explored triangle.
    pub fn abs_rays_per_triangle(&self) -> usize {
        9 + 3 * self.n_abs_edge as usize
    }

    /// RS rays per discontinuity (at most).
    pub fn rs_rays_per_discontinuity(&self) -> usize {
        self.reverse.origins_per_discontinuity()
    }

    /// Discontinuities reverse-sampled together: a batch of about [`crate::rays::BATCH`] rays,
    /// and no more than `rays_left` rays allow (at least one).
    pub fn rs_group_size(&self, rays_left: u64) -> usize {
        self.reverse
            .group_size()
            .min(fitting(rays_left, self.reverse.origins_per_discontinuity()))
    }

    /// The RS rays (4.3) of a group of discontinuities.
    pub fn rs_rays(&mut self, ctx: &CellContext<'_>, group: &[Discontinuity]) -> Vec<Ray> {
        let rays = self.reverse.rays(ctx, group, self.rs_groups);
        self.rs_groups += 1;
        rays
    }

    /// Ends a round that cast `round_rays` rays and returns whether the termination rule
    /// (4.4) holds.
    pub fn end_round(&mut self, round_rays: u64) -> bool {
        let new = self.found.end_round();
        self.termination.round_done(round_rays, new)
    }

    /// Records a batch of the schedule by yield that cast `rays` rays and found `new`
    /// triangles; whether the termination rule holds over the recent batches.
    pub fn batch_done(&mut self, rays: u64, new: usize) -> bool {
        self.termination.round_done(rays, new)
    }

    /// Which kinds of batch of the schedule by yield have work, indexed by the kind's value
    /// (random, border, reverse, refinement, neighbour; random rays always have work).
    pub fn work(&self) -> [bool; 5] {
        [
            true,
            !self.queue.is_empty(),
            !self.pending.is_empty(),
            !self.refine.is_empty(),
            self.neighbours.as_ref().is_some_and(|n| n.has_work()),
        ]
    }

    /// Nothing waits for exploration: only random rays have work.
    pub fn idle(&self) -> bool {
        !self.work()[1..].contains(&true)
    }
}

/// How many steps costing `cost` rays each fit in `rays_left` (at least one, so a step always
/// makes progress; with no ray limit, `u64::MAX`, any count fits).
pub(crate) fn fitting(rays_left: u64, cost: usize) -> usize {
    (rays_left / cost.max(1) as u64)
        .min(usize::MAX as u64)
        .max(1) as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;
    use sightline_core::Scene;

    use crate::viewcell::ViewCell;

    /// A unit cell and a box in front of it.
    fn box_scene() -> (Scene, ViewCell) {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::new(3.0, -1.0, -1.0), Vec3::new(4.0, 1.0, 1.0));
        let cell = ViewCell::aabb(Vec3::ZERO, Vec3::ONE).unwrap();
        (b.finish(), cell)
    }

    /// Runs `f` with the context of `box_scene`'s cell.
    fn with_box_cell(f: impl FnOnce(&CellContext<'_>)) {
        let (scene, cell) = box_scene();
        let bvh = Bvh::build(&scene);
        f(&CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 1,
            free_space: None,
        });
    }

    fn params() -> GvsPlusPlusParams {
        GvsPlusPlusParams {
            n_rand: 100_000,
            ..GvsPlusPlusParams::default()
        }
    }

    #[test]
    fn paper_rounds_keep_n_rand_and_take_whole_chunks_within_the_budget() {
        with_box_cell(|ctx| {
            let mut state = GvsppCell::new(ctx, &params(), Rounds::Paper);
            assert_eq!(state.round_size(), 100_000);
            assert_eq!(state.explore_take(u64::MAX), ABS_CHUNK);
            // Ten triangles' worth of rays left: ten triangles; less than one: still one.
            let ten = 10 * EXPLORE_RAYS_PER_TRIANGLE as u64;
            assert_eq!(state.explore_take(ten), 10);
            assert_eq!(state.explore_take(1), 1);
            state.end_round(150_000);
            assert_eq!(state.round_size(), 100_000);
        });
    }

    #[test]
    fn empty_queue_gives_no_abs_rays() {
        with_box_cell(|ctx| {
            let mut state = GvsppCell::new(ctx, &params(), Rounds::Paper);
            let (rays, targets) = state.abs_rays(ctx, ABS_CHUNK);
            assert!(rays.is_empty() && targets.is_empty());
            assert!(state.discontinuities(&rays, &[], &targets).is_empty());
            assert!(state.rs_rays(ctx, &[]).is_empty());
        });
    }

    #[test]
    fn per_round_termination_ends_a_quiet_round() {
        with_box_cell(|ctx| {
            let mut per_round = GvsppCell::new(ctx, &params(), Rounds::PaperPerRound);
            let mut windowed = GvsppCell::new(ctx, &params(), Rounds::Paper);
            for state in [&mut per_round, &mut windowed] {
                state.found.credit(Phase::Random, 3);
            }
            // Three new triangles in 100k rays: below T = 10, but the window needs 10^7 rays.
            assert!(per_round.end_round(100_000));
            assert!(!windowed.end_round(100_000));
        });
    }
}
