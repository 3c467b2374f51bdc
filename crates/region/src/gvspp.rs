//! GVS++: guided visibility sampling with fixed-rate adaptive border sampling and view-cell
//! reverse sampling.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. Proc. ACM CGIT 4(1), 2021:
//! random sampling (section 4.1), adaptive border sampling with a fixed number of samples per
//! border-polygon edge (4.2), discontinuity detection and reverse sampling from points spread
//! over the view cell (4.3), the exploration queue and the termination rule (4.4).
//!
//! One round: `n_rand` random rays; every newly found triangle enters the queue with the ray
//! that found it; the queue is drained by ABS (rays from that ray's origin to the 9 vertices of
//! the triangle's enlarged border polygon and to `n_abs_edge` points on each of its three long
//! edges), and each border *vertex* ray that hits something closer than its target (by more
//! than Δ) or nothing at all marks a discontinuity, handled by RS: rays from the cell's corners,
//! `n_rs_edge` points per cell edge and `n_rs_area` Halton points on the cell surface to the
//! target, skipping origins whose segment to the target passes through the occluder (the paper
//! projects the occluder onto the cell plane and tests the sample points against the projected
//! triangle; the segment test is the same predicate and also works on all six faces of a box).
//! New triangles from ABS and RS enter the queue too. When the queue is empty, the round ends;
//! without a ray or time budget, sampling stops once the most recent rounds that together cast
//! at least [`TERMINATION_WINDOW`] rays found fewer than `T` new triangles. With a budget, rounds
//! continue until it is spent (so comparisons at equal rays are fair).
//!
//! # Round sizes (not the paper's)
//! The paper casts `n_rand` = 10^7 random rays per round, sized for a GPU that casts them in
//! milliseconds. On a CPU (7 M rays/s on two cores) the first round alone spends any budget up to
//! 1.5 s before border or reverse sampling run once, so a time- or ray-limited bake was RAND.
//! Under a ray or time budget rounds are therefore adaptive: the first has [`FIRST_ROUND`] random
//! rays, each doubles the next (and makes it at least as large as its exploration) up to
//! `n_rand`, and a round explores at most half as many rays as its random phase cast, the rest
//! of the queue waiting for the next round.
//! `fixed_rounds` restores the paper's rounds of `n_rand`. A bake without a budget (to
//! convergence) keeps the paper's rounds: adaptive ones reached the same error with 1.5x the
//! rays there. The termination rule is the paper's (T = 10 new triangles in a 10^7-ray round)
//! over a window of at least [`TERMINATION_WINDOW`] rays instead of one round, so that a small
//! `n_rand` does not stop a bake early; with the default `n_rand` it is the paper's rule.
//!
//! Distances: the paper gives Δ_ABS = 0.001 in scene units of km-scale scenes; here both
//! distances are fractions of the scene's bounding-box diagonal (`delta_abs` 1e-6 ≈ 1 mm on a
//! 1 km scene), so the defaults work on a bunny and on a city alike.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use sightline_core::sampling::ShiftedHalton;
use sightline_core::trace::triangle::{intersect, ShearedRay};
use sightline_core::{Hit, Ray};

use crate::border::{border_polygon, vertex_targets, LONG_EDGES};
use crate::rays::{cast, discover, Discovery, RandomRays, BATCH};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};
use crate::viewcell::CellSurface;

/// Parameters of GVS++ (defaults: the paper's, section 6 and table 1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GvsPlusPlusParams {
    /// Random rays per round (`n_rand`).
    pub n_rand: u64,
    /// Samples along each long edge of the border polygon (`n_ABSEdge`).
    pub n_abs_edge: u32,
    /// Border polygon offset (`Δ_ABS`) as a fraction of the scene diagonal.
    pub delta_abs: f32,
    /// Reverse-sampling origins per view-cell edge (`n_RSEdge`).
    pub n_rs_edge: u32,
    /// Reverse-sampling origins on the view-cell surface (`n_RSArea`).
    pub n_rs_area: u32,
    /// Discontinuity threshold (`Δ`) as a fraction of the scene diagonal.
    pub delta_discontinuity: f32,
    /// Stop when the rounds of the last [`TERMINATION_WINDOW`] rays found fewer new triangles
    /// than this (`T`).
    pub termination_threshold: usize,
    /// Every round casts `n_rand` random rays (the paper). Off by default: under a budget,
    /// rounds start at [`FIRST_ROUND`] rays and grow (see the module docs).
    pub fixed_rounds: bool,
}

