//! Exact analytic visibility of the Stanford bunny (69k triangles) at 1024²: visibility time
//! (projection to visible polygons) and integration time (box filter; Gaussian of radius 2.3 px
//! for 16 px bins), measured separately, for several bin sizes. The paper reports 122 ms visibility and 51 ms integration (Gaussian
//! filter) on a GTX 680 for its 70k bunny at 1024².
//!
//! Run: `cargo bench -p sightline-point --bench analytic`. The scene is read from
//! `../shared/scenes/models/stanford_bunny.obj.gz` (override with `SIGHTLINE_BUNNY`); the bench
//! is skipped with a message when the file is missing.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::Camera;
use sightline_point::analytic::{integrate, visible_fragments, AnalyticOptions, Filter};

fn bunny_path() -> String {
    std::env::var("SIGHTLINE_BUNNY").unwrap_or_else(|_| {
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/scenes/models/stanford_bunny.obj.gz"
        )
        .to_string()
    })
}

fn bench_bunny(c: &mut Criterion) {
    let path = bunny_path();
    let scene = match open(&path, &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("skipping analytic bench: cannot load {path}: {e}");
            return;
        }
    };
    let bounds = scene.bounds();
    let centre = bounds.center();
    let radius = 0.5 * bounds.diagonal();
    // Front view, the bunny filling most of the image (as in the paper's figure 5).
    let Ok(cam) = Camera::look_at(
        centre + Vec3::new(0.0, 0.0, 2.4 * radius),
        centre,
        Vec3::Y,
        45.0,
        1024,
        1024,
        0.01 * radius,
    ) else {
        eprintln!("skipping analytic bench: bad camera");
        return;
    };
    let mut group = c.benchmark_group("analytic_bunny_1024");
    group.sample_size(10);
    for bin_size in [8u32, 16, 32] {
        let options = AnalyticOptions { bin_size };
        let Ok(result) = visible_fragments(&scene, &cam, &options) else {
            return;
        };
        let s = result.stats;
        eprintln!(
            "bin {bin_size}: {} tris in frustum, {} bins, {} pieces (max {}/bin), {} overlaps, \
             {} visible + {} completion segments, {} polygons, {} visible tris, {} exact \
             fallbacks, warnings {:?}, {:?}",
            s.triangles_in_frustum,
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
        group.bench_function(format!("visibility_bin{bin_size}"), |b| {
            b.iter(|| visible_fragments(&scene, &cam, &options))
        });
        group.bench_function(format!("integration_box_bin{bin_size}"), |b| {
            b.iter(|| integrate(&result, Filter::Box, |_| 1.0))
        });
        if bin_size == 16 {
            group.bench_function("integration_gauss2.3_bin16", |b| {
                b.iter(|| integrate(&result, Filter::Gauss { radius_px: 2.3 }, |_| 1.0))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_bunny);
criterion_main!(benches);
