//! Ray generation and hit bookkeeping shared by the ray-casting samplers.

use glam::Vec3;
use rayon::prelude::*;
use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::sampling::ShiftedHalton;
use sightline_core::trace::RayCaster;
use sightline_core::{Aabb, Hit, Ray, Scene};

use crate::sampler::{CellContext, ConvergencePoint, Tally};
use crate::viewcell::{CellSurface, ViewCell};

/// Rays cast per batch: large enough to keep both cores busy inside the caster, small enough
/// that budgets and progress stay fine-grained.
pub(crate) const BATCH: usize = 1 << 16;

/// How random rays leave the cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Directions {
    /// The hemisphere around each face's outward normal (eq. 2 of Koch & Wimmer 2021): enough
    /// for a closed box cell with nothing inside it, since every sight line from inside the box
    /// to the outside leaves through the surface.
    OutwardHemisphere,
    /// The whole sphere: for flat cells (seen from both sides) and for cells with geometry
    /// inside them.
    Sphere,
}

impl Directions {
    /// The right choice for `cell` in `scene`.
    pub fn for_cell(cell: &ViewCell, scene: &Scene) -> Self {
        if cell.is_flat() || geometry_inside(cell, scene) {
            Directions::Sphere
        } else {
            Directions::OutwardHemisphere
        }
    }
}

/// True when some triangle's bounding box overlaps the cell's bounding box (conservative: a
/// false positive only costs rays).
fn geometry_inside(cell: &ViewCell, scene: &Scene) -> bool {
    let cell_box = Aabb::from_points(cell.corners());
    scene.triangles.par_iter().any(|t| {
        let b = Aabb::from_points(t.map(|i| scene.positions[i as usize]));
        b.min.cmple(cell_box.max).all() && b.max.cmpge(cell_box.min).all()
    })
}

/// Random rays per section 4.1: origin = Halton point on the cell surface (eq. 1), direction
/// from two more Halton dimensions (eq. 2) in the frame of the face.
pub(crate) struct RandomRays {
    surface: CellSurface,
    halton: ShiftedHalton<5>,
    directions: Directions,
    /// Index of the next ray of the sequence: later phases continue where earlier ones stopped.
    next: u64,
    /// Origins drawn since the last batch with an allowed one (all of them refused).
    refused_in_a_row: u64,
}

impl RandomRays {
    pub fn new(cell: &ViewCell, scene: &Scene, seed: u64) -> Self {
        Self {
            surface: CellSurface::new(cell),
            halton: ShiftedHalton::new(seed),
            directions: Directions::for_cell(cell, scene),
            next: 0,
            refused_in_a_row: 0,
        }
    }

    /// Ray number `index` of the sequence.
    pub fn ray(&self, index: u64) -> Ray {
        let h = self.halton.point(index);
        let (origin, face) = self.surface.sample([h[0], h[1], h[2]]);
        let phi = std::f32::consts::TAU * h[3];
        let z = match self.directions {
            Directions::OutwardHemisphere => h[4],
            Directions::Sphere => 2.0 * h[4] - 1.0,
        };
        let r = (1.0 - z * z).max(0.0).sqrt();
        let n = face.normal();
        let u = face.u.normalize_or_zero();
        let v = n.cross(u);
        Ray::new(origin, u * (r * phi.cos()) + v * (r * phi.sin()) + n * z)
    }

    /// Rays `first .. first + count` of the sequence whose origins `ctx` allows (all of them
    /// unless the cell has a free-space predicate).
    pub fn batch(&self, ctx: &CellContext<'_>, first: u64, count: usize) -> Vec<Ray> {
        (0..count as u64)
            .into_par_iter()
            .map(|i| self.ray(first + i))
            .filter(|r| ctx.origin_allowed(r.origin))
            .collect()
    }
}

/// The smallest batch of random rays whose origins, all outside the cell's free space, tell
/// that the cell has none.
const FREE_SPACE_PROBE: usize = 256;

impl RandomRays {
    /// The next `count` rays of the sequence whose origins `ctx` allows; the sequence moves on
    /// by `count` (allowed or not).
    pub fn next_batch(&mut self, ctx: &CellContext<'_>, count: usize) -> Vec<Ray> {
        let rays = self.batch(ctx, self.next, count);
        self.next += count as u64;
        self.refused_in_a_row = if rays.is_empty() {
            self.refused_in_a_row + count as u64
        } else {
            0
        };
        rays
    }

    /// One random-sampling phase (section 4.1): up to `n_rays` more rays of the sequence,
    /// within the budget of `tally`, in batches; returns the newly found triangles in ray
    /// order, or `None` when [`FREE_SPACE_PROBE`] origins in a row were refused (the cell has
    /// no free space).
    pub fn sample_round(
        &mut self,
        ctx: &CellContext<'_>,
        tally: &mut Tally,
        n_rays: u64,
        progress: &(dyn Fn(&ConvergencePoint) + Sync),
    ) -> Option<Vec<Discovery>> {
        let mut found = Vec::new();
        let mut remaining = n_rays;
        while remaining > 0 && !tally.exhausted() {
            let n = remaining.min(BATCH as u64).min(tally.rays_left()) as usize;
            let rays = self.next_batch(ctx, n);
            remaining -= n as u64;
            if rays.is_empty() {
                // No allowed origin among the last [`FREE_SPACE_PROBE`] or more, in this batch
                // or the small ones before it: the cell has no free space. A smaller run (the
                // last rays of a budget) may just have drawn its few origins in the cell's
                // closed part: the sequence moves on. (Counting per batch alone, a budget
                // below the probe never ended in a cell without free space.)
                if self.refused_in_a_row >= FREE_SPACE_PROBE as u64 {
                    return None;
                }
                continue;
            }
            found.extend(discover(&tally.pvs, &rays, &cast(ctx.caster, &rays)));
            tally.batch_done(rays.len(), progress);
        }
        Some(found)
    }
}

