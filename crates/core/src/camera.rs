//! The pinhole camera shared by the rasterizer, ray casting and every evaluation.
//!
//! Conventions (pinned here once; the rasterizer and [`Camera::pixel_ray`] must agree exactly):
//! - right-handed view basis: `right = forward × up`, the image's `+y` points *down*;
//! - pixel `(x, y)` covers `[x, x+1) × [y, y+1)` and is sampled at its centre `(x + 0.5, y + 0.5)`;
//! - a world point `p` with view coordinates `(vx, vy, vz) = (dot(p-eye, right), dot(p-eye, up),
//!   dot(p-eye, forward))` lands on screen at
//!   `sx = (vx / (vz * tan_half_x) + 1) * width / 2`, `sy = (1 - vy / (vz * tan_half_y)) * height / 2`;
//! - depth is the view-space distance along `forward` (`vz`), visible only for `vz >= near`.

use glam::{DVec2, DVec3, Vec3};

use crate::geometry::Ray;

/// A perspective pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit up vector, orthogonal to `forward`.
    pub up: Vec3,
    /// Unit right vector, `forward × up`.
    pub right: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Near-plane distance along `forward` (> 0).
    pub near: f32,
}

/// Why a camera could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum CameraError {
    /// Eye, target or up is NaN or infinite.
    #[error("camera {0} is not finite")]
    NotFinite(&'static str),
    /// Eye and look-at point coincide.
    #[error("camera eye and look-at point coincide")]
    ZeroViewDirection,
    /// The up vector is parallel to the view direction.
    #[error("camera up vector is parallel to the view direction")]
    UpParallelToView,
    /// The field of view is outside (0, 180) degrees.
    #[error("field of view {0} degrees is outside (0, 180)")]
    BadFov(f32),
    /// Width or height is zero or above 16384.
    #[error("image size {0}x{1} is outside 1..=16384")]
    BadSize(u32, u32),
    /// The near plane is not positive and finite.
    #[error("near plane {0} must be positive and finite")]
    BadNear(f32),
}