/// Random rays in the first round of an adaptive bake: about 2 ms on two cores, so that border
/// and reverse sampling start at once however small the budget.
pub const FIRST_ROUND: u64 = 16_384;

/// The rays over which the termination rule counts new triangles: the paper's round (10^7
/// random rays, plus their exploration).
pub const TERMINATION_WINDOW: u64 = 10_000_000;

impl Default for GvsPlusPlusParams {
    fn default() -> Self {
        Self {
            n_rand: 10_000_000,
            n_abs_edge: 20,
            delta_abs: 1e-6,
            n_rs_edge: 20,
            n_rs_area: 20,
            delta_discontinuity: 1e-5,
            termination_threshold: 10,
            fixed_rounds: false,
        }
    }
}

impl GvsPlusPlusParams {
    /// Checks that the parameters make sense.
    pub fn validate(&self) -> Result<(), GvsPlusPlusParamsError> {
        if self.n_rand == 0 {
            return Err(GvsPlusPlusParamsError::NoRandomRays);
        }
        if !(self.delta_abs > 0.0 && self.delta_abs < 0.1) {
            return Err(GvsPlusPlusParamsError::DeltaAbs(self.delta_abs));
        }
        if !(self.delta_discontinuity >= 0.0 && self.delta_discontinuity < 0.1) {
            return Err(GvsPlusPlusParamsError::Delta(self.delta_discontinuity));
        }
        if self.n_abs_edge > 10_000 || self.n_rs_edge > 10_000 || self.n_rs_area > 100_000 {
            return Err(GvsPlusPlusParamsError::TooManySamples);
        }
        Ok(())
    }
}

/// Why [`GvsPlusPlusParams`] make no sense.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GvsPlusPlusParamsError {
    /// `n_rand` is 0.
    #[error("n_rand must be >= 1")]
    NoRandomRays,
    /// `delta_abs` is outside (0, 0.1).
    #[error("delta_abs {0} must be in (0, 0.1)")]
    DeltaAbs(f32),
    /// `delta_discontinuity` is outside [0, 0.1).
    #[error("delta {0} must be in [0, 0.1)")]
    Delta(f32),
    /// `n_abs_edge` or `n_rs_edge` is above 10,000, or `n_rs_area` above 100,000.
    #[error("sample counts are implausibly large")]
    TooManySamples,
}

/// The GVS++ sampler.
#[derive(Clone, Debug, Default)]
pub struct GvsPlusPlus {
    /// Parameters.
    pub params: GvsPlusPlusParams,
}

/// Under a budget, the exploration rays of a round as a share of its random rays: random rays
/// keep two thirds of the budget.
const EXPLORE_SHARE: f64 = 0.5;

/// Rays the exploration of one triangle costs on average (69 ABS rays at the defaults, plus
/// reverse sampling where its border rays find a discontinuity), for sizing chunks to a share.
const EXPLORE_RAYS_PER_TRIANGLE: f64 = 300.0;

/// Triangles processed per ABS batch (each gives 9 + 3 n_ABSEdge rays).
pub(crate) const ABS_CHUNK: usize = 1024;

