//! Ray sharing: GVS++ for many view cells at once, where every ray cast for one cell also
//! counts for every other cell it passes through.
//!
//! Based on: Bittner, Mattausch, Wonka, Havran, Wimmer. Adaptive Global Visibility Sampling.
//! ACM TOG 28(3), 2009 (a ray contributes to all view cells it intersects), as proposed for
//! GVS++ in Koch, Wimmer. Guided Visibility Sampling++. 2021, section 7; the per-cell phases are
//! GVS++'s (sections 4.1–4.4, see `gvspp.rs`).
//!
//! A ray is cast forward to its closest hit and (random rays, see below) also backward, in the
//! reversed direction, to the closest hit behind its origin. The segment between the two hits is
//! empty, so from every point `P` of it both end triangles are visible (the path from `P` to
//! either end lies inside the segment). For every cell whose volume the segment crosses (found
//! with `segment_cells.rs`), a point `P` of the crossing that lies in the cell's free space
//! becomes the origin of a discovery for that cell: both end triangles enter its PVS *by
//! construction*, never by proximity or guesswork. A hit-nothing end makes the segment unbounded
//! on that side and contributes no triangle.
//!
//! Schedule, in the paper's rounds of GVS++ (`n_rand` random rays each, as GVS++ with
//! `fixed_rounds`; the adaptive rounds of a budgeted single-cell bake are not shared yet):
//! (1) random sampling, `n_rand` rays from each cell that has not
//! converged, each also cast backward (a second random-like ray through the cell for one more
//! cast); (2) exploration: every cell takes the next `ABS_CHUNK` triangles of its queue, casts
//! their ABS rays from the discovery's origin (which lies in the cell), then RS rays from its
//! own reverse origins for the discontinuities of its own border-vertex rays — exactly what
//! `gvspp.rs` does for one cell; guided rays are cast forward only (their backward half would be
//! an untargeted ray at the price of a targeted one) and shared too; (3) termination per cell:
//! a cell whose round found fewer than `T` new triangles (from any cell's rays) stops random
//! sampling but still explores what its own rays hit. By default a cell explores the triangles
//! its own rays hit (once each) and only *adds* those it receives to its PVS, so with
//! `backward = false` every cell casts exactly the rays of its independent GVS++ bake and its
//! set can only grow by sharing (tested); `explore_shared` also explores received triangles,
//! from their crossing point. With a budget (per cell, counted on the rays a cell casts itself,
//! backward casts included), cells sample until their own budget is spent and still receive
//! other cells' rays for free.
//!
//! Determinism: rays are generated, cast and turned into contributions in parallel but collected
//! in ray order; each cell then inserts its contributions in that order. Batch sizes depend only
//! on the state, never on the thread count, so a seed gives the same sets on any machine.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::json;
use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray, Scene, TriangleSet};

use crate::bake::cell_seed;
use crate::guided::Phase;
use crate::gvspp::{GvsPlusPlusParams, GvsppCell, Rounds};
use crate::pvs_file::{CellPvs, PvsFile};
use crate::rays::{cast, Discovery, BATCH};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint};
use crate::segment_cells::SegmentCells;
use crate::viewcell::ViewCell;

/// Parameters of a shared bake.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShareParams {
    /// The per-cell GVS++ parameters (`n_rand` is the random rays per cell and round).
    pub gvspp: GvsPlusPlusParams,
    /// Also cast every random ray backward from its origin, doubling the free segment it yields
    /// for two casts (the backward cast is counted in the rays). Guided rays (ABS, RS) are cast
    /// forward only: their backward half would be an untargeted ray at the price of a targeted
    /// one.
    pub backward: bool,
    /// Triangles a cell receives from other cells' rays enter its exploration queue (ABS and RS
    /// around them, from the crossing point); when false they only enter its PVS, and the cell
    /// explores exactly the triangles its own rays hit, as an independent GVS++ bake would.
    pub explore_shared: bool,
}

impl Default for ShareParams {
    fn default() -> Self {
        Self {
            gvspp: GvsPlusPlusParams::default(),
            backward: true,
            explore_shared: false,
        }
    }
}

/// Running totals of a shared bake, reported after every batch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SharedProgress {
    /// Round (random phase + exploration) in progress, from 0.
    pub round: usize,
    /// Rays cast so far by all cells.
    pub rays: u64,
    /// Seconds so far.
    pub seconds: f64,
    /// Cells still random sampling.
    pub sampling_cells: usize,
    /// Sum of the PVS sizes of all cells.
    pub total_pvs: usize,
}

