//! Cameras at the edges of the exact analytic visibility's input domain (issue 16): a tiny
//! image, fields of view near 180°, a far camera with a narrow field of view.
//!
//! The reference is independent of the pipeline: f64 rays from the eye through points inside
//! each triangle, tested against every triangle's projection and plane. A triangle counts as
//! *clearly seen* when one of its sample points is at least [`CLEARANCE`] grid units inside its
//! own projection and inside the image, and every other triangle whose projection comes within
//! [`CLEARANCE`] of it is farther along the ray by more than [`DEPTH_MARGIN`] (relative). The
//! exact set must contain every clearly seen triangle: the pipeline is exact for the scene
//! snapped to 2^-20 px, with depth ties below about 2e-9 of the distance, so only points closer
//! to an edge or a nearer surface than that may be decided otherwise (see the module docs of
//! `sightline_point::analytic`, "Exactness"). Cameras outside the documented range must be
//! refused with `AnalyticError::OutsideExactRange`.
#![allow(clippy::unwrap_used)]

use glam::{DVec2, DVec3, Vec3};
use sightline_core::scene::{open, LoadOptions, SceneBuilder};
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{
    visible_fragments, AnalyticError, AnalyticOptions, AnalyticResult,
};

/// Grid units per pixel of the pipeline's snapping (2^20).
const GRID: f64 = 1_048_576.0;
/// Screen clearance of a reference sample (grid units): snapping moves a vertex by at most half
/// a unit per coordinate.
const CLEARANCE: f64 = 2.0;
/// Relative depth margin of the reference (far above the pipeline's tie tolerance).
const DEPTH_MARGIN: f64 = 1e-6;

fn bunny() -> Scene {
    // The low-resolution bunny kept in the repository (3,674 triangles, no intersections).
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/bunny.obj");
    open(path, &LoadOptions::default()).unwrap()
}

/// A camera at `distance` radii from the scene's centre (front view, as the bunny test).
fn front(scene: &Scene, distance: f32, fov: f32, w: u32, h: u32) -> Camera {
    let b = scene.bounds();
    let r = 0.5 * b.diagonal();
    Camera::look_at(
        b.center() + Vec3::new(0.3, 0.2, 1.0).normalize() * distance * r,
        b.center(),
        Vec3::Y,
        fov,
        w,
        h,
        0.01 * r,
    )
    .unwrap()
}

fn run(scene: &Scene, cam: &Camera) -> AnalyticResult {
    visible_fragments(scene, cam, &AnalyticOptions::default()).unwrap()
}

/// Signed distance (pixels) of `q` from the boundary of the screen triangle `t`, positive inside.
fn inside_distance(t: &[DVec2; 3], q: DVec2) -> f64 {
    let orient = (t[1] - t[0]).perp_dot(t[2] - t[0]).signum();
    if orient == 0.0 {
        return f64::NEG_INFINITY;
    }
    (0..3)
        .map(|i| {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            let len = (b - a).length();
            if len == 0.0 {
                return f64::NEG_INFINITY;
            }
            orient * (b - a).perp_dot(q - a) / len
        })
        .fold(f64::INFINITY, f64::min)
}

