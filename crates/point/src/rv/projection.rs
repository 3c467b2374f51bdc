//! View-space transform, screen mapping and convex polygon clipping against planes through or
//! near the eye: the geometric basics every other RV step stands on.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, sections 4.1, 4.2 and 4.6 (planes, halfspaces, clipping a convex polygon by a plane).
//!
//! The thesis works in homogeneous clip space; we work in f64 *view space* (eye at the origin,
//! `x` right, `y` up, `z` forward, see `sightline_core::camera`), which is the same projective
//! geometry with `w = z`. A plane is `[a, b, c, d]` with `a x + b y + c z + d >= 0` inside. A bin
//! of the screen is the frustum of four planes through the eye (`d = 0`).

use glam::{DVec3, Vec3};
use sightline_core::camera::ScreenMapping;
use sightline_core::Camera;

/// Most vertices a clipped polygon can have: a triangle gains at most one vertex per clipping
/// plane (near + 4 bin sides + one occluder plane = 9), rounded up.
pub(crate) const MAX_POLY: usize = 12;

/// A small fixed-capacity convex polygon in view space (no heap: it lives on the stack of the
/// visibility stage's inner loop).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Poly {
    pub(crate) verts: [DVec3; MAX_POLY],
    pub(crate) len: usize,
}

impl Poly {
    /// The empty polygon.
    pub(crate) fn new() -> Self {
        Self {
            verts: [DVec3::ZERO; MAX_POLY],
            len: 0,
        }
    }

    /// A polygon with the given corners.
    pub(crate) fn from_slice(v: &[DVec3]) -> Self {
        let mut p = Self::new();
        for &x in v {
            p.push(x);
        }
        p
    }

    fn push(&mut self, v: DVec3) {
        debug_assert!(self.len < MAX_POLY, "clipped polygon overflow");
        if self.len < MAX_POLY {
            self.verts[self.len] = v;
            self.len += 1;
        }
    }

    /// The corners.
    pub(crate) fn as_slice(&self) -> &[DVec3] {
        &self.verts[..self.len]
    }

    /// True when nothing is left.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Signed value of `plane` at `v` (positive inside).
#[inline]
pub(crate) fn plane_value(plane: &[f64; 4], v: DVec3) -> f64 {
    plane[0] * v.x + plane[1] * v.y + plane[2] * v.z + plane[3]
}

/// Keeps the part of `poly` where `plane_value >= 0` (Sutherland–Hodgman, one plane). An edge is
/// always cut by interpolating from its inside end towards its outside end, so two polygons
/// sharing an edge get bit-identical cut points.
pub(crate) fn clip(poly: &Poly, plane: &[f64; 4]) -> Poly {
    let mut out = Poly::new();
    if clip_into(poly, plane, &mut out) {
        out
    } else {
        *poly
    }
}

/// [`clip`] into `out`, without copying polygons: false (and `out` untouched) when `poly` lies
/// wholly inside, so the clipped polygon is `poly` itself; true when it is `out`.
pub(crate) fn clip_into(poly: &Poly, plane: &[f64; 4], out: &mut Poly) -> bool {
    let n = poly.len;
    if n == 0 {
        return false;
    }
    let mut all_inside = true;
    let mut values = [0.0f64; MAX_POLY];
    for (i, v) in poly.as_slice().iter().enumerate() {
        values[i] = plane_value(plane, *v);
        all_inside &= values[i] >= 0.0;
    }
    if all_inside {
        return false;
    }
    out.len = 0;
    for i in 0..n {
        let j = (i + 1) % n;
        let (a, b) = (poly.verts[i], poly.verts[j]);
        let (da, db) = (values[i], values[j]);
        if da >= 0.0 {
            out.push(a);
        }
        // A strict sign change only: an end point exactly on the plane is kept as a vertex
        // and must not be duplicated as a cut point.
        if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
            // Eq. 4.13, always from the inside point.
            let (inside, outside, di, dout) = if da > 0.0 {
                (a, b, da, db)
            } else {
                (b, a, db, da)
            };
            let t = di / (di - dout);
            out.push(inside + (outside - inside) * t);
        }
    }
    true
}

