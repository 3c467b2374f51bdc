//! The shared bake scheduled by yield (the default; `fixed_rounds` keeps the paper's rounds,
//! `bake.rs`): in every step each cell that is still going picks the kind of its next batch
//! (random, border, its refinement, reverse or neighbour sampling) by its own recent yields, as
//! a single-cell bake does (`gvspp/by_yield.rs`); the steps' batches are cast together, kind by
//! kind, and shared along their free segments; then each cell records its batch's yield (the
//! new triangles its own rays found), the discontinuities of its border rays and the
//! termination rule. Triangles received from other cells' rays enter its PVS, and neighbour
//! sampling skips them.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4 (the
//! phases) and 7 (sharing rays between cells, after Bittner et al. 2009); the schedule by yield
//! is ours (`gvspp/by_yield.rs` says why).
//!
//! Determinism: cells plan in cell order and each bucket is cast in that order, so a seed gives
//! the same sets on any machine (batch sizes depend only on the state).

use glam::Vec3;
use sightline_core::{Hit, Ray};

use super::{Bake, SHARED_BATCH};
use crate::gvspp::{guided_batch, Kind, YieldScheduler, YIELD_BATCH};
use crate::sampler::ConvergencePoint;

/// One cell's batch in a bucket: its rays are `start..end` of the bucket's, and border batches
/// keep the targets searched for discontinuities.
struct Planned {
    cell: usize,
    start: usize,
    end: usize,
    targets: Vec<Option<Vec3>>,
}

/// The rays of one kind waiting to be cast, from several cells.
#[derive(Default)]
struct Bucket {
    owners: Vec<u32>,
    rays: Vec<Ray>,
    planned: Vec<Planned>,
}