/// The triangles the f64 ray reference sees clearly (see the file docs), and how many it saw.
fn clearly_seen(scene: &Scene, cam: &Camera) -> (Vec<bool>, usize) {
    let (eye, right, up, fwd) = (
        cam.eye.as_dvec3(),
        cam.right.as_dvec3(),
        cam.up.as_dvec3(),
        cam.forward.as_dvec3(),
    );
    let (tx, ty) = (f64::from(cam.tan_half_x()), f64::from(cam.tan_half_y()));
    let (w, h) = (f64::from(cam.width), f64::from(cam.height));
    let near = f64::from(cam.near);
    let view = |p: Vec3| {
        let d = p.as_dvec3() - eye;
        DVec3::new(d.dot(right), d.dot(up), d.dot(fwd))
    };
    let screen = |v: DVec3| {
        DVec2::new(
            (v.x / (v.z * tx) + 1.0) * 0.5 * w,
            (1.0 - v.y / (v.z * ty)) * 0.5 * h,
        )
    };
    let tris: Vec<[DVec3; 3]> = scene
        .triangles
        .iter()
        .map(|t| t.map(|i| view(scene.positions[i as usize])))
        .collect();
    assert!(
        tris.iter().flatten().all(|v| v.z > near),
        "the reference needs the whole scene in front of the near plane"
    );
    let shapes: Vec<[DVec2; 3]> = tris.iter().map(|t| t.map(screen)).collect();
    // The f32 input's precision per triangle (2^-22 of its largest coordinate): the exact
    // method ties depths within it (coincident faces), so the judge does not call those.
    let input_noise: Vec<f64> = scene
        .triangles
        .iter()
        .map(|t| {
            let m = t
                .iter()
                .map(|&i| scene.positions[i as usize].abs().max_element())
                .fold(0.0f32, f32::max);
            f64::from(m) / f64::from(1u32 << 22)
        })
        .collect();
    let c = CLEARANCE / GRID;
    // Candidates per cell of a uniform grid over the image.
    const CELLS: usize = 64;
    let cell_of = |q: DVec2| {
        let cx = ((q.x / w * CELLS as f64).floor() as i64).clamp(0, CELLS as i64 - 1);
        let cy = ((q.y / h * CELLS as f64).floor() as i64).clamp(0, CELLS as i64 - 1);
        (cx as usize, cy as usize)
    };
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); CELLS * CELLS];
    for (k, s) in shapes.iter().enumerate() {
        let lo = s[0].min(s[1]).min(s[2]) - DVec2::splat(c);
        let hi = s[0].max(s[1]).max(s[2]) + DVec2::splat(c);
        if hi.x < 0.0 || hi.y < 0.0 || lo.x > w || lo.y > h {
            continue;
        }
        let ((x0, y0), (x1, y1)) = (cell_of(lo), cell_of(hi));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                grid[cy * CELLS + cx].push(k as u32);
            }
        }
    }
    let samples = [
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [0.6, 0.2, 0.2],
        [0.2, 0.6, 0.2],
        [0.2, 0.2, 0.6],
        [0.45, 0.45, 0.1],
        [0.45, 0.1, 0.45],
        [0.1, 0.45, 0.45],
    ];
    let mut seen = vec![false; tris.len()];
    for (k, t) in tris.iter().enumerate() {
        'samples: for s in samples {
            let p = t[0] * s[0] + t[1] * s[1] + t[2] * s[2];
            let q = screen(p);
            if q.x < c || q.y < c || q.x > w - c || q.y > h - c {
                continue;
            }
            if inside_distance(&shapes[k], q) < c {
                continue;
            }
            let dir = p / p.z;
            let (cx, cy) = cell_of(q);
            for &o in &grid[cy * CELLS + cx] {
                let o = o as usize;
                if o == k {
                    continue;
                }
                let d = inside_distance(&shapes[o], q);
                if d < -c {
                    continue;
                }
                // Depth of o's plane along the ray through q.
                let ot = &tris[o];
                let n = (ot[1] - ot[0]).cross(ot[2] - ot[0]);
                let depth = n.dot(ot[0]) / n.dot(dir);
                let margin = p.z * DEPTH_MARGIN + 2.0 * (input_noise[k] + input_noise[o]);
                if depth.is_finite() && depth > p.z + margin {
                    continue;
                }
                // In front (hidden here) or too close to call: try the next sample.
                continue 'samples;
            }
            seen[k] = true;
            break;
        }
    }
    let count = seen.iter().filter(|&&s| s).count();
    (seen, count)
}

/// Triangles the reference sees clearly but the exact set lacks.
fn real_misses(scene: &Scene, cam: &Camera, r: &AnalyticResult) -> (Vec<usize>, usize) {
    let (seen, count) = clearly_seen(scene, cam);
    let misses = (0..seen.len())
        .filter(|&k| seen[k] && !r.visible.contains(k))
        .collect();
    (misses, count)
}

