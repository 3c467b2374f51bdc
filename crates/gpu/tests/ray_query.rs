//! The hardware ray-query caster against the CPU caster (`sightline_core::trace::Bvh`) on the
//! shared scenes. The driver's triangle test is not the CPU's, so every ray is sorted into one
//! of these, and anything else fails:
//! - both miss, or both hit the same triangle with `t` within `RAY_QUERY_T_TOLERANCE` (as its
//!   documentation measures it, [`t_error`]);
//! - a tie: both hit, another triangle, and the CPU's own test of the GPU's triangle alone
//!   (`sightline_core::trace::triangle::intersect`) hits it too, at the same `t` within the
//!   tolerance: at most 1 in 1,000 of the rays both hit. Lavapipe gives 3 in 44,000 hits of the
//!   random, camera, axis and ranged rays, all coplanar overlapping faces of the Quake 3 map;
//! - a graze: one hits where the other misses, or they hit triangles at different `t`, and the
//!   ray passes within rounding ([`EDGE`]) of an edge of a triangle either of them hit: the
//!   two roundings put it on different sides of a silhouette edge. At most
//!   [`GRAZES_PER_MILLION`] of the rays: lavapipe gives none in 112,000 random, camera, axis
//!   and ranged rays, and 719 of 12,861 rays aimed exactly at the bunny's vertices and edge
//!   midpoints (that test allows any number, each still checked).
//!
//! `occluded` must equal the caster's own closest hits exactly (the same structure and test)
//! and the CPU's except on grazes. These tests FAIL, never skip, where the adapter has no ray
//! queries.

use glam::Vec3;
use sightline_core::scene::{Scene, SceneBuilder};
use sightline_core::trace::triangle::{intersect, ShearedRay};
use sightline_core::trace::{measure, Bvh, RayCaster};
use sightline_core::{Hit, Ray};
use sightline_gpu::{GpuError, RayQueryCaster, RayQueryOptions, RAY_QUERY_T_TOLERANCE};

use super::scenes::{self, axis_rays, bunny, camera_rays, city, q3_map, ranged_rays};
use super::shared_device;

/// "Within rounding of an edge": the distance from where the ray meets the triangle's plane to
/// the triangle's nearest edge, over the largest coordinate of the ray's origin and the
/// triangle's corners ([`edge_distance`]). f32 rounds to 6e-8 of a coordinate; the grazes of
/// the rays aimed at the bunny's vertices and edges lie within 2.8e-6 (lavapipe), the sheared
/// corners' rounding magnified by the edge functions' products. Three and a half times that.
const EDGE: f32 = 1e-5;
/// Grazes allowed per million rays of the random, camera, axis and ranged sets. Each graze is
/// checked on its own (within [`EDGE`] of an edge, so a wrong hit away from edges fails
/// anyway); the count only keeps a systematic difference at edges from hiding among them.
/// Lavapipe gives none in 112,000 such rays; 2 of the 20,000 rays of a set may, for drivers
/// that round otherwise.
const GRAZES_PER_MILLION: usize = 100;

/// The ray-query caster for `scene` on the shared device, failing (not skipping) without ray
/// queries.
fn caster_with(scene: &Scene, options: RayQueryOptions) -> RayQueryCaster {
    let (device, queue, info) = shared_device();
    assert!(
        RayQueryCaster::supported(device),
        "adapter {:?} (driver {} {}) offers no hardware ray queries (VK_KHR_ray_query); these \
         tests fail rather than skip. CI installs Mesa >= 24.1 lavapipe, which has them, from \
         bookworm-backports (.ci/run); on Debian 12: apt-get install -y -t bookworm-backports \
         mesa-vulkan-drivers",
        info.name,
        info.driver,
        info.driver_info
    );
    RayQueryCaster::with_options(device, queue, info.clone(), scene, options).unwrap()
}

fn caster(scene: &Scene) -> RayQueryCaster {
    caster_with(scene, RayQueryOptions::default())
}

/// The CPU's own test of triangle `id` alone: its `t`, if it hits within the ray's range.
fn cpu_triangle(scene: &Scene, ray: &Ray, id: u32) -> Option<f32> {
    let [a, b, c] = scene.triangle(id);
    intersect(&ShearedRay::new(ray), a, b, c)
}

