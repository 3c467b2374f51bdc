//! The exact analytic visibility on the shared real scenes (city meshes, a building, Quake 3
//! maps): real misses against f64 rays, the set across bin sizes, intersecting pairs resolved,
//! and CPU time. Prints a markdown table (one row per scene and view).
//!
//! A *real miss* is a triangle that a ray through a sample hits first, but that the exact set
//! lacks: each sample is cast with the BVH (f32), and when its triangle is not in the set the
//! hit is confirmed in f64 (Möller–Trumbore, at least 1e-6 inside the triangle in barycentric
//! terms, no triangle of the set hit nearer in f64 or at the same depth up to the f32 input's
//! precision), so ties along shared edges and between coincident faces are not counted. Samples: a stratified 2×2 grid per pixel.
//!
//! Run: `cargo bench -p sightline-point --bench exact_real_scenes`. `EXACT_SIZE=PX` sets the
//! image size (default 512), `EXACT_SCENES=munich,fzk` picks scenes by name, `EXACT_DIAG=1`
//! prints each missed triangle, `EXACT_NO_PRECULL=1` turns depth pre-culling off.
//!
//! `EXACT_ANGLES=N` sweeps instead (as `rv_angles` does for RV): from the close view's eye the
//! camera turns 360°/N per frame about the up axis, and the aerial camera orbits the scene
//! centre in N steps; one row per scene and sweep with the sums over its N views.

use std::path::Path;
use std::time::Instant;

use glam::{DVec3, Vec3};
use sightline_core::scene::{open, LoadOptions};
use sightline_core::trace::{Bvh, RayCaster};
use sightline_core::{Camera, Hit, Ray, Scene, TriangleSet};
use sightline_point::analytic::{
    visible_fragments, AnalyticOptions, AnalyticResult, MIN_VISIBLE_AREA_PX2,
};
use sightline_region::cell_sources::random_free_cells;

/// The f64 ray parameter and smallest barycentric of `ray` against triangle `id`.
fn hit_f64(scene: &Scene, ray: &Ray, id: usize) -> Option<(f64, f64)> {
    let p = scene.triangles[id].map(|i| scene.positions[i as usize].as_dvec3());
    let (o, dir): (DVec3, DVec3) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let h = dir.cross(e2);
    let a = e1.dot(h);
    if a == 0.0 {
        return None;
    }
    let s = o - p[0];
    let u = s.dot(h) / a;
    let q = s.cross(e1);
    let v = dir.dot(q) / a;
    let t = e2.dot(q) / a;
    let margin = u.min(v).min(1.0 - u - v);
    (margin >= 0.0 && t >= f64::from(ray.t_min)).then_some((t, margin))
}

/// Real misses of `exact`: (missed triangles, samples showing one).
fn real_misses(scene: &Scene, bvh: &Bvh, cam: &Camera, exact: &TriangleSet) -> (usize, usize) {
    let mut rays = Vec::with_capacity((cam.width * cam.height * 4) as usize);
    for y in 0..cam.height {
        for x in 0..cam.width {
            for (dx, dy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                rays.push(cam.screen_ray(x as f32 + dx, y as f32 + dy));
            }
        }
    }
    let mut hits = vec![Hit::default(); rays.len()];
    bvh.cast(&rays, &mut hits);
    let in_set: Vec<usize> = exact.ones().collect();
    let mut missed = TriangleSet::with_capacity(scene.triangle_count());
    let mut samples = 0;
    for (ray, hit) in rays.iter().zip(&hits) {
        let id = hit.triangle as usize;
        if hit.triangle == Hit::NONE || exact.contains(id) {
            continue;
        }
        let Some((t, margin)) = hit_f64(scene, ray, id) else {
            continue;
        };
        if margin < 1e-6 {
            continue;
        }
        // A triangle of the set nearer, or at the same depth up to the f32 input's precision
        // (coincident faces, where the exact method's rule is that the lower id wins), explains
        // the sample: the tie tolerance of the exact method (`project.rs`, F32_NOISE).
        let magnitude = |k: usize| {
            scene.triangles[k]
                .iter()
                .map(|&i| scene.positions[i as usize].abs().max_element())
                .fold(0.0, f32::max) as f64
        };
        let noise = 2f64.powi(-22);
        let nearer = in_set.iter().any(|&k| {
            hit_f64(scene, ray, k)
                .is_some_and(|(tk, _)| tk <= t + noise * (magnitude(k) + magnitude(id)) + 1e-9 * t)
        });
        if !nearer {
            if std::env::var_os("EXACT_DIAG").is_some() && !missed.contains(id) {
                let p = scene.triangles[id].map(|i| scene.positions[i as usize]);
                println!("<!-- missed {id} at t {t:.4} margin {margin:.3e}: {p:?} -->");
            }
            missed.insert(id);
            samples += 1;
        }
    }
    (missed.count_ones(..), samples)
}

