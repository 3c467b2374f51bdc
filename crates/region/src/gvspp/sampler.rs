//! The per-cell GVS++ sampler: one cell's rounds, its rays cast alone.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4 (the state
//! it steps is `cell.rs`; the algorithm and its round sizes are described in `gvspp/mod.rs`).

use crate::guided::Phase;
use crate::rays::{cast, discover};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};

use super::cell::{GvsppCell, Rounds};
use super::params::GvsPlusPlusParams;

/// The GVS++ sampler.
#[derive(Clone, Debug, Default)]
pub struct GvsPlusPlus {
    /// Parameters.
    pub params: GvsPlusPlusParams,
}

impl Sampler for GvsPlusPlus {
    fn name(&self) -> &'static str {
        "gvs++"
    }

    fn sample(
        &self,
        ctx: &CellContext<'_>,
        budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult {
        let mut tally = Tally::new(ctx.scene.triangle_count(), *budget);
        // Adaptive rounds only under a budget: a bake to convergence keeps the paper's rounds
        // (measured: adaptive rounds cast 1.5x the rays for the same error on etoile's cells).
        let rounds = if !self.params.fixed_rounds && !budget.is_unlimited() {
            Rounds::Adaptive
        } else {
            Rounds::Paper
        };
        let mut cell = GvsppCell::new(ctx, &self.params, rounds);
        loop {
            let round_start = tally.rays;
            // Random sampling (4.1).
            let Some(new) = cell
                .random
                .sample_round(ctx, &mut tally, cell.round_size(), progress)
            else {
                break;
            };
            let random_rays = tally.rays - round_start;
            cell.found_new(Phase::Random, new);
            // Exploration (4.2, 4.3): drain the queue, FIFO. Under a budget a round explores
            // at most EXPLORE_SHARE times the rays its random phase cast and the rest waits for
            // the next round, so that random rays keep finding whole streets while the queue
            // of the first 16k random rays explores their neighbours.
            let explore_start = tally.rays;
            while !cell.queue.is_empty() && !tally.exhausted() {
                let explored = tally.rays - explore_start;
                let Some(take) = cell.explore_take(random_rays, explored, tally.rays_left()) else {
                    break;
                };
                explore_step(ctx, &mut cell, &mut tally, take, progress);
            }
            // Termination (4.4).
            let converged = cell.end_round(tally.rays - round_start, random_rays);
            if tally.exhausted() || (budget.is_unlimited() && converged) {
                break;
            }
        }
        tally.finish(cell.found.found_by())
    }
}

/// One exploration step: ABS (4.2) of the next `take` triangles of the queue, then RS (4.3) of
/// the discontinuities of their border-vertex rays, group by group while the budget lasts.
fn explore_step(
    ctx: &CellContext<'_>,
    cell: &mut GvsppCell,
    tally: &mut Tally,
    take: usize,
    progress: &(dyn Fn(&ConvergencePoint) + Sync),
) {
    let (rays, targets) = cell.abs_rays(ctx, take);
    let hits = cast(ctx.caster, &rays);
    cell.found_new(Phase::Abs, discover(&tally.pvs, &rays, &hits));
    tally.batch_done(rays.len(), progress);
    let discontinuities = cell.discontinuities(&rays, &hits, &targets);
    let mut rest = &discontinuities[..];
    while !rest.is_empty() && !tally.exhausted() {
        let size = cell.rs_group_size(tally.rays_left());
        let (group, after) = rest.split_at(size.min(rest.len()));
        rest = after;
        let rs = cell.rs_rays(ctx, group);
        cell.found_new(Phase::Rs, discover(&tally.pvs, &rs, &cast(ctx.caster, &rs)));
        tally.batch_done(rs.len(), progress);
    }
}