/// The distance from where `ray` meets the plane of triangle `id` to the triangle's nearest
/// edge, relative to the coordinates' size (see [`EDGE`]).
fn edge_distance(scene: &Scene, ray: &Ray, id: u32) -> f32 {
    let [a, b, c] = scene.triangle(id);
    let n = (b - a).cross(c - a);
    let t = n.dot(a - ray.origin) / n.dot(ray.dir);
    let p = ray.origin + ray.dir * t;
    let to_segment = |u: Vec3, v: Vec3| {
        let s = ((p - u).dot(v - u) / (v - u).length_squared()).clamp(0.0, 1.0);
        (p - (u + (v - u) * s)).length()
    };
    let edge = to_segment(a, b).min(to_segment(b, c)).min(to_segment(c, a));
    let scale = [ray.origin, a, b, c]
        .iter()
        .map(|v| v.abs().max_element())
        .fold(f32::MIN_POSITIVE, f32::max);
    edge / scale
}

/// The difference of two hit distances `s`, `t` on `ray` to triangle `id`, relative as
/// `RAY_QUERY_T_TOLERANCE` states it: over the largest of the triangle's corners' distances
/// along the ray and the coordinates of the origin and the corners, in units of the direction.
fn t_error(scene: &Scene, ray: &Ray, id: u32, s: f32, t: f32) -> f32 {
    let d = ray.dir.abs().max_element();
    let corners = scene.triangle(id);
    let depth = corners
        .iter()
        .map(|c| ((*c - ray.origin).dot(ray.dir) / ray.dir.length_squared()).abs() * d)
        .fold(0.0, f32::max);
    let scale = corners
        .iter()
        .chain([&ray.origin])
        .map(|v| v.abs().max_element())
        .fold(depth, f32::max);
    (s - t).abs() * d / scale.max(f32::MIN_POSITIVE)
}

fn t_close(scene: &Scene, ray: &Ray, id: u32, s: f32, t: f32) -> bool {
    t_error(scene, ray, id, s, t) <= RAY_QUERY_T_TOLERANCE
}

/// What a comparison found.
#[derive(Debug, Default)]
struct Agreement {
    /// Rays both casters hit.
    hits: usize,
    /// Of those, rays hitting another triangle at the same `t`.
    ties: usize,
    /// Rays explained by a graze of a silhouette edge.
    grazes: usize,
    /// Largest relative difference of `t` on the same triangle (see [`t_error`]).
    worst_t: f32,
    /// Largest relative distance of a grazing ray from the edge it grazes.
    worst_edge: f32,
}

/// Sorts one ray's two hits, the CPU's `w` and the GPU's `g` (see the module documentation);
/// an error for a disagreement that is neither a tie nor a graze.
fn judge(scene: &Scene, ray: &Ray, w: Hit, g: Hit, found: &mut Agreement) -> Result<(), String> {
    if w.is_hit() && g.is_hit() {
        found.hits += 1;
        if w.triangle == g.triangle {
            let rel = t_error(scene, ray, w.triangle, w.t, g.t);
            found.worst_t = found.worst_t.max(rel);
            if rel > RAY_QUERY_T_TOLERANCE {
                return Err(format!("t differs by {rel:e} (relative)"));
            }
            return Ok(());
        }
        // A tie: the CPU's own test hits the GPU's triangle too, at the same distance.
        if t_close(scene, ray, g.triangle, w.t, g.t)
            && cpu_triangle(scene, ray, g.triangle)
                .is_some_and(|t| t_close(scene, ray, g.triangle, t, g.t))
        {
            found.ties += 1;
            return Ok(());
        }
    } else if !w.is_hit() && !g.is_hit() {
        return Ok(());
    }
    // A graze: the ray passes within rounding of an edge of a triangle one of them hit.
    let edge = [w, g]
        .iter()
        .filter(|h| h.is_hit())
        .map(|h| edge_distance(scene, ray, h.triangle))
        .fold(f32::INFINITY, f32::min);
    if edge > EDGE {
        return Err(format!(
            "neither a tie nor a graze: the ray passes {edge:e} (relative) from the triangles' \
             edges"
        ));
    }
    found.grazes += 1;
    found.worst_edge = found.worst_edge.max(edge);
    Ok(())
}

