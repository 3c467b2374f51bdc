//! The exact visible set of a real scan must not depend on the screen-space bin size: polygons
//! are never clipped to bins, so bins only change the work split, never the result. (Timings
//! are measured by the criterion bench `benches/analytic.rs`, not here.)
#![allow(clippy::unwrap_used)]

use glam::Vec3;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::Camera;
use sightline_point::analytic::{visible_fragments, AnalyticOptions};

/// The visible set and areas must not depend on the bin size (polygons are never clipped).
#[test]
fn bunny_bin_size_does_not_change_the_result() {
    // The low-resolution bunny kept in the repository (3,674 triangles): seconds at most.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/bunny.obj");
    let scene = open(path, &LoadOptions::default()).unwrap();
    let b = scene.bounds();
    let radius = 0.5 * b.diagonal();
    let cam = Camera::look_at(
        b.center() + Vec3::new(0.0, 0.0, 2.4 * radius),
        b.center(),
        Vec3::Y,
        45.0,
        512,
        512,
        0.01 * radius,
    )
    .unwrap();
    let r8 = visible_fragments(
        &scene,
        &cam,
        &AnalyticOptions {
            bin_size: 8,
            ..AnalyticOptions::default()
        },
    )
    .unwrap();
    let r32 = visible_fragments(
        &scene,
        &cam,
        &AnalyticOptions {
            bin_size: 32,
            ..AnalyticOptions::default()
        },
    )
    .unwrap();
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
