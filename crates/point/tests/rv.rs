//! RV conservativeness: on procedural and real scenes, from several camera angles, every
//! triangle the reference rasterizer shows at 8x supersampling must be in the RV set.
//! Prints the overestimation |RV| / |reference| - 1 per scene (run with `--nocapture`).
#![allow(clippy::unwrap_used)]

use std::path::Path;

use glam::Vec3;
use sightline_core::raster::render;
use sightline_core::scene::{open, LoadOptions};
use sightline_core::{Camera, Scene};
use sightline_point::rv::{conservative_visible, RvOptions, SceneSource};

/// Base image size; the reference renders at 8x this.
const SIZE: u32 = 128;
/// Camera angles per scene (the thesis' 3-degree orbit, reduced: 8 angles 45 degrees apart).
const ANGLES: usize = 8;

fn options() -> RvOptions {
    RvOptions {
        bins: (16, 16),
        threads: 2,
        ..RvOptions::default()
    }
}

/// Where cameras go: orbiting outside the model, or looking around from inside the scene.
enum Placement {
    Orbit,
    Inside { height: f32 },
}

fn cameras(scene: &Scene, placement: &Placement) -> Vec<Camera> {
    let b = scene.bounds();
    let (c, diag) = (b.center(), b.diagonal());
    let up = scene.up.vector();
    // Two horizontal axes orthogonal to up.
    let (e1, e2) = if up == Vec3::Z {
        (Vec3::X, Vec3::Y)
    } else {
        (Vec3::Z, Vec3::X)
    };
    (0..ANGLES)
        .map(|k| {
            let a = (k as f32) * std::f32::consts::TAU / ANGLES as f32 + 0.05;
            let dir = e1 * a.cos() + e2 * a.sin();
            let (eye, target) = match placement {
                Placement::Orbit => {
                    let eye = c + dir * diag * 0.9 + up * diag * 0.25;
                    (eye, c)
                }
                Placement::Inside { height } => {
                    let eye = c + up * (*height - up.dot(c - b.min));
                    (eye, eye + dir * 10.0 - up * 1.5)
                }
            };
            Camera::look_at(eye, target, up, 60.0, SIZE, SIZE, diag * 1e-4).unwrap()
        })
        .collect()
}

/// Runs RV and the 8x reference from every camera; asserts no false negative; returns the
/// mean overestimation.
fn check_scene(name: &str, scene: &Scene, placement: Placement) -> f64 {
    let n = scene.triangle_count();
    let mut over = Vec::new();
    let mut peak = 0;
    for (k, cam) in cameras(scene, &placement).iter().enumerate() {
        let big = Camera::looking(
            cam.eye,
            cam.forward,
            cam.up,
            cam.fov_y_deg,
            cam.width * 8,
            cam.height * 8,
            cam.near,
        )
        .unwrap();
        let reference = render(scene, &big).visible_set(n);
        let rv = conservative_visible(&mut SceneSource::new(scene), cam, &options()).unwrap();
        let missing: Vec<usize> = reference.difference(&rv.visible).collect();
        assert!(
            missing.is_empty(),
            "{name} angle {k}: {} visible triangles missing from RV, e.g. {:?}",
            missing.len(),
            &missing[..missing.len().min(10)]
        );
        let (r, v) = (reference.count_ones(..), rv.visible.count_ones(..));
        if r > 0 {
            over.push(v as f64 / r as f64 - 1.0);
        }
        peak = peak.max(rv.peak_memory_bytes);
    }
    let mean = over.iter().sum::<f64>() / over.len().max(1) as f64;
    let max = over.iter().copied().fold(0.0, f64::max);
    println!(
        "rv {name}: {n} triangles, overestimation mean {:.1}% max {:.1}%, peak {:.1} MiB",
        mean * 100.0,
        max * 100.0,
        peak as f64 / (1 << 20) as f64
    );
    mean
}

fn procedural(spec: &str) -> Scene {
    open(spec, &LoadOptions::default()).unwrap()
}

fn shared(path: &str) -> Option<Scene> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes")
        .join(path);
    if !p.exists() {
        eprintln!("skipping {path}: not found");
        return None;
    }
    Some(open(p.to_str().unwrap(), &LoadOptions::default()).unwrap())
}

#[test]
fn rv_conservative_boxes() {
    check_scene(
        "boxes",
        &procedural("procedural:boxes?size=3000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_city() {
    check_scene(
        "city",
        &procedural("procedural:city?size=8000"),
        Placement::Inside { height: 40.0 },
    );
}

#[test]
fn rv_conservative_rooms() {
    check_scene(
        "rooms",
        &procedural("procedural:rooms?size=4000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_spheres() {
    check_scene(
        "spheres",
        &procedural("procedural:spheres?size=6000"),
        Placement::Orbit,
    );
}

#[test]
fn rv_conservative_bunny() {
    if let Some(s) = shared("models/bunny.obj") {
        check_scene("bunny", &s, Placement::Orbit);
    }
}

#[test]
fn rv_conservative_teapot() {
    if let Some(s) = shared("models/teapot.obj") {
        check_scene("teapot", &s, Placement::Orbit);
    }
}

#[test]
fn rv_conservative_q3dm6ish() {
    if let Some(s) = shared("q3/q3dm6ish.bsp") {
        check_scene("q3dm6ish", &s, Placement::Inside { height: 120.0 });
    }
}

/// A street-level view down a long street of a city streamed block by block (far blocks can
/// arrive before the near walls that hide them): still no false negative against the 8x
/// reference, and the set stays within a small multiple of it. Before occluder eviction and
/// the re-test pass, full bins near the vanishing point kept the far occluders that arrived
/// first and RV reported about 270 times the reference on this kind of view.
#[test]
fn rv_streamed_city_street_view_is_conservative_and_tight() {
    use sightline_point::rv::StreamingCity;
    let size = 150_000;
    let scene = procedural(&format!("procedural:city?seed=1&size={size}"));
    // The blocks per side are even here, so a street crossing sits at (-6, -6).
    let eye = Vec3::new(-6.0, -6.0, 2.0);
    let cam = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 256, 256, 0.1).unwrap();
    let big = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 2048, 2048, 0.1).unwrap();
    let reference = render(&scene, &big).visible_set(scene.triangle_count());
    let rv = conservative_visible(&mut StreamingCity::new(1, size), &cam, &options()).unwrap();
    assert!(rv.stats.retested);
    let missing: Vec<usize> = reference.difference(&rv.visible).collect();
    assert!(
        missing.is_empty(),
        "{} visible triangles missing",
        missing.len()
    );
    let (r, v) = (reference.count_ones(..), rv.visible.count_ones(..));
    println!(
        "rv streamed street: {} triangles, reference {r}, RV {v} (first pass {})",
        scene.triangle_count(),
        rv.stats.first_pass_visible
    );
    assert!(r > 50, "the view sees too little to judge ({r})");
    assert!(v <= 8 * r, "RV {v} against reference {r}");
}