/// What a shared bake found.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedBake {
    /// One result per cell, in cell order. `rays` are the rays the cell cast itself; `seconds`
    /// is the bake's wall-clock time divided by the number of cells (cells are baked together);
    /// `found_by` has "random", "abs", "rs" (the cell's own rays) and "shared" (other cells').
    pub cells: Vec<CellResult>,
    /// Rays cast by all cells (forward and backward).
    pub total_rays: u64,
    /// Wall-clock seconds of the whole bake.
    pub seconds: f64,
    /// Triangles a cell received from another cell's ray.
    pub shared_insertions: u64,
}

impl SharedBake {
    /// The `.pvs` file of this bake of `cells` (the same cells, in the same order) in `scene`,
    /// with `extra_metadata` merged into the metadata.
    pub fn to_pvs_file(
        &self,
        scene: &Scene,
        cells: &[ViewCell],
        params: &ShareParams,
        budget: &Budget,
        seed: u64,
        extra_metadata: serde_json::Value,
    ) -> PvsFile {
        let mut file = PvsFile::for_scene(scene, serde_json::Value::Null);
        file.cells = cells
            .iter()
            .zip(&self.cells)
            .map(|(cell, r)| CellPvs {
                cell: *cell,
                visible: r.visible.clone(),
            })
            .collect();
        let stats: Vec<serde_json::Value> = self
            .cells
            .iter()
            .map(|r| {
                json!({
                    "rays": r.rays,
                    "pvs_size": r.visible.count_ones(..),
                    "found_by": r.found_by.iter().map(|(k, v)| json!([k, v])).collect::<Vec<_>>(),
                })
            })
            .collect();
        let mut metadata = json!({
            "tool": format!("sightline {}", env!("CARGO_PKG_VERSION")),
            "scene": scene.source,
            "method": "gvs++ shared",
            "share_params": params,
            "seed": seed,
            "budget": budget,
            "total_rays": self.total_rays,
            "seconds": self.seconds,
            "shared_insertions": self.shared_insertions,
            "cells": stats,
        });
        if let (Some(m), serde_json::Value::Object(extra)) =
            (metadata.as_object_mut(), extra_metadata)
        {
            m.extend(extra);
        }
        file.metadata = metadata;
        file
    }
}

/// A triangle seen from a point of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Contribution {
    cell: u32,
    /// True when the cell cast the ray itself.
    own: bool,
    discovery: Discovery,
}

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
    /// Random rays the cell cast this round.
    random_rays: u64,
    /// Stopped random sampling (converged, or no free space for origins).
    converged: bool,
    convergence: Vec<ConvergencePoint>,
}

impl CellState {
    /// Rays the cell cast exploring this round.
    fn explored(&self) -> u64 {
        self.rays - self.round_start - self.random_rays
    }

