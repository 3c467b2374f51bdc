//! The reference software rasterizer: triangle-id and depth buffers, the ground truth of every
//! evaluation in sightline.
//!
//! Based on: Pineda. A Parallel Algorithm for Polygon Rasterization. SIGGRAPH 1988 (edge
//! functions); the top-left fill rule of Direct3D; Sutherland, Hodgman 1974 (clipping); the
//! binning of common tiled software rasterizers (see `tiled.rs`).
//!
//! Pipeline: world → view space (f64) → clip against `z = near` (no far plane) → project with
//! exactly the mapping of [`crate::camera`] → clip to a 2D guard band of ±2^20 px (only for
//! vertices that project that far) → snap to 1/256 px → bin into bands of 32 rows → rasterize
//! the bands in parallel. Triangles are double-sided (no back-face culling). Degenerate
//! triangles (zero area in 3D, non-finite corners, out-of-range indices) are never drawn.
//!
//! # Agreement with ray casting
//! A pixel holds the triangle that [`crate::trace::BruteForce`] hits with
//! [`Camera::pixel_ray`], except
//! (a) when the pixel centre is within the snapping distance (1/512 px per coordinate, plus f32
//!     rounding of the ray caster) of a triangle's projected edge, and
//! (b) when two triangles' depths at the pixel centre tie to f32 precision (intersecting or
//!     coplanar triangles): both rules pick the lower id on an exact tie, but the two methods
//!     compute depth with different rounding.
//! Depth is the view depth `z` of the hit point (the ray's `t`, since `screen_ray` directions
//! have a forward component of 1), computed in f64 from the triangle's plane and stored as f32.
//!
//! # Determinism
//! Coverage is exact integer arithmetic; the depth test is `z < stored` with ties to the lower
//! id, so the frame does not depend on thread scheduling.

mod clip;
mod frame;
mod setup;
mod tiled;

use glam::Vec3;

use crate::camera::{Camera, CameraError};
use crate::scene::Scene;
use crate::TriangleSet;

pub use frame::Frame;
pub use setup::SUBPIXEL_BITS;
pub use tiled::{Rasterizer, BAND_ROWS, CHUNK};

/// Renders `scene` from `camera`.
pub fn render(scene: &Scene, camera: &Camera) -> Frame {
    let mut frame = Frame::new(camera.width, camera.height);
    Rasterizer::new(scene).render(camera, None, &mut frame);
    frame
}

/// Renders only the triangles of `scene` whose bit is set in `triangles` (e.g. a PVS).
pub fn render_subset(scene: &Scene, camera: &Camera, triangles: &TriangleSet) -> Frame {
    let mut frame = Frame::new(camera.width, camera.height);
    Rasterizer::new(scene).render(camera, Some(triangles), &mut frame);
    frame
}