impl Bake<'_> {
    /// Steps every cell by yield until each has spent its budget or, without one, until the
    /// termination rule holds for it with nothing left to explore.
    pub(super) fn run_by_yield(&mut self) {
        let mut schedulers = vec![YieldScheduler::default(); self.states.len()];
        let mut buckets: [Bucket; 5] = Default::default();
        loop {
            let mut planned_any = false;
            for i in 0..self.states.len() {
                if self.states[i].converged
                    || self.exhausted(i)
                    || self.rays_left(i) < self.random_cost()
                {
                    continue;
                }
                let Some((kind, rays, targets)) = self.plan(i, &schedulers[i]) else {
                    continue;
                };
                planned_any = true;
                let bucket = &mut buckets[kind as usize];
                let start = bucket.rays.len();
                bucket
                    .owners
                    .extend(std::iter::repeat_n(i as u32, rays.len()));
                bucket.rays.extend(rays);
                let end = bucket.rays.len();
                bucket.planned.push(Planned {
                    cell: i,
                    start,
                    end,
                    targets,
                });
                if end >= SHARED_BATCH {
                    self.cast_bucket(kind, &mut buckets[kind as usize], &mut schedulers);
                }
            }
            // One bucket of rays per kind, in the order of [`Kind::ALL`].
            for kind in Kind::ALL {
                self.cast_bucket(kind, &mut buckets[kind as usize], &mut schedulers);
            }
            self.round += 1;
            if !planned_any || self.out_of_time() {
                break;
            }
        }
    }

    /// Cell `i`'s next batch: the kind its scheduler picks among those with work, its rays
    /// within the cell's budget and, for border kinds, their targets. `None` when the cell
    /// has nothing to do (its random rays found no free space: it stops).
    fn plan(
        &mut self,
        i: usize,
        scheduler: &YieldScheduler,
    ) -> Option<(Kind, Vec<Ray>, Vec<Option<Vec3>>)> {
        let rays_left = self.rays_left(i);
        let random_cost = self.random_cost();
        let ctx = &self.contexts[i];
        let s = &mut self.states[i];
        let kind = scheduler.choose(s.gvspp.work())?;
        if kind != Kind::Random {
            let pvs = &s.pvs;
            let is_found = |id: u32| pvs.contains(id as usize);
            let (rays, targets) = guided_batch(ctx, &mut s.gvspp, kind, rays_left, is_found);
            return Some((kind, rays, targets));
        }
        let n = (YIELD_BATCH as u64).min(rays_left / random_cost) as usize;
        let rays = s.gvspp.random.next_batch(ctx, n);
        if rays.is_empty() {
            // A whole batch without an allowed origin: no free space in this cell.
            s.converged = true;
            return None;
        }
        Some((kind, rays, Vec::new()))
    }

    /// Casts and shares `bucket`'s rays, then gives each cell in it its batch's outcome: the
    /// yield for its scheduler, its border rays' discontinuities, the termination rule.
    fn cast_bucket(&mut self, kind: Kind, bucket: &mut Bucket, schedulers: &mut [YieldScheduler]) {
        if bucket.planned.is_empty() {
            return;
        }
        let before: Vec<u64> = bucket
            .planned
            .iter()
            .map(|p| self.states[p.cell].rays)
            .collect();
        let hits: Vec<Hit> = if bucket.rays.is_empty() {
            Vec::new()
        } else {
            self.cast_and_share(&bucket.owners, &bucket.rays, kind.phase())
        };
        let unlimited = self.budget.is_unlimited();
        let seconds = self.start.elapsed().as_secs_f64();
        for (p, rays_before) in bucket.planned.drain(..).zip(before) {
            // (Without rays there is no cast and no hit: every range is empty then.)
            let (rays, hits) = (&bucket.rays[p.start..p.end], &hits[p.start..p.end]);
            let s = &mut self.states[p.cell];
            // Each cell has at most one batch in a cast, so `own_new` is this batch's.
            let new = if rays.is_empty() { 0 } else { s.own_new };
            let cast = s.rays - rays_before;
            if !p.targets.is_empty() {
                let found = s.gvspp.discontinuities(rays, hits, &p.targets);
                s.gvspp.pending.extend(found);
            }
            schedulers[p.cell].record(kind, cast as usize, new);
            let rule = s.gvspp.batch_done(cast, new);
            if unlimited && rule && s.gvspp.idle() {
                s.converged = true;
            }
            s.convergence.push(ConvergencePoint {
                rays: s.rays,
                seconds,
                pvs_size: s.pvs_size,
            });
        }
        bucket.owners.clear();
        bucket.rays.clear();
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use sightline_core::trace::Bvh;

    use super::super::{bake_shared, ShareParams};
    use crate::gvspp::GvsPlusPlusParams;
    use crate::ray_sharing::fixtures::{city_cells, on_threads, small_city, two_cell_scene};
    use crate::sampler::Budget;

    /// The shared schedule by yield (`fixed_rounds` off), with the fixtures' small reverse
    /// sampling.
    fn by_yield() -> ShareParams {
        ShareParams {
            gvspp: GvsPlusPlusParams {
                n_rs_edge: 4,
                n_rs_area: 8,
                ..GvsPlusPlusParams::default()
            },
            explore_shared: true,
            ..ShareParams::default()
        }
    }

    #[test]
    fn cells_explore_by_yield_within_their_budgets_on_any_thread_count() {
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let cells = city_cells(&scene, 4);
        let budget = 150_000;
        let run = |threads: usize| {
            on_threads(threads, || {
                let (p, b) = (by_yield(), Budget::rays(budget));
                bake_shared(&scene, &bvh, &cells, &p, &b, 9, &|_, _| true, &|_| {})
            })
        };
        let (one, three) = (run(1), run(3));
        assert!(one.shared_insertions > 0);
        let mut explored = 0;
        for (a, b) in one.cells.iter().zip(&three.cells) {
            assert_eq!(a.visible, b.visible);
            assert_eq!((a.rays, &a.found_by), (b.rays, &b.found_by));
            // Within the budget, up to one reverse-sampled discontinuity (the last batch
            // takes at least one item); and most of it spent.
            assert!(a.rays >= budget - 2 && a.rays <= budget + 300, "{}", a.rays);
            let found = |name: &str| {
                a.found_by
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map_or(0, |f| f.1)
            };
            explored += found("abs") + found("rs") + found("adjacent");
            // Budget-stopped cells are not reported converged.
            assert_eq!(a.converged, Some(false));
        }
        assert!(explored > 0);
        assert_eq!(one.total_rays, three.total_rays);
    }

    #[test]
    fn without_a_budget_each_cell_stops_by_the_termination_rule() {
        let (scene, cells) = two_cell_scene();
        let bvh = Bvh::build(&scene);
        let free = |_: usize, _: Vec3| true;
        let r = bake_shared(
            &scene,
            &bvh,
            &cells,
            &by_yield(),
            &Budget::default(),
            2,
            &free,
            &|_| {},
        );
        for c in &r.cells {
            assert_eq!(c.converged, Some(true), "{:?}", c.found_by);
            // The rule needs a whole window of rays with fewer than T new triangles.
            assert!(c.rays >= crate::gvspp::TERMINATION_WINDOW, "{}", c.rays);
        }
        // Cell A sees the blocker's face towards it; the enclosure is seen from both.
        assert!(r
            .cells
            .iter()
            .all(|c| (0..12).all(|t| c.visible.contains(t))));
    }
}
