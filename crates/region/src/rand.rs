//! RAND: brute-force random visibility sampling, the baseline of Koch & Wimmer 2021 (section
//! 6.1): the random sampling of GVS++ (section 4.1, eq. 1 and 2) without any guided
//! exploration.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 and 6.1.

use crate::rays::{RandomRays, BATCH};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};

/// Rays cast when the budget sets no limit.
pub const DEFAULT_RAYS: u64 = 10_000_000;

/// The RAND sampler.
#[derive(Clone, Debug, Default)]
pub struct RandomSampler;

impl Sampler for RandomSampler {
    fn name(&self) -> &'static str {
        "rand"
    }

    fn sample(
        &self,
        ctx: &CellContext<'_>,
        budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult {
        let budget = if budget.is_unlimited() {
            Budget::rays(DEFAULT_RAYS)
        } else {
            *budget
        };
        let mut tally = Tally::new(ctx.scene.triangle_count(), budget);
        let mut generator = RandomRays::new(ctx.cell, ctx.scene, ctx.seed);
        while !tally.exhausted() {
            // A round per batch keeps time budgets fine-grained; `None`: no free space.
            if generator
                .sample_round(ctx, &mut tally, BATCH as u64, progress)
                .is_none()
            {
                break;
            }
        }
        let found = tally.pvs.count();
        tally.finish(vec![("random", found)])
    }
}
