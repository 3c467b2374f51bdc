//! GVS: the original guided visibility sampling, the baseline GVS++ improves on.
//!
//! Based on: Wonka, Wimmer, Zhou, Maierhofer, Hesina, Reshetov. Guided Visibility Sampling.
//! ACM TOG 25(3), 2006 — as summarised and re-implemented for comparison by Koch & Wimmer 2021
//! (sections 4.2, 4.3, figure 3 and table 1: recursive subdivision up to three times).
//!
//! Differences from GVS++ (`gvspp/`), which are the point of this baseline:
//! - adaptive border sampling samples the 9 border-polygon vertices and subdivides a border
//!   edge (at its midpoint, recursively, at most `max_subdivision` times) only when the samples
//!   at its two ends hit different triangles — so an edge whose ends see the same triangle is
//!   never sampled inside (figure 3a);
//! - reverse sampling shoots one mutated ray per discontinuity: from the target, past the
//!   occluder's nearest edge (pushed out by Δ_ABS), back to the plane of the view-cell face the
//!   original ray started on; when that point lies outside the cell, the discontinuity is
//!   dropped (figure 3b). This is our reading of the original mutation, which the GVS++ paper
//!   describes only by its shortcoming.
//!
//! Random sampling, the queue and termination are the same as in GVS++ (the skeleton both
//! share is `guided.rs`); GVS ends after a round that found fewer than `T` new triangles.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use sightline_core::{Hit, Ray, Scene};

use crate::border::vertex_targets;
use crate::guided::{ExploreQueue, Found, Phase, Termination};
use crate::rays::{cast, discover, Discovery, RandomRays};
use crate::sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler, Tally};
use crate::viewcell::{Rect, ViewCell};

/// Parameters of GVS.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GvsParams {
    /// Random rays per round.
    pub n_rand: u64,
    /// Border polygon offset as a fraction of the scene diagonal (as GVS++).
    pub delta_abs: f32,
    /// Recursive border-edge subdivisions (the paper's comparison uses 3).
    pub max_subdivision: u32,
    /// Discontinuity threshold as a fraction of the scene diagonal.
    pub delta_discontinuity: f32,
    /// Stop after a round with fewer new triangles than this.
    pub termination_threshold: usize,
}

impl Default for GvsParams {
    fn default() -> Self {
        Self {
            n_rand: 10_000_000,
            delta_abs: 1e-6,
            max_subdivision: 3,
            delta_discontinuity: 1e-5,
            termination_threshold: 10,
        }
    }
}

/// The GVS sampler.
#[derive(Clone, Debug, Default)]
pub struct Gvs {
    /// Parameters.
    pub params: GvsParams,
}

/// One border sample: where it aimed, from where, and what it hit.
#[derive(Clone, Copy, Debug)]
struct BorderSample {
    origin: Vec3,
    target: Vec3,
    hit: Hit,
}

impl Sampler for Gvs {
    fn name(&self) -> &'static str {
        "gvs"
    }

    fn sample(
        &self,
        ctx: &CellContext<'_>,
        budget: &Budget,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> CellResult {
        let p = &self.params;
        let diagonal = ctx.scene.bounds().diagonal().max(f32::MIN_POSITIVE);
        let explorer = Explorer {
            ctx,
            faces: ctx.cell.faces(),
            delta_abs: p.delta_abs * diagonal,
            delta: p.delta_discontinuity * diagonal,
            max_subdivision: p.max_subdivision,
        };
        let mut tally = Tally::new(ctx.scene.triangle_count(), *budget);
        let mut random = RandomRays::new(ctx.cell, ctx.scene, ctx.seed);
        let mut queue = ExploreQueue::default();
        let mut found = Found::default();
        let mut termination = Termination::per_round(p.termination_threshold);
        let mut rule_held = false;
        loop {
            let round_start = tally.rays;
            let Some(new) = random.sample_round(ctx, &mut tally, p.n_rand, progress) else {
                break;
            };
            found.credit(Phase::Random, new.len());
            queue.extend(new);
            while !queue.is_empty() && !tally.exhausted() {
                let chunk = queue.take(EXPLORE_CHUNK);
                explorer.explore(&chunk, &mut tally, &mut queue, &mut found, progress);
            }
            let converged = termination.round_done(tally.rays - round_start, found.end_round());
            rule_held |= converged;
            if tally.exhausted() || (budget.is_unlimited() && converged) {
                break;
            }
        }
        tally.finish_guided(found.found_by(), rule_held)
    }
}

/// Triangles explored per step.
const EXPLORE_CHUNK: usize = 2048;

/// GVS's exploration of one chunk of the queue: what it needs besides the queue and counters.
struct Explorer<'a> {
    ctx: &'a CellContext<'a>,
    faces: Vec<Rect>,
    delta_abs: f32,
    delta: f32,
    max_subdivision: u32,
}

