//! Ray casting: the [`RayCaster`] trait and its backends.
//!
//! Hits are closest hits over `[ray.t_min, ray.t_max]`. Degenerate (zero-area) triangles are
//! never hit. Triangles are double-sided.

pub mod brute;
pub mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
pub mod measure;
mod tri4;
pub mod triangle;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

pub use brute::BruteForce;
pub use bvh::Bvh;
#[cfg(feature = "embree")]
pub use embree::{EmbreeCaster, EmbreeError};

/// The default ray caster for `scene`: our SAH [`Bvh`].
pub fn build_default(scene: &Scene) -> Box<dyn RayCaster> {
    Box::new(Bvh::build(scene))
}

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