/// A border vertex whose ray hit something closer than it, or nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Discontinuity {
    target: Vec3,
    occluder: Option<u32>,
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
        let p = &self.params;
        let diagonal = ctx.scene.bounds().diagonal().max(f32::MIN_POSITIVE);
        let delta_abs = p.delta_abs * diagonal;
        let delta = p.delta_discontinuity * diagonal;
        let mut tally = Tally::new(ctx.scene.triangle_count(), *budget);
        let mut random = RandomRays::new(ctx.cell, ctx.scene, ctx.seed);
        let reverse = ReverseOrigins::new(ctx, p.n_rs_edge, p.n_rs_area);
        let mut found = [0usize; 3]; // random, ABS, RS
        let mut rs_round = 0u64;
        // Adaptive rounds only under a budget: a bake to convergence keeps the paper's rounds
        // (measured: adaptive rounds cast 1.5x the rays for the same error on etoile's cells).
        let adaptive = !p.fixed_rounds && !budget.is_unlimited();
        let mut round_size = if adaptive {
            FIRST_ROUND.min(p.n_rand)
        } else {
            p.n_rand
        };
        // (rays, new triangles) of the recent rounds, newest last, for the termination rule.
        let mut recent: std::collections::VecDeque<(u64, usize)> = Default::default();
        // The exploration queue. Without a budget each round drains it (the paper); under a
        // budget a round explores at most half the rays its random phase cast and the rest
        // waits for the next round, so that random rays keep two thirds of the budget: in a
        // city the queue of the first 16k random rays would otherwise take any budget,
        // exploring small neighbours while whole streets stay unfound (3.3x RAND's error on
        // etoile at 1M rays; equal to RAND with this cap, docs/BENCHMARKS.md).
        let mut queue: Vec<Discovery> = Vec::new();
        let mut head = 0;
        loop {
            let mut round_new = 0usize;
            let round_start = tally.rays;
            // Random sampling (4.1).
            let Some(new) = random.sample_round(ctx, &mut tally, round_size, progress) else {
                break;
            };
            let random_rays = tally.rays - round_start;
            found[0] += new.len();
            round_new += new.len();
            queue.extend(new);
            // Exploration (4.2, 4.3): drain the queue, FIFO (under a budget: up to the random
            // phase's rays).
            let explore_start = tally.rays;
            while head < queue.len()
                && !tally.exhausted()
                && !(adaptive
                    && (tally.rays - explore_start) as f64 >= EXPLORE_SHARE * random_rays as f64)
            {
                // Under a budget, no more triangles than the rest of the round's share can
                // explore (about 69 ABS rays each, plus reverse sampling of its discontinuities):
                // one full chunk could cost 300k rays in a city and take the whole share.
                let take = if adaptive {
                    let left =
                        EXPLORE_SHARE * random_rays as f64 - (tally.rays - explore_start) as f64;
                    ((left / EXPLORE_RAYS_PER_TRIANGLE) as usize).clamp(1, ABS_CHUNK)
                } else {
                    ABS_CHUNK
                };
                let chunk: Vec<Discovery> = queue[head..(head + take).min(queue.len())].to_vec();
                head += chunk.len();
                let (rays, vertex_targets) = abs_rays(ctx, &chunk, delta_abs, p.n_abs_edge);
                let hits = cast(ctx.caster, &rays);
                let new = discover(&tally.pvs, &rays, &hits);
                found[1] += new.len();
                round_new += new.len();
                queue.extend(new);
                tally.batch_done(rays.len(), progress);
                let discontinuities = find_discontinuities(&rays, &hits, &vertex_targets, delta);
                for group in discontinuities.chunks(reverse.group_size()) {
                    if tally.exhausted() {
                        break;
                    }
                    let rs = reverse.rays(ctx, group, rs_round);
                    rs_round += 1;
                    let new = discover(&tally.pvs, &rs, &cast(ctx.caster, &rs));
                    found[2] += new.len();
                    round_new += new.len();
                    queue.extend(new);
                    tally.batch_done(rs.len(), progress);
                }
            }
            let round_rays = tally.rays - round_start;
            if head == queue.len() {
                queue.clear();
                head = 0;
            }
            // The next round's size: double, and at least the exploration this round cast.
            let explore_rays = round_rays - random_rays;
            if adaptive {
                round_size = (round_size * 2).max(explore_rays).min(p.n_rand);
            }
            // Termination (4.4), over the last TERMINATION_WINDOW rays.
            recent.push_back((round_rays, round_new));
            while recent.len() > 1
                && recent.iter().skip(1).map(|r| r.0).sum::<u64>() >= TERMINATION_WINDOW
            {
                recent.pop_front();
            }
            let window_rays: u64 = recent.iter().map(|r| r.0).sum();
            let window_new: usize = recent.iter().map(|r| r.1).sum();
            // With rounds of the paper's size the window is the last round: the paper's rule.
            let converged =
                window_rays >= TERMINATION_WINDOW && window_new < p.termination_threshold;
            if tally.exhausted() || (budget.is_unlimited() && converged) {
                break;
            }
        }
        tally.finish(vec![
            ("random", found[0]),
            ("abs", found[1]),
            ("rs", found[2]),
        ])
    }
}

