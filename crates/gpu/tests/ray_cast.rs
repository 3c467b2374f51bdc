//! The GPU ray caster against the CPU caster (`sightline_core::trace::Bvh`) on the shared
//! scenes: the same triangle for every ray, and the same `t` bits where the adapter has
//! `SHADER_F64` (lavapipe has it), else `t` within `APPROXIMATE_T_ULPS` and another triangle
//! only at a tie within that bound. Random incoherent rays, camera rays, rays along the axes
//! (the city's walls are axis-aligned: exact-zero edge functions and rays parallel to slabs),
//! limited ranges, unusable rays, several node widths and chunk sizes.

use glam::Vec3;
use sightline_core::scene::{Scene, SceneBuilder};
use sightline_core::trace::{measure, Bvh, RayCaster};
use sightline_core::{Hit, Ray};
use sightline_gpu::{GpuError, GpuRayCaster, GpuRayCasterOptions, APPROXIMATE_T_ULPS};

use super::scenes::{self, axis_rays, bunny, camera_rays, city, q3_map, ranged_rays};
use super::shared_device;

fn caster(scene: &Scene, options: GpuRayCasterOptions) -> GpuRayCaster {
    let (device, queue, info) = shared_device();
    GpuRayCaster::with_device(device, queue, info.clone(), scene, options).unwrap()
}

/// Distance in ulps between two finite floats of the same sign.
fn ulps(a: f32, b: f32) -> u32 {
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
}

/// Casts `rays` on the CPU and the GPU and checks that every hit agrees (see the module
/// documentation), and that `occluded` agrees exactly. Returns the number of hits.
fn agrees(what: &str, scene: &Scene, gpu: &GpuRayCaster, rays: &[Ray]) -> usize {
    let cpu = Bvh::build(scene);
    let mut want = vec![Hit::MISS; rays.len()];
    cpu.cast(rays, &mut want);
    let mut got = vec![Hit::MISS; rays.len()];
    gpu.try_cast(rays, &mut got).unwrap();
    let mut ties = 0;
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        if gpu.exact() {
            assert!(
                w.triangle == g.triangle && w.t.to_bits() == g.t.to_bits(),
                "{what}: ray {i} {:?}: CPU {w:?}, GPU {g:?}",
                rays[i]
            );
        } else {
            assert_eq!(
                w.is_hit(),
                g.is_hit(),
                "{what}: ray {i}: CPU {w:?}, GPU {g:?}"
            );
            if w.is_hit() {
                assert!(
                    ulps(w.t, g.t) <= APPROXIMATE_T_ULPS,
                    "{what}: ray {i}: CPU {w:?}, GPU {g:?}"
                );
                ties += usize::from(w.triangle != g.triangle);
            }
        }
    }
    // Another triangle at the same distance (within the bound) only at edges: rare.
    assert!(ties * 1000 <= rays.len(), "{what}: {ties} ties");
    let mut want_occ = vec![false; rays.len()];
    cpu.occluded(rays, &mut want_occ);
    let mut got_occ = vec![true; rays.len()];
    gpu.try_occluded(rays, &mut got_occ).unwrap();
    for (i, (w, g)) in want_occ.iter().zip(&got_occ).enumerate() {
        assert_eq!(w, g, "{what}: occluded ray {i} {:?}", rays[i]);
    }
    want.iter().filter(|h| h.is_hit()).count()
}

/// Checks the three ray sets a scene gets; each must hit something and miss something.
fn scene_agrees(name: &str, scene: &Scene, options: GpuRayCasterOptions) {
    let gpu = caster(scene, options);
    eprintln!(
        "{name}: {} triangles, exact {}, stack {} of the shader's",
        scene.triangle_count(),
        gpu.exact(),
        gpu.stack_needed()
    );
    let incoherent = measure::incoherent_rays(scene.bounds(), 20_000, 3);
    let camera = camera_rays(scene, 96);
    for (what, rays) in [("incoherent", incoherent), ("camera", camera)] {
        let hits = agrees(&format!("{name} {what}"), scene, &gpu, &rays);
        assert!(hits > 0, "{name} {what}: no hits");
    }
}

#[test]
fn bunny_hits_equal_cpu() {
    scene_agrees("bunny", &bunny(), GpuRayCasterOptions::default());
}

#[test]
fn city_hits_equal_cpu() {
    scene_agrees("city", &city(), GpuRayCasterOptions::default());
}

#[test]
fn q3_map_hits_equal_cpu() {
    scene_agrees("q3dm6ish", &q3_map(), GpuRayCasterOptions::default());
}

#[test]
fn without_f64_hits_are_within_the_bound() {
    let options = GpuRayCasterOptions {
        use_f64: false,
        ..Default::default()
    };
    for (name, scene) in [("bunny", bunny()), ("city", city())] {
        let gpu = caster(&scene, options);
        assert!(!gpu.exact());
        let rays = measure::incoherent_rays(scene.bounds(), 10_000, 4);
        assert!(agrees(&format!("{name} without f64"), &scene, &gpu, &rays) > 0);
    }
}

#[test]
fn city_axis_rays_equal_cpu() {
    let scene = city();
    let gpu = caster(&scene, GpuRayCasterOptions::default());
    let hits = agrees("city axis", &scene, &gpu, &axis_rays(&scene, 12_000));
    assert!(hits > 1000);
}

#[test]
fn ranged_rays_equal_cpu() {
    let scene = q3_map();
    let gpu = caster(&scene, GpuRayCasterOptions::default());
    let rays = ranged_rays(&scene, 12_000);
    let hits = agrees("q3dm6ish ranged", &scene, &gpu, &rays);
    assert!(hits > 100 && hits < rays.len());
}

