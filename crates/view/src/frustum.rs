//! The frustum of a pinhole camera as geometry: its corners on the near plane and on a far
//! plane, and the twelve edges drawn while culling is frozen (key F). The camera's own far
//! plane is at infinity (the renderer's reversed-Z), so the drawn far plane is clamped to the
//! scene's bounds: the farthest bounds corner along the view direction, where the frustum has
//! covered everything it can see.

use glam::Vec3;
use sightline_core::{Aabb, Camera};

/// The corners of `camera`'s frustum between its near plane and the plane at distance `far`
/// along the view direction: near plane first, then far plane, each in the order
/// bottom-left, bottom-right, top-right, top-left (as seen through the camera).
pub fn frustum_corners(camera: &Camera, far: f32) -> [Vec3; 8] {
    let (tx, ty) = (camera.tan_half_x(), camera.tan_half_y());
    let corner = |d: f32, sx: f32, sy: f32| {
        camera.eye + camera.forward * d + camera.right * (sx * d * tx) + camera.up * (sy * d * ty)
    };
    let signs = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let mut out = [Vec3::ZERO; 8];
    for (i, (sx, sy)) in signs.into_iter().enumerate() {
        out[i] = corner(camera.near, sx, sy);
        out[4 + i] = corner(far, sx, sy);
    }
    out
}

/// The far plane's distance for drawing `camera`'s frustum over a scene of `bounds`: the
/// largest distance of a bounds corner along the view direction, at least twice the near
/// plane (a scene behind the camera, or an empty one, still gets a visible frustum).
pub fn clamped_far(camera: &Camera, bounds: &Aabb) -> f32 {
    let floor = camera.near * 2.0;
    if bounds.is_empty() {
        return floor;
    }
    bounds
        .corners()
        .into_iter()
        .map(|p| (p - camera.eye).dot(camera.forward))
        .fold(floor, f32::max)
}

/// The twelve edges of the frustum with `corners` (as [`frustum_corners`] orders them): the
/// near rectangle, the far rectangle and the four edges joining them.
pub fn frustum_edges(corners: &[Vec3; 8]) -> [(Vec3, Vec3); 12] {
    std::array::from_fn(|e| {
        let (ring, i) = (e / 4, e % 4);
        match ring {
            0 => (corners[i], corners[(i + 1) % 4]),
            1 => (corners[4 + i], corners[4 + (i + 1) % 4]),
            _ => (corners[i], corners[4 + i]),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera::look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(10.0, 5.0, 2.0),
            Vec3::Z,
            50.0,
            160,
            90,
            0.25,
        )
        .unwrap()
    }

    #[test]
    fn corners_lie_on_the_frustum_planes() {
        let c = camera();
        let corners = frustum_corners(&c, 40.0);
        for (i, p) in corners.iter().enumerate() {
            let v = c.to_view(*p);
            let depth = if i < 4 { c.near } else { 40.0 };
            assert!(
                (v.z - depth).abs() < 1e-3 * depth,
                "corner {i}: depth {}",
                v.z
            );
            // On a side plane left or right, and on one bottom or top.
            assert!(
                (v.x.abs() / v.z - c.tan_half_x()).abs() < 1e-4,
                "corner {i}"
            );
            assert!(
                (v.y.abs() / v.z - c.tan_half_y()).abs() < 1e-4,
                "corner {i}"
            );
            // The image corners, in the documented order.
            let (sx, sy) = c.view_to_screen(v);
            let want = [(0.0, 90.0), (160.0, 90.0), (160.0, 0.0), (0.0, 0.0)][i % 4];
            assert!(
                (sx - want.0).abs() < 0.05 && (sy - want.1).abs() < 0.05,
                "corner {i}"
            );
        }
    }

    #[test]
    fn far_plane_is_clamped_to_the_farthest_bounds_corner() {
        let c = camera();
        let bounds = Aabb::new(Vec3::new(-5.0, -5.0, 0.0), Vec3::new(30.0, 20.0, 8.0));
        let far = clamped_far(&c, &bounds);
        assert!(far.is_finite());
        // The corner (30, 20, z) is the farthest along forward: its distance exactly.
        let expect = (Vec3::new(30.0, 20.0, 0.0) - c.eye)
            .dot(c.forward)
            .max((Vec3::new(30.0, 20.0, 8.0) - c.eye).dot(c.forward));
        assert!((far - expect).abs() < 1e-4, "{far} vs {expect}");
        // A scene behind the camera, or none, still gives a frustum beyond the near plane.
        let behind = Aabb::new(Vec3::splat(-20.0), Vec3::splat(-10.0));
        assert_eq!(clamped_far(&c, &behind), 2.0 * c.near);
        assert_eq!(clamped_far(&c, &Aabb::EMPTY), 2.0 * c.near);
    }

    #[test]
    fn edges_are_two_rectangles_and_their_joins() {
        let corners = frustum_corners(&camera(), 10.0);
        let edges = frustum_edges(&corners);
        // Every corner ends three edges.
        for p in corners {
            let ends = edges.iter().filter(|(a, b)| *a == p || *b == p).count();
            assert_eq!(ends, 3, "{p}");
        }
        assert_eq!(edges[8], (corners[0], corners[4]));
    }
}