fn refusal(scene: &Scene, cam: &Camera) -> (&'static str, String) {
    match visible_fragments(scene, cam, &AnalyticOptions::default()) {
        Err(AnalyticError::OutsideExactRange { parameter, detail }) => (parameter, detail),
        Err(e) => panic!("unexpected error {e}"),
        Ok(_) => panic!(
            "fov {} at {}x{} was not refused",
            cam.fov_y_deg, cam.width, cam.height
        ),
    }
}

#[test]
fn one_pixel_image_sees_what_the_rays_see_with_the_work_of_a_large_one() {
    let scene = bunny();
    let big = run(&scene, &front(&scene, 2.4, 45.0, 512, 512));
    for size in [1, 4] {
        let cam = front(&scene, 2.4, 45.0, size, size);
        let small = run(&scene, &cam);
        let (misses, seen) = real_misses(&scene, &cam, &small);
        let differ = (0..scene.triangles.len())
            .filter(|&k| small.visible.contains(k) != big.visible.contains(k))
            .count();
        eprintln!(
            "{size}x{size}: {} visible ({} at 512²; {differ} differ), {seen} clearly seen by \
             rays, misses {misses:?}; {} pre-culled ({} at 512²), {} overlaps ({} at 512²)",
            small.visible.count_ones(..),
            big.visible.count_ones(..),
            small.stats.preculled,
            big.stats.preculled,
            small.stats.intersections,
            big.stats.intersections
        );
        assert!(seen > 1000, "the reference must see the bunny ({seen})");
        assert!(misses.is_empty(), "{size}x{size} misses {misses:?}");
        // The sets differ only in sub-grid slivers (a grid unit is 512 times coarser here).
        assert!(
            differ * 200 <= big.visible.count_ones(..),
            "{differ} differ"
        );
        // One bin holds the whole bunny, yet pre-culling still works (it used to cull nothing
        // in a one-pixel raster) and the pipeline's work stays that of the large image.
        assert!(
            small.stats.preculled * 10 >= big.stats.preculled * 9,
            "pre-culled {} of {}",
            small.stats.preculled,
            big.stats.preculled
        );
        assert!(small.stats.intersections <= 2 * big.stats.intersections);
        assert!(small.stats.bin_assignments <= 2 * big.stats.bin_assignments);
    }
}

#[test]
fn fields_of_view_near_180_degrees_are_refused_with_the_limit() {
    let scene = bunny();
    for fov in [179.999, 179.9999, 173.0] {
        let (parameter, detail) = refusal(&scene, &front(&scene, 2.4, fov, 1024, 1024));
        assert_eq!(parameter, "field of view");
        assert!(
            detail.contains("170.00°") && detail.contains("Camera::cube_faces"),
            "{detail}"
        );
    }
    // Horizontally: a 16:1 image at fov 120° sees 179.4° across.
    let (parameter, _) = refusal(&scene, &front(&scene, 2.4, 120.0, 1024, 64));
    assert_eq!(parameter, "horizontal field of view");
    // A one-pixel image at fov 160°: the grid spans 1.1e-5 of the view, above 2^-17.
    let (parameter, detail) = refusal(&scene, &front(&scene, 2.4, 160.0, 1, 1));
    assert_eq!(parameter, "image size");
    assert!(detail.contains("at least 2 px high"), "{detail}");
}

#[test]
fn widest_exact_field_of_view_sees_what_the_rays_see() {
    let scene = bunny();
    // Just inside the limit: the bunny, 2.4 radii away, shrinks to a few pixels at the centre.
    for (fov, size) in [(170.0, 1024), (151.9, 1)] {
        let cam = front(&scene, 2.4, fov, size, size);
        let r = run(&scene, &cam);
        let (misses, seen) = real_misses(&scene, &cam, &r);
        eprintln!(
            "fov {fov} at {size}²: {} visible, {seen} clearly seen, misses {misses:?}",
            r.visible.count_ones(..)
        );
        assert!(seen > 500, "the reference must see the bunny ({seen})");
        assert!(misses.is_empty(), "fov {fov}: misses {misses:?}");
    }
}

