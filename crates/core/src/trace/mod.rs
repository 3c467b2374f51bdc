//! Ray casting: the [`RayCaster`] trait and its backends.
//!
//! Hits are closest hits over `[ray.t_min, ray.t_max]`. Degenerate (zero-area) triangles are
//! never hit. Triangles are double-sided.
//!
//! The backends take the trait from `ray_caster.rs`, never from this file, which re-exports it.

pub mod brute;
pub mod bvh;
#[cfg(feature = "embree")]
pub mod embree;
pub mod measure;
mod ray_caster;
mod tri4;
pub mod triangle;

use crate::scene::Scene;

pub use brute::BruteForce;
pub use bvh::Bvh;
#[cfg(feature = "embree")]
pub use embree::{EmbreeCaster, EmbreeError};
pub use ray_caster::RayCaster;

/// The default ray caster for `scene`: our SAH [`Bvh`].
pub fn build_default(scene: &Scene) -> Box<dyn RayCaster> {
    Box::new(Bvh::build(scene))
}