/// Casts `rays` on the CPU and the GPU and sorts every ray (see the module documentation);
/// checks `occluded` against both and the bounds on ties and grazes. Returns what it found.
fn agrees(what: &str, scene: &Scene, gpu: &RayQueryCaster, rays: &[Ray]) -> Agreement {
    let found = sort_rays(what, scene, gpu, rays);
    assert!(found.ties * 1000 <= found.hits, "{what}: {found:?}");
    assert!(
        found.grazes * 1_000_000 <= GRAZES_PER_MILLION * rays.len(),
        "{what}: {found:?}"
    );
    found
}

/// [`agrees`] without the bounds on how many rays tie or graze (each is still checked).
fn sort_rays(what: &str, scene: &Scene, gpu: &RayQueryCaster, rays: &[Ray]) -> Agreement {
    let cpu = Bvh::build(scene);
    let mut want = vec![Hit::MISS; rays.len()];
    cpu.cast(rays, &mut want);
    let mut got = vec![Hit::MISS; rays.len()];
    gpu.try_cast(rays, &mut got).unwrap();
    let mut found = Agreement::default();
    for (i, (w, g)) in want.iter().zip(&got).enumerate() {
        if let Err(e) = judge(scene, &rays[i], *w, *g, &mut found) {
            panic!("{what}: ray {i} {:?}: CPU {w:?}, GPU {g:?}: {e}", rays[i]);
        }
    }
    let mut occluded = vec![false; rays.len()];
    gpu.try_occluded(rays, &mut occluded).unwrap();
    let mut occlusion_grazes = 0;
    for (i, ((o, w), g)) in occluded.iter().zip(&want).zip(&got).enumerate() {
        // Another traversal of the same structure with the same test: exactly its hits.
        assert_eq!(*o, g.is_hit(), "{what}: occluded ray {i} {:?}", rays[i]);
        occlusion_grazes += usize::from(*o != w.is_hit());
    }
    eprintln!(
        "{what}: {} rays, {} hit by both, {} ties, {} grazes (worst edge {:e}), worst t {:e}",
        rays.len(),
        found.hits,
        found.ties,
        found.grazes,
        found.worst_edge,
        found.worst_t
    );
    assert!(occlusion_grazes <= found.grazes, "{what}: {found:?}");
    found
}

/// The incoherent and camera rays of a scene; each set must hit something.
fn scene_agrees(name: &str, scene: &Scene) {
    let gpu = caster(scene);
    eprintln!(
        "{name}: {} triangles, memory {:?}",
        scene.triangle_count(),
        gpu.memory()
    );
    let incoherent = measure::incoherent_rays(scene.bounds(), 20_000, 3);
    let camera = camera_rays(scene, 96);
    for (what, rays) in [("incoherent", incoherent), ("camera", camera)] {
        let found = agrees(&format!("{name} {what}"), scene, &gpu, &rays);
        assert!(found.hits > 0, "{name} {what}: no hits");
    }
}

#[test]
fn bunny_hits_agree_with_cpu() {
    scene_agrees("bunny", &bunny());
}

#[test]
fn city_hits_agree_with_cpu() {
    scene_agrees("city", &city());
}

#[test]
fn q3_map_hits_agree_with_cpu() {
    scene_agrees("q3dm6ish", &q3_map());
}

#[test]
fn city_axis_rays_agree_with_cpu() {
    let scene = city();
    let gpu = caster(&scene);
    let found = agrees("city axis", &scene, &gpu, &axis_rays(&scene, 12_000));
    assert!(found.hits > 1000);
}