fn run(scene: &Scene, cam: &Camera, bin_size: u32) -> AnalyticResult {
    visible_fragments(
        scene,
        cam,
        &AnalyticOptions {
            bin_size,
            depth_preculling: std::env::var_os("EXACT_NO_PRECULL").is_none(),
        },
    )
    .expect("valid camera")
}

/// What one view gives.
struct ViewCheck {
    visible: usize,
    crossing_pairs: u64,
    missed: usize,
    samples: usize,
    /// Triangles (with at least MIN_VISIBLE_AREA_PX2) whose membership differs at bin 1 and 32.
    differs: [usize; 2],
    wall: f64,
}

fn check_view(scene: &Scene, bvh: &Bvh, cam: &Camera) -> ViewCheck {
    let start = Instant::now();
    let r = run(scene, cam, 16);
    let wall = start.elapsed().as_secs_f64();
    let (missed, samples) = real_misses(scene, bvh, cam, &r.visible);
    // Sets of the triangles with at least MIN_VISIBLE_AREA_PX2 (smaller pieces are rounding
    // along shared edges, and differ between bin sizes).
    let clear =
        |x: &AnalyticResult| x.visible_at_least(scene.triangle_count(), MIN_VISIBLE_AREA_PX2);
    let differs = [1, 32].map(|bs| {
        let o = run(scene, cam, bs);
        if std::env::var_os("EXACT_DIAG").is_some() {
            let (ao, ar) = (
                o.visible_area(scene.triangle_count()),
                r.visible_area(scene.triangle_count()),
            );
            for t in clear(&o).symmetric_difference(&clear(&r)) {
                println!(
                    "<!-- bin {bs}: triangle {t} area {:.6e} px² (bin 16: {:.6e}) -->",
                    ao[t], ar[t]
                );
            }
        }
        clear(&o).symmetric_difference(&clear(&r)).count()
    });
    ViewCheck {
        visible: r.visible.count_ones(..),
        crossing_pairs: r.stats.crossing_pairs,
        missed,
        samples,
        differs,
        wall,
    }
}

fn same_or(d: usize) -> String {
    if d == 0 {
        "same".to_string()
    } else {
        format!("{d} differ")
    }
}

/// The sweep's cameras: `angles` views turning about `up` from `eye` (looking at `look` first),
/// or orbiting `look` at `eye`'s distance and height.
fn sweep(eye: Vec3, look: Vec3, up: Vec3, orbit: bool, angles: usize) -> Vec<(Vec3, Vec3)> {
    (0..angles)
        .map(|k| {
            let turn =
                glam::Quat::from_axis_angle(up, k as f32 * std::f32::consts::TAU / angles as f32);
            if orbit {
                (look + turn * (eye - look), look)
            } else {
                (eye, eye + turn * (look - eye))
            }
        })
        .collect()
}

