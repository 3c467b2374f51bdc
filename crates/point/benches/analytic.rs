//! Exact analytic visibility of the Stanford bunny (69k triangles) at 1024²: visibility time
//! (projection to visible polygons) and integration time (box filter; Gaussian of radius 2.3 px
//! for 16 px bins), measured separately, for several bin sizes. The paper reports 122 ms visibility and 51 ms integration (Gaussian
//! filter) on a GTX 680 for its 70k bunny at 1024².
//!
//! A SPIKES-like scene (5184 triangles of square pyramids; the paper: 448 ms visibility, 25M
//! edge intersections) is measured the same way with the default bin size.
//!
//! Run: `cargo bench -p sightline-point --bench analytic`. The scene is read from
//! `../shared/scenes/models/stanford_bunny.obj.gz` (override with `SIGHTLINE_BUNNY`); the bench
//! is skipped with a message when the file is missing.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use sightline_core::scene::{open, LoadOptions, SceneBuilder};
use sightline_core::{Camera, Scene};
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

/// SPIKES-like: a 36×36 grid of square pyramids of varying height sharing their base edges
/// (5184 triangles; the paper's SPIKES has 5.0k), for a high depth complexity.
fn spikes() -> Scene {
    let n = 36usize;
    let mut b = SceneBuilder::new("spikes");
    let mut grid = vec![0u32; (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            grid[j * (n + 1) + i] = b.add_vertex(Vec3::new(i as f32, 0.0, j as f32));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let h = 2.0 + ((i * 7 + j * 13) % 11) as f32 * 0.8;
            let apex = b.add_vertex(Vec3::new(i as f32 + 0.5, h, j as f32 + 0.5));
            let c = [
                grid[j * (n + 1) + i],
                grid[j * (n + 1) + i + 1],
                grid[(j + 1) * (n + 1) + i + 1],
                grid[(j + 1) * (n + 1) + i],
            ];
            for k in 0..4 {
                b.add_triangle([c[k], c[(k + 1) % 4], apex]);
            }
        }
    }
    b.finish()
}

fn bench_spikes(c: &mut Criterion) {
    let scene = spikes();
    let Ok(cam) = Camera::look_at(
        Vec3::new(-10.0, 14.0, -10.0),
        Vec3::new(18.0, 0.0, 18.0),
        Vec3::Y,
        60.0,
        1024,
        1024,
        0.1,
    ) else {
        return;
    };
    let options = AnalyticOptions::default();
    let Ok(result) = visible_fragments(&scene, &cam, &options) else {
        return;
    };
    let s = result.stats;
    eprintln!(
        "spikes: {} overlaps, {} visible + {} completion segments, {} polygons, {} visible \
         tris, {:?}",
        s.intersections,
        s.visible_segments,
        s.completion_segments,
        result.polygons.len(),
        result.visible.count_ones(..),
        s.visibility_time,
    );
    let mut group = c.benchmark_group("analytic_spikes_1024");
    group.sample_size(10);
    group.bench_function("visibility", |b| {
        b.iter(|| visible_fragments(&scene, &cam, &options))
    });
    group.bench_function("integration_box", |b| {
        b.iter(|| integrate(&result, Filter::Box, |_| 1.0))
    });
    group.finish();
}

criterion_group!(benches, bench_bunny, bench_spikes);
criterion_main!(benches);
