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

/// Which of a triangle's border samples ABS casts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum EdgeSamples {
    /// The paper's fixed rate: the 9 border vertices and `n` points on each long edge.
    Fixed(u32),
    /// The 9 border vertices and, on each long edge, one point per `step` radians of the angle
    /// the edge spans from the discovery's origin (at least 1, at most `n`): a first pass that
    /// costs a few rays on a triangle a few pixels wide (ours, see `by_yield.rs`).
    Coarse { n: u32, step: f32 },
    /// Only the `n` points on each long edge, no vertices: the rest of [`EdgeSamples::Fixed`]
    /// after a coarse pass (its vertex rays and their discontinuities are done).
    EdgesOnly(u32),
}

impl EdgeSamples {
    /// Samples on the border-polygon edge `a -> b` seen from `origin`.
    fn on_edge(self, origin: Vec3, a: Vec3, b: Vec3) -> u32 {
        match self {
            Self::Fixed(n) | Self::EdgesOnly(n) => n,
            Self::Coarse { n, step } => {
                let (u, v) = (
                    (a - origin).normalize_or_zero(),
                    (b - origin).normalize_or_zero(),
                );
                let angle = u.dot(v).clamp(-1.0, 1.0).acos();
                ((angle / step).ceil() as u32).clamp(1, n.max(1))
            }
        }
    }

    fn with_vertices(self) -> bool {
        !matches!(self, Self::EdgesOnly(_))
    }
}

/// ABS rays for a chunk of discoveries, and for each ray that aims at a border *vertex* (and,
/// with `edge_targets`, at an edge sample too), its target, where [`find_discontinuities`]
/// looks for a discontinuity; other rays get `None`. With [`EdgeSamples::Coarse`], also
/// whether each discovery had fewer edge samples than `n` somewhere (it then needs an
/// [`EdgeSamples::EdgesOnly`] pass to complete the paper's samples).
pub(crate) fn abs_rays(
    ctx: &CellContext<'_>,
    chunk: &[Discovery],
    delta_abs: f32,
    samples: EdgeSamples,
    edge_targets: bool,
) -> (Vec<Ray>, Vec<Option<Vec3>>, Vec<bool>) {
    let full = match samples {
        EdgeSamples::Fixed(n) | EdgeSamples::EdgesOnly(n) | EdgeSamples::Coarse { n, .. } => n,
    };
    // Per discovery: its rays with their vertex targets, and whether an edge got fewer
    // samples than the paper's.
    type TriangleRays = (Vec<(Ray, Option<Vec3>)>, bool);
    let per_triangle: Vec<TriangleRays> = chunk
        .par_iter()
        .map(|d| {
            let triangle = ctx.scene.triangle(d.triangle);
            let polygon = border_polygon(triangle, delta_abs);
            let mut out = Vec::with_capacity(9 + 3 * full as usize);
            if samples.with_vertices() {
                for v in vertex_targets(triangle, delta_abs) {
                    out.push((Ray::new(d.origin, v - d.origin), Some(v)));
                }
            }
            let mut partial = false;
            for (a, b) in LONG_EDGES {
                let n_edge = samples.on_edge(d.origin, polygon[a], polygon[b]);
                partial |= n_edge < full;
                for k in 0..n_edge {
                    let f = (k + 1) as f32 / (n_edge + 1) as f32;
                    let target = polygon[a].lerp(polygon[b], f);
                    let kept = edge_targets.then_some(target);
                    out.push((Ray::new(d.origin, target - d.origin), kept));
                }
            }
            (out, partial)
        })
        .collect();
    let mut rays = Vec::new();
    let mut targets = Vec::new();
    let mut partial = Vec::with_capacity(chunk.len());
    for (pairs, p) in per_triangle {
        for (r, t) in pairs {
            rays.push(r);
            targets.push(t);
        }
        partial.push(p);
    }
    (rays, targets, partial)
}

