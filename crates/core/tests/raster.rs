//! Integration tests of the reference rasterizer against watertight brute-force ray casting
//! through every pixel centre, plus watertightness, edge-case and cube-map tests.
//!
//! Tolerances: a pixel where the rasterizer and the ray caster disagree on the triangle is
//! *excused* when the pixel centre lies within `EDGE_EPS` pixels of the projected (near-clipped)
//! boundary of either candidate triangle — the rasterizer snaps to 1/256 px (error up to
//! 1/512 px per coordinate) and the ray caster works in f32 — or when the two candidates' depths
//! at the pixel centre tie within `DEPTH_TIE` relative. Excused pixels must stay below 0.5 %.

use glam::{DVec2, DVec3, Vec3};
use sightline_core::raster::{render, render_cube, Frame, Rasterizer};
use sightline_core::scene::SceneBuilder;
use sightline_core::trace::{BruteForce, RayCaster};
use sightline_core::{Camera, Hit, Ray, Scene};

/// Excuse distance from a triangle edge, in pixels (about 5x the snapping error).
const EDGE_EPS: f64 = 0.01;
/// Relative depth difference under which two triangles count as tied.
const DEPTH_TIE: f64 = 1e-5;
/// Relative depth agreement required where the ids agree.
const DEPTH_AGREE: f32 = 1e-4;

/// SplitMix64, so the tests need no random crate and are reproducible.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }

    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

fn random_boxes(seed: u64, n: usize, extent: f32) -> Scene {
    let mut rng = Rng(seed);
    let mut b = SceneBuilder::new("random boxes");
    for _ in 0..n {
        let c = rng.vec(-extent, extent);
        let h = rng.vec(0.05, 0.1 * extent);
        b.add_box(c - h, c + h);
    }
    b.finish()
}

fn triangle_soup(seed: u64, n: usize, extent: f32, size: f32) -> Scene {
    let mut rng = Rng(seed);
    let mut b = SceneBuilder::new("soup");
    for _ in 0..n {
        let c = rng.vec(-extent, extent);
        let v = [
            b.add_vertex(c + rng.vec(-size, size)),
            b.add_vertex(c + rng.vec(-size, size)),
            b.add_vertex(c + rng.vec(-size, size)),
        ];
        b.add_triangle(v);
    }
    b.finish()
}

/// Distance in pixels from screen point `p` to segment `a–b`.
fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// View coordinates of world point `p` in f64.
fn view_of(cam: &Camera, p: Vec3) -> DVec3 {
    let d = p.as_dvec3() - cam.eye.as_dvec3();
    DVec3::new(
        d.dot(cam.right.as_dvec3()),
        d.dot(cam.up.as_dvec3()),
        d.dot(cam.forward.as_dvec3()),
    )
}

fn screen_of(cam: &Camera, v: DVec3) -> DVec2 {
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    DVec2::new(
        (v.x / (v.z * tx) + 1.0) * 0.5 * f64::from(cam.width),
        (1.0 - v.y / (v.z * ty)) * 0.5 * f64::from(cam.height),
    )
}

/// Distance in pixels from the centre of pixel `(x, y)` to the boundary of triangle `id`'s
/// projection after clipping at the near plane (infinite when it is entirely behind).
fn edge_distance(scene: &Scene, cam: &Camera, id: u32, x: u32, y: u32) -> f64 {
    let near = f64::from(cam.near);
    let v = scene.triangle(id).map(|p| view_of(cam, p));
    let mut poly = Vec::new();
    for k in 0..3 {
        let (a, b) = (v[k], v[(k + 1) % 3]);
        if a.z >= near {
            poly.push(a);
        }
        if (a.z >= near) != (b.z >= near) {
            let t = (near - a.z) / (b.z - a.z);
            poly.push(a + (b - a) * t);
        }
    }
    let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
    let s: Vec<DVec2> = poly.iter().map(|&v| screen_of(cam, v)).collect();
    (0..s.len())
        .map(|k| segment_distance(p, s[k], s[(k + 1) % s.len()]))
        .fold(f64::INFINITY, f64::min)
}

/// Where the ray hits the plane of triangle `id` (f64), the depth both methods should agree on.
fn plane_depth(scene: &Scene, ray: &Ray, id: u32) -> f64 {
    let [a, b, c] = scene.triangle(id).map(|p| p.as_dvec3());
    let n = (b - a).cross(c - a);
    n.dot(a - ray.origin.as_dvec3()) / n.dot(ray.dir.as_dvec3())
}

