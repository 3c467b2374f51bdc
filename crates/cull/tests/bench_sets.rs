//! The bench's occluder sets (`sightline_cull::bench_sets`) are what they claim: right
//! triangles whose legs project to the asked length along the screen axes, inside the screen.

use sightline_cull::bench_sets::{self, LEGS_PX};

#[test]
fn legs_have_the_asked_length_and_stay_on_screen() {
    let cam = bench_sets::camera();
    let (w, h) = (cam.width as f32, cam.height as f32);
    for leg in LEGS_PX {
        let tris = bench_sets::right_triangles(&cam, 1000, leg, 3);
        assert_eq!(tris.len(), 3000);
        for t in tris.chunks_exact(3) {
            let s: Vec<(f32, f32)> = t
                .iter()
                .map(|&p| cam.view_to_screen(cam.to_view(p)))
                .collect();
            for &(x, y) in &s {
                assert!((0.0..=w).contains(&x) && (0.0..=h).contains(&y), "{x},{y}");
            }
            let along_x = ((s[1].0 - s[0].0).powi(2) + (s[1].1 - s[0].1).powi(2)).sqrt();
            let along_y = ((s[2].0 - s[0].0).powi(2) + (s[2].1 - s[0].1).powi(2)).sqrt();
            assert!((along_x - leg).abs() <= 0.01 * leg, "leg {leg}: {along_x}");
            assert!((along_y - leg).abs() <= 0.01 * leg, "leg {leg}: {along_y}");
            // A right angle at the first corner: the legs run along x and y.
            assert!((s[1].1 - s[0].1).abs() <= 0.01 * leg);
            assert!((s[2].0 - s[0].0).abs() <= 0.01 * leg);
        }
    }
}

#[test]
fn sets_are_deterministic_and_seeds_differ() {
    let cam = bench_sets::camera();
    let a = bench_sets::right_triangles(&cam, 10, 25.0, 1);
    assert_eq!(a, bench_sets::right_triangles(&cam, 10, 25.0, 1));
    assert_ne!(a, bench_sets::right_triangles(&cam, 10, 25.0, 2));
    let (set, set_cam) = bench_sets::occluder_set(25.0);
    assert_eq!(set.len(), 3 * bench_sets::TRIANGLES);
    assert_eq!(set_cam, cam);
    assert_eq!(&set[..30], &a[..]);
}

#[test]
fn frame_occluders_records_one_frame_of_the_grid_method() {
    let scene = sightline_cull::scenes::the_grid(1, 2);
    let config = sightline_cull::SimConfig {
        width: 160,
        height: 96,
        ..Default::default()
    };
    let camera_of = |f: u32| scene.path.camera(f as f32 / config.fps, 160, 96, 60.0);
    let tris = bench_sets::frame_occluders(&scene, &camera_of, &config, 3).unwrap();
    assert!(!tris.is_empty());
    assert_eq!(tris.len() % 3, 0);
    // Deterministic, and another frame draws another set (the camera moves).
    assert_eq!(
        tris,
        bench_sets::frame_occluders(&scene, &camera_of, &config, 3).unwrap()
    );
    let later = bench_sets::frame_occluders(&scene, &camera_of, &config, 40).unwrap();
    assert_ne!(tris, later);
    // No camera for the frame: nothing drawn.
    let none = |_: u32| None;
    assert!(bench_sets::frame_occluders(&scene, &none, &config, 3)
        .unwrap()
        .is_empty());
}
