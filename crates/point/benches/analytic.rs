//! Exact analytic visibility at 1024² on the paper's scenes: the Stanford bunny (69k
//! triangles), PLANETS-like spheres (`procedural:spheres`, 37k), SPIKES-like pyramids
//! (`procedural:spikes`, 5k) and two superposed zone plates (`procedural:zoneplate`, 14k).
//! Visibility time (projection to visible polygons) and integration time (box filter; Gaussian
//! of radius 2.3 px on the bunny) are measured separately; the bunny also for several bin
//! sizes and with depth pre-culling switched off, side by side. The paper (GTX 680, 8² bins,
//! table 3) reports visibility/integration in ms: PLANETS 94/31, SPIKES 448/43, ZPLATE
//! 165/104, BUNNY 122/51.
//!
//! Run: `cargo bench -p sightline-point --bench analytic`. The bunny is read from
//! `../shared/scenes/models/stanford_bunny.obj.gz` (override with `SIGHTLINE_BUNNY`); its
//! part is skipped with a message when the file is missing.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{
    integrate, visible_fragments, AnalyticOptions, AnalyticResult, Filter,
};

fn bunny_path() -> String {
    std::env::var("SIGHTLINE_BUNNY").unwrap_or_else(|_| {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/scenes/models/stanford_bunny.obj.gz"
        )
        .to_string()
    })
}

/// Prints the counters of one run (the numbers the paper's tables give).
fn report(label: &str, result: &AnalyticResult) {
    let s = &result.stats;
    eprintln!(
        "{label}: {} tris in frustum, {} pre-culled ({:?}), {} bins, {} pieces (max {}/bin), \
         {} overlaps, {} visible + {} completion segments, {} polygons, {} visible tris, {} \
         exact fallbacks, warnings {:?}, {:?}",
        s.triangles_in_frustum,
        s.preculled,
        s.precull_time,
        s.bins_filled,
        s.bin_assignments,
        s.max_pieces_per_bin,
        s.intersections,
        s.visible_segments,
        s.completion_segments,
        result.polygons.len(),
        result.visible.count_ones(..),
        s.exact_fallbacks,
        s.warnings,
        s.visibility_time,
    );
}

/// A camera at `eye` looking at `at`, 1024², 50° (45° for the bunny as in the paper's figure).
fn camera(eye: Vec3, at: Vec3, up: Vec3, fov: f32, near: f32) -> Option<Camera> {
    Camera::look_at(eye, at, up, fov, 1024, 1024, near).ok()
}

fn bench_bunny(c: &mut Criterion) {
    let path = bunny_path();
    let scene = match open(&path, &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("skipping the bunny: cannot load {path}: {e}");
            return;
        }
    };
    let bounds = scene.bounds();
    let centre = bounds.center();
    let radius = 0.5 * bounds.diagonal();
    // Front view, the bunny filling most of the image (as in the paper's figure 5).
    let Some(cam) = camera(
        centre + Vec3::new(0.0, 0.0, 2.4 * radius),
        centre,
        Vec3::Y,
        45.0,
        0.01 * radius,
    ) else {
        return;
    };
    let mut group = c.benchmark_group("analytic_bunny_1024");
    group.sample_size(10);
    for (bin_size, depth_preculling) in [(8u32, true), (16, true), (32, true), (16, false)] {
        let options = AnalyticOptions {
            bin_size,
            depth_preculling,
        };
        let Ok(result) = visible_fragments(&scene, &cam, &options) else {
            return;
        };
        let label = if depth_preculling {
            format!("bin{bin_size}")
        } else {
            format!("bin{bin_size}_no_preculling")
        };
        report(&format!("bunny {label}"), &result);
        group.bench_function(format!("visibility_{label}"), |b| {
            b.iter(|| visible_fragments(&scene, &cam, &options))
        });
        if depth_preculling {
            group.bench_function(format!("integration_box_{label}"), |b| {
                b.iter(|| integrate(&result, Filter::Box, |_| 1.0))
            });
        }
        if bin_size == 16 && depth_preculling {
            group.bench_function("integration_gauss2.3_bin16", |b| {
                b.iter(|| integrate(&result, Filter::Gauss { radius_px: 2.3 }, |_| 1.0))
            });
        }
    }
    group.finish();
}

/// One of the paper's other scenes, re-created procedurally: visibility and box integration.
fn bench_scene(c: &mut Criterion, name: &str, scene: &Scene, cam: &Camera) {
    let options = AnalyticOptions::default();
    let Ok(result) = visible_fragments(scene, cam, &options) else {
        return;
    };
    report(name, &result);
    let mut group = c.benchmark_group(format!("analytic_{name}_1024"));
    group.sample_size(10);
    group.bench_function("visibility", |b| {
        b.iter(|| visible_fragments(scene, cam, &options))
    });
    group.bench_function("integration_box", |b| {
        b.iter(|| integrate(&result, Filter::Box, |_| 1.0))
    });
    group.finish();
}

fn bench_paper_scenes(c: &mut Criterion) {
    let load = |spec: &str| open(spec, &LoadOptions::default()).ok();
    // SPIKES: looking across the pyramid field, high depth complexity (the paper's 5.0k).
    if let (Some(scene), Some(cam)) = (
        load("procedural:spikes?size=5000"),
        camera(
            Vec3::new(-10.0, 14.0, -10.0),
            Vec3::new(18.0, 0.0, 18.0),
            Vec3::Y,
            60.0,
            0.1,
        ),
    ) {
        bench_scene(c, "spikes", &scene, &cam);
    }
    // PLANETS: spheres floating in space (the paper's 37k), seen from outside the cloud.
    if let Some(scene) = load("procedural:spheres?size=37000") {
        let b = scene.bounds();
        if let Some(cam) = camera(
            b.center() + Vec3::new(0.3, 0.4, 1.2) * b.diagonal(),
            b.center(),
            Vec3::Z,
            50.0,
            0.01,
        ) {
            bench_scene(c, "planets", &scene, &cam);
        }
    }
    // ZONEPLATES: both plates filling the view, slightly oblique (the paper's 14k).
    if let (Some(scene), Some(cam)) = (
        load("procedural:zoneplate?size=14000"),
        camera(
            Vec3::new(1.0, -3.0, 24.0),
            Vec3::new(1.0, 0.5, 0.0),
            Vec3::Y,
            50.0,
            0.1,
        ),
    ) {
        bench_scene(c, "zoneplates", &scene, &cam);
    }
}

criterion_group!(benches, bench_bunny, bench_paper_scenes);
criterion_main!(benches);
