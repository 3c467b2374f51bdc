//! The shared bake: every cell's GVS++ state (`gvspp/cell.rs`) stepped phase by phase, all
//! cells' rays of a phase cast together and shared along their free segments.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.1 to 4.4 (the
//! phases) and 7 (sharing rays between cells, after Bittner et al. 2009); see
//! `ray_sharing/mod.rs` for the schedule.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray, Scene, TriangleSet};

use super::free_segment::{ray_contributions, Contribution};
use super::types::{ShareParams, SharedBake, SharedProgress};
use crate::bake::{cell_seed, touch_free_space};
use crate::guided::Phase;
use crate::gvspp::{GvsppCell, Rounds};
use crate::rays::{cast, BATCH};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint};
use crate::segment_cells::SegmentCells;
use crate::viewcell::ViewCell;

mod by_yield;

/// One cell's state: its GVS++ state, stepped as the per-cell sampler steps it, and the PVS
/// that its own and other cells' rays fill.
struct CellState {
    gvspp: GvsppCell,
    pvs: TriangleSet,
    pvs_size: usize,
    /// Triangles queued for exploration (a subset of `pvs`).
    explored: TriangleSet,
    /// Rays the cell cast itself.
    rays: u64,
    /// `rays` when the round began.
    round_start: u64,
    /// Stopped random sampling (converged, or no free space for origins).
    converged: bool,
    convergence: Vec<ConvergencePoint>,
    /// New triangles the cell's own rays found in the last cast (the schedule by yield's
    /// measure of a batch; a cell has at most one batch in a cast there).
    own_new: usize,
}

impl CellState {
    /// How many queued triangles the cell explores next with `rays_left` rays left in its
    /// budget (see [`GvsppCell::explore_take`]); `None` when its queue is empty.
    fn explore_take(&self, rays_left: u64) -> Option<usize> {
        (!self.gvspp.queue.is_empty()).then(|| self.gvspp.explore_take(rays_left))
    }
}

/// Rays per shared batch: several caster batches, so each batch's bookkeeping (crossings,
/// grouping by cell) is amortised, while memory stays bounded.
const SHARED_BATCH: usize = 4 * BATCH;

/// The bake: cells, their contexts and states, the crossing index.
struct Bake<'a> {
    caster: &'a dyn RayCaster,
    contexts: Vec<CellContext<'a>>,
    index: SegmentCells,
    params: &'a ShareParams,
    budget: Budget,
    /// Deadline of a time budget (per-cell time times the number of cells).
    deadline: Option<Instant>,
    start: Instant,
    states: Vec<CellState>,
    free_space: &'a (dyn Fn(usize, Vec3) -> bool + Sync),
    total_rays: u64,
    shared_insertions: u64,
    round: usize,
    progress: &'a (dyn Fn(&SharedProgress) + Sync),
}