/// Casts `rays` and returns their hits.
pub(crate) fn cast(caster: &dyn RayCaster, rays: &[Ray]) -> Vec<Hit> {
    let mut hits = vec![Hit::MISS; rays.len()];
    caster.cast(rays, &mut hits);
    hits
}

/// A newly found triangle with the ray that found it: the seed of adaptive border sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Discovery {
    pub triangle: u32,
    pub origin: Vec3,
    pub hit_point: Vec3,
}

/// Inserts the hit triangles into `pvs` and returns those that were new, in ray order.
///
/// Parallel and deterministic: a parallel pass drops hits on triangles already in the set (by
/// far the most, once sampling is under way), then the few candidates are inserted in ray order,
/// so the ray credited with a discovery never depends on thread timing.
pub(crate) fn discover(pvs: &AtomicTriangleSet, rays: &[Ray], hits: &[Hit]) -> Vec<Discovery> {
    let candidates: Vec<usize> = hits
        .par_iter()
        .enumerate()
        .filter(|(_, h)| h.is_hit() && !pvs.contains(h.triangle))
        .map(|(i, _)| i)
        .collect();
    candidates
        .into_iter()
        .filter(|&i| pvs.insert(hits[i].triangle))
        .map(|i| Discovery {
            triangle: hits[i].triangle,
            origin: rays[i].origin,
            hit_point: rays[i].at(hits[i].t),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::scene::SceneBuilder;

    fn far_box_scene() -> Scene {
        let mut b = SceneBuilder::new("far box");
        b.add_box(Vec3::splat(10.0), Vec3::splat(11.0));
        b.finish()
    }

    #[test]
    fn only_a_full_probe_without_free_origins_means_no_free_space() {
        let scene = far_box_scene();
        let bvh = sightline_core::trace::Bvh::build(&scene);
        let cell = ViewCell::aabb(Vec3::ZERO, Vec3::ONE).unwrap();
        let round = |free: &(dyn Fn(Vec3) -> bool + Sync), n: u64| {
            let ctx = CellContext {
                scene: &scene,
                caster: &bvh,
                cell: &cell,
                seed: 1,
                free_space: Some(free),
            };
            let mut rays = RandomRays::new(&cell, &scene, 1);
            let mut tally = Tally::new(scene.triangle_count(), crate::sampler::Budget::rays(n));
            let found = rays.sample_round(&ctx, &mut tally, n, &|_| {});
            (found.is_some(), tally.rays, rays.next)
        };
        // The first origin of the sequence lies in the closed part: a one-ray remainder of a
        // budget moves the sequence on instead of giving up on the cell.
        let first = RandomRays::new(&cell, &scene, 1).ray(0).origin;
        assert_eq!(round(&|p| p != first, 1), (true, 0, 1));
        // No origin allowed at all: a probe of 256 rays tells the cell has no free space.
        assert_eq!(round(&|_| false, FREE_SPACE_PROBE as u64), (false, 0, 256));
        assert_eq!(round(&|_| true, 300), (true, 300, 300));
    }

    #[test]
    fn box_cell_rays_leave_through_their_face() {
        let scene = far_box_scene();
        let cell = ViewCell::aabb(Vec3::ZERO, Vec3::ONE).unwrap();
        let rays = RandomRays::new(&cell, &scene, 1);
        assert_eq!(rays.directions, Directions::OutwardHemisphere);
        for i in 0..2000 {
            let r = rays.ray(i);
            assert!(cell.contains(r.origin));
            // A step along the ray never enters the cell's interior (it may graze the
            // surface when the direction is nearly tangent).
            let q = r.at(1e-3);
            let strictly_inside =
                q.cmpgt(Vec3::splat(1e-6)).all() && q.cmplt(Vec3::splat(1.0 - 1e-6)).all();
            assert!(!strictly_inside, "ray {i} goes inward: {r:?}");
            assert!((r.dir.length() - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn flat_cell_and_cell_with_geometry_use_sphere() {
        let scene = far_box_scene();
        let flat = ViewCell::aabb(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)).unwrap();
        assert_eq!(Directions::for_cell(&flat, &scene), Directions::Sphere);
        let around = ViewCell::aabb(Vec3::splat(9.0), Vec3::splat(12.0)).unwrap();
        assert_eq!(Directions::for_cell(&around, &scene), Directions::Sphere);
    }

    #[test]
    fn discover_reports_each_triangle_once_in_ray_order() {
        let pvs = AtomicTriangleSet::new(10);
        let rays: Vec<Ray> = (0..4)
            .map(|i| Ray::new(Vec3::splat(i as f32), Vec3::X))
            .collect();
        let hits = [
            Hit {
                triangle: 3,
                t: 1.0,
            },
            Hit::MISS,
            Hit {
                triangle: 3,
                t: 2.0,
            },
            Hit {
                triangle: 5,
                t: 1.0,
            },
        ];
        let found = discover(&pvs, &rays, &hits);
        assert_eq!(
            found.iter().map(|d| d.triangle).collect::<Vec<_>>(),
            vec![3, 5]
        );
        assert_eq!(found[0].hit_point, Vec3::new(1.0, 0.0, 0.0));
        assert!(discover(&pvs, &rays, &hits).is_empty());
    }
}
