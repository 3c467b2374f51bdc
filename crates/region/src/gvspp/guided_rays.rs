//! The rays of GVS++'s guided phases: adaptive border sampling with a fixed number of samples
//! per border-polygon edge, the discontinuities its border-vertex rays reveal, and reverse
//! sampling from points spread over the view cell.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, sections 4.2 (ABS) and 4.3
//! (discontinuities, RS); the border polygon itself is `border.rs`.

use glam::Vec3;
use rayon::prelude::*;
use sightline_core::sampling::ShiftedHalton;
use sightline_core::trace::triangle::{intersect, ShearedRay};
use sightline_core::{Hit, Ray};

use crate::border::{border_polygon, vertex_targets, LONG_EDGES};
use crate::rays::{Discovery, BATCH};
use crate::sampler::CellContext;
use crate::viewcell::CellSurface;

/// A border vertex whose ray hit something closer than it, or nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Discontinuity {
    target: Vec3,
    occluder: Option<u32>,
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

    pub(crate) fn origins_per_discontinuity(&self) -> usize {
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