/// Renders `scene` and compares with brute-force ray casting; returns the excused pixel count.
fn compare(name: &str, scene: &Scene, cam: &Camera) -> usize {
    let frame = render(scene, cam);
    compare_frame(name, scene, cam, &frame, DepthRef::RayT)
}

/// What the rasterizer's depth is checked against where the ids agree.
#[derive(Clone, Copy, PartialEq)]
enum DepthRef {
    /// The ray caster's `t` (f32), within `DEPTH_AGREE` relative.
    RayT,
    /// The f64 ray/plane distance, within 1e-6 relative: for scenes with coordinates so large
    /// (1e6) that the f32 ray caster's `t` is itself off by several percent.
    PlaneF64,
}

fn compare_frame(
    name: &str,
    scene: &Scene,
    cam: &Camera,
    frame: &Frame,
    depth_ref: DepthRef,
) -> usize {
    let (w, h) = (cam.width, cam.height);
    let rays: Vec<Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| cam.pixel_ray(x, y))
        .collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    BruteForce::new(scene).cast(&rays, &mut hits);
    let mut excused = 0;
    let mut hit_pixels = 0;
    for (i, (hit, ray)) in hits.iter().zip(&rays).enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let (rid, rdepth) = (frame.ids[i], frame.depth[i]);
        if hit.is_hit() {
            hit_pixels += 1;
        }
        if rid == hit.triangle {
            if hit.is_hit() {
                let (reference, tol) = match depth_ref {
                    DepthRef::RayT => (hit.t, DEPTH_AGREE),
                    DepthRef::PlaneF64 => (plane_depth(scene, ray, rid) as f32, 1e-6),
                };
                let err = (rdepth - reference).abs() / reference;
                assert!(
                    err <= tol,
                    "{name}: pixel ({x},{y}) id {rid}: depth {rdepth} vs {reference}",
                );
            } else {
                assert!(rdepth.is_infinite(), "{name}: background with depth");
            }
            continue;
        }
        let near_edge = [rid, hit.triangle]
            .iter()
            .filter(|&&id| id != Hit::NONE)
            .any(|&id| edge_distance(scene, cam, id, x, y) < EDGE_EPS);
        let tie = rid != Hit::NONE && hit.is_hit() && {
            let (a, b) = (
                plane_depth(scene, ray, rid),
                plane_depth(scene, ray, hit.triangle),
            );
            (a - b).abs() <= DEPTH_TIE * a.abs().max(b.abs())
        };
        assert!(
            near_edge || tie,
            "{name}: pixel ({x},{y}) raster id {rid} (depth {rdepth}) vs ray id {} (t {})",
            hit.triangle,
            hit.t
        );
        excused += 1;
    }
    let total = (w * h) as usize;
    println!(
        "{name}: {excused} excused of {total} pixels ({:.4} %), {hit_pixels} hit by rays",
        100.0 * excused as f64 / total as f64
    );
    assert!(
        (excused as f64) < 0.005 * total as f64,
        "{name}: too many excused pixels"
    );
    excused
}

fn look(eye: Vec3, target: Vec3, w: u32, h: u32, near: f32) -> Camera {
    Camera::look_at(eye, target, Vec3::Y, 70.0, w, h, near).expect("test camera")
}

// ---- agreement with ray casting -------------------------------------------------------------

#[test]
fn matches_ray_casting_random_boxes() {
    let scene = random_boxes(1, 40, 5.0);
    for (k, eye) in [Vec3::new(0.0, 1.0, 14.0), Vec3::new(3.0, 2.0, -1.0)]
        .into_iter()
        .enumerate()
    {
        let cam = look(eye, Vec3::ZERO, 160, 120, 0.05);
        compare(&format!("random boxes view {k}"), &scene, &cam);
    }
}

#[test]
fn matches_ray_casting_intersecting_soup() {
    let scene = triangle_soup(2, 300, 2.0, 1.5);
    let cam = look(Vec3::new(1.0, 0.5, 7.0), Vec3::ZERO, 160, 120, 0.05);
    compare("intersecting soup", &scene, &cam);
}

#[test]
fn matches_ray_casting_across_near_plane() {
    // Large triangles around the eye, many crossing z = near; a big near plane makes the cut
    // visible on screen.
    let scene = triangle_soup(3, 120, 3.0, 4.0);
    let cam = look(Vec3::ZERO, Vec3::new(0.2, 0.1, -1.0), 128, 96, 1.0);
    compare("near plane crossing", &scene, &cam);
}

