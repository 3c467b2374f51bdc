//! The exact analytic visibility on intersecting geometry (issue 16): boxes pushed into each
//! other, a roof pierced by walls, a terrain crossing buildings, tilted triangles through
//! others. Checked against the independent brute force (which splits the screen along the
//! projected intersection segments too) for exact per-triangle areas, against 16×16
//! supersampling of the rasterizer (no visible triangle missed), and across bin sizes (the same
//! set, the same areas).
#![allow(clippy::unwrap_used)]

mod exact_reference;

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::scene::SceneBuilder;
use sightline_core::{Camera, Scene};
use sightline_point::analytic::{visible_fragments, AnalyticOptions};

use exact_reference::*;

/// Three boxes pushed into each other and into the ground.
fn pushed_boxes() -> Scene {
    let mut b = SceneBuilder::new("pushed boxes");
    ground(&mut b, -1.0);
    b.add_box(Vec3::new(-2.0, -1.5, -9.0), Vec3::new(0.5, 1.0, -6.0));
    b.add_box(Vec3::new(-0.5, -1.2, -8.0), Vec3::new(2.0, 0.4, -5.5));
    b.add_box(Vec3::new(-1.2, -0.3, -7.2), Vec3::new(0.8, 1.6, -6.6));
    b.finish()
}

/// A slanted roof (two triangles) pierced by three walls that rise through it.
fn pierced_roof() -> Scene {
    let mut b = SceneBuilder::new("pierced roof");
    let r = [
        b.add_vertex(Vec3::new(-4.0, 0.0, -4.0)),
        b.add_vertex(Vec3::new(4.0, 0.0, -4.0)),
        b.add_vertex(Vec3::new(4.0, 1.5, -12.0)),
        b.add_vertex(Vec3::new(-4.0, 1.5, -12.0)),
    ];
    b.add_triangle([r[0], r[1], r[2]]);
    b.add_triangle([r[0], r[2], r[3]]);
    for (x, z0, z1) in [(-2.0, -5.0, -11.0), (0.3, -6.0, -10.0), (2.5, -4.5, -9.0)] {
        // A thin wall (a box) from below the roof to above it.
        b.add_box(Vec3::new(x - 0.1, -1.0, z1), Vec3::new(x + 0.1, 2.5, z0));
    }
    b.finish()
}

