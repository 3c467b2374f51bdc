//! The scenes and ray sets the GPU ray casters' tests share (`ray_cast.rs`, `ray_query.rs`):
//! the repository's bunny and Quake 3 map, a procedural city, and camera, axis and ranged rays;
//! the checks that calls from many threads equal one call and that an empty scene misses.

use glam::Vec3;
use sightline_core::scene::{self, LoadOptions, Scene};
use sightline_core::trace::{measure, RayCaster};
use sightline_core::{Camera, Hit, Ray};

fn load(spec: &str) -> Scene {
    scene::open(spec, &LoadOptions::default()).unwrap()
}

/// A file of the repository's `scenes/`, or of `$SIGHTLINE_TEST_SCENES` when set (the test
/// binary copied to another machine by `scripts/gpu-check`).
fn scene_file(name: &str) -> String {
    match std::env::var("SIGHTLINE_TEST_SCENES") {
        Ok(dir) => format!("{dir}/{name}"),
        Err(_) => format!("{}/../../scenes/{name}", env!("CARGO_MANIFEST_DIR")),
    }
}

pub(crate) fn bunny() -> Scene {
    load(&scene_file("bunny.obj"))
}

pub(crate) fn q3_map() -> Scene {
    load(&scene_file("q3dm6ish.bsp"))
}

pub(crate) fn city() -> Scene {
    load("procedural:city?size=20000")
}

/// Rays from a camera outside the scene looking at its centre, `size` x `size`.
pub(crate) fn camera_rays(scene: &Scene, size: u32) -> Vec<Ray> {
    let b = scene.bounds();
    let eye = b.center() + Vec3::new(0.6, 0.35, 0.8) * b.diagonal();
    let cam = Camera::look_at(eye, b.center(), scene.up.vector(), 60.0, size, size, 0.01).unwrap();
    measure::coherent_rays(&cam)
}

/// Rays along the six axis directions from random origins in the scene's box.
pub(crate) fn axis_rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let dirs = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    measure::incoherent_rays(scene.bounds(), n, 11)
        .into_iter()
        .enumerate()
        .map(|(i, r)| Ray::new(r.origin, dirs[i % 6]))
        .collect()
}

/// Incoherent rays with random `[t_min, t_max]` ranges (some empty, some from 0).
pub(crate) fn ranged_rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let d = scene.bounds().diagonal();
    measure::incoherent_rays(scene.bounds(), n, 5)
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let a = (i % 17) as f32 / 17.0 * d * 0.5;
            let b = (i % 13) as f32 / 13.0 * d * 0.7;
            if i % 5 == 0 {
                r.with_range(0.0, b)
            } else {
                r.with_range(a, b)
            }
        })
        .collect()
}

/// Casts 12,000 incoherent rays over `scene` with `gpu` in one call and in calls of 1,500
/// rays from eight threads at once (each several of the caster's chunks long when its chunk
/// is small), and checks that both give the same hits, some of them hits.
pub(crate) fn concurrent_calls_equal_one_call(scene: &Scene, gpu: &dyn RayCaster) {
    use rayon::prelude::*;
    let rays = measure::incoherent_rays(scene.bounds(), 12_000, 21);
    let mut whole = vec![Hit::MISS; rays.len()];
    gpu.cast(&rays, &mut whole);
    let mut parts = vec![Hit::MISS; rays.len()];
    rays.par_chunks(1500)
        .zip(parts.par_chunks_mut(1500))
        .with_max_len(1)
        .for_each(|(r, h)| gpu.cast(r, h));
    assert_eq!(whole, parts);
    assert!(whole.iter().any(|h| h.is_hit()));
}

/// Checks that `gpu`, a caster of an empty scene, misses with every ray, closest hit and
/// any hit alike, and takes an empty batch.
pub(crate) fn misses_everything(gpu: &dyn RayCaster) {
    let rays = measure::incoherent_rays(sightline_core::Aabb::EMPTY, 10, 1);
    let mut hits = vec![
        Hit {
            triangle: 0,
            t: 0.0
        };
        rays.len()
    ];
    gpu.cast(&rays, &mut hits);
    assert!(hits.iter().all(|h| *h == Hit::MISS));
    let mut occ = vec![true; rays.len()];
    gpu.occluded(&rays, &mut occ);
    assert!(occ.iter().all(|o| !o));
    gpu.cast(&[], &mut []);
}