/// Renders the six faces of a `size × size` cube map at `eye`, in the order of
/// [`Camera::cube_faces`] (+X, -X, +Y, -Y, +Z, -Z). Fails when the faces' cameras cannot be
/// built (non-finite eye, bad size or near plane).
pub fn render_cube(
    scene: &Scene,
    eye: Vec3,
    size: u32,
    near: f32,
) -> Result<[Frame; 6], CameraError> {
    let faces = Camera::cube_faces(eye, size, near)?;
    let mut raster = Rasterizer::new(scene);
    Ok(faces.map(|cam| {
        let mut frame = Frame::new(size, size);
        raster.render(&cam, None, &mut frame);
        frame
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Hit;
    use crate::scene::SceneBuilder;

    fn camera(width: u32, height: u32) -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, width, height, 0.1)
            .expect("valid camera")
    }

    fn quad_scene(z: f32, half: f32) -> Scene {
        let mut b = SceneBuilder::new("quad");
        let p = [
            b.add_vertex(Vec3::new(-half, -half, z)),
            b.add_vertex(Vec3::new(half, -half, z)),
            b.add_vertex(Vec3::new(half, half, z)),
            b.add_vertex(Vec3::new(-half, half, z)),
        ];
        b.add_triangle([p[0], p[1], p[2]]);
        b.add_triangle([p[0], p[2], p[3]]);
        b.finish()
    }

    #[test]
    fn empty_scene_renders_background() {
        let f = render(&Scene::default(), &camera(16, 8));
        assert_eq!(f.ids.len(), 128);
        assert!(f.ids.iter().all(|&id| id == Hit::NONE));
        assert!(f.depth.iter().all(|d| d.is_infinite()));
        assert_eq!(f.visible_set(0).count_ones(..), 0);
    }

    #[test]
    fn full_screen_quad_covers_every_pixel() {
        let f = render(&quad_scene(-2.0, 100.0), &camera(32, 16));
        assert!(f.ids.iter().all(|&id| id < 2));
        assert!(f.depth.iter().all(|&d| (d - 2.0).abs() < 1e-5));
    }

    #[test]
    fn camera_looking_away_sees_nothing() {
        let f = render(&quad_scene(2.0, 1.0), &camera(16, 16));
        assert!(f.ids.iter().all(|&id| id == Hit::NONE));
    }

    #[test]
    fn triangle_behind_near_plane_is_dropped() {
        let f = render(&quad_scene(-0.05, 1.0), &camera(16, 16));
        assert!(f.ids.iter().all(|&id| id == Hit::NONE));
    }

    #[test]
    fn subset_renders_only_set_bits() {
        let scene = quad_scene(-2.0, 100.0);
        let mut set = TriangleSet::with_capacity(2);
        set.insert(1);
        let f = render_subset(&scene, &camera(16, 16), &set);
        assert!(f.ids.iter().all(|&id| id == 1 || id == Hit::NONE));
        assert!(f.ids.contains(&1));
        let empty = render_subset(&scene, &camera(16, 16), &TriangleSet::new());
        assert!(empty.ids.iter().all(|&id| id == Hit::NONE));
    }

    #[test]
    fn equal_depth_goes_to_lower_id() {
        // Two identical full-screen quads: ids 0..2 and 2..4; only the first pair may show.
        let mut b = SceneBuilder::new("twin");
        for _ in 0..2 {
            let p = [
                b.add_vertex(Vec3::new(-9.0, -9.0, -2.0)),
                b.add_vertex(Vec3::new(9.0, -9.0, -2.0)),
                b.add_vertex(Vec3::new(9.0, 9.0, -2.0)),
                b.add_vertex(Vec3::new(-9.0, 9.0, -2.0)),
            ];
            b.add_triangle([p[0], p[1], p[2]]);
            b.add_triangle([p[0], p[2], p[3]]);
        }
        let f = render(&b.finish(), &camera(16, 16));
        assert!(f.ids.iter().all(|&id| id < 2));
    }

    #[test]
    fn degenerate_triangle_is_never_drawn() {
        let mut b = SceneBuilder::new("flat");
        let p = [
            b.add_vertex(Vec3::new(-1.0, 0.0, -2.0)),
            b.add_vertex(Vec3::new(0.0, 0.0, -2.0)),
            b.add_vertex(Vec3::new(1.0, 0.0, -2.0)),
            b.add_vertex(Vec3::new(0.0, f32::NAN, -2.0)),
        ];
        b.add_triangle([p[0], p[1], p[2]]);
        b.add_triangle([p[0], p[1], p[3]]);
        b.add_triangle([p[0], p[1], 99]);
        let f = render(&b.finish(), &camera(16, 16));
        assert!(f.ids.iter().all(|&id| id == Hit::NONE));
    }

    #[test]
    fn visible_set_ignores_out_of_range_ids() {
        let f = render(&quad_scene(-2.0, 100.0), &camera(8, 8));
        let s = f.visible_set(1);
        assert_eq!(s.len(), 1);
        assert!(s.contains(0));
    }

    #[test]
    fn cube_rejects_zero_size() {
        assert!(render_cube(&Scene::default(), Vec3::ZERO, 0, 0.1).is_err());
    }

    #[test]
    fn rasterizer_reuse_gives_same_frame() {
        let scene = quad_scene(-2.0, 1.0);
        let mut r = Rasterizer::new(&scene);
        let mut f = Frame::new(1, 1);
        r.render(&camera(20, 10), None, &mut f);
        let first = f.clone();
        r.render(&camera(7, 7), None, &mut f);
        r.render(&camera(20, 10), None, &mut f);
        assert_eq!(f, first);
    }
}