impl Camera {
    /// A camera at `eye` looking at `target`, with `up` as the approximate up direction.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
    ) -> Result<Self, CameraError> {
        if !eye.is_finite() {
            return Err(CameraError::NotFinite("eye"));
        }
        if !target.is_finite() {
            return Err(CameraError::NotFinite("look-at point"));
        }
        if !up.is_finite() {
            return Err(CameraError::NotFinite("up vector"));
        }
        let forward = (target - eye)
            .try_normalize()
            .ok_or(CameraError::ZeroViewDirection)?;
        Self::looking(eye, forward, up, fov_y_deg, width, height, near)
    }

    /// A camera at `eye` looking along `forward`.
    pub fn looking(
        eye: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
    ) -> Result<Self, CameraError> {
        let forward = forward
            .try_normalize()
            .ok_or(CameraError::ZeroViewDirection)?;
        if !(fov_y_deg > 0.0 && fov_y_deg < 180.0) {
            return Err(CameraError::BadFov(fov_y_deg));
        }
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(CameraError::BadSize(width, height));
        }
        if !(near > 0.0 && near.is_finite()) {
            return Err(CameraError::BadNear(near));
        }
        let right = forward.cross(up);
        if right.length_squared() < 1e-12 * up.length_squared().max(1e-30) {
            return Err(CameraError::UpParallelToView);
        }
        let right = right.normalize();
        let up = right.cross(forward).normalize();
        Ok(Self {
            eye,
            forward,
            up,
            right,
            fov_y_deg,
            width,
            height,
            near,
        })
    }

    /// The six 90-degree square faces of a cube map at `eye`, in the order
    /// +X, -X, +Y, -Y, +Z, -Z (each face's up vector as in OpenGL cube maps).
    pub fn cube_faces(eye: Vec3, size: u32, near: f32) -> Result<[Camera; 6], CameraError> {
        let faces = [
            (Vec3::X, Vec3::NEG_Y),
            (Vec3::NEG_X, Vec3::NEG_Y),
            (Vec3::Y, Vec3::Z),
            (Vec3::NEG_Y, Vec3::NEG_Z),
            (Vec3::Z, Vec3::NEG_Y),
            (Vec3::NEG_Z, Vec3::NEG_Y),
        ];
        let mk = |(f, u): (Vec3, Vec3)| Camera::looking(eye, f, u, 90.0, size, size, near);
        Ok([
            mk(faces[0])?,
            mk(faces[1])?,
            mk(faces[2])?,
            mk(faces[3])?,
            mk(faces[4])?,
            mk(faces[5])?,
        ])
    }

    /// `tan(fov_y / 2)`.
    pub fn tan_half_y(&self) -> f32 {
        (self.fov_y_deg.to_radians() * 0.5).tan()
    }

    /// `tan(fov_x / 2)` = `tan_half_y * width / height`.
    pub fn tan_half_x(&self) -> f32 {
        self.tan_half_y() * self.width as f32 / self.height as f32
    }

    /// World point to view coordinates `(right, up, forward)`.
    pub fn to_view(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// View coordinates (with `z > 0`) to continuous screen coordinates `(sx, sy)` in pixels.
    pub fn view_to_screen(&self, v: Vec3) -> (f32, f32) {
        let sx = (v.x / (v.z * self.tan_half_x()) + 1.0) * 0.5 * self.width as f32;
        let sy = (1.0 - v.y / (v.z * self.tan_half_y())) * 0.5 * self.height as f32;
        (sx, sy)
    }

    /// The ray through continuous screen point `(sx, sy)`. Its direction has a forward component
    /// of exactly 1, so a hit's `t` is its view depth; `t_min` is the near plane.
    pub fn screen_ray(&self, sx: f32, sy: f32) -> Ray {
        let u = (2.0 * sx / self.width as f32 - 1.0) * self.tan_half_x();
        let v = (1.0 - 2.0 * sy / self.height as f32) * self.tan_half_y();
        let dir = self.forward + self.right * u + self.up * v;
        Ray {
            origin: self.eye,
            dir,
            t_min: self.near,
            t_max: f32::INFINITY,
        }
    }

    /// The ray through the centre of pixel `(x, y)` (see [`Camera::screen_ray`]).
    pub fn pixel_ray(&self, x: u32, y: u32) -> Ray {
        self.screen_ray(x as f32 + 0.5, y as f32 + 0.5)
    }
}

/// The camera mapping in f64, shared by every algorithm that must see exactly the screen
/// positions the rasterizer sees (the rasterizer itself, exact analytic visibility, RV). The
/// camera's f32 vectors and tangents are widened, not recomputed, so the mapping is the one
/// [`Camera::pixel_ray`] uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenMapping {
    /// Eye position.
    pub eye: DVec3,
    /// Unit right vector.
    pub right: DVec3,
    /// Unit up vector.
    pub up: DVec3,
    /// Unit view direction.
    pub forward: DVec3,
    /// Image width in pixels.
    pub width: f64,
    /// Image height in pixels.
    pub height: f64,
    /// `tan(fov_x / 2)`, from the camera's f32 value.
    pub tan_half_x: f64,
    /// `tan(fov_y / 2)`, from the camera's f32 value.
    pub tan_half_y: f64,
    /// Near-plane distance.
    pub near: f64,
}

impl ScreenMapping {
    /// The mapping of `camera`.
    pub fn new(camera: &Camera) -> Self {
        Self {
            eye: camera.eye.as_dvec3(),
            right: camera.right.as_dvec3(),
            up: camera.up.as_dvec3(),
            forward: camera.forward.as_dvec3(),
            width: f64::from(camera.width),
            height: f64::from(camera.height),
            tan_half_x: f64::from(camera.tan_half_x()),
            tan_half_y: f64::from(camera.tan_half_y()),
            near: f64::from(camera.near),
        }
    }