/// Bakes `cells` of `scene` with GVS++ and ray sharing (see the module docs). `budget` is per
/// cell: `max_rays` counts the rays a cell casts itself, `max_time` is multiplied by the number
/// of cells for the whole bake; without either, every cell runs until GVS++'s termination rule
/// holds for it. `free_space(cell, point)` tells whether a point of cell `cell` is empty space
/// (ray origins and shared crossing points elsewhere are skipped; pass `&|_, _| true` for plain
/// cells). Cell `i` uses the seed [`cell_seed`]`(seed, i)`, as the independent bake does.
#[allow(clippy::too_many_arguments)]
pub fn bake_shared(
    scene: &Scene,
    caster: &dyn RayCaster,
    cells: &[ViewCell],
    params: &ShareParams,
    budget: &Budget,
    seed: u64,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    progress: &(dyn Fn(&SharedProgress) + Sync),
) -> SharedBake {
    let start = Instant::now();
    // Each cell's free-space test is touched once here, one cell after the other, before any
    // parallel loop asks it: see `bake::touch_free_space`.
    for (i, cell) in cells.iter().enumerate() {
        touch_free_space(free_space, i, cell);
    }
    let inside: Vec<_> = (0..cells.len())
        .map(|i| move |p: Vec3| free_space(i, p))
        .collect();
    let contexts: Vec<CellContext<'_>> = cells
        .iter()
        .zip(&inside)
        .enumerate()
        .map(|(i, (cell, inside))| CellContext {
            scene,
            caster,
            cell,
            seed: cell_seed(seed, i),
            free_space: Some(inside as &(dyn Fn(Vec3) -> bool + Sync)),
        })
        .collect();
    let p = &params.gvspp;
    let rounds = if p.fixed_rounds {
        Rounds::PaperPerRound
    } else {
        Rounds::ByYield
    };
    let states: Vec<CellState> = contexts
        .par_iter()
        .map(|ctx| CellState {
            gvspp: GvsppCell::new(ctx, p, rounds),
            pvs: TriangleSet::with_capacity(scene.triangle_count()),
            pvs_size: 0,
            explored: TriangleSet::with_capacity(scene.triangle_count()),
            rays: 0,
            round_start: 0,
            converged: false,
            convergence: Vec::new(),
            own_new: 0,
        })
        .collect();
    let mut bake = Bake {
        caster,
        contexts,
        index: SegmentCells::new(cells),
        params,
        budget: *budget,
        deadline: budget
            .max_time
            .map(|t| start + t.saturating_mul(cells.len().min(u32::MAX as usize) as u32)),
        start,
        states,
        free_space,
        total_rays: 0,
        shared_insertions: 0,
        round: 0,
        progress,
    };
    if p.fixed_rounds {
        bake.run();
    } else {
        bake.run_by_yield();
    }
    let seconds = start.elapsed().as_secs_f64();
    let per_cell = seconds / cells.len().max(1) as f64;
    let results = bake
        .states
        .into_iter()
        .map(|s| CellResult {
            visible: s.pvs,
            rays: s.rays,
            seconds: per_cell,
            convergence: s.convergence,
            found_by: s.gvspp.found.found_by_with_shared(),
            converged: Some(s.converged),
        })
        .collect();
    SharedBake {
        cells: results,
        total_rays: bake.total_rays,
        seconds,
        shared_insertions: bake.shared_insertions,
    }
}

