//! The per-cell GVS++ sampler: one cell's rays cast alone, scheduled by yield (`by_yield.rs`),
//! or in the paper's rounds with `fixed_rounds`.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4 (the state
//! it steps is `cell.rs`; the algorithm and its schedules are described in `gvspp/mod.rs`).

use crate::guided::Phase;
use crate::rays::{cast, discover};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};

use super::by_yield::sample_by_yield;
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
        // The schedule by yield unless `fixed_rounds`: under a budget until it is spent,
        // without one until the termination rule (4.4) holds with nothing left to explore.
        if !self.params.fixed_rounds {
            let mut cell = GvsppCell::new(ctx, &self.params, Rounds::ByYield);
            let rule_held = sample_by_yield(ctx, &mut cell, &mut tally, progress);
            return tally.finish_guided(cell.found.found_by(), rule_held);
        }
        let mut cell = GvsppCell::new(ctx, &self.params, Rounds::Paper);
        let mut rule_held = false;
        loop {
            let round_start = tally.rays;
            // Random sampling (4.1).
            let Some(new) = cell
                .random
                .sample_round(ctx, &mut tally, cell.round_size(), progress)
            else {
                break;
            };
            cell.found_new(ctx, Phase::Random, new);
            // Exploration (4.2, 4.3): drain the queue, FIFO, within the budget.
            while !cell.queue.is_empty() && !tally.exhausted() {
                let take = cell.explore_take(tally.rays_left());
                explore_step(ctx, &mut cell, &mut tally, take, progress);
            }
            // Termination (4.4).
            let converged = cell.end_round(tally.rays - round_start);
            rule_held |= converged;
            if tally.exhausted() || (budget.is_unlimited() && converged) {
                break;
            }
        }
        tally.finish_guided(cell.found.found_by(), rule_held)
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
    cell.found_new(ctx, Phase::Abs, discover(&tally.pvs, &rays, &hits));
    tally.batch_done(rays.len(), progress);
    let discontinuities = cell.discontinuities(&rays, &hits, &targets);
    let mut rest = &discontinuities[..];
    while !rest.is_empty() && !tally.exhausted() {
        let size = cell.rs_group_size(tally.rays_left());
        let (group, after) = rest.split_at(size.min(rest.len()));
        rest = after;
        let rs = cell.rs_rays(ctx, group);
        cell.found_new(
            ctx,
            Phase::Rs,
            discover(&tally.pvs, &rs, &cast(ctx.caster, &rs)),
        );
        tally.batch_done(rs.len(), progress);
    }
}