/// The camera mapping of `camera.rs` in f64: `sightline_core::camera::ScreenMapping`, the one
/// the rasterizer uses, plus this algorithm's clipping helpers.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Projection(ScreenMapping);

impl std::ops::Deref for Projection {
    type Target = ScreenMapping;

    fn deref(&self) -> &ScreenMapping {
        &self.0
    }
}

impl Projection {
    /// The mapping of `camera`.
    pub(crate) fn new(camera: &Camera) -> Self {
        Self(ScreenMapping::new(camera))
    }

    /// World point to view coordinates `(right, up, forward)`.
    #[inline]
    pub(crate) fn view_of(&self, p: Vec3) -> DVec3 {
        self.0.view_of(p.as_dvec3())
    }

    /// The near plane moved towards the eye by a relative `1e-6`: the rasterizer keeps
    /// `z >= near`, and keeping slightly more is conservative.
    pub(crate) fn near_plane(&self) -> [f64; 4] {
        [0.0, 0.0, 1.0, -self.near * (1.0 - 1e-6)]
    }

    /// The four planes through the eye bounding the screen rectangle `[x0, x1] × [y0, y1]`
    /// (pixels, `y` down): `sx >= x0`, `sx <= x1`, `sy >= y0`, `sy <= y1`.
    pub(crate) fn rect_planes(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> [[f64; 4]; 4] {
        // sx >= X  <=>  vx - vz * tx * (2X/W - 1) >= 0 for vz > 0; likewise for y (image y down).
        let kx = |x: f64| self.tan_half_x * (2.0 * x / self.width - 1.0);
        let ky = |y: f64| self.tan_half_y * (1.0 - 2.0 * y / self.height);
        [
            [1.0, 0.0, -kx(x0), 0.0],
            [-1.0, 0.0, kx(x1), 0.0],
            [0.0, -1.0, ky(y0), 0.0],
            [0.0, 1.0, -ky(y1), 0.0],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 100, 50, 0.1).expect("camera")
    }

    #[test]
    fn clip_empty_polygon_is_empty() {
        assert!(clip(&Poly::new(), &[1.0, 0.0, 0.0, 0.0]).is_empty());
    }

    #[test]
    fn clip_triangle_by_plane_keeps_inside_half() {
        let t = Poly::from_slice(&[
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ]);
        let c = clip(&t, &[1.0, 0.0, 0.0, 0.0]);
        assert_eq!(c.len, 3);
        assert!(c.as_slice().iter().all(|v| v.x >= 0.0));
    }

    #[test]
    fn clip_into_leaves_output_alone_when_all_inside() {
        let t = Poly::from_slice(&[
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(1.0, 1.0, 1.0),
        ]);
        let mut out = Poly::new();
        assert!(!clip_into(&t, &[1.0, 0.0, 0.0, 0.0], &mut out));
        assert!(out.is_empty());
        // Cut by x >= 1.5: the same polygon `clip` gives.
        assert!(clip_into(&t, &[1.0, 0.0, 0.0, -1.5], &mut out));
        let c = clip(&t, &[1.0, 0.0, 0.0, -1.5]);
        assert_eq!(out.as_slice(), c.as_slice());
        assert!(out.len == 3 && out.as_slice().iter().all(|v| v.x >= 1.5));
    }

    #[test]
    fn rect_planes_match_screen_mapping() {
        let cam = camera();
        let p = Projection::new(&cam);
        let planes = p.rect_planes(10.0, 20.0, 5.0, 15.0);
        let inside = p.view_of(cam.screen_ray(15.0, 10.0).at(3.0));
        let outside = p.view_of(cam.screen_ray(25.0, 10.0).at(3.0));
        assert!(planes.iter().all(|pl| plane_value(pl, inside) > 0.0));
        assert!(planes.iter().any(|pl| plane_value(pl, outside) < 0.0));
        let s = p.screen_of(inside);
        assert!((s.x - 15.0).abs() < 1e-3 && (s.y - 10.0).abs() < 1e-3);
    }
}