fn main() {
    let size: u32 = std::env::var("EXACT_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(512);
    let angles: Option<usize> = std::env::var("EXACT_ANGLES")
        .ok()
        .and_then(|s| s.parse().ok());
    let filter: Vec<String> = std::env::var("EXACT_SCENES")
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    let names = [
        "city/munich.ply.gz",
        "city/etoile.ply.gz",
        "buildings/fzk_haus.obj.gz",
        "q3/q3dm6ish.bsp",
        "q3/czest3ctf.bsp",
    ];
    if angles.is_some() {
        println!(
            "| scene | sweep | views | mean visible | real misses (samples) | views whose set differs at bin 1 / 32 | mean wall s |"
        );
        println!("|---|---|---:|---:|---:|---|---:|");
    } else {
        println!(
            "| scene | view | triangles | visible | intersecting pairs (per bin) | real misses (samples) | set differs at bin 1 / 32 | wall s |"
        );
        println!("|---|---|---:|---:|---:|---:|---|---:|");
    }
    for name in names {
        if !filter.is_empty() && !filter.iter().any(|f| name.contains(f.as_str())) {
            continue;
        }
        let path = shared.join(name);
        let Ok(scene) = open(&path.to_string_lossy(), &LoadOptions::default()) else {
            println!("<!-- {name}: not found under {} -->", shared.display());
            continue;
        };
        let bvh = Bvh::build(&scene);
        let b = scene.bounds();
        let up = scene.up.vector();
        let side = if up == Vec3::Z { Vec3::X } else { Vec3::Z };
        let aerial_eye = b.center() + (side + up * 0.8).normalize() * b.diagonal() * 0.7;
        let mut views = vec![("aerial", aerial_eye, b.center())];
        if let Some(cell) = random_free_cells(&scene, &bvh, 1, 0.002 * b.diagonal(), 11).first() {
            views.push(("close", cell.center, b.center()));
        }
        let camera = |eye: Vec3, look: Vec3| {
            Camera::look_at(eye, look, up, 60.0, size, size, b.diagonal() * 1e-5).ok()
        };
        for (view, eye, look) in views {
            let Some(n) = angles else {
                let Some(cam) = camera(eye, look) else {
                    continue;
                };
                let v = check_view(&scene, &bvh, &cam);
                println!(
                    "| {name} | {view} | {} | {} | {} | {} ({}) | {} / {} | {:.2} |",
                    scene.triangle_count(),
                    v.visible,
                    v.crossing_pairs,
                    v.missed,
                    v.samples,
                    same_or(v.differs[0]),
                    same_or(v.differs[1]),
                    v.wall,
                );
                continue;
            };
            let orbit = view == "aerial";
            let checks: Vec<ViewCheck> = sweep(eye, look, up, orbit, n)
                .into_iter()
                .filter_map(|(e, l)| Some((e, l, camera(e, l)?)))
                .map(|(e, l, cam)| {
                    let v = check_view(&scene, &bvh, &cam);
                    if std::env::var_os("EXACT_DIAG").is_some()
                        && (v.missed > 0 || v.differs.iter().any(|&d| d > 0))
                    {
                        println!("<!-- view eye {e:?} look {l:?} -->");
                    }
                    v
                })
                .collect();
            let views = checks.len().max(1) as f64;
            let sum = |f: &dyn Fn(&ViewCheck) -> usize| checks.iter().map(f).sum::<usize>();
            println!(
                "| {name} | {} | {} | {:.0} | {} ({}) | {} / {} | {:.2} |",
                if orbit { "aerial orbit" } else { "close turn" },
                checks.len(),
                sum(&|v| v.visible) as f64 / views,
                sum(&|v| v.missed),
                sum(&|v| v.samples),
                sum(&|v| usize::from(v.differs[0] > 0)),
                sum(&|v| usize::from(v.differs[1] > 0)),
                checks.iter().map(|v| v.wall).sum::<f64>() / views,
            );
        }
    }
}
