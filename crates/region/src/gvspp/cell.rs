//! One view cell's GVS++ state, stepped phase by phase by both drivers: the per-cell sampler
//! (`sampler.rs`, which casts the cell's rays alone) and the shared-ray bake (`ray_sharing/`,
//! which casts many cells' rays together). The state holds what a cell carries from phase to
//! phase and round to round: its random-ray sequence, its reverse-sampling origins, the
//! exploration queue, the count of triangles each phase found, the size of the next round and
//! the termination rule. The drivers cast the rays and keep the PVS.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4; the
//! adaptive round sizes under a budget are ours (see `gvspp/mod.rs`).

use glam::Vec3;
use sightline_core::{Hit, Ray};

use super::guided_rays::{abs_rays, find_discontinuities, Discontinuity, ReverseOrigins};
use super::params::{GvsPlusPlusParams, ABS_CHUNK, EXPLORE_RAYS_PER_TRIANGLE, EXPLORE_SHARE};
use super::params::{FIRST_ROUND, TERMINATION_WINDOW};
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
    /// Rounds from [`FIRST_ROUND`] random rays up, each exploring at most [`EXPLORE_SHARE`]
    /// times its random rays: the per-cell bake under a budget.
    Adaptive,
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
    /// Triangles found by each phase.
    pub found: Found,
    termination: Termination,
    adaptive: bool,
    /// Random rays of the next round.
    round_size: u64,
    n_rand: u64,
    n_abs_edge: u32,
    /// Border offset `Δ_ABS` in scene units.
    delta_abs: f32,
    /// Discontinuity threshold `Δ` in scene units.
    delta: f32,
}

impl GvsppCell {
    /// The state of `ctx.cell` before its first round.
    pub fn new(ctx: &CellContext<'_>, p: &GvsPlusPlusParams, rounds: Rounds) -> Self {
        let diagonal = ctx.scene.bounds().diagonal().max(f32::MIN_POSITIVE);
        let adaptive = rounds == Rounds::Adaptive;
        let termination = match rounds {
            Rounds::PaperPerRound => Termination::per_round(p.termination_threshold),
            _ => Termination::over_window(p.termination_threshold, TERMINATION_WINDOW),
        };
        Self {
            random: RandomRays::new(ctx.cell, ctx.scene, ctx.seed),
            reverse: ReverseOrigins::new(ctx, p.n_rs_edge, p.n_rs_area),
            rs_groups: 0,
            queue: ExploreQueue::default(),
            found: Found::default(),
            termination,
            adaptive,
            round_size: if adaptive {
                FIRST_ROUND.min(p.n_rand)
            } else {
                p.n_rand
            },
            n_rand: p.n_rand,
            n_abs_edge: p.n_abs_edge,
            delta_abs: p.delta_abs * diagonal,
            delta: p.delta_discontinuity * diagonal,
        }
    }

    /// Random rays this round casts.
    pub fn round_size(&self) -> u64 {
        self.round_size
    }

    /// Credits the triangles `phase` found to it and queues them for exploration.
    pub fn found_new(&mut self, phase: Phase, new: Vec<Discovery>) {
        self.found.credit(phase, new.len());
        self.queue.extend(new);
    }

    /// How many queued triangles the next exploration step takes, once this round cast
    /// `random_rays` random rays and `explored` rays exploring, with `rays_left` rays left in
    /// the budget (`u64::MAX` without a ray limit); `None` when the round's share of exploration
    /// is spent (adaptive rounds only: the paper's rounds drain the queue). Never more
    /// triangles than the rays left can explore, so a small budget is kept to within one
    /// triangle's step.
    pub fn explore_take(&self, random_rays: u64, explored: u64, rays_left: u64) -> Option<usize> {
        let within_budget = fitting(rays_left, EXPLORE_RAYS_PER_TRIANGLE as usize);
        if !self.adaptive {
            return Some(ABS_CHUNK.min(within_budget));
        }
        let share = EXPLORE_SHARE * random_rays as f64;
        if explored as f64 >= share {
            return None;
        }
        // No more triangles than the rest of the share can explore (about 69 ABS rays each,
        // plus reverse sampling of their discontinuities): one full chunk could cost 300k
        // rays in a city and take the whole share.
        let left = share - explored as f64;
        Some(
            ((left / EXPLORE_RAYS_PER_TRIANGLE) as usize)
                .clamp(1, ABS_CHUNK)
                .min(within_budget),
        )
    }

    /// Takes up to `n` triangles off the queue and returns their ABS rays (4.2) with, for each
    /// ray aimed at a border vertex, its target.
    pub fn abs_rays(&mut self, ctx: &CellContext<'_>, n: usize) -> (Vec<Ray>, Vec<Option<Vec3>>) {
        let chunk = self.queue.take(n);
        abs_rays(ctx, &chunk, self.delta_abs, self.n_abs_edge)
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

    /// Ends a round that cast `round_rays` rays, `random_rays` of them random: sizes the next
    /// round (adaptive rounds double, and grow to at least this round's exploration) and
    /// returns whether the termination rule (4.4) holds.
    pub fn end_round(&mut self, round_rays: u64, random_rays: u64) -> bool {
        if self.adaptive {
            let explore_rays = round_rays - random_rays;
            self.round_size = (self.round_size * 2).max(explore_rays).min(self.n_rand);
        }
        let new = self.found.end_round();
        self.termination.round_done(round_rays, new)
    }
}

/// How many steps costing `cost` rays each fit in `rays_left` (at least one, so a step always
/// makes progress; with no ray limit, `u64::MAX`, any count fits).
fn fitting(rays_left: u64, cost: usize) -> usize {
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
    fn adaptive_rounds_double_up_to_n_rand_and_cover_exploration() {
        with_box_cell(|ctx| {
            let mut state = GvsppCell::new(ctx, &params(), Rounds::Adaptive);
            assert_eq!(state.round_size(), FIRST_ROUND);
            state.end_round(FIRST_ROUND, FIRST_ROUND);
            assert_eq!(state.round_size(), 2 * FIRST_ROUND);
            // An exploration larger than the doubled round sets the next round's size.
            state.end_round(2 * FIRST_ROUND + 70_000, 2 * FIRST_ROUND);
            assert_eq!(state.round_size(), 70_000);
            state.end_round(70_000, 70_000);
            assert_eq!(state.round_size(), 100_000);
        });
    }

    #[test]
    fn paper_rounds_keep_n_rand_and_take_whole_chunks() {
        with_box_cell(|ctx| {
            let mut state = GvsppCell::new(ctx, &params(), Rounds::Paper);
            assert_eq!(state.round_size(), 100_000);
            assert_eq!(
                state.explore_take(0, u64::MAX / 2, u64::MAX),
                Some(ABS_CHUNK)
            );
            state.end_round(150_000, 100_000);
            assert_eq!(state.round_size(), 100_000);
        });
    }

    #[test]
    fn adaptive_exploration_stops_at_its_share() {
        with_box_cell(|ctx| {
            let state = GvsppCell::new(ctx, &params(), Rounds::Adaptive);
            let share = (EXPLORE_SHARE * 1000.0) as u64;
            assert_eq!(state.explore_take(1000, share, u64::MAX), None);
            // Less than one triangle's worth left: still one triangle.
            assert_eq!(state.explore_take(1000, share - 1, u64::MAX), Some(1));
            assert_eq!(
                state.explore_take(1_000_000_000, 0, u64::MAX),
                Some(ABS_CHUNK)
            );
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
            assert!(per_round.end_round(100_000, 100_000));
            assert!(!windowed.end_round(100_000, 100_000));
        });
    }
}