    /// World point to view coordinates `(right, up, forward)`.
    pub fn view_of(&self, p: DVec3) -> DVec3 {
        let d = p - self.eye;
        DVec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// [`Camera::view_to_screen`] in f64 (same formula, same operation order).
    pub fn screen_of(&self, v: DVec3) -> DVec2 {
        DVec2::new(
            (v.x / (v.z * self.tan_half_x) + 1.0) * 0.5 * self.width,
            (1.0 - v.y / (v.z * self.tan_half_y)) * 0.5 * self.height,
        )
    }

    /// Coefficients `[kx, ky, k0]` of `1/z = kx sx + ky sy + k0` over pixel coordinates for the
    /// plane through view-space `a, b, c`: the ray of screen point `s` has direction `(u, v, 1)`
    /// with `u = (2 sx / w - 1) tan_x`, `v = (1 - 2 sy / h) tan_y`, and meets the plane
    /// `n·p = d` at `z = d / n·(u, v, 1)`. `None` when the plane passes through the eye (the
    /// triangle is seen edge-on and covers no area).
    pub fn inv_z_plane(&self, a: DVec3, b: DVec3, c: DVec3) -> Option<[f64; 3]> {
        let n = (b - a).cross(c - a);
        let d = n.dot(a);
        if d == 0.0 || !d.is_finite() {
            return None;
        }
        let (tx, ty) = (self.tan_half_x, self.tan_half_y);
        let rd = 1.0 / d;
        let plane = [
            n.x * tx * 2.0 / self.width * rd,
            -n.y * ty * 2.0 / self.height * rd,
            (n.z - n.x * tx + n.y * ty) * rd,
        ];
        plane.iter().all(|k| k.is_finite()).then_some(plane)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn front_camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 200, 100, 0.01).unwrap()
    }

    #[test]
    fn projection_inverts_screen_ray() {
        let cam = front_camera();
        let ray = cam.screen_ray(37.25, 81.5);
        let p = ray.at(5.0);
        let v = cam.to_view(p);
        assert!((v.z - 5.0).abs() < 1e-4, "t is view depth");
        let (sx, sy) = cam.view_to_screen(v);
        assert!((sx - 37.25).abs() < 1e-3 && (sy - 81.5).abs() < 1e-3);
    }

    #[test]
    fn image_y_points_down() {
        let cam = front_camera();
        let (_, sy) = cam.view_to_screen(Vec3::new(0.0, 1.0, 2.0));
        assert!(sy < 50.0);
    }

    #[test]
    fn up_parallel_to_view_is_error() {
        let r = Camera::look_at(Vec3::ZERO, Vec3::Y, Vec3::Y, 60.0, 10, 10, 0.1);
        assert_eq!(r, Err(CameraError::UpParallelToView));
    }

    #[test]
    fn nan_eye_is_error() {
        let r = Camera::look_at(Vec3::NAN, Vec3::Y, Vec3::Z, 60.0, 10, 10, 0.1);
        assert_eq!(r, Err(CameraError::NotFinite("eye")));
    }

    #[test]
    fn cube_faces_cover_all_axes() {
        let faces = Camera::cube_faces(Vec3::ZERO, 8, 0.1).unwrap();
        let sum: Vec3 = faces.iter().map(|c| c.forward.abs()).sum();
        assert_eq!(sum, Vec3::splat(2.0));
    }

    #[test]
    fn screen_mapping_agrees_with_camera_and_plane_depth() {
        let cam = front_camera();
        let m = ScreenMapping::new(&cam);
        let p = Vec3::new(0.7, -0.4, -3.0);
        let v = m.view_of(p.as_dvec3());
        let (sx, sy) = cam.view_to_screen(cam.to_view(p));
        let s = m.screen_of(v);
        assert!((s.x - f64::from(sx)).abs() < 1e-3 && (s.y - f64::from(sy)).abs() < 1e-3);
        // A plane z = 3 in view space: 1/z is 1/3 everywhere on screen.
        let [kx, ky, k0] = m
            .inv_z_plane(
                DVec3::new(0.0, 0.0, 3.0),
                DVec3::new(1.0, 0.0, 3.0),
                DVec3::new(0.0, 1.0, 3.0),
            )
            .unwrap();
        for (x, y) in [(0.0, 0.0), (37.5, 81.25), (200.0, 100.0)] {
            assert!((kx * x + ky * y + k0 - 1.0 / 3.0).abs() < 1e-12);
        }
        // A plane through the eye is seen edge-on.
        assert!(m.inv_z_plane(DVec3::ZERO, DVec3::X, DVec3::Y).is_none());
    }
}
