//! Clipping a convex polygon by a plane (Sutherland-Hodgman), shared by the column pieces
//! (`columns.rs`) and the triangles a depth cube tests (`cube_depth.rs`).

use glam::DVec3;

/// The part of convex `polygon` where `plane(p) >= 0` (`plane` affine).
pub(super) fn clip_by(polygon: &[DVec3], plane: impl Fn(DVec3) -> f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (k, &p) in polygon.iter().enumerate() {
        let q = polygon[(k + 1) % polygon.len()];
        let (dp, dq) = (plane(p), plane(q));
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp >= 0.0) != (dq >= 0.0) {
            out.push(p + (q - p) * (dp / (dp - dq)));
        }
    }
    out
}