/// A bumpy terrain (a height field of 6×6 quads) with boxes sunk into it.
fn terrain_and_buildings(seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let mut b = SceneBuilder::new("terrain and buildings");
    let n = 6;
    let mut v = vec![0u32; (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (-6.0 + 2.0 * i as f32, -3.0 - 2.0 * j as f32);
            v[j * (n + 1) + i] = b.add_vertex(Vec3::new(x, -1.0 + rng.range_f32(-0.4, 0.4), z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = j * (n + 1) + i;
            b.add_triangle([v[k], v[k + 1], v[k + n + 2]]);
            b.add_triangle([v[k], v[k + n + 2], v[k + n + 1]]);
        }
    }
    for _ in 0..5 {
        let (cx, cz) = (rng.range_f32(-4.0, 4.0), rng.range_f32(-12.0, -5.0));
        let (hx, hz) = (rng.range_f32(0.4, 1.0), rng.range_f32(0.4, 1.0));
        let top = rng.range_f32(-0.2, 1.5);
        b.add_box(
            Vec3::new(cx - hx, -2.0, cz - hz),
            Vec3::new(cx + hx, top, cz + hz),
        );
    }
    b.finish()
}

/// Tilted triangles through each other and through a background quad, seen head on.
fn tilted_through(seed: u64) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let mut b = SceneBuilder::new("tilted");
    ground(&mut b, -1.0);
    for _ in 0..12 {
        let c = Vec3::new(
            rng.range_f32(-2.0, 2.0),
            rng.range_f32(-0.8, 1.0),
            rng.range_f32(-9.0, -5.0),
        );
        let mut corner = || {
            c + Vec3::new(
                rng.range_f32(-1.5, 1.5),
                rng.range_f32(-1.0, 1.0),
                rng.range_f32(-2.0, 2.0),
            )
        };
        let t = [corner(), corner(), corner()].map(|p| b.add_vertex(p));
        b.add_triangle(t);
    }
    b.finish()
}

/// A ground quad at height `y`.
fn ground(b: &mut SceneBuilder, y: f32) {
    let g = [
        b.add_vertex(Vec3::new(-12.0, y, 0.0)),
        b.add_vertex(Vec3::new(12.0, y, 0.0)),
        b.add_vertex(Vec3::new(12.0, y, -20.0)),
        b.add_vertex(Vec3::new(-12.0, y, -20.0)),
    ];
    b.add_triangle([g[0], g[1], g[2]]);
    b.add_triangle([g[0], g[2], g[3]]);
}

/// Cameras around the scenes (which sit around z = -7): in front, from the side, from above.
fn cameras(w: u32, h: u32) -> Vec<Camera> {
    [
        (Vec3::new(0.0, 1.0, 1.0), Vec3::new(0.0, 0.0, -7.0)),
        (Vec3::new(-6.0, 2.5, -2.0), Vec3::new(0.5, 0.0, -7.5)),
        (Vec3::new(1.0, 7.0, -4.0), Vec3::new(0.0, 0.0, -8.0)),
        (Vec3::new(4.0, 0.2, -1.0), Vec3::new(-1.0, 0.3, -8.0)),
    ]
    .into_iter()
    .map(|(eye, look)| Camera::look_at(eye, look, Vec3::Y, 60.0, w, h, 0.1).unwrap())
    .collect()
}

fn scenes() -> Vec<Scene> {
    vec![
        pushed_boxes(),
        pierced_roof(),
        terrain_and_buildings(3),
        tilted_through(5),
    ]
}

#[test]
fn every_scene_has_intersections_that_are_resolved() {
    for scene in scenes() {
        let mut pairs = 0;
        for cam in cameras(48, 40) {
            let r = visible_fragments(&scene, &cam, &AnalyticOptions::default()).unwrap();
            pairs += r.stats.crossing_pairs;
            assert_eq!(r.stats.warnings.unresolved_crossings, 0, "{}", scene.source);
        }
        assert!(pairs > 0, "{}: no intersection seen", scene.source);
    }
}

#[test]
fn areas_match_the_brute_force() {
    for scene in scenes() {
        for (k, cam) in cameras(48, 40).iter().enumerate() {
            let max = check_against_brute(&scene, cam);
            eprintln!(
                "{} camera {k}: max area difference {max:.2e} px²",
                scene.source
            );
        }
    }
}

#[test]
fn no_sampled_triangle_is_missed() {
    for scene in scenes() {
        for (k, cam) in cameras(40, 32).iter().enumerate() {
            let (max, mean) = check_against_raster(&scene, cam);
            eprintln!(
                "{} camera {k}: max pixel error {max:.4}, mean {mean:.5}",
                scene.source
            );
            assert!(
                max <= 2.0 * PIXEL_TOL && mean <= MEAN_TOL,
                "{} camera {k}: max {max} mean {mean}",
                scene.source
            );
        }
    }
}

#[test]
fn bin_size_changes_neither_the_set_nor_the_areas() {
    for scene in scenes() {
        for (k, cam) in cameras(48, 40).iter().enumerate() {
            let run = |bin_size| {
                visible_fragments(
                    &scene,
                    cam,
                    &AnalyticOptions {
                        bin_size,
                        ..AnalyticOptions::default()
                    },
                )
                .unwrap()
            };
            let reference = run(16);
            let tolerance = area_tolerance(cam);
            let reference_area = reference.visible_area(scene.triangle_count());
            for bin_size in [1, 4, 7, 32, 64] {
                let r = run(bin_size);
                assert_eq!(
                    r.visible, reference.visible,
                    "{} camera {k}: bin size {bin_size} changes the set",
                    scene.source
                );
                for (id, (a, b)) in r
                    .visible_area(scene.triangle_count())
                    .iter()
                    .zip(&reference_area)
                    .enumerate()
                {
                    assert!(
                        (a - b).abs() <= tolerance,
                        "{} camera {k}: bin size {bin_size}, triangle {id}: {a} vs {b} px²",
                        scene.source
                    );
                }
            }
        }
    }
}