#[test]
fn every_width_equals_cpu() {
    let scene = bunny();
    for width in [2, 4, 8] {
        let options = GpuRayCasterOptions {
            width,
            ..Default::default()
        };
        let gpu = caster(&scene, options);
        assert_eq!(gpu.width(), width);
        let rays = measure::incoherent_rays(scene.bounds(), 5_000, 9);
        agrees(&format!("bunny width {width}"), &scene, &gpu, &rays);
    }
}

#[test]
fn batch_of_many_chunks_equals_one_chunk() {
    let scene = bunny();
    let small = caster(
        &scene,
        GpuRayCasterOptions {
            chunk_rays: 1000,
            ..Default::default()
        },
    );
    assert_eq!(small.chunk_rays(), 1000);
    let rays = camera_rays(&scene, 75); // 5625 rays: five full chunks and a partial one
    let hits = agrees("bunny chunked", &scene, &small, &rays);
    assert!(hits > 0);
    let whole = caster(&scene, GpuRayCasterOptions::default());
    let mut a = vec![Hit::MISS; rays.len()];
    let mut b = vec![Hit::MISS; rays.len()];
    small.cast(&rays, &mut a);
    whole.cast(&rays, &mut b);
    assert_eq!(a, b);
}

#[test]
fn concurrent_calls_equal_one_call() {
    let scene = q3_map();
    let options = GpuRayCasterOptions {
        chunk_rays: 700,
        ..Default::default()
    };
    scenes::concurrent_calls_equal_one_call(&scene, &caster(&scene, options));
}

#[test]
fn unusable_rays_miss_as_on_cpu() {
    let scene = bunny();
    let gpu = caster(&scene, GpuRayCasterOptions::default());
    let c = scene.bounds().center();
    let far = c + Vec3::X * scene.bounds().diagonal();
    let nan = f32::NAN;
    let rays = [
        Ray::new(far, Vec3::NEG_X), // a hit, between the others
        Ray::new(c, Vec3::ZERO),
        Ray::new(Vec3::splat(nan), Vec3::X),
        Ray::new(far, Vec3::new(nan, 0.0, 0.0)),
        Ray::new(far, Vec3::new(f32::INFINITY, 0.0, 0.0)),
        Ray::new(far, Vec3::NEG_X).with_range(5.0, 1.0),
        Ray::new(far, Vec3::NEG_X).with_range(nan, f32::INFINITY),
        Ray::new(far, Vec3::NEG_X).with_range(0.0, nan),
        Ray::new(far, Vec3::NEG_X).with_range(f32::NEG_INFINITY, f32::INFINITY),
    ];
    let mut hits = vec![Hit::MISS; rays.len()];
    gpu.cast(&rays, &mut hits);
    assert!(hits[0].is_hit());
    for (i, h) in hits.iter().enumerate().skip(1).take(7) {
        assert_eq!(*h, Hit::MISS, "ray {i}");
    }
    agrees("bunny unusable", &scene, &gpu, &rays);
}

#[test]
fn empty_batch_is_fine() {
    let scene = bunny();
    let gpu = caster(&scene, GpuRayCasterOptions::default());
    gpu.cast(&[], &mut []);
    gpu.occluded(&[], &mut []);
}

#[test]
fn empty_scene_misses_everything() {
    scenes::misses_everything(&caster(&Scene::default(), GpuRayCasterOptions::default()));
}

#[test]
fn degenerate_triangles_are_never_hit() {
    let mut b = SceneBuilder::new("flat");
    let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0].map(|p| b.add_vertex(p));
    b.add_triangle(v);
    let gpu = caster(&b.finish(), GpuRayCasterOptions::default());
    let hit = gpu.cast_one(&Ray::new(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z));
    assert_eq!(hit, Hit::MISS);
}

#[test]
fn cast_one_hits_a_box_face() {
    let mut b = SceneBuilder::new("one box");
    b.add_box(Vec3::splat(1.0), Vec3::splat(2.0));
    let gpu = caster(&b.finish(), GpuRayCasterOptions::default());
    let hit = gpu.cast_one(&Ray::new(Vec3::new(0.0, 1.5, 1.5), Vec3::X));
    assert_eq!(hit.t, 1.0);
    assert!(hit.is_hit());
}

#[test]
fn length_mismatch_is_an_error() {
    let gpu = caster(&bunny(), GpuRayCasterOptions::default());
    let rays = [Ray::new(Vec3::ZERO, Vec3::X); 3];
    let mut hits = [Hit::MISS; 2];
    assert!(matches!(
        gpu.try_cast(&rays, &mut hits),
        Err(GpuError::LengthMismatch { rays: 3, out: 2 })
    ));
}

#[test]
fn bad_options_are_errors() {
    let (device, queue, info) = shared_device();
    let scene = bunny();
    let with = |options| GpuRayCaster::with_device(device, queue, info.clone(), &scene, options);
    assert!(matches!(
        with(GpuRayCasterOptions {
            width: 3,
            ..Default::default()
        }),
        Err(GpuError::UnsupportedWidth(3))
    ));
    assert!(matches!(
        with(GpuRayCasterOptions {
            chunk_rays: 0,
            ..Default::default()
        }),
        Err(GpuError::ZeroChunk)
    ));
}

#[test]
fn reports_the_stack_it_needs() {
    let gpu = caster(&q3_map(), GpuRayCasterOptions::default());
    // A binary tree over 2,621 triangles in leaves of up to 8 is at least 9 levels deep.
    assert!(gpu.stack_needed() >= 9, "{}", gpu.stack_needed());
}