impl Bake<'_> {
    /// Rays one cast of a random ray costs (two with the backward cast).
    fn random_cost(&self) -> u64 {
        if self.params.backward {
            2
        } else {
            1
        }
    }

    fn out_of_time(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// True when cell `i` may cast no more rays.
    fn exhausted(&self, i: usize) -> bool {
        self.rays_left(i) == 0 || self.out_of_time()
    }

    fn rays_left(&self, i: usize) -> u64 {
        self.budget
            .max_rays
            .map_or(u64::MAX, |m| m.saturating_sub(self.states[i].rays))
    }

    fn run(&mut self) {
        let unlimited = self.budget.is_unlimited();
        loop {
            let rays_before = self.total_rays;
            for s in &mut self.states {
                s.round_start = s.rays;
            }
            self.random_phase();
            self.exploration_phase();
            let mut sampling = 0;
            for s in &mut self.states {
                // Termination (4.4): here over the cell's last round alone (see the module docs).
                let done = s.gvspp.end_round(s.rays - s.round_start);
                if unlimited && done {
                    s.converged = true;
                }
                sampling += usize::from(!s.converged);
                s.convergence.push(ConvergencePoint {
                    rays: s.rays,
                    seconds: self.start.elapsed().as_secs_f64(),
                    pvs_size: s.pvs_size,
                });
            }
            self.round += 1;
            let nothing_cast = self.total_rays == rays_before;
            let nothing_left = (0..self.states.len()).all(|i| {
                self.exhausted(i)
                    || (self.states[i].converged && self.states[i].gvspp.queue.is_empty())
            });
            if nothing_cast || nothing_left || self.out_of_time() || sampling == 0 && unlimited {
                // With sampling == 0 every cell has converged; the last exploration phase
                // drained every queue (it runs until all are empty or out of budget).
                break;
            }
        }
    }

    /// GVS++ random sampling (4.1) from every cell still sampling, a round's rays each.
    fn random_phase(&mut self) {
        let mut owners: Vec<u32> = Vec::new();
        let mut rays: Vec<Ray> = Vec::new();
        for i in 0..self.states.len() {
            if self.states[i].converged {
                continue;
            }
            let round_size = self.states[i].gvspp.round_size();
            let mut remaining = round_size.min(self.rays_left(i) / self.random_cost());
            while remaining > 0 && !self.out_of_time() {
                let n = remaining.min(SHARED_BATCH as u64) as usize;
                let s = &mut self.states[i];
                let batch = s.gvspp.random.next_batch(&self.contexts[i], n);
                remaining -= n as u64;
                if batch.is_empty() {
                    // A whole batch without an allowed origin: no free space in this cell.
                    s.converged = true;
                    break;
                }
                owners.extend(std::iter::repeat_n(i as u32, batch.len()));
                rays.extend(batch);
                if rays.len() >= SHARED_BATCH {
                    self.cast_and_share(&owners, &rays, Phase::Random);
                    owners.clear();
                    rays.clear();
                }
            }
        }
        if !rays.is_empty() {
            self.cast_and_share(&owners, &rays, Phase::Random);
        }
    }

    /// Exploration (4.2, 4.3): every cell's queue drained a few triangles at a time, all cells
    /// together, until all queues are empty or out of budget.
    fn exploration_phase(&mut self) {
        loop {
            let active: Vec<usize> = (0..self.states.len())
                .filter(|&i| {
                    self.states[i].explore_take(self.rays_left(i)).is_some() && !self.exhausted(i)
                })
                .collect();
            if active.is_empty() {
                return;
            }
            // Each active cell takes the next chunk of its queue, as the per-cell sampler does
            // (all their ABS rays, then RS of their discontinuities); cells are grouped so that
            // a group casts about SHARED_BATCH ABS rays at once.
            let mut k = 0;
            while k < active.len() {
                let mut owners = Vec::new();
                let mut rays = Vec::new();
                let mut targets = Vec::new();
                let mut ranges = Vec::new();
                while k < active.len() && rays.len() < SHARED_BATCH {
                    let i = active[k];
                    k += 1;
                    // Earlier groups' rays may have used up the time budget.
                    if self.exhausted(i) {
                        continue;
                    }
                    let rays_left = self.rays_left(i);
                    let s = &mut self.states[i];
                    let Some(take) = s.explore_take(rays_left) else {
                        continue;
                    };
                    let (r, t) = s.gvspp.abs_rays(&self.contexts[i], take);
                    ranges.push((i, rays.len(), rays.len() + r.len()));
                    owners.extend(std::iter::repeat_n(i as u32, r.len()));
                    rays.extend(r);
                    targets.extend(t);
                }
                if rays.is_empty() {
                    continue;
                }
                let hits = self.cast_and_share(&owners, &rays, Phase::Abs);
                self.reverse_sampling(&ranges, &rays, &hits, &targets);
            }
        }
    }

    /// Reverse sampling (4.3) of the discontinuities of each cell's ABS rays `rays[a..b]`
    /// (`ranges` holds `(cell, a, b)`), from the cell's own reverse origins, within its budget.
    fn reverse_sampling(
        &mut self,
        ranges: &[(usize, usize, usize)],
        rays: &[Ray],
        hits: &[Hit],
        targets: &[Option<Vec3>],
    ) {
        let mut rs_owners = Vec::new();
        let mut rs_rays = Vec::new();
        for &(i, a, b) in ranges {
            let cell = &self.states[i].gvspp;
            let found = cell.discontinuities(&rays[a..b], &hits[a..b], &targets[a..b]);
            // RS rays of this cell generated but not yet cast (the budget counts them).
            let mut pending = 0u64;
            let mut rest = &found[..];
            while !rest.is_empty() {
                if self.rays_left(i) <= pending || self.out_of_time() {
                    break;
                }
                let size = self.states[i]
                    .gvspp
                    .rs_group_size(self.rays_left(i) - pending);
                let (group, after) = rest.split_at(size.min(rest.len()));
                rest = after;
                let r = self.states[i].gvspp.rs_rays(&self.contexts[i], group);
                pending += r.len() as u64;
                rs_owners.extend(std::iter::repeat_n(i as u32, r.len()));
                rs_rays.extend(r);
                if rs_rays.len() >= SHARED_BATCH {
                    self.cast_and_share(&rs_owners, &rs_rays, Phase::Rs);
                    rs_owners.clear();
                    rs_rays.clear();
                    pending = 0;
                }
            }
        }
        if !rs_rays.is_empty() {
            self.cast_and_share(&rs_owners, &rs_rays, Phase::Rs);
        }
    }

    /// Casts `rays` (ray `k` belongs to cell `owners[k]`) forward and, with `backward`, backward;
    /// hands every end triangle to the owner and to every cell the free segment crosses; returns
    /// the forward hits.
    fn cast_and_share(&mut self, owners: &[u32], rays: &[Ray], phase: Phase) -> Vec<Hit> {
        let forward = cast(self.caster, rays);
        let backward = if self.params.backward && phase == Phase::Random {
            let reversed: Vec<Ray> = rays.iter().map(|r| Ray::new(r.origin, -r.dir)).collect();
            Some(cast(self.caster, &reversed))
        } else {
            None
        };
        let cost = if backward.is_some() { 2 } else { 1 };
        for &o in owners {
            self.states[o as usize].rays += cost;
        }
        self.total_rays += cost * rays.len() as u64;
        let contributions = self.contributions(owners, rays, &forward, backward.as_deref());
        // Group by cell, keeping ray order inside each group.
        let mut by_cell: Vec<Vec<Contribution>> = vec![Vec::new(); self.states.len()];
        for c in contributions {
            by_cell[c.cell as usize].push(c);
        }
        let explore_shared = self.params.explore_shared;
        let new_shared: u64 = self
            .states
            .par_iter_mut()
            .zip(by_cell)
            .zip(&self.contexts)
            .map(|((s, list), ctx)| {
                let mut shared = 0u64;
                s.own_new = 0;
                for c in list {
                    let t = c.discovery.triangle as usize;
                    if !s.pvs.contains(t) {
                        s.pvs.insert(t);
                        s.pvs_size += 1;
                        // Neighbour sampling (schedule by yield) skips what the cell knows.
                        if let Some(n) = s.gvspp.neighbours.as_mut() {
                            n.found(ctx, [c.discovery.triangle]);
                        }
                        if c.own {
                            s.gvspp.found.credit(phase, 1);
                            s.own_new += 1;
                        } else {
                            s.gvspp.found.credit(Phase::Shared, 1);
                            shared += 1;
                        }
                    }
                    if (c.own || explore_shared) && !s.explored.contains(t) {
                        s.explored.insert(t);
                        s.gvspp.queue.push(c.discovery);
                    }
                }
                shared
            })
            .sum();
        self.shared_insertions += new_shared;
        let report = SharedProgress {
            round: self.round,
            rays: self.total_rays,
            seconds: self.start.elapsed().as_secs_f64(),
            sampling_cells: self.states.iter().filter(|s| !s.converged).count(),
            total_pvs: self.states.iter().map(|s| s.pvs_size).sum(),
        };
        (self.progress)(&report);
        forward
    }

    /// The triangles each ray's free segment shows to its owner and to the cells it crosses,
    /// skipping those already in a cell's PVS; in ray order.
    fn contributions(
        &self,
        owners: &[u32],
        rays: &[Ray],
        forward: &[Hit],
        backward: Option<&[Hit]>,
    ) -> Vec<Contribution> {
        const CHUNK: usize = 1024;
        // A cell's own rays report triangles it has not explored yet; other cells' rays, those
        // not in its PVS yet (or not explored, when it explores what it receives).
        let explore_shared = self.params.explore_shared;
        let known = |cell: u32, triangle: u32, own: bool| {
            let s = &self.states[cell as usize];
            if own || explore_shared {
                s.explored.contains(triangle as usize)
            } else {
                s.pvs.contains(triangle as usize)
            }
        };
        let chunks: Vec<Vec<Contribution>> = rays
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(k, chunk)| {
                let mut scratch = Vec::new();
                let mut crossings = Vec::new();
                let mut out = Vec::new();
                for (j, ray) in chunk.iter().enumerate() {
                    let i = k * CHUNK + j;
                    let back = backward.map(|b| b[i]);
                    ray_contributions(
                        &self.index,
                        self.free_space,
                        &known,
                        owners[i],
                        ray,
                        forward[i],
                        back,
                        &mut scratch,
                        &mut crossings,
                        &mut out,
                    );
                }
                out
            })
            .collect();
        chunks.into_iter().flatten().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray_sharing::fixtures::{
        city_cells, face, on_threads, small_city, small_params, two_cell_scene,
    };
    use serde_json::json;
    use sightline_core::trace::Bvh;

    #[test]
    fn a_cell_without_origins_gets_its_set_from_its_neighbours_rays() {
        let (scene, cells) = two_cell_scene();
        assert_eq!(scene.triangle_count(), 36);
        let bvh = Bvh::build(&scene);
        // B's surface is no free space, so it casts no ray of its own except ABS from points
        // inside it that A's rays crossed.
        let free = |cell: usize, p: Vec3| {
            cell == 0 || (p.x > 4.01 && p.x < 5.99 && p.y.abs() < 0.99 && p.z.abs() < 0.99)
        };
        // B explores what it receives (from points inside it, its only free space).
        let params = ShareParams {
            explore_shared: true,
            ..small_params()
        };
        let result = bake_shared(
            &scene,
            &bvh,
            &cells,
            &params,
            &Budget::rays(400_000),
            5,
            &free,
            &|_| {},
        );
        let b = &result.cells[1];
        let found = |name: &str| b.found_by.iter().find(|(k, _)| *k == name).unwrap().1;
        assert_eq!((found("random"), found("rs")), (0, 0));
        assert!(found("shared") >= 14, "{:?}", b.found_by);
        // The enclosure and the marker's face toward B, which only A's rays passing through B
        // can have found first ...
        let marker_front = face(&scene, 24..36, 7.5);
        assert_eq!(marker_front.len(), 2);
        for t in (0..12).chain(marker_front) {
            assert!(
                b.visible.contains(t),
                "B misses triangle {t}: {:?}",
                b.found_by
            );
        }
        // ... but not the blocker's face toward A (A sees it; sharing along the whole line
        // instead of the free segment would hand it to B), nor the marker's back.
        let hidden = [face(&scene, 12..24, -0.3), face(&scene, 24..36, 8.5)].concat();
        assert_eq!(hidden.len(), 4);
        for t in hidden {
            assert!(!b.visible.contains(t), "B got the hidden triangle {t}");
        }
        for t in face(&scene, 12..24, -0.3) {
            assert!(result.cells[0].visible.contains(t));
        }
    }

    #[test]
    fn result_does_not_depend_on_thread_count() {
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let cells = city_cells(&scene, 4);
        let run = |threads: usize| {
            on_threads(threads, || {
                bake_shared(
                    &scene,
                    &bvh,
                    &cells,
                    &small_params(),
                    &Budget::rays(150_000),
                    9,
                    &|_, _| true,
                    &|_| {},
                )
            })
        };
        let one = run(1);
        let three = run(3);
        assert!(one.shared_insertions > 0);
        for (a, b) in one.cells.iter().zip(&three.cells) {
            assert_eq!(a.visible, b.visible);
            assert_eq!((a.rays, &a.found_by), (b.rays, &b.found_by));
        }
        assert_eq!(one.total_rays, three.total_rays);
    }

    #[test]
    fn no_cells_and_budgets() {
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let empty = bake_shared(
            &scene,
            &bvh,
            &[],
            &small_params(),
            &Budget::rays(1000),
            1,
            &|_, _| true,
            &|_| {},
        );
        assert!(empty.cells.is_empty());
        assert_eq!(empty.total_rays, 0);
        // A ray budget holds per cell, up to one step's overshoot.
        let cells = city_cells(&scene, 2);
        let r = bake_shared(
            &scene,
            &bvh,
            &cells,
            &small_params(),
            &Budget::rays(50_000),
            1,
            &|_, _| true,
            &|_| {},
        );
        for c in &r.cells {
            assert!(
                c.rays >= 40_000 && c.rays <= 50_000 + 2 * SHARED_BATCH as u64,
                "{}",
                c.rays
            );
        }
        let file = r.to_pvs_file(
            &scene,
            &cells,
            &small_params(),
            &Budget::rays(50_000),
            1,
            json!({"x": 1}),
        );
        assert!(file.check_scene(&scene).is_ok());
        assert_eq!(file.cells.len(), 4);
        assert_eq!(file.metadata["x"], 1);
        assert_eq!(file.cells[2].visible, r.cells[2].visible);
    }

    #[test]
    fn forward_only_sharing_contains_the_independent_bake_at_equal_rays() {
        use crate::sampler::Sampler;
        // Without backward casts and without exploring what it receives, a cell casts exactly
        // the rays of its independent GVS++ bake: sharing can only add to its set.
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let cells = city_cells(&scene, 4);
        let params = ShareParams {
            backward: false,
            explore_shared: false,
            ..small_params()
        };
        let budget = Budget::rays(60_000);
        let shared = bake_shared(
            &scene,
            &bvh,
            &cells,
            &params,
            &budget,
            3,
            &|_, _| true,
            &|_| {},
        );
        let independent = crate::GvsPlusPlus {
            params: params.gvspp.clone(),
        };
        let mut added = 0;
        for (k, cell) in cells.iter().enumerate() {
            let ctx = CellContext {
                scene: &scene,
                caster: &bvh,
                cell,
                seed: cell_seed(3, k),
                free_space: None,
            };
            let alone = independent.sample(&ctx, &budget, &|_| {});
            let s = &shared.cells[k];
            assert_eq!(alone.rays, s.rays, "cell {k}");
            assert!(
                alone.visible.is_subset(&s.visible),
                "cell {k} lost triangles"
            );
            added += s.visible.count_ones(..) - alone.visible.count_ones(..);
        }
        assert!(added > 0);
    }

    #[test]
    fn without_a_budget_every_cell_stops_by_the_termination_rule() {
        let (scene, cells) = two_cell_scene();
        let bvh = Bvh::build(&scene);
        let r = bake_shared(
            &scene,
            &bvh,
            &cells,
            &small_params(),
            &Budget::default(),
            2,
            &|_, _| true,
            &|_| {},
        );
        for (k, c) in r.cells.iter().enumerate() {
            // Enclosure and the blocker's face toward the cell; at least two random rounds.
            assert!(c.visible.count_ones(..) >= 14, "cell {k}: {:?}", c.found_by);
            assert!(c.rays >= 2 * 2 * 20_000, "cell {k}: {} rays", c.rays);
            assert!(c.convergence.len() >= 2);
        }
    }
}