/// Rays from outside the bunny aimed exactly at its vertices and at the midpoints of its
/// triangles' edges: the rays where the two triangle tests differ most often (ties between
/// the triangles sharing the vertex or edge, grazes at the silhouette). Each disagreement must
/// still be a tie or a graze.
#[test]
fn rays_at_vertices_and_edges_agree_with_cpu() {
    let scene = bunny();
    let gpu = caster(&scene);
    let b = scene.bounds();
    let eye = b.center() + Vec3::new(0.6, 0.35, 0.8) * b.diagonal();
    let mut targets: Vec<Vec3> = scene.positions.clone();
    for id in 0..scene.triangle_count() as u32 {
        let [a, b, c] = scene.triangle(id);
        targets.extend([(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]);
    }
    let rays: Vec<Ray> = targets.iter().map(|&p| Ray::new(eye, p - eye)).collect();
    let found = sort_rays("bunny vertices and edges", &scene, &gpu, &rays);
    assert!(found.hits > rays.len() / 3, "{found:?}");
}

#[test]
fn ranged_rays_agree_with_cpu() {
    let scene = q3_map();
    let gpu = caster(&scene);
    let rays = ranged_rays(&scene, 12_000);
    let found = agrees("q3dm6ish ranged", &scene, &gpu, &rays);
    assert!(found.hits > 100 && found.hits < rays.len());
}

#[test]
fn ranges_around_the_first_hit() {
    let scene = bunny();
    let gpu = caster(&scene);
    let cpu = Bvh::build(&scene);
    let rays = camera_rays(&scene, 64);
    let mut first = vec![Hit::MISS; rays.len()];
    cpu.cast(&rays, &mut first);
    let hit: Vec<(Ray, Hit)> = rays
        .into_iter()
        .zip(first)
        .filter(|(_, h)| h.is_hit())
        .collect();
    assert!(hit.len() > 500, "{}", hit.len());
    // Ending just before the first hit: nothing (beyond grazes) to hit.
    let short: Vec<Ray> = hit
        .iter()
        .map(|(r, h)| r.with_range(0.0, h.t * 0.999))
        .collect();
    let found = agrees("bunny short", &scene, &gpu, &short);
    let mut none = vec![Hit::MISS; short.len()];
    gpu.cast(&short, &mut none);
    let hits = none.iter().filter(|h| h.is_hit()).count();
    assert!(hits <= found.grazes, "{hits} hits, {found:?}");
    // Starting just after it: the next hit (the bunny's far side), as on the CPU.
    let past: Vec<Ray> = hit
        .iter()
        .map(|(r, h)| r.with_range(h.t * 1.001, f32::INFINITY))
        .collect();
    let found = agrees("bunny past the first hit", &scene, &gpu, &past);
    assert!(found.hits * 10 > past.len() * 9, "{found:?}");
    let mut next = vec![Hit::MISS; past.len()];
    gpu.cast(&past, &mut next);
    for ((_, h), n) in hit.iter().zip(&next) {
        assert!(!n.is_hit() || n.t > h.t);
    }
}

/// Two unit quads facing +z at z = 1 and z = 2 (ids 0, 1 and 2, 3).
fn two_quads() -> Scene {
    let mut b = SceneBuilder::new("two quads");
    for z in [1.0, 2.0] {
        let v = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
            .map(|(x, y)| b.add_vertex(Vec3::new(x, y, z)));
        b.add_triangle([v[0], v[1], v[2]]);
        b.add_triangle([v[0], v[2], v[3]]);
    }
    b.finish()
}

#[test]
fn ranges_directions_and_faces_on_two_quads() {
    let scene = two_quads();
    let gpu = caster(&scene);
    let o = Vec3::new(0.7, 0.2, 0.0);
    let up = Ray::new(o, Vec3::Z);
    let cases = [
        // (ray, expected triangle, expected t)
        (up, Some(0), 1.0f32),
        (up.with_range(0.0, 0.5), None, 0.0),
        (up.with_range(1.5, 10.0), Some(2), 2.0),
        (up.with_range(2.5, 10.0), None, 0.0),
        // t in units of the direction, not normalised.
        (Ray::new(o, Vec3::Z * 4.0), Some(0), 0.25),
        // The back faces count.
        (
            Ray::new(Vec3::new(0.7, 0.2, 3.0), Vec3::NEG_Z),
            Some(2),
            1.0,
        ),
        // Behind the origin: the nearest hit from t_min on.
        (
            Ray::new(Vec3::new(0.7, 0.2, 1.5), Vec3::Z).with_range(f32::NEG_INFINITY, 10.0),
            Some(0),
            -0.5,
        ),
        (
            Ray::new(Vec3::new(0.7, 0.2, 5.0), Vec3::Z).with_range(-3.5, -1.0),
            Some(2),
            -3.0,
        ),
        (
            Ray::new(Vec3::new(0.7, 0.2, 5.0), Vec3::Z).with_range(-2.5, 10.0),
            None,
            0.0,
        ),
    ];
    let rays: Vec<Ray> = cases.iter().map(|c| c.0).collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    gpu.cast(&rays, &mut hits);
    let mut occluded = vec![false; rays.len()];
    gpu.occluded(&rays, &mut occluded);
    for (i, ((ray, id, t), h)) in cases.iter().zip(&hits).enumerate() {
        assert_eq!(h.triangle(), *id, "case {i}: {ray:?}: {h:?}");
        assert_eq!(occluded[i], id.is_some(), "case {i}");
        if id.is_some() {
            let bound = RAY_QUERY_T_TOLERANCE * (t.abs() + ray.t_min.max(-10.0).abs());
            assert!((h.t - t).abs() <= bound, "case {i}: {ray:?}: {h:?}");
        }
    }
}

#[test]
fn unusable_rays_miss() {
    let scene = bunny();
    let gpu = caster(&scene);
    let c = scene.bounds().center();
    let far = c + Vec3::X * scene.bounds().diagonal();
    let nan = f32::NAN;
    let rays = [
        Ray::new(far, Vec3::NEG_X), // a hit, between the others
        Ray::new(c, Vec3::ZERO),
        Ray::new(Vec3::splat(nan), Vec3::X),
        Ray::new(far, Vec3::new(nan, 0.0, 0.0)),
        Ray::new(far, Vec3::new(f32::INFINITY, 0.0, 0.0)),
        Ray::new(Vec3::new(f32::INFINITY, c.y, c.z), Vec3::NEG_X),
        Ray::new(far, Vec3::NEG_X).with_range(5.0, 1.0),
        Ray::new(far, Vec3::NEG_X).with_range(nan, f32::INFINITY),
        Ray::new(far, Vec3::NEG_X).with_range(0.0, nan),
        Ray::new(far, Vec3::NEG_X).with_range(f32::INFINITY, f32::INFINITY),
    ];
    let mut hits = vec![Hit::MISS; rays.len()];
    gpu.cast(&rays, &mut hits);
    let mut occluded = vec![true; rays.len()];
    gpu.occluded(&rays, &mut occluded);
    assert!(hits[0].is_hit() && occluded[0]);
    for i in 1..rays.len() {
        assert_eq!(hits[i], Hit::MISS, "ray {i}");
        assert!(!occluded[i], "ray {i}");
    }
    agrees("bunny unusable", &scene, &gpu, &rays);
}

#[test]
fn unusable_triangles_are_never_hit() {
    let mut b = SceneBuilder::new("flat");
    // A zero-area triangle on the x axis, a good one above it.
    let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0].map(|p| b.add_vertex(p));
    b.add_triangle(v);
    let w = [Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::Y * 2.0].map(|p| b.add_vertex(p));
    b.add_triangle(w);
    let mut scene = b.finish();
    // A NaN corner and an index out of range, over the first: never hit on the CPU either.
    scene.positions.push(Vec3::new(f32::NAN, 0.0, 0.0));
    scene.triangles.push([0, 2, 6]);
    scene.triangles.push([0, 2, 99]);
    scene.triangles.push([3, 4, 5]); // the same as triangle 1: ties go to either
    let gpu = caster(&scene);
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 1.0), Vec3::NEG_Z);
    let rays = [down(0.5, 0.0), down(0.2, 1.2), down(1.5, 0.0)];
    let mut hits = vec![Hit::MISS; rays.len()];
    gpu.cast(&rays, &mut hits);
    assert_eq!(hits[0], Hit::MISS);
    assert!(matches!(hits[1].triangle(), Some(1 | 4)), "{:?}", hits[1]);
    assert!((hits[1].t - 1.0).abs() <= RAY_QUERY_T_TOLERANCE);
    assert_eq!(hits[2], Hit::MISS);
}

