//! The headless driver writes the frames and their numbers.

use sightline_view::{orbit, run_headless, HeadlessOptions, Method, Viewer, ViewerOptions};

use super::{outside_camera, shared_device, small_scene};

#[test]
fn headless_frames_are_written_non_blank_and_of_the_right_size() {
    let (device, queue, info) = shared_device();
    let scene = small_scene("procedural:city?size=3000");
    let start = outside_camera(&scene, 96, 64);
    let look = scene.bounds().center();
    let cameras: Vec<_> = orbit(start.eye, look, glam::Vec3::Z, 3)
        .into_iter()
        .map(|(eye, look)| {
            sightline_core::Camera::look_at(eye, look, glam::Vec3::Z, 60.0, 96, 64, start.near)
                .unwrap()
        })
        .collect();
    let mut viewer = Viewer::new(scene, None, ViewerOptions::default()).unwrap();
    viewer.set_method(Method::Occlusion);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    let report = run_headless(
        device,
        queue,
        &info.name,
        &mut viewer,
        &cameras,
        &out,
        &HeadlessOptions::default(),
    )
    .unwrap();
    assert_eq!(report.frames.len(), 3);
    for (i, path) in report.pngs.iter().enumerate() {
        assert_eq!(path, &out.join(format!("frame_{i:04}.png")));
        let img = image::open(path).unwrap().to_rgba8();
        assert_eq!(img.dimensions(), (96, 64));
        // Not blank: many distinct colours (shaded faces of several objects and background).
        let mut colours: Vec<[u8; 4]> = img.pixels().map(|p| p.0).collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(
            colours.len() > 20,
            "frame {i}: only {} colours",
            colours.len()
        );
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("frames.json")).unwrap()).unwrap();
    let frames = json["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for f in frames {
        assert_eq!(f["method"], "occlusion");
        let drawn = f["triangles_drawn"].as_u64().unwrap();
        assert!(drawn > 0 && drawn <= f["triangles_total"].as_u64().unwrap());
        assert!(f["popping_pixels"].is_u64());
    }
    // Orbiting frames differ.
    let a = std::fs::read(&report.pngs[0]).unwrap();
    let b = std::fs::read(&report.pngs[1]).unwrap();
    assert_ne!(a, b);
}
