//! SVG output of the visible polygons, one colour per triangle.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 6 (the visibility output allows "direct rendering to vector graphics").

use std::io::{self, Write};

use super::types::AnalyticResult;

/// A stable, well-spread colour for a triangle id (a 32-bit integer hash).
fn colour(id: u32) -> [u8; 3] {
    let mut h = id.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    h ^= h >> 15;
    h = h.wrapping_mul(0xC2B2_AE35);
    h ^= h >> 13;
    let b = h.to_le_bytes();
    // Keep colours away from black so that they stand out from the background.
    [
        64 + b[0] / 2 + b[3] / 4,
        64 + b[1] / 2,
        64 + b[2] / 2 + b[3] / 4,
    ]
}

/// Writes the visible polygons of `result` as an SVG image of the camera's size (screen pixels,
/// y down), each filled with its triangle's colour, on a black background.
pub fn write_svg(result: &AnalyticResult, mut w: impl Write) -> io::Result<()> {
    let (width, height) = (result.width(), result.height());
    writeln!(
        w,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}">"#
    )?;
    writeln!(
        w,
        r#"<rect width="{width}" height="{height}" fill="black"/>"#
    )?;
    for p in &result.polygons {
        let [r, g, b] = colour(p.triangle);
        write!(w, r##"<path fill="#{r:02x}{g:02x}{b:02x}" d=""##)?;
        for (k, q) in p.points.iter().enumerate() {
            let cmd = if k == 0 { 'M' } else { 'L' };
            write!(w, "{cmd}{:.4} {:.4}", q.x, q.y)?;
        }
        writeln!(w, r#"Z"><title>{}</title></path>"#, p.triangle)?;
    }
    writeln!(w, "</svg>")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::driver::visible_fragments;
    use crate::analytic::types::AnalyticOptions;
    use glam::Vec3;
    use sightline_core::{Camera, Scene};

    #[test]
    fn empty_result_is_valid_svg() {
        let cam =
            Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 8, 8, 0.1).expect("camera");
        let r =
            visible_fragments(&Scene::default(), &cam, &AnalyticOptions::default()).expect("valid");
        let mut out = Vec::new();
        write_svg(&r, &mut out).expect("write");
        let text = String::from_utf8(out).expect("utf8");
        assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    }
}