impl Explorer<'_> {
    /// Adaptive border sampling with recursive edge subdivision around the triangles of
    /// `chunk`, then one mutated reverse-sampling ray per discontinuity; new triangles are
    /// credited in `found` and queued.
    fn explore(
        &self,
        chunk: &[Discovery],
        tally: &mut Tally,
        queue: &mut ExploreQueue,
        found: &mut Found,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) {
        let ctx = self.ctx;
        // Level 0: the nine border vertices of every triangle in the chunk.
        let mut samples: Vec<BorderSample> = chunk
            .iter()
            .flat_map(|d| {
                vertex_targets(ctx.scene.triangle(d.triangle), self.delta_abs).map(|target| {
                    BorderSample {
                        origin: d.origin,
                        target,
                        hit: Hit::MISS,
                    }
                })
            })
            .collect();
        let rays = sample_rays(&samples);
        let hits = cast(ctx.caster, &rays);
        for (s, h) in samples.iter_mut().zip(&hits) {
            s.hit = *h;
        }
        let new = discover(&tally.pvs, &rays, &hits);
        found.credit(Phase::Abs, new.len());
        queue.extend(new);
        tally.batch_done(rays.len(), progress);
        // Border edges between consecutive vertices (cyclic, 9 per triangle).
        let mut edges: Vec<(BorderSample, BorderSample)> = samples
            .chunks(9)
            .flat_map(|poly| (0..9).map(move |k| (poly[k], poly[(k + 1) % 9])))
            .collect();
        let mut all = samples;
        for _ in 0..self.max_subdivision {
            let split: Vec<(BorderSample, BorderSample)> = edges
                .into_iter()
                .filter(|(a, b)| a.hit.triangle != b.hit.triangle)
                .collect();
            if split.is_empty() || tally.exhausted() {
                break;
            }
            let mids: Vec<BorderSample> = split
                .iter()
                .map(|(a, b)| BorderSample {
                    origin: a.origin,
                    target: (a.target + b.target) * 0.5,
                    hit: Hit::MISS,
                })
                .collect();
            let rays = sample_rays(&mids);
            let hits = cast(ctx.caster, &rays);
            let new = discover(&tally.pvs, &rays, &hits);
            found.credit(Phase::Abs, new.len());
            queue.extend(new);
            tally.batch_done(rays.len(), progress);
            let mids: Vec<BorderSample> = mids
                .into_iter()
                .zip(&hits)
                .map(|(m, h)| BorderSample { hit: *h, ..m })
                .collect();
            edges = split
                .iter()
                .zip(&mids)
                .flat_map(|((a, b), m)| [(*a, *m), (*m, *b)])
                .collect();
            all.extend(mids);
        }
        // Reverse sampling: one mutated ray per discontinuity.
        let rs: Vec<Ray> = all
            .par_iter()
            .filter_map(|s| {
                mutated_ray(
                    ctx.scene,
                    ctx.cell,
                    &self.faces,
                    s,
                    self.delta,
                    self.delta_abs,
                )
            })
            .filter(|r| ctx.origin_allowed(r.origin))
            .collect();
        if !rs.is_empty() && !tally.exhausted() {
            let new = discover(&tally.pvs, &rs, &cast(ctx.caster, &rs));
            found.credit(Phase::Rs, new.len());
            queue.extend(new);
            tally.batch_done(rs.len(), progress);
        }
    }
}

fn sample_rays(samples: &[BorderSample]) -> Vec<Ray> {
    samples
        .iter()
        .map(|s| Ray::new(s.origin, s.target - s.origin))
        .collect()
}

/// The GVS reverse-sampling ray for a border sample whose hit lies closer than its target, or
/// `None` when there is no such discontinuity or the mutated origin falls outside the cell.
fn mutated_ray(
    scene: &Scene,
    cell: &ViewCell,
    faces: &[Rect],
    s: &BorderSample,
    delta: f32,
    delta_abs: f32,
) -> Option<Ray> {
    if !s.hit.is_hit() {
        return None;
    }
    let to_target = s.target - s.origin;
    if (1.0 - s.hit.t) * to_target.length() <= delta {
        return None;
    }
    let hit_point = s.origin + to_target * s.hit.t;
    let corners = scene.triangle(s.hit.triangle);
    let normal = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize_or_zero();
    // The occluder edge nearest to the hit point, and a point just past it in its plane.
    let (edge_point, outward) = (0..3)
        .map(|i| {
            let (a, b) = (corners[i], corners[(i + 1) % 3]);
            let ab = b - a;
            let f = ((hit_point - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE))
                .clamp(0.0, 1.0);
            let q = a + ab * f;
            let out = ab.cross(normal).normalize_or_zero();
            (q, out, q.distance_squared(hit_point))
        })
        .min_by(|x, y| x.2.total_cmp(&y.2))
        .map(|(q, out, _)| (q, out))?;
    let pass = edge_point + outward * delta_abs.max(delta);
    // Back along target -> pass to the plane of the face the original ray started on.
    let face = faces.iter().min_by(|a, b| {
        let da = (s.origin - a.center).dot(a.normal()).abs();
        let db = (s.origin - b.center).dot(b.normal()).abs();
        da.total_cmp(&db)
    })?;
    let dir = pass - s.target;
    let denom = dir.dot(face.normal());
    if denom.abs() < 1e-12 {
        return None;
    }
    let t = (face.center - s.target).dot(face.normal()) / denom;
    let origin = s.target + dir * t;
    if t <= 0.0 || !cell.contains(origin) {
        return None;
    }
    Some(Ray::new(origin, s.target - origin))
}
