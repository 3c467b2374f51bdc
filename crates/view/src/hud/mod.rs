//! The HUD (heads-up display): a few lines of text in the top-left corner of the frame, with
//! the numbers that explain what the viewer shows (method, cell, drawn and total triangles
//! and objects, popping pixels; the window adds fps and its help lines). The window title
//! carries the same numbers, but a title is not in a screenshot or a recorded frame.
//!
//! The panel is drawn on the CPU ([`text`]: 8x8 bitmap glyphs into an RGBA image) and
//! blended over the finished frame by the renderer's overlay pass: a texture of the panel's
//! size uploaded each frame, which needs nothing from the GPU beyond what the frame already
//! uses (and so behaves the same on lavapipe as on hardware).

pub(crate) mod text;

use text::{text_width, Canvas, GLYPH_SIZE};

use crate::viewer::{cell_label, FrameRecord, Method, Viewer};

/// Colour of the HUD's text: opaque, so its pixels keep exactly this colour in a frame (the
/// tests find the text by it), and a warm yellow that few shaded faces have.
pub const HUD_TEXT: [u8; 4] = [255, 236, 112, 255];
/// The panel's background: black at 65% opacity, which keeps the text readable over bright
/// faces while the scene still shows through.
const HUD_BACKGROUND: [u8; 4] = [0, 0, 0, 166];
/// Margin around the text and gap between lines, in pixels at scale 1.
const PAD: u32 = 3;
const LINE_GAP: u32 = 2;

/// The scale of HUD text on an image `height` pixels tall: 1 up to 1079 rows, then one more
/// per 540 rows, so the 8-pixel glyphs stay about 1.5% of the height or more.
pub(crate) fn hud_scale(height: u32) -> u32 {
    (height / 540).max(1)
}

/// Height in pixels of a panel of `lines` lines at `scale` (before clipping to the image).
pub fn hud_height(lines: usize, scale: u32) -> u32 {
    let scale = scale.max(1);
    (2 * PAD + lines as u32 * (GLYPH_SIZE + LINE_GAP) - LINE_GAP.min(lines as u32 * LINE_GAP))
        * scale
}

/// The lines describing frame `r` of `viewer`: the method (with what the exact method's
/// reduced resolution means), the cell when a `.pvs` is loaded, triangles and objects drawn
/// of the total, and the frame's popping with its maximum and mean since the method changed.
pub(crate) fn frame_lines(viewer: &Viewer, r: &FrameRecord) -> Vec<String> {
    let mut method = format!("[{}] {}", r.method.key(), r.method.name());
    let divisor = viewer.options().exact_divisor.max(1);
    if r.method == Method::Exact && divisor > 1 {
        // Named so that nobody takes the method's popping for a resolution artefact: the
        // analytic set hardly depends on the resolution (the same set and popping at 1/4 and
        // full resolution, tests/popping.rs); what popping remains is where the GPU's and the
        // analytic method's edge and tie rules differ.
        method.push_str(&format!(" (set at 1/{divisor} res)"));
    }
    if viewer.shading.xray {
        method.push_str(" x-ray");
    }
    if viewer.pvs().is_some() {
        match r.cell {
            Some(c) => method.push_str(&format!("  {}", cell_label(c, r.cell_picked))),
            None if r.method == Method::Pvs => method.push_str("  no cell: all drawn"),
            None => method.push_str("  no cell"),
        }
    }
    let popping = viewer.popping();
    let mut lines = vec![
        method,
        format!("tris {}/{}", r.triangles_drawn, r.triangles_total),
        format!("objects {}/{}", r.objects_drawn, r.objects_total),
        format!(
            "popping {} px (max {}, mean {:.1})",
            r.popping_pixels,
            popping.max,
            popping.mean()
        ),
    ];
    if let Some(modes) = mode_line(r) {
        lines.push(modes);
    }
    lines
}

/// The line naming the frozen culling and the overview, when either is on; it says that the
/// frame's popping is not counted then (see `viewer.rs`).
fn mode_line(r: &FrameRecord) -> Option<String> {
    let mut modes = Vec::new();
    if let Some(f) = r.frozen_at {
        modes.push(format!("frozen at frame {f}"));
    }
    if r.overview {
        modes.push("overview".to_string());
    }
    if modes.is_empty() {
        return None;
    }
    let counted = if r.popping_counted {
        ""
    } else {
        " (popping not counted)"
    };
    Some(format!("{}{counted}", modes.join(", ")))
}

