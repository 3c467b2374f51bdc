//! The top-down overview (key O, `--overview`): an orthographic camera looking down the
//! scene's up axis over the whole scene, oriented as the report's cell map
//! (`sightline_eval::report::Plan`: Z-up scenes show x to the right and y up the image,
//! Y-up scenes x and -z), so the overview and the report's map look alike.
//!
//! The renderer draws through either camera ([`ViewCamera`]); the overview's guides (cells,
//! eye marker, frozen frustum) are flattened onto a plane just below the camera's near plane
//! ([`OrthoCamera::flatten`]), above all geometry, so no building hides them.

use glam::Vec3;
use sightline_core::{Aabb, Camera, UpAxis};
use sightline_eval::report::Plan;

/// Room left around the scene in the image, as a fraction of its larger half extent.
const MARGIN: f32 = 0.05;

/// An orthographic camera: parallel rays along `forward` through a `2 half_width x 2
/// half_height` rectangle, depth between `near` and `far` (both along `forward` from `eye`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrthoCamera {
    /// Centre of the image rectangle, above the scene.
    pub eye: Vec3,
    /// Unit view direction (down the scene's up axis).
    pub forward: Vec3,
    /// Unit right direction of the image.
    pub right: Vec3,
    /// Unit up direction of the image.
    pub up: Vec3,
    /// Half the width of the viewed rectangle, in scene units.
    pub half_width: f32,
    /// Half its height.
    pub half_height: f32,
    /// Nearest depth drawn.
    pub near: f32,
    /// Farthest depth drawn.
    pub far: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl OrthoCamera {
    /// The camera over all of `bounds` seen down `up`, for a `width x height` image: the
    /// bounds' footprint fills the image with a margin, at the image's aspect ratio (pixels
    /// square), and every point of the bounds lies between the near and far planes.
    pub fn over(bounds: &Aabb, up: UpAxis, width: u32, height: u32) -> Self {
        let [right, page_up, up_axis] = Plan::new(up).axes();
        let bounds = if bounds.is_empty() {
            Aabb::new(Vec3::ZERO, Vec3::ZERO)
        } else {
            *bounds
        };
        let (centre, extent) = (bounds.center(), bounds.extent());
        let (width, height) = (width.max(1), height.max(1));
        let aspect = width as f32 / height as f32;
        let half_x = extent.dot(right).abs() * 0.5;
        let half_y = extent.dot(page_up).abs() * 0.5;
        let half_up = extent.dot(up_axis).abs() * 0.5;
        // At least 1e-3 of the scene's size, so a flat or point scene still has a view.
        let size = (half_x.max(half_y).max(half_up)).max(1e-3);
        let margin = MARGIN * size;
        // Tall enough for the footprint's height, and for its width at the image's aspect.
        let half_height = half_y.max(half_x / aspect) + margin;
        let half_width = half_height * aspect;
        // The eye 2 margins above the top; the near plane 1 margin below it.
        let eye = centre + up_axis * (half_up + 2.0 * margin);
        Self {
            eye,
            forward: -up_axis,
            right,
            up: page_up,
            half_width,
            half_height,
            near: margin,
            far: half_up * 2.0 + 3.0 * margin,
            width,
            height,
        }
    }

    /// `p` in normalized device coordinates: x and y in [-1, 1] inside the image (y up),
    /// z the reversed depth, 1 at the near plane and 0 at the far one (as `renderer.wgsl`).
    pub fn ndc(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        let depth = d.dot(self.forward);
        Vec3::new(
            d.dot(self.right) / self.half_width,
            d.dot(self.up) / self.half_height,
            (self.far - depth) / (self.far - self.near),
        )
    }

    /// `p` moved along the view direction onto the plane 1.5 near distances below the eye:
    /// between the near plane and the scene's top, so what is drawn there is seen over
    /// everything.
    pub fn flatten(&self, p: Vec3) -> Vec3 {
        let depth = (p - self.eye).dot(self.forward);
        p + self.forward * (1.5 * self.near - depth)
    }
}

/// The camera the renderer draws through: the fly camera's pinhole or the overview's
/// orthographic one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewCamera {
    /// A perspective camera.
    Perspective(Camera),
    /// The top-down orthographic camera.
    Orthographic(OrthoCamera),
}

impl ViewCamera {
    /// The image size `(width, height)`.
    pub fn size(&self) -> (u32, u32) {
        match self {
            ViewCamera::Perspective(c) => (c.width, c.height),
            ViewCamera::Orthographic(c) => (c.width, c.height),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corners(b: &Aabb) -> Vec<Vec3> {
        b.corners().to_vec()
    }

    fn assert_contains(cam: &OrthoCamera, b: &Aabb) {
        for p in corners(b) {
            let n = cam.ndc(p);
            assert!(n.x.abs() < 1.0 && n.y.abs() < 1.0, "{p} at {n}");
            assert!(n.z > 0.0 && n.z < 1.0, "{p} depth {}", n.z);
            // The map plane is nearer than every point of the scene, and inside the depth range.
            let m = cam.ndc(cam.flatten(p));
            assert!(m.z > n.z && m.z < 1.0, "{p}: map depth {} vs {}", m.z, n.z);
            assert!((m.x - n.x).abs() < 1e-5 && (m.y - n.y).abs() < 1e-5);
        }
    }

    #[test]
    fn overview_contains_the_bounds_of_z_and_y_up_scenes() {
        let b = Aabb::new(Vec3::new(-150.0, -40.0, 0.0), Vec3::new(150.0, 60.0, 35.0));
        for (w, h) in [(320, 180), (100, 400), (64, 64)] {
            let z = OrthoCamera::over(&b, UpAxis::Z, w, h);
            assert_eq!(z.forward, Vec3::NEG_Z);
            assert_contains(&z, &b);
            // Square pixels.
            let ratio = (z.half_width / z.half_height) / (w as f32 / h as f32);
            assert!((ratio - 1.0).abs() < 1e-5);
            let y = OrthoCamera::over(&b, UpAxis::Y, w, h);
            assert_eq!(y.forward, Vec3::NEG_Y);
            assert_contains(&y, &b);
        }
    }

    #[test]
    fn overview_is_oriented_as_the_report_map_and_fills_the_image() {
        let b = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(100.0, 50.0, 10.0));
        let cam = OrthoCamera::over(&b, UpAxis::Z, 200, 100);
        // +x right, +y up the image.
        assert!(cam.ndc(Vec3::new(100.0, 25.0, 5.0)).x > 0.85);
        assert!(cam.ndc(Vec3::new(50.0, 50.0, 5.0)).y > 0.85);
        // Y-up: -z is up the image.
        let cam = OrthoCamera::over(&b, UpAxis::Y, 200, 100);
        assert!(cam.ndc(Vec3::new(50.0, 5.0, 0.0)).y > cam.ndc(Vec3::new(50.0, 5.0, 10.0)).y);
    }

    #[test]
    fn empty_scene_still_gives_a_camera() {
        let cam = OrthoCamera::over(&Aabb::EMPTY, UpAxis::Z, 10, 10);
        assert!(cam.half_width > 0.0 && cam.far > cam.near && cam.eye.is_finite());
        assert_eq!(ViewCamera::Orthographic(cam).size(), (10, 10));
    }
}
