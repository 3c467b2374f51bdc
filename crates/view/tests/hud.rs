//! The HUD in headless frames: drawn only when asked, only in its top-left panel, with text.

use sightline_view::{
    hud_height, run_headless, HeadlessOptions, Method, Offscreen, Viewer, ViewerOptions, HUD_TEXT,
};

use super::{outside_camera, shared_device, small_scene};

const W: u32 = 192;
const H: u32 = 128;

/// Pixels of exactly the HUD's text colour in rows `rows` of `img`.
fn text_pixels(img: &image::RgbaImage, rows: std::ops::Range<u32>) -> usize {
    img.enumerate_pixels()
        .filter(|(_, y, p)| rows.contains(y) && p.0 == HUD_TEXT)
        .count()
}

#[test]
fn hud_changes_only_its_panel_and_the_plain_frame_is_the_render() {
    let (device, queue, info) = shared_device();
    let scene = small_scene("procedural:city?size=3000");
    let camera = outside_camera(&scene, W, H);
    let viewer = || {
        let mut v = Viewer::new(scene.clone(), None, ViewerOptions::default()).unwrap();
        v.set_method(Method::Occlusion);
        v
    };
    // The renderer's own output, through the path that existed before the HUD.
    let mut v = viewer();
    let mut off = Offscreen::new(device, queue, &v, W, H).unwrap();
    off.frame(&mut v, &camera).unwrap();
    let rendered = off.read_rgba().unwrap();

    let dir = tempfile::tempdir().unwrap();
    let frame = |hud: bool| {
        let out = dir.path().join(if hud { "hud" } else { "plain" });
        let report = run_headless(
            device,
            queue,
            &info.name,
            &mut viewer(),
            &[camera],
            &out,
            &HeadlessOptions {
                hud,
                ..Default::default()
            },
        )
        .unwrap();
        image::open(&report.pngs[0]).unwrap().to_rgba8()
    };
    let plain = frame(false);
    let hud = frame(true);
    assert!(
        plain == rendered,
        "without --hud the frame is not the plain render"
    );

    // Headless HUD: method, triangles, objects, popping, frame number, at scale 1.
    let band = hud_height(5, 1);
    let mut changed = 0;
    for (x, y, p) in hud.enumerate_pixels() {
        if p != plain.get_pixel(x, y) {
            assert!(
                y < band,
                "pixel ({x}, {y}) changed below the HUD's {band} rows"
            );
            changed += 1;
        }
    }
    // Five lines of text are hundreds of glyph pixels (a glyph sets about 15-25 of its 64).
    let text = text_pixels(&hud, 0..band);
    assert!(text > 400, "only {text} pixels of the HUD's text colour");
    assert!(changed >= text, "{changed} changed, {text} text");
    assert!(
        text_pixels(&plain, 0..H) < 10,
        "the plain frame has the HUD's colour"
    );
    assert_eq!(text_pixels(&hud, band..H), text_pixels(&plain, band..H));
}
