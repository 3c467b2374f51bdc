//! The GPU's triangle-id image with no culling against the reference rasterizer's.
//!
//! Tolerance: at least 99% of the pixels must hold the same triangle (or both background).
//! The two rasterize with different rules where it does not matter for visibility: the GPU
//! (lavapipe: 8 sub-pixel bits, its own edge evaluation, f32 depth interpolated in screen
//! space) and the reference (1/256 px snapping, top-left rule, depth from the plane in f64)
//! disagree on pixels whose centre lies within a sub-pixel of a triangle edge, and where two
//! triangles' depths tie to f32 precision (shared edges seen at grazing angles, coplanar
//! faces). Both are thin lines of pixels: well under 1% of the image on these scenes.

use sightline_core::raster;
use sightline_view::{IdImage, Method, Offscreen, Viewer, ViewerOptions};

use super::{outside_camera, shared_device, small_scene, street_camera};

fn agreement(spec: &str, street: bool) -> f64 {
    let (device, queue, _) = shared_device();
    let scene = small_scene(spec);
    let (w, h) = (160, 120);
    let camera = if street {
        street_camera(&scene, w, h)
    } else {
        outside_camera(&scene, w, h)
    };
    let reference = raster::render(&scene, &camera);
    let mut viewer = Viewer::new(scene, None, ViewerOptions::default()).unwrap();
    viewer.set_method(Method::None);
    let mut off = Offscreen::new(device, queue, &viewer, w, h).unwrap();
    off.frame(&mut viewer, &camera).unwrap();
    let gpu = off.renderer.read_ids(IdImage::Full).unwrap();
    assert_eq!(gpu.len(), reference.ids.len());
    let covered = reference
        .ids
        .iter()
        .filter(|&&id| id != sightline_core::Hit::NONE)
        .count();
    assert!(
        covered > (w * h / 4) as usize,
        "the view shows too little: {covered} px"
    );
    let same = gpu
        .iter()
        .zip(&reference.ids)
        .filter(|(a, b)| a == b)
        .count();
    same as f64 / gpu.len() as f64
}

#[test]
fn no_culling_ids_match_the_reference_rasterizer_on_the_city() {
    let a = agreement("procedural:city?size=3000", false);
    eprintln!("city, outside view: {:.4}% of pixels agree", a * 100.0);
    assert!(a >= 0.99, "only {:.3}% of pixels agree", a * 100.0);
}

#[test]
fn no_culling_ids_match_the_reference_rasterizer_at_street_level() {
    let a = agreement("procedural:city?size=3000", true);
    eprintln!("city, street view: {:.4}% of pixels agree", a * 100.0);
    assert!(a >= 0.99, "only {:.3}% of pixels agree", a * 100.0);
}

#[test]
fn no_culling_ids_match_the_reference_rasterizer_on_the_bunny() {
    // A scanned mesh: small triangles, so a large share of pixels lie near an edge.
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/bunny.obj");
    let a = agreement(bunny, false);
    eprintln!("bunny: {:.4}% of pixels agree", a * 100.0);
    assert!(a >= 0.99, "only {:.3}% of pixels agree", a * 100.0);
}

#[test]
fn empty_scene_renders_background_without_popping() {
    let (device, queue, _) = shared_device();
    let scene = sightline_core::Scene::default();
    let camera = sightline_core::Camera::look_at(
        glam::Vec3::ZERO,
        glam::Vec3::X,
        glam::Vec3::Z,
        60.0,
        32,
        24,
        0.1,
    )
    .unwrap();
    let mut viewer = Viewer::new(scene, None, ViewerOptions::default()).unwrap();
    let mut off = Offscreen::new(device, queue, &viewer, 32, 24).unwrap();
    for method in [Method::None, Method::Occlusion, Method::Exact] {
        viewer.set_method(method);
        let r = off.frame(&mut viewer, &camera).unwrap();
        assert_eq!((r.triangles_drawn, r.popping_pixels), (0, 0));
        let ids = off.renderer.read_ids(IdImage::Full).unwrap();
        assert!(ids.iter().all(|&id| id == sightline_core::Hit::NONE));
    }
}
