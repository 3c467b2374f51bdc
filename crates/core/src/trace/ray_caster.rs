//! The [`RayCaster`] trait: batched, thread-safe ray queries, the one interface of every
//! backend. A leaf of `trace`: the backends (`brute.rs`, `bvh/`, `embree.rs`) take the trait
//! from here, never from the module's face (`mod.rs`), which re-exports it.

use crate::geometry::{Hit, Ray};

/// Batched, thread-safe ray queries against one scene.
pub trait RayCaster: Send + Sync {
    /// For each ray, the closest hit in `[t_min, t_max]` (or [`Hit::MISS`]).
    /// `hits.len()` must equal `rays.len()`.
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]);

    /// For each ray, whether anything is hit in `[t_min, t_max]`. The default uses
    /// [`RayCaster::cast`]; backends override it with a cheaper any-hit traversal.
    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        let mut hits = vec![Hit::MISS; rays.len()];
        self.cast(rays, &mut hits);
        for (o, h) in out.iter_mut().zip(&hits) {
            *o = h.is_hit();
        }
    }

    /// The closest hit of one ray.
    fn cast_one(&self, ray: &Ray) -> Hit {
        let mut hit = [Hit::MISS];
        self.cast(std::slice::from_ref(ray), &mut hit);
        hit[0]
    }
}