#[test]
fn empty_scene_misses_everything() {
    let gpu = caster(&Scene::default());
    assert_eq!(gpu.memory().blas, None);
    scenes::misses_everything(&gpu);
}

#[test]
fn length_mismatch_and_zero_chunk_are_errors() {
    let gpu = caster(&two_quads());
    let rays = [Ray::new(Vec3::ZERO, Vec3::X); 3];
    let mut hits = [Hit::MISS; 2];
    assert!(matches!(
        gpu.try_cast(&rays, &mut hits),
        Err(GpuError::LengthMismatch { rays: 3, out: 2 })
    ));
    let mut out = [false; 4];
    assert!(matches!(
        gpu.try_occluded(&rays, &mut out),
        Err(GpuError::LengthMismatch { rays: 3, out: 4 })
    ));
    let (device, queue, info) = shared_device();
    let options = RayQueryOptions { chunk_rays: 0 };
    let zero = RayQueryCaster::with_options(device, queue, info.clone(), &two_quads(), options);
    assert!(matches!(zero, Err(GpuError::ZeroChunk)));
}

/// A device of the shared device's adapter with the given features and limits.
fn device_with(features: wgpu::Features, limits: wgpu::Limits) -> (wgpu::Device, wgpu::Queue) {
    let (_, _, info) = shared_device();
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    let adapter = adapters
        .into_iter()
        .find(|a| a.get_info().name == info.name)
        .unwrap();
    // SAFETY (of the test): the same request `vulkan_device` makes, with a lower limit.
    let experimental = unsafe { wgpu::ExperimentalFeatures::enabled() };
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: features,
        required_limits: limits,
        experimental_features: experimental,
        ..Default::default()
    }))
    .unwrap()
}

