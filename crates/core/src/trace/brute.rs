//! Brute-force ray casting: every ray against every triangle. The slow, obviously-correct
//! reference that tests compare the BVH, Embree and the rasterizer with.

use rayon::prelude::*;

use crate::geometry::{Hit, Ray};
use crate::scene::Scene;

use super::ray_caster::RayCaster;
use super::triangle::{intersect, ShearedRay};

/// Tests every triangle for every ray. Use only on small scenes.
#[derive(Debug)]
pub struct BruteForce<'a> {
    scene: &'a Scene,
}

impl<'a> BruteForce<'a> {
    /// A brute-force caster over `scene` (indices must be in range, see `validate`).
    pub fn new(scene: &'a Scene) -> Self {
        Self { scene }
    }

    fn closest(&self, ray: &Ray) -> Hit {
        let sheared = ShearedRay::new(ray);
        let mut best = Hit::MISS;
        for (id, t) in self.scene.triangles.iter().enumerate() {
            let p = |i: u32| self.scene.positions[i as usize];
            if let Some(t) = intersect(&sheared, p(t[0]), p(t[1]), p(t[2])) {
                // Ties go to the lower id, the same rule as the BVH and the rasterizer.
                if t < best.t {
                    best = Hit {
                        triangle: id as u32,
                        t,
                    };
                }
            }
        }
        best
    }
}

impl RayCaster for BruteForce<'_> {
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        hits.par_iter_mut()
            .zip(rays.par_iter())
            .for_each(|(h, r)| *h = self.closest(r));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;
    use glam::Vec3;

    #[test]
    fn empty_scene_misses() {
        let s = Scene::default();
        let h = BruteForce::new(&s).cast_one(&Ray::new(Vec3::ZERO, Vec3::X));
        assert!(!h.is_hit());
    }

    #[test]
    fn nearer_box_wins() {
        let mut b = SceneBuilder::new("two boxes");
        b.add_box(Vec3::new(2.0, -1.0, -1.0), Vec3::new(3.0, 1.0, 1.0));
        b.add_box(Vec3::new(5.0, -1.0, -1.0), Vec3::new(6.0, 1.0, 1.0));
        let s = b.finish();
        let h = BruteForce::new(&s).cast_one(&Ray::new(Vec3::ZERO, Vec3::X));
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!(h.triangle < 12);
    }
}
