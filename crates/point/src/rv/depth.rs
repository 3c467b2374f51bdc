//! Depth relation of an occludee polygon and an occluder triangle: the quick halfspace tests,
//! and the plane split when they are ambiguous.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 4.5 (depth relation, eqs. 4.10-4.12) and chapter 5 (triangle test: split the
//! occludee at the occluder's plane and test the front part for overlap, figure 5.13).
//!
//! Planes are oriented so the eye (the view-space origin) is on the positive side: `d > 0`.
//! "Behind by a relative margin `e`" means further along the eye ray by a factor of `1 + e`, so
//! the test is scale-free: the ray through `v` meets the plane at `s v` with
//! `s = d / -(n·v)`, and `v` is behind when `s < 1 - e`, i.e. `d + (1 - e) n·v < 0`. `e` is far
//! above f32 depth precision, so the reference rasterizer (f32 depth, ties to the lower id) can
//! never show a triangle this test called behind.

use glam::{DVec2, DVec3};

use super::overlap::convex_overlap;
use super::projection::{clip, Poly, Projection};

/// Relative depth margin (see the module documentation).
pub(crate) const DEPTH_EPS: f64 = 1e-5;

/// The plane of a triangle with the eye on its positive side, or `None` when the triangle is
/// degenerate or seen (almost) edge-on, where no depth order along eye rays is meaningful.
pub(crate) fn eye_plane(a: DVec3, b: DVec3, c: DVec3) -> Option<[f64; 4]> {
    let n = (b - a).cross(c - a);
    let len = n.length();
    if len == 0.0 || !len.is_finite() {
        return None;
    }
    let n = n / len;
    let mut d = -n.dot(a);
    let scale = a.length().max(b.length()).max(c.length());
    // Edge-on: the plane passes within a relative 1e-9 of the eye.
    if d.abs() <= 1e-9 * scale || !d.is_finite() {
        return None;
    }
    let mut n = n;
    if d < 0.0 {
        n = -n;
        d = -d;
    }
    Some([n.x, n.y, n.z, d])
}

/// True when `v` is behind `plane` by the relative margin.
#[inline]
pub(crate) fn behind(plane: &[f64; 4], v: DVec3) -> bool {
    plane[3] + (1.0 - DEPTH_EPS) * (plane[0] * v.x + plane[1] * v.y + plane[2] * v.z) < 0.0
}

/// True when `v` is in front of (nearer than) `plane` by the relative margin.
#[inline]
pub(crate) fn in_front(plane: &[f64; 4], v: DVec3) -> bool {
    plane[3] + (1.0 + DEPTH_EPS) * (plane[0] * v.x + plane[1] * v.y + plane[2] * v.z) > 0.0
}

/// An occluder triangle as the depth test needs it.
pub(crate) struct OccluderView<'a> {
    /// View-space corners.
    pub(crate) corners: &'a [DVec3; 3],
    /// Screen corners.
    pub(crate) screen: &'a [DVec2; 3],
    /// Eye-positive plane.
    pub(crate) plane: &'a [f64; 4],
}

/// True when every point of occludee `p` (view space, in front of the near plane) that projects
/// within `margin` px of triangle `t` lies behind `t` by the relative margin. `p_plane` is the
/// occludee's own eye-positive plane when it has one.
pub(crate) fn occludee_behind(
    p: &[DVec3],
    p_plane: Option<&[f64; 4]>,
    t: &OccluderView<'_>,
    proj: &Projection,
    margin: f64,
) -> bool {
    // Eq. 4.11, first half: all of p behind t's plane.
    if p.iter().all(|&v| behind(t.plane, v)) {
        return true;
    }
    // Eq. 4.11, second half: all of t in front of p's plane.
    if let Some(pp) = p_plane {
        if t.corners.iter().all(|&u| in_front(pp, u)) {
            return true;
        }
    }
    // Ambiguous (figure 5.13): keep the part of p that is not safely behind t's plane and see
    // whether it projects onto t at all.
    let s = 1.0 - DEPTH_EPS;
    let not_behind = [t.plane[0] * s, t.plane[1] * s, t.plane[2] * s, t.plane[3]];
    let front = clip(&Poly::from_slice(p), &not_behind);
    if front.is_empty() {
        return true;
    }
    let mut pts = [DVec2::ZERO; super::projection::MAX_POLY];
    for (i, v) in front.as_slice().iter().enumerate() {
        if v.z <= 0.0 {
            // Cannot happen for occludees clipped to the near plane; be conservative.
            return false;
        }
        pts[i] = proj.screen_of(*v);
    }
    !convex_overlap(&pts[..front.len], t.screen, margin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::Camera;

    fn proj() -> Projection {
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 90.0, 64, 64, 0.1).expect("cam");
        Projection::new(&cam)
    }

    fn tri_at(z0: f64, z1: f64, z2: f64, half: f64) -> [DVec3; 3] {
        [
            DVec3::new(-half, -half, z0),
            DVec3::new(half, -half, z1),
            DVec3::new(0.0, half, z2),
        ]
    }

    fn check(p: [DVec3; 3], t: [DVec3; 3]) -> bool {
        let pr = proj();
        let screen = t.map(|v| pr.screen_of(v));
        let plane = eye_plane(t[0], t[1], t[2]).expect("plane");
        let pp = eye_plane(p[0], p[1], p[2]);
        occludee_behind(
            &p,
            pp.as_ref(),
            &OccluderView {
                corners: &t,
                screen: &screen,
                plane: &plane,
            },
            &pr,
            1e-3,
        )
    }

    #[test]
    fn edge_on_triangle_has_no_plane() {
        let a = DVec3::new(0.0, 0.0, 1.0);
        assert!(eye_plane(a, a * 2.0, DVec3::new(0.0, 1.0, 1.0) * 3.0).is_none());
    }

    #[test]
    fn plane_faces_eye() {
        let t = tri_at(5.0, 5.0, 5.0, 1.0);
        let p = eye_plane(t[0], t[1], t[2]).expect("plane");
        assert!(p[3] > 0.0);
    }

    #[test]
    fn parallel_behind_is_behind() {
        assert!(check(
            tri_at(6.0, 6.0, 6.0, 1.0),
            tri_at(5.0, 5.0, 5.0, 1.0)
        ));
    }

    #[test]
    fn parallel_in_front_is_not_behind() {
        assert!(!check(
            tri_at(4.0, 4.0, 4.0, 1.0),
            tri_at(5.0, 5.0, 5.0, 1.0)
        ));
    }

    #[test]
    fn coplanar_is_not_behind() {
        // Depth ties go to the lower id in the rasterizer: never call them occluded.
        assert!(!check(
            tri_at(5.0, 5.0, 5.0, 0.5),
            tri_at(5.0, 5.0, 5.0, 1.0)
        ));
    }

    #[test]
    fn intersecting_is_not_behind() {
        assert!(!check(
            tri_at(4.0, 6.0, 5.0, 1.0),
            tri_at(5.0, 5.0, 5.0, 1.0)
        ));
    }
}