#[test]
fn devices_without_ray_queries_or_room_are_errors() {
    let (shared, _, info) = shared_device();
    let bunny = bunny();
    // No EXPERIMENTAL_RAY_QUERY.
    let (plain, queue) = device_with(wgpu::Features::empty(), wgpu::Limits::default());
    assert!(!RayQueryCaster::supported(&plain));
    let err = RayQueryCaster::with_device(&plain, &queue, info.clone(), &bunny).err();
    assert!(
        matches!(&err, Some(GpuError::NoRayQuery { adapter }) if *adapter == info.name),
        "{err:?}"
    );
    // Fewer triangles per BLAS than the bunny has.
    let small = wgpu::Limits {
        max_blas_primitive_count: 1000,
        ..wgpu::Limits::default().using_acceleration_structure_values(shared.limits())
    };
    let (device, queue) = device_with(wgpu::Features::EXPERIMENTAL_RAY_QUERY, small);
    let err = RayQueryCaster::with_device(&device, &queue, info.clone(), &bunny).err();
    assert!(
        matches!(
            err,
            Some(GpuError::TooManyTriangles {
                triangles,
                limit: 1000
            }) if triangles == bunny.triangle_count()
        ),
        "{err:?}"
    );
}

#[test]
fn batch_of_many_chunks_equals_one_chunk() {
    let scene = bunny();
    let small = caster_with(&scene, RayQueryOptions { chunk_rays: 1000 });
    assert_eq!(small.chunk_rays(), 1000);
    let rays = camera_rays(&scene, 75); // 5625 rays: five full chunks and a partial one
    let found = agrees("bunny chunked", &scene, &small, &rays);
    assert!(found.hits > 0);
    let whole = caster(&scene);
    let mut a = vec![Hit::MISS; rays.len()];
    let mut b = vec![Hit::MISS; rays.len()];
    small.cast(&rays, &mut a);
    whole.cast(&rays, &mut b);
    assert_eq!(a, b);
}

#[test]
fn concurrent_calls_equal_one_call() {
    let scene = q3_map();
    let gpu = caster_with(&scene, RayQueryOptions { chunk_rays: 700 });
    scenes::concurrent_calls_equal_one_call(&scene, &gpu);
}

#[test]
fn reports_its_acceleration_structures() {
    let scene = city();
    let gpu = caster(&scene);
    let memory = gpu.memory();
    assert_eq!(
        memory.build_input,
        (scene.positions.len() as u64 + 1) * 12 + scene.triangle_count() as u64 * 12
    );
    // wgpu's Vulkan backend reports its allocations; a BLAS holds at least its triangles.
    let blas = memory.blas.unwrap();
    assert!(blas >= scene.triangle_count() as u64 * 12, "{memory:?}");
    assert!(memory.tlas.unwrap() > 0);
}