#[test]
fn matches_ray_casting_grazing() {
    // A large tessellated floor seen almost edge-on, with boxes standing on it.
    let mut b = SceneBuilder::new("grazing");
    let n = 40;
    let size = 200.0;
    let idx = |i: u32, j: u32| i * (n + 1) + j;
    for i in 0..=n {
        for j in 0..=n {
            let x = -size + 2.0 * size * i as f32 / n as f32;
            let z = -size + 2.0 * size * j as f32 / n as f32;
            b.add_vertex(Vec3::new(x, 0.0, z));
        }
    }
    for i in 0..n {
        for j in 0..n {
            b.add_triangle([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            b.add_triangle([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    let mut rng = Rng(4);
    for _ in 0..20 {
        let c = Vec3::new(rng.range(-50.0, 50.0), 0.0, rng.range(-100.0, -5.0));
        b.add_box(c - Vec3::new(1.0, 0.0, 1.0), c + Vec3::new(1.0, 0.3, 1.0));
    }
    let scene = b.finish();
    let cam = look(
        Vec3::new(0.0, 0.05, 0.0),
        Vec3::new(0.0, 0.0, -100.0),
        160,
        100,
        0.01,
    );
    compare("grazing floor", &scene, &cam);
}

#[test]
fn matches_ray_casting_huge_triangles() {
    let mut b = SceneBuilder::new("huge");
    let big = 1e6;
    let p = [
        b.add_vertex(Vec3::new(-big, -big, -50.0)),
        b.add_vertex(Vec3::new(big, -big, -60.0)),
        b.add_vertex(Vec3::new(0.0, big, -70.0)),
        // A huge triangle crossing the near plane and passing beside the eye.
        b.add_vertex(Vec3::new(-big, 3.0, big)),
        b.add_vertex(Vec3::new(big, 2.0, big)),
        b.add_vertex(Vec3::new(0.0, -1.0, -big)),
    ];
    b.add_triangle([p[0], p[1], p[2]]);
    b.add_triangle([p[3], p[4], p[5]]);
    b.add_box(Vec3::new(-1.0, -1.0, -10.0), Vec3::new(1.0, 1.0, -8.0));
    let scene = b.finish();
    let cam = look(Vec3::ZERO, Vec3::NEG_Z, 128, 128, 0.1);
    let frame = render(&scene, &cam);
    assert!(frame.ids.iter().all(|&id| id != Hit::NONE), "no background");
    compare_frame("huge triangles", &scene, &cam, &frame, DepthRef::PlaneF64);
}

#[test]
fn matches_ray_casting_bunny() {
    let Some(scene) = load_bunny() else {
        println!("bunny.obj not found, skipped");
        return;
    };
    let c = scene.bounds().center();
    let d = scene.bounds().diagonal();
    for (k, dir) in [Vec3::new(0.3, 0.4, 1.0), Vec3::new(-1.0, 0.2, -0.4)]
        .into_iter()
        .enumerate()
    {
        let cam = look(c + dir.normalize() * d * 0.8, c, 128, 128, 0.01 * d);
        compare(&format!("bunny view {k}"), &scene, &cam);
    }
}

/// The `v` and `f` lines of the shared bunny (no loader dependency).
fn load_bunny() -> Option<Scene> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/models/bunny.obj"
    );
    let text = std::fs::read_to_string(path).ok()?;
    let mut b = SceneBuilder::new("bunny");
    for line in text.lines() {
        let mut it = line.split_whitespace();
        let tag = it.next();
        let nums: Vec<&str> = it.collect();
        match tag {
            Some("v") => {
                let c: Vec<f32> = nums.iter().filter_map(|s| s.parse().ok()).collect();
                b.add_vertex(Vec3::new(*c.first()?, *c.get(1)?, *c.get(2)?));
            }
            Some("f") => {
                let ids: Vec<u32> = nums
                    .iter()
                    .filter_map(|s| s.split('/').next()?.parse::<u32>().ok())
                    .map(|i| i - 1)
                    .collect();
                for k in 1..ids.len().saturating_sub(1) {
                    b.add_triangle([ids[0], ids[k], ids[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Some(b.finish())
}

#[test]
fn matches_ray_casting_1x1_and_4096x1() {
    // Boxes crossing the view's centre row, in front of a back wall.
    let mut b = SceneBuilder::new("row");
    let mut rng = Rng(5);
    for _ in 0..40 {
        let c = Vec3::new(
            rng.range(-8.0, 8.0),
            rng.range(-0.3, 0.3),
            rng.range(-3.0, 3.0),
        );
        b.add_box(c - Vec3::splat(0.4), c + Vec3::splat(0.4));
    }
    b.add_box(Vec3::new(-50.0, -50.0, -6.0), Vec3::new(50.0, 50.0, -5.0));
    let scene = b.finish();
    let one = look(Vec3::new(0.0, 0.0, 9.0), Vec3::ZERO, 1, 1, 0.1);
    compare("1x1", &scene, &one);
    // fov_y 0.02° on one row: 4096 px span about 71° horizontally.
    let wide = Camera::look_at(
        Vec3::new(0.0, 0.0, 9.0),
        Vec3::ZERO,
        Vec3::Y,
        0.02,
        4096,
        1,
        0.1,
    )
    .expect("wide camera");
    compare("4096x1", &scene, &wide);
}

// ---- watertightness --------------------------------------------------------------------------

/// Camera at the origin looking down -Z with a 90° field of view on a 64² image: the plane
/// `z = -1` maps `x = sx / 32 - 1`, so world multiples of 1/64 land exactly on pixel centres
/// and pixel edges.
fn aligned_camera() -> Camera {
    Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 64, 64, 0.1).expect("camera")
}

/// A grid on `z = -1` with cell size `cell` (world), alternating diagonals when `alternate`.
fn grid(cell: f32, cells: u32, origin: f32, alternate: bool) -> Scene {
    let mut b = SceneBuilder::new("grid");
    let idx = |i: u32, j: u32| i * (cells + 1) + j;
    for i in 0..=cells {
        for j in 0..=cells {
            b.add_vertex(Vec3::new(
                origin + cell * j as f32,
                origin + cell * i as f32,
                -1.0,
            ));
        }
    }
    for i in 0..cells {
        for j in 0..cells {
            let (a, b1, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j));
            if alternate && (i + j) % 2 == 1 {
                b.add_triangle([a, b1, d]);
                b.add_triangle([b1, c, d]);
            } else {
                b.add_triangle([a, b1, c]);
                b.add_triangle([a, c, d]);
            }
        }
    }
    b.finish()
}

fn assert_single_cover(name: &str, scene: &Scene, cam: &Camera) {
    let mut counts = Vec::new();
    Rasterizer::new(scene).coverage_counts(cam, None, &mut counts);
    let bad: Vec<usize> = (0..counts.len()).filter(|&i| counts[i] != 1).collect();
    assert!(
        bad.is_empty(),
        "{name}: {} pixels not covered exactly once, first {:?} (count {})",
        bad.len(),
        bad.first(),
        bad.first().map_or(0, |&i| counts[i])
    );
    let frame = render(scene, cam);
    assert!(frame.ids.iter().all(|&id| id != Hit::NONE), "{name}: crack");
}

#[test]
fn grid_with_vertices_on_pixel_centres_is_watertight() {
    // Cell 1/32 = one pixel, vertices at pixel centres (odd multiples of 1/64).
    let scene = grid(1.0 / 32.0, 80, -1.25 + 1.0 / 64.0, true);
    assert_single_cover("centre grid", &scene, &aligned_camera());
}

#[test]
fn grid_with_edges_through_pixel_centres_is_watertight() {
    // Cell 3/64: vertices on pixel corners and centres alternately, diagonals through centres.
    let scene = grid(3.0 / 64.0, 60, -1.5, false);
    assert_single_cover("3/64 grid", &scene, &aligned_camera());
}

#[test]
fn irregular_grid_is_watertight() {
    // A grid with jittered vertices (shared, so still a single layer).
    let mut scene = grid(1.0 / 16.0, 40, -1.25, true);
    let mut rng = Rng(6);
    for p in &mut scene.positions {
        p.x += rng.range(-0.02, 0.02);
        p.y += rng.range(-0.02, 0.02);
    }
    assert_single_cover("jittered grid", &scene, &aligned_camera());
}

#[test]
fn fan_around_pixel_centre_is_watertight() {
    // 16 triangles around the centre of pixel (32, 32), inside a 4-triangle frame filling
    // the screen.
    let mut b = SceneBuilder::new("fan");
    let c = b.add_vertex(Vec3::new(1.0 / 64.0, 1.0 / 64.0, -1.0));
    let ring: Vec<u32> = (0..16)
        .map(|k| {
            let a = k as f32 / 16.0 * std::f32::consts::TAU;
            b.add_vertex(Vec3::new(3.0 * a.cos(), 3.0 * a.sin(), -1.0))
        })
        .collect();
    for k in 0..16 {
        b.add_triangle([c, ring[k], ring[(k + 1) % 16]]);
    }
    let scene = b.finish();
    assert_single_cover("fan", &scene, &aligned_camera());
}

/// A UV sphere of radius `r` around `centre`, `rings × segments`, triangles at the poles.
fn sphere(centre: Vec3, r: f32, rings: u32, segments: u32) -> Scene {
    let mut b = SceneBuilder::new("sphere");
    let top = b.add_vertex(centre + Vec3::Y * r);
    let mut rows = Vec::new();
    for i in 1..rings {
        let phi = std::f32::consts::PI * i as f32 / rings as f32;
        let row: Vec<u32> = (0..segments)
            .map(|j| {
                let th = std::f32::consts::TAU * j as f32 / segments as f32;
                b.add_vertex(
                    centre + r * Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin()),
                )
            })
            .collect();
        rows.push(row);
    }
    let bottom = b.add_vertex(centre - Vec3::Y * r);
    let s = segments as usize;
    for j in 0..s {
        b.add_triangle([top, rows[0][j], rows[0][(j + 1) % s]]);
        let last = &rows[rows.len() - 1];
        b.add_triangle([bottom, last[(j + 1) % s], last[j]]);
    }
    for w in rows.windows(2) {
        for j in 0..s {
            let (a, b1) = (w[0][j], w[0][(j + 1) % s]);
            let (c, d) = (w[1][j], w[1][(j + 1) % s]);
            b.add_triangle([a, c, d]);
            b.add_triangle([a, d, b1]);
        }
    }
    b.finish()
}

#[test]
fn closed_sphere_around_eye_is_watertight() {
    // Seen from inside, every pixel ray leaves the sphere exactly once; many triangles cross
    // the near plane and the clip path must stay watertight too.
    let scene = sphere(Vec3::new(0.1, -0.2, 0.05), 1.0, 24, 48);
    for (k, target) in [Vec3::NEG_Z, Vec3::new(1.0, 0.9, 0.3)]
        .into_iter()
        .enumerate()
    {
        let cam = look(Vec3::ZERO, target, 96, 80, 0.01);
        assert_single_cover(&format!("sphere view {k}"), &scene, &cam);
    }
}

// ---- edge cases ---------------------------------------------------------------------------------

#[test]
fn triangle_straddling_near_plane_is_cut_at_near() {
    let mut b = SceneBuilder::new("straddle");
    let p = [
        b.add_vertex(Vec3::new(-1.0, -0.2, 1.0)),
        b.add_vertex(Vec3::new(1.0, -0.2, 1.0)),
        b.add_vertex(Vec3::new(0.0, -0.2, -5.0)),
    ];
    b.add_triangle(p);
    let scene = b.finish();
    let cam = look(Vec3::ZERO, Vec3::NEG_Z, 64, 64, 0.5);
    let frame = render(&scene, &cam);
    assert!(frame.ids.contains(&0));
    assert!(frame.depth.iter().all(|&d| d.is_infinite() || d >= 0.5));
    compare_frame("straddle", &scene, &cam, &frame, DepthRef::RayT);
}

#[test]
fn camera_inside_box_sees_all_walls_in_cube_map() {
    let mut b = SceneBuilder::new("room");
    b.add_box(Vec3::splat(-1.0), Vec3::splat(1.0));
    let scene = b.finish();
    let faces = render_cube(&scene, Vec3::new(0.1, 0.2, 0.3), 32, 0.01).expect("cube");
    let mut seen = sightline_core::TriangleSet::with_capacity(12);
    for f in &faces {
        assert!(f.ids.iter().all(|&id| id != Hit::NONE), "cube face crack");
        seen.union_with(&f.visible_set(12));
    }
    assert_eq!(seen.count_ones(..), 12);
}

#[test]
fn rendering_is_deterministic_across_thread_counts() {
    let scene = triangle_soup(7, 2000, 3.0, 0.8);
    let cam = look(Vec3::new(0.0, 0.0, 9.0), Vec3::ZERO, 300, 200, 0.1);
    let a = render(&scene, &cam);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let b = pool.install(|| render(&scene, &cam));
    assert_eq!(a, b);
}