/// Border rays with a target whose hit is closer than the target by more than `delta` (an
/// occluder in front) or that hit nothing (section 4.3). Rays aim at their target with `t = 1`.
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

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    use crate::viewcell::ViewCell;

    /// One triangle 1 unit across, seen from `distance` away: its rays at the three sampling
    /// modes, how many of them have a target (vertices only, or every sample with
    /// `edge_targets`), and whether the coarse pass left samples out.
    fn rays_with(distance: f32, samples: EdgeSamples, edge_targets: bool) -> (usize, usize, bool) {
        let mut b = SceneBuilder::new("one");
        let (p, q, r) = (
            Vec3::new(-0.5, -0.5, distance),
            Vec3::new(0.5, -0.5, distance),
            Vec3::new(0.0, 0.5, distance),
        );
        let t = [b.add_vertex(p), b.add_vertex(q), b.add_vertex(r)];
        b.add_triangle(t);
        let scene = b.finish();
        let bvh = Bvh::build(&scene);
        let cell = ViewCell::aabb(Vec3::splat(-0.1), Vec3::splat(0.1)).unwrap();
        let ctx = CellContext {
            scene: &scene,
            caster: &bvh,
            cell: &cell,
            seed: 1,
            free_space: None,
        };
        let d = Discovery {
            triangle: 0,
            origin: Vec3::ZERO,
            hit_point: Vec3::new(0.0, 0.0, distance),
        };
        let (rays, targets, partial) = abs_rays(&ctx, &[d], 1e-4, samples, edge_targets);
        let with_target = targets.iter().filter(|t| t.is_some()).count();
        (rays.len(), with_target, partial[0])
    }

    /// [`rays_with`] as the paper does it: targets at the border vertices only.
    fn rays_at(distance: f32, samples: EdgeSamples) -> (usize, usize, bool) {
        rays_with(distance, samples, false)
    }

    #[test]
    fn coarse_border_sampling_spaces_edge_samples_by_angle() {
        let coarse = EdgeSamples::Coarse { n: 20, step: 0.003 };
        // The paper's rate: 9 vertices and 20 points on each of the three long edges.
        assert_eq!(rays_at(2.0, EdgeSamples::Fixed(20)), (69, 9, false));
        // Near (an edge spans about 0.5 rad): every edge gets its 20 samples, nothing to refine.
        assert_eq!(rays_at(2.0, coarse), (69, 9, false));
        // Far (about 2.5 mrad per edge at 400 units): one sample per edge, to be refined.
        assert_eq!(rays_at(400.0, coarse), (12, 9, true));
        // The refinement casts the 60 edge samples and no vertex rays.
        assert_eq!(rays_at(400.0, EdgeSamples::EdgesOnly(20)), (60, 0, false));
    }

    #[test]
    fn edge_discontinuities_give_every_border_sample_a_target() {
        // Every ray aims at a point of the border polygon, so every one can reveal an occluder.
        assert_eq!(
            rays_with(2.0, EdgeSamples::Fixed(20), true),
            (69, 69, false)
        );
        let coarse = EdgeSamples::Coarse { n: 20, step: 0.003 };
        assert_eq!(rays_with(400.0, coarse, true), (12, 12, true));
        assert_eq!(
            rays_with(400.0, EdgeSamples::EdgesOnly(20), true),
            (60, 60, false)
        );
    }

    #[test]
    fn a_border_sample_behind_an_occluder_is_a_discontinuity_and_one_past_it_is_not() {
        let origin = Vec3::ZERO;
        let target = Vec3::new(0.0, 0.0, 10.0);
        let ray = Ray::new(origin, target - origin);
        let hit = |t: f32| Hit { triangle: 7, t };
        let rays = [ray, ray, ray, ray];
        // In front by 1 unit (found), at the target, past it, and nothing at all (found).
        let hits = [hit(0.9), hit(1.0), hit(1.5), Hit::MISS];
        let targets = [Some(target); 4];
        let found = find_discontinuities(&rays, &hits, &targets, 0.01);
        assert_eq!(found.len(), 2);
        assert_eq!(found[0].occluder, Some(7));
        assert_eq!(found[1].occluder, None);
        // Without a target (an edge sample in the paper's mode) nothing is looked for.
        assert!(find_discontinuities(&rays, &hits, &[None; 4], 0.01).is_empty());
    }
}