/// The panel of `lines` at `scale`: text on the translucent background, as wide as the
/// longest line, clipped to `max_width x max_height` (the image it goes over).
pub(crate) fn panel(lines: &[String], scale: u32, max_width: u32, max_height: u32) -> Canvas {
    let scale = scale.max(1);
    let widest = lines
        .iter()
        .map(|l| text_width(l, scale))
        .max()
        .unwrap_or(0);
    let width = (widest + 2 * PAD * scale).min(max_width).max(1);
    let height = hud_height(lines.len(), scale).min(max_height).max(1);
    let mut canvas = Canvas::new(width, height, HUD_BACKGROUND);
    for (i, line) in lines.iter().enumerate() {
        let y = (PAD + i as u32 * (GLYPH_SIZE + LINE_GAP)) * scale;
        canvas.draw_text(PAD * scale, y, line, HUD_TEXT, scale);
    }
    canvas
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panel_fits_its_longest_line() {
        let lines = vec!["ab".to_string(), "abcd".to_string()];
        let p = panel(&lines, 1, 1000, 1000);
        assert_eq!((p.width, p.height), (4 * 8 + 6, hud_height(2, 1)));
        assert_eq!(hud_height(2, 1), 6 + 8 + 2 + 8);
        // The corner is background, and some pixel of the first glyph is text.
        assert_eq!(p.pixel(0, 0), Some(HUD_BACKGROUND));
        assert!((0..8).any(|x| (0..8).any(|y| p.pixel(3 + x, 3 + y) == Some(HUD_TEXT))));
    }

    #[test]
    fn panel_is_clipped_to_the_image() {
        let lines = vec!["a long line of text".to_string(); 5];
        let p = panel(&lines, 2, 40, 30);
        assert_eq!((p.width, p.height), (40, 30));
    }

    #[test]
    fn panel_without_lines_is_only_margin() {
        let p = panel(&[], 1, 100, 100);
        assert_eq!((p.width, p.height), (6, 6));
        assert_eq!(hud_height(0, 3), 18);
    }

    /// A record of `method` drawing 5 of 10 triangles, in no cell.
    fn record(method: Method) -> FrameRecord {
        FrameRecord {
            frame: 3,
            method,
            eye: [0.0; 3],
            forward: [1.0, 0.0, 0.0],
            cell: None,
            cell_picked: false,
            frozen_at: None,
            overview: false,
            popping_counted: true,
            triangles_drawn: 5,
            triangles_total: 10,
            objects_drawn: 2,
            objects_total: 4,
            popping_pixels: 7,
            covered_pixels: 100,
            cull_ms: 1.0,
        }
    }

    fn viewer(exact_divisor: u32) -> Viewer {
        let scene = sightline_core::scene::open("procedural:city?size=200", &Default::default())
            .expect("the procedural city opens");
        let options = crate::viewer::ViewerOptions {
            exact_divisor,
            ..Default::default()
        };
        Viewer::new(scene, None, options).expect("no .pvs to check")
    }

    #[test]
    fn frame_lines_name_the_numbers() {
        let lines = frame_lines(&viewer(4), &record(Method::Occlusion));
        assert_eq!(lines[0], "[3] occlusion");
        assert_eq!(lines[1], "tris 5/10");
        assert_eq!(lines[2], "objects 2/4");
        // The viewer has rendered no frame: its running maximum and mean are 0.
        assert_eq!(lines[3], "popping 7 px (max 0, mean 0.0)");
    }

    #[test]
    fn exact_method_names_its_resolution_unless_full() {
        let quarter = frame_lines(&viewer(4), &record(Method::Exact));
        assert_eq!(quarter[0], "[4] exact (set at 1/4 res)");
        let full = frame_lines(&viewer(1), &record(Method::Exact));
        assert_eq!(full[0], "[4] exact");
    }

    #[test]
    fn frozen_and_overview_frames_say_so_and_that_popping_is_not_counted() {
        let plain = frame_lines(&viewer(4), &record(Method::Pvs));
        assert_eq!(plain.len(), 4);
        let mut r = record(Method::Pvs);
        r.frozen_at = Some(12);
        r.popping_counted = false;
        let lines = frame_lines(&viewer(4), &r);
        assert_eq!(lines[4], "frozen at frame 12 (popping not counted)");
        r.overview = true;
        let lines = frame_lines(&viewer(4), &r);
        assert_eq!(
            lines[4],
            "frozen at frame 12, overview (popping not counted)"
        );
    }

    #[test]
    fn cell_label_names_where_the_cell_came_from() {
        assert_eq!(cell_label(12, true), "cell 12 (picked)");
        assert_eq!(cell_label(12, false), "cell 12 (eye)");
    }

    #[test]
    fn text_scale_grows_with_the_image() {
        assert_eq!(hud_scale(1), 1);
        assert_eq!(hud_scale(1079), 1);
        assert_eq!(hud_scale(1080), 2);
        assert_eq!(hud_scale(2160), 4);
    }
}