#[test]
fn far_camera_with_a_narrow_field_of_view_sees_what_the_rays_see() {
    // A city (no intersecting triangles) from 100 km with a 1° field of view: it fills the
    // image; depth gaps between buildings are metres, far above the 0.2 mm ties at that
    // distance.
    let scene = open("procedural:city", &LoadOptions::default()).unwrap();
    let b = scene.bounds();
    let centre = b.center();
    let eye = centre + Vec3::new(-0.55, -0.75, 0.6).normalize() * 100_000.0;
    let cam = Camera::look_at(eye, centre, Vec3::Z, 0.6, 256, 192, 1.0).unwrap();
    let r = run(&scene, &cam);
    let (misses, seen) = real_misses(&scene, &cam, &r);
    eprintln!(
        "city from 100 km: {} visible, {seen} clearly seen, misses {misses:?}, {} pre-culled",
        r.visible.count_ones(..),
        r.stats.preculled
    );
    assert!(seen > 1000, "the reference must see the city ({seen})");
    assert!(misses.is_empty(), "misses {misses:?}");
    // A small model far away is as coarse as a whole scene in one pixel: still no clear miss,
    // and (with the bin index over the occupied part of the bin) no quadratic work.
    let bunny = bunny();
    let cam = front(&bunny, 2.0e4, 1.0, 256, 256);
    let r = run(&bunny, &cam);
    let (misses, seen) = real_misses(&bunny, &cam, &r);
    eprintln!(
        "bunny from 20,000 radii at 1°: {} visible, {seen} clearly seen, misses {misses:?}",
        r.visible.count_ones(..)
    );
    assert!(misses.is_empty(), "misses {misses:?}");
}

/// Two nearly coplanar walls (a 0.075° kink) meeting at a corner where the top vertex of one
/// lies on the other's edge (a T-junction; from the Munich scene, triangles 179 and 204). When
/// snapping puts that vertex a fraction of a grid unit inside the other wall, each wall's corner
/// edge lies inside the other's polygon, the midpoint depth test calls it a tie, and the slope
/// rule (valid when the planes meet on the edge, not a fraction of a unit beside it) puts each
/// wall in front on the other's side: both corner edges are hidden, and the region assembly
/// loses most of both walls. Snapping decides, so it happens at about half of all distances,
/// near or far (99 of 200 in a sweep from 100 m to 100 km). The cause is in `intersect.rs`
/// (`in_front`), outside this files; see the report of issue 16.
#[test]
fn t_junction_of_two_nearly_coplanar_walls_keeps_both_walls() {
    let walls = [
        [
            Vec3::new(96.93575, -181.67537, 29.0),
            Vec3::new(96.93575, -181.67537, 0.0),
            Vec3::new(91.847015, -190.06894, 0.0),
        ],
        [
            Vec3::new(99.6027, -177.28934, 0.0),
            Vec3::new(96.93575, -181.67537, 0.0),
            Vec3::new(96.93575, -181.67537, 27.0),
        ],
    ];
    let build = |which: &[usize]| {
        let mut b = SceneBuilder::new("walls");
        for &k in which {
            let i = walls[k].map(|p| b.add_vertex(p));
            b.add_triangle(i);
        }
        b.finish()
    };
    let look = Vec3::new(-67.850464, -85.782776, 49.285);
    let eye = look + Vec3::new(-0.55, 0.45, 0.75).normalize() * 1.0e5;
    let cam = Camera::look_at(eye, look, Vec3::Y, 1.0, 1024, 768, 0.1).unwrap();
    let both = run(&build(&[0, 1]), &cam).visible_area(2);
    let alone = [0, 1].map(|k| run(&build(&[k]), &cam).visible_area(1)[0]);
    // The walls do not overlap on screen: together each keeps its own area.
    for k in 0..2 {
        assert!(
            (both[k] - alone[k]).abs() <= 1e-6 * alone[k],
            "wall {k}: {} together, {} alone",
            both[k],
            alone[k]
        );
    }
}