/// ABS rays for a chunk of discoveries, and for each ray that aims at a border *vertex*, its
/// target (rays at edge samples get `None`).
pub(crate) fn abs_rays(
    ctx: &CellContext<'_>,
    chunk: &[Discovery],
    delta_abs: f32,
    n_edge: u32,
) -> (Vec<Ray>, Vec<Option<Vec3>>) {
    let per_triangle = 9 + 3 * n_edge as usize;
    let pairs: Vec<(Ray, Option<Vec3>)> = chunk
        .par_iter()
        .flat_map_iter(|d| {
            let triangle = ctx.scene.triangle(d.triangle);
            let polygon = border_polygon(triangle, delta_abs);
            let mut out = Vec::with_capacity(per_triangle);
            for v in vertex_targets(triangle, delta_abs) {
                out.push((Ray::new(d.origin, v - d.origin), Some(v)));
            }
            for (a, b) in LONG_EDGES {
                for k in 0..n_edge {
                    let f = (k + 1) as f32 / (n_edge + 1) as f32;
                    let target = polygon[a].lerp(polygon[b], f);
                    out.push((Ray::new(d.origin, target - d.origin), None));
                }
            }
            out
        })
        .collect();
    pairs.into_iter().unzip()
}

/// Border-vertex rays whose hit is closer than the target by more than `delta` (an occluder in
/// front) or that hit nothing (section 4.3). Rays aim at their target with `t = 1`.
pub(crate) fn find_discontinuities(
    rays: &[Ray],
    hits: &[Hit],
    targets: &[Option<Vec3>],
    delta: f32,
) -> Vec<Discontinuity> {
    rays.iter()
        .zip(hits)
        .zip(targets)
        .filter_map(|((ray, hit), target)| {
            let target = (*target)?;
            if !hit.is_hit() {
                return Some(Discontinuity {
                    target,
                    occluder: None,
                });
            }
            let length = ray.dir.length();
            ((1.0 - hit.t) * length > delta).then_some(Discontinuity {
                target,
                occluder: Some(hit.triangle),
            })
        })
        .collect()
}

/// The origins of reverse sampling on the view cell: its corners, `n_rs_edge` points on each
/// edge (fixed), and `n_rs_area` Halton points on its surface (a fresh stretch of the sequence
/// for every group of discontinuities, so repeated discontinuities are sampled from new places).
pub(crate) struct ReverseOrigins {
    fixed: Vec<Vec3>,
    surface: CellSurface,
    halton: ShiftedHalton<3>,
    n_area: u32,
}

impl ReverseOrigins {
    pub(crate) fn new(ctx: &CellContext<'_>, n_edge: u32, n_area: u32) -> Self {
        let mut fixed = ctx.cell.distinct_corners();
        for (a, b) in ctx.cell.edges() {
            for k in 0..n_edge {
                fixed.push(a.lerp(b, (k + 1) as f32 / (n_edge + 1) as f32));
            }
        }
        Self {
            fixed,
            surface: CellSurface::new(ctx.cell),
            halton: ShiftedHalton::new(ctx.seed ^ 0x5253),
            n_area,
        }
    }

    fn origins_per_discontinuity(&self) -> usize {
        self.fixed.len() + self.n_area as usize
    }

    /// Discontinuities per RS batch, so that a batch is about [`BATCH`] rays.
    pub(crate) fn group_size(&self) -> usize {
        (BATCH / self.origins_per_discontinuity().max(1)).max(1)
    }

    pub(crate) fn rays(
        &self,
        ctx: &CellContext<'_>,
        group: &[Discontinuity],
        round: u64,
    ) -> Vec<Ray> {
        let area: Vec<Vec3> = (0..u64::from(self.n_area))
            .map(|j| {
                self.surface
                    .sample(self.halton.point(round * u64::from(self.n_area) + j))
                    .0
            })
            .collect();
        group
            .par_iter()
            .flat_map_iter(|d| {
                let occluder = d.occluder.map(|t| ctx.scene.triangle(t));
                self.fixed.iter().chain(&area).filter_map(move |&origin| {
                    if !ctx.origin_allowed(origin) {
                        return None;
                    }
                    let to_target = d.target - origin;
                    if let Some([a, b, c]) = occluder {
                        // Skip origins from which the occluder hides the target (the paper's
                        // "inside the projected triangle" test).
                        let segment = Ray {
                            origin,
                            dir: to_target,
                            t_min: 0.0,
                            t_max: 1.0,
                        };
                        if intersect(&ShearedRay::new(&segment), a, b, c).is_some() {
                            return None;
                        }
                    }
                    (to_target.length_squared() > 0.0).then(|| Ray::new(origin, to_target))
                })
            })
            .collect()
    }
}