    /// How many queued triangles the cell explores next (see [`GvsppCell::explore_take`]);
    /// `None` when it explores no more this round.
    fn explore_take(&self) -> Option<usize> {
        if self.gvspp.queue.is_empty() {
            return None;
        }
        self.gvspp.explore_take(self.random_rays, self.explored())
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
    let states: Vec<CellState> = contexts
        .par_iter()
        .map(|ctx| CellState {
            gvspp: GvsppCell::new(ctx, p, Rounds::PaperPerRound),
            pvs: TriangleSet::with_capacity(scene.triangle_count()),
            pvs_size: 0,
            explored: TriangleSet::with_capacity(scene.triangle_count()),
            rays: 0,
            round_start: 0,
            random_rays: 0,
            converged: false,
            convergence: Vec::new(),
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
    bake.run();
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
            for s in &mut self.states {
                s.random_rays = s.rays - s.round_start;
            }
            self.exploration_phase();
            let mut sampling = 0;
            for s in &mut self.states {
                // Termination (4.4): here over the cell's last round alone (see the module docs).
                let done = s.gvspp.end_round(s.rays - s.round_start, s.random_rays);
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
                .filter(|&i| self.states[i].explore_take().is_some() && !self.exhausted(i))
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
                    let s = &mut self.states[i];
                    let Some(take) = s.explore_take() else {
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
            let group_size = cell.rs_group_size();
            // RS rays of this cell generated but not yet cast (the budget counts them).
            let mut pending = 0u64;
            for group in found.chunks(group_size) {
                if self.rays_left(i) <= pending || self.out_of_time() {
                    break;
                }
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
            .map(|(s, list)| {
                let mut shared = 0u64;
                for c in list {
                    let t = c.discovery.triangle as usize;
                    if !s.pvs.contains(t) {
                        s.pvs.insert(t);
                        s.pvs_size += 1;
                        if c.own {
                            s.gvspp.found.credit(phase, 1);
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

/// The triangles that `ray`'s free segment shows to its owner (from the ray's origin) and to
/// every cell it crosses (from a point of the crossing in the cell's free space), skipping those
/// `known(cell, triangle, own)` says the cell needs no more; appended to `out`. The segment runs from the
/// backward hit (the origin without `backward`) to the forward hit (infinity on a miss).
#[allow(clippy::too_many_arguments)]
fn ray_contributions(
    index: &SegmentCells,
    free_space: &(dyn Fn(usize, Vec3) -> bool + Sync),
    known: &dyn Fn(u32, u32, bool) -> bool,
    owner: u32,
    ray: &Ray,
    forward: Hit,
    backward: Option<Hit>,
    scratch: &mut Vec<u32>,
    crossings: &mut Vec<crate::segment_cells::Crossing>,
    out: &mut Vec<Contribution>,
) {
    let (o, d) = (ray.origin, ray.dir);
    // The free segment: (t_back, t_fwd) along the ray, with its end triangles.
    let t_fwd = forward.t;
    let t_back = match backward {
        Some(b) => -b.t,
        None => 0.0,
    };
    let fwd_end = forward.triangle().map(|t| (t, o + d * t_fwd));
    let back_end = backward.and_then(|b| b.triangle().map(|t| (t, o - d * b.t)));
    let mut push = |cell: u32, own: bool, origin: Vec3, end: (u32, Vec3)| {
        if !known(cell, end.0, own) {
            out.push(Contribution {
                cell,
                own,
                discovery: Discovery {
                    triangle: end.0,
                    origin,
                    hit_point: end.1,
                },
            });
        }
    };
    for end in [fwd_end, back_end].into_iter().flatten() {
        push(owner, true, o, end);
    }
    crossings.clear();
    if index.is_regular() && t_fwd.is_finite() && t_back.is_finite() {
        // Both ends inside the owner's box: the segment crosses no other cell of a grid.
        let cell = &index.cells()[owner as usize];
        if cell.contains(o + d * t_fwd) && cell.contains(o + d * t_back) {
            return;
        }
    }
    index.crossings(o, d, t_back, t_fwd, scratch, crossings);
    for c in crossings.iter() {
        if c.cell == owner {
            continue;
        }
        let fwd_new = fwd_end.filter(|e| !known(c.cell, e.0, false));
        let back_new = back_end.filter(|e| !known(c.cell, e.0, false));
        if fwd_new.is_none() && back_new.is_none() {
            // Nothing new for this cell: skip the free-space test (it may cost rays).
            continue;
        }
        // A point of the crossing in the cell's free space: its middle, else a quarter in.
        let Some(t) = [0.5f32, 0.25, 0.75].iter().find_map(|&f| {
            let t = c.t_enter + (c.t_exit - c.t_enter) * f;
            (t.is_finite() && free_space(c.cell as usize, o + d * t)).then_some(t)
        }) else {
            continue;
        };
        let p = o + d * t;
        if let Some(end) = fwd_new.filter(|_| t < t_fwd) {
            push(c.cell, false, p, end);
        }
        if let Some(end) = back_new.filter(|_| t > t_back) {
            push(c.cell, false, p, end);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::random::SplitMix64;
    use sightline_core::scene::{self, LoadOptions, SceneBuilder};
    use sightline_core::trace::Bvh;

    fn small_city() -> Scene {
        scene::open("procedural:city?seed=3&size=3000", &LoadOptions::default()).unwrap()
    }

    /// An 8x8 layer of cells over the city, from the ground to 12 m.
    fn city_cells(scene: &Scene, n: u32) -> Vec<ViewCell> {
        let b = scene.bounds();
        ViewCell::grid(
            Vec3::new(b.min.x, b.min.y, 0.5),
            Vec3::new(b.max.x, b.max.y, 12.0),
            [n, n, 1],
        )
        .unwrap()
    }

    fn small_params() -> ShareParams {
        ShareParams {
            gvspp: GvsPlusPlusParams {
                n_rand: 20_000,
                n_rs_edge: 4,
                n_rs_area: 8,
                // The shared schedule runs the paper's rounds (see the module docs).
                fixed_rounds: true,
                ..GvsPlusPlusParams::default()
            },
            ..ShareParams::default()
        }
    }

    #[test]
    fn every_shared_triangle_is_seen_from_its_crossing_point() {
        let scene = small_city();
        let bvh = Bvh::build(&scene);
        let cells = city_cells(&scene, 8);
        let index = SegmentCells::new(&cells);
        let mut rng = SplitMix64::new(21);
        let rays: Vec<(u32, Ray)> = (0..4000)
            .map(|_| {
                let owner = (rng.next_u64() % cells.len() as u64) as u32;
                let o = cells[owner as usize].interior_point([
                    rng.next_f32(),
                    rng.next_f32(),
                    rng.next_f32(),
                ]);
                let z = rng.range_f32(-1.0, 1.0);
                let phi = rng.range_f32(0.0, std::f32::consts::TAU);
                let r = (1.0 - z * z).sqrt();
                (
                    owner,
                    Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z)),
                )
            })
            .collect();
        let plain: Vec<Ray> = rays.iter().map(|(_, r)| *r).collect();
        let forward = cast(&bvh, &plain);
        let reversed: Vec<Ray> = plain.iter().map(|r| Ray::new(r.origin, -r.dir)).collect();
        let backward = cast(&bvh, &reversed);
        let (mut scratch, mut crossings, mut out) = (Vec::new(), Vec::new(), Vec::new());
        for (k, (owner, ray)) in rays.iter().enumerate() {
            ray_contributions(
                &index,
                &|_, _| true,
                &|_, _, _| false,
                *owner,
                ray,
                forward[k],
                Some(backward[k]),
                &mut scratch,
                &mut crossings,
                &mut out,
            );
        }
        let shared: Vec<&Contribution> = out.iter().filter(|c| !c.own).collect();
        assert!(
            shared.len() > 1000,
            "only {} shared contributions",
            shared.len()
        );
        // Check each one: the point is in the cell, and a ray from it toward the hit point
        // finds the triangle there. Where it finds another triangle, the hit point lies on an
        // edge shared with it (same point, within rounding).
        let checks: Vec<Ray> = shared
            .iter()
            .map(|c| {
                Ray::new(
                    c.discovery.origin,
                    c.discovery.hit_point - c.discovery.origin,
                )
            })
            .collect();
        let hits = cast(&bvh, &checks);
        let mut on_edges = 0;
        for (c, h) in shared.iter().zip(&hits) {
            assert!(cells[c.cell as usize].contains(c.discovery.origin));
            assert!(
                h.is_hit(),
                "{c:?}: nothing between the cell and the hit point"
            );
            let length = c.discovery.hit_point.distance(c.discovery.origin);
            assert!(
                ((1.0 - h.t) * length).abs() < 1e-3 * length.max(1.0),
                "{c:?}: hit at t = {} instead of 1",
                h.t
            );
            on_edges += usize::from(h.triangle != c.discovery.triangle);
        }
        assert!(
            on_edges * 100 <= shared.len(),
            "{on_edges} of {} checks found another triangle",
            shared.len()
        );
    }

    /// An enclosure (a big box seen from inside) with a small blocker between two cells A and
    /// B, and a small marker box beyond B.
    fn two_cell_scene() -> (Scene, [ViewCell; 2]) {
        let mut b = SceneBuilder::new("two cells");
        b.begin_object("enclosure");
        b.add_box(Vec3::splat(-10.0), Vec3::splat(10.0));
        b.begin_object("blocker");
        b.add_box(Vec3::splat(-0.3), Vec3::splat(0.3));
        b.begin_object("marker");
        b.add_box(Vec3::new(7.5, -0.5, -0.5), Vec3::new(8.5, 0.5, 0.5));
        let a = ViewCell::aabb(Vec3::new(-6.0, -1.0, -1.0), Vec3::new(-4.0, 1.0, 1.0)).unwrap();
        let bb = ViewCell::aabb(Vec3::new(4.0, -1.0, -1.0), Vec3::new(6.0, 1.0, 1.0)).unwrap();
        (b.finish(), [a, bb])
    }

    /// The triangles of `objects` whose plane is `x = x`.
    fn face(scene: &Scene, objects: std::ops::Range<usize>, x: f32) -> Vec<usize> {
        objects
            .filter(|&t| {
                scene
                    .triangle(t as u32)
                    .iter()
                    .all(|p| (p.x - x).abs() < 1e-6)
            })
            .collect()
    }

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
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
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
