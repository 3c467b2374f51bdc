//! SAH BVH (being written).

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

use super::RayCaster;

/// A bounding volume hierarchy over a scene's triangles.
#[derive(Debug)]
pub struct Bvh {}

impl Bvh {
    /// Builds the BVH for `scene`.
    pub fn build(_scene: &Scene) -> Self {
        Self {}
    }
}

impl RayCaster for Bvh {
    fn cast(&self, _rays: &[Ray], hits: &mut [Hit]) {
        hits.fill(Hit::MISS);
    }
}
