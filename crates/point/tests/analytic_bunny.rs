//! Timing and sanity run on the Stanford bunny at 1024² (ignored by default; the criterion
//! bench `benches/analytic.rs` is the measurement). Run with
//! `cargo test -p sightline-point --release --test analytic_bunny -- --ignored --nocapture`.
#![allow(clippy::unwrap_used)]

use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::Camera;
use sightline_point::analytic::{integrate, visible_fragments, AnalyticOptions, Filter};

/// CPU time of this process so far (user + system, from `/proc/self/stat`, 10 ms ticks), so
/// that timings on a shared machine can be reported as CPU time too.
fn cpu_time() -> std::time::Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<u64> = after
        .split_whitespace()
        .map(|x| x.parse().unwrap_or(0))
        .collect();
    // Fields 14 and 15 (utime, stime) are at 11 and 12 after the command name.
    let ticks = f.get(11).copied().unwrap_or(0) + f.get(12).copied().unwrap_or(0);
    std::time::Duration::from_millis(ticks * 10)
}

#[test]
#[ignore = "needs ../shared/scenes and takes seconds"]
fn bunny_1024_phases() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/models/stanford_bunny.obj.gz"
    );
    let scene = open(path, &LoadOptions::default()).unwrap();
    let b = scene.bounds();
    let radius = 0.5 * b.diagonal();
    let cam = Camera::look_at(
        b.center() + Vec3::new(0.0, 0.0, 2.4 * radius),
        b.center(),
        Vec3::Y,
        45.0,
        1024,
        1024,
        0.01 * radius,
    )
    .unwrap();
    for bin_size in [8, 16, 32, 64] {
        let c0 = cpu_time();
        let r = visible_fragments(&scene, &cam, &AnalyticOptions { bin_size }).unwrap();
        let cpu = cpu_time() - c0;
        let t = std::time::Instant::now();
        let img = integrate(&r, Filter::Box, |_| 1.0);
        let it = t.elapsed();
        let t = std::time::Instant::now();
        let gauss = integrate(&r, Filter::Gauss { radius_px: 2.3 }, |_| 1.0);
        let gt = t.elapsed();
        let gsum: f32 = gauss.iter().sum();
        let s = r.stats;
        eprintln!(
            "bin {bin_size}: vis {:?} (cpu {cpu:?}; proj {:?}, bin {:?}), integ box {it:?} gauss {gt:?} (sum {gsum:.1}); {} pieces max {}/bin, {} overlaps, {} polys, {} visible, fallbacks {}, coverage {:.1}",
            s.visibility_time,
            s.projection_time,
            s.binning_time,
            s.bin_assignments,
            s.max_pieces_per_bin,
            s.intersections,
            r.polygons.len(),
            r.visible.count_ones(..),
            s.exact_fallbacks,
            img.iter().sum::<f32>()
        );
    }
}

/// The visible set and areas must not depend on the bin size (polygons are never clipped).
#[test]
#[ignore = "needs ../shared/scenes and takes seconds"]
fn bunny_bin_size_does_not_change_the_result() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/scenes/models/stanford_bunny.obj.gz"
    );
    let scene = open(path, &LoadOptions::default()).unwrap();
    let b = scene.bounds();
    let radius = 0.5 * b.diagonal();
    let cam = Camera::look_at(
        b.center() + Vec3::new(0.0, 0.0, 2.4 * radius),
        b.center(),
        Vec3::Y,
        45.0,
        1024,
        1024,
        0.01 * radius,
    )
    .unwrap();
    let r8 = visible_fragments(&scene, &cam, &AnalyticOptions { bin_size: 8 }).unwrap();
    let r32 = visible_fragments(&scene, &cam, &AnalyticOptions { bin_size: 32 }).unwrap();
    let a8 = r8.visible_area(scene.triangles.len());
    let a32 = r32.visible_area(scene.triangles.len());
    let mut worst = 0.0f64;
    for id in 0..scene.triangles.len() {
        worst = worst.max((a8[id] - a32[id]).abs());
        if r8.visible.contains(id) != r32.visible.contains(id) || (a8[id] - a32[id]).abs() > 1e-3 {
            eprintln!(
                "tri {id}: {} {} areas {} {}",
                r8.visible.contains(id),
                r32.visible.contains(id),
                a8[id],
                a32[id]
            );
            for p in r8.polygons.iter().filter(|p| p.triangle == id as u32) {
                eprintln!("   {:?}", p.points);
            }
        }
    }
    eprintln!("worst area diff {worst}");
    assert!(worst < 1e-6);
    assert_eq!(r8.visible, r32.visible);
}
