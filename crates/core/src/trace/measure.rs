//! Ray-casting throughput: the ray sets and the timing loop that `benches/trace.rs` and
//! `sightline bench trace` share, so both report the same Mrays/s.
//!
//! Based on: Aila, Laine. Understanding the efficiency of ray traversal on GPUs. HPG 2009
//! (primary = coherent, diffuse-like random = incoherent ray sets).

use std::time::Instant;

use glam::Vec3;

use crate::camera::Camera;
use crate::geometry::{Aabb, Hit, Ray};

use super::ray_caster::RayCaster;

/// Rays per second of `caster` closest-hit casting `rays` in one batch, repeated until at least
/// `min_seconds` have passed (at least once). Returns 0 for no rays.
pub fn rays_per_second(caster: &dyn RayCaster, rays: &[Ray], min_seconds: f64) -> f64 {
    if rays.is_empty() {
        return 0.0;
    }
    let mut hits = vec![Hit::MISS; rays.len()];
    let start = Instant::now();
    let mut cast = 0usize;
    loop {
        caster.cast(rays, &mut hits);
        cast += rays.len();
        let elapsed = start.elapsed().as_secs_f64();
        if elapsed >= min_seconds && elapsed > 0.0 {
            return cast as f64 / elapsed;
        }
    }
}

/// `n` incoherent rays: origins uniform in `bounds` (all at the world origin when `bounds`
/// is empty), directions uniform on the unit sphere, range `[0, inf)`. The same `seed` gives
/// the same rays on every platform.
pub fn incoherent_rays(bounds: Aabb, n: usize, seed: u64) -> Vec<Ray> {
    // splitmix64 seeding so that small seeds (0, 1, 2) still give unrelated streams.
    let mut state = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        // 24 random bits: exactly representable in [0, 1).
        (z >> 40) as f32 / (1u32 << 24) as f32
    };
    let (min, extent) = if bounds.is_empty() {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (bounds.min, bounds.extent())
    };
    (0..n)
        .map(|_| {
            let origin = min + Vec3::new(next(), next(), next()) * extent;
            // Uniform on the sphere: uniform z and uniform angle (Archimedes).
            let z = 2.0 * next() - 1.0;
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Ray::new(origin, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// One ray per pixel of `camera`, through the pixel centres, row by row
/// ([`Camera::pixel_ray`]).
pub fn coherent_rays(camera: &Camera) -> Vec<Ray> {
    (0..camera.height)
        .flat_map(|y| (0..camera.width).map(move |x| camera.pixel_ray(x, y)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Scene, SceneBuilder};
    use crate::trace::Bvh;

    fn unit_box() -> Aabb {
        Aabb::new(Vec3::ZERO, Vec3::ONE)
    }

    #[test]
    fn incoherent_rays_empty_for_zero_count() {
        assert!(incoherent_rays(unit_box(), 0, 1).is_empty());
    }

    #[test]
    fn incoherent_rays_start_inside_with_unit_directions() {
        let rays = incoherent_rays(unit_box(), 1000, 3);
        assert_eq!(rays.len(), 1000);
        for r in &rays {
            assert!(unit_box().contains(r.origin));
            assert!((r.dir.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn incoherent_rays_are_deterministic_per_seed() {
        assert_eq!(
            incoherent_rays(unit_box(), 10, 7),
            incoherent_rays(unit_box(), 10, 7)
        );
        assert_ne!(
            incoherent_rays(unit_box(), 10, 7),
            incoherent_rays(unit_box(), 10, 8)
        );
    }

    #[test]
    fn incoherent_rays_in_empty_bounds_start_at_origin() {
        let rays = incoherent_rays(Aabb::EMPTY, 5, 1);
        assert!(rays.iter().all(|r| r.origin == Vec3::ZERO));
    }

    #[test]
    fn coherent_rays_cover_every_pixel() {
        let cam = Camera::look_at(Vec3::Z * 5.0, Vec3::ZERO, Vec3::Y, 60.0, 8, 4, 0.1)
            .expect("valid camera");
        let rays = coherent_rays(&cam);
        assert_eq!(rays.len(), 32);
        assert_eq!(rays[9], cam.pixel_ray(1, 1));
    }

    #[test]
    fn rays_per_second_of_no_rays_is_zero() {
        let bvh = Bvh::build(&Scene::default());
        assert_eq!(rays_per_second(&bvh, &[], 0.01), 0.0);
    }

    #[test]
    fn rays_per_second_is_positive() {
        let mut b = SceneBuilder::new("box");
        b.add_box(Vec3::ZERO, Vec3::ONE);
        let bvh = Bvh::build(&b.finish());
        let rays = incoherent_rays(unit_box(), 100, 1);
        assert!(rays_per_second(&bvh, &rays, 0.001) > 0.0);
    }
}
