//! The fly camera: position, yaw and pitch about the scene's up axis; keys move it, mouse
//! motion turns it, the scroll wheel changes its speed. No window code: the window driver feeds
//! it key states and mouse deltas, the tests do the same.

use glam::Vec3;
use sightline_core::camera::CameraError;
use sightline_core::Camera;

/// The movement keys held down (W/S forward/back, A/D left/right, E/Q up/down).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Movement {
    /// W: along the view direction.
    pub forward: bool,
    /// S: against the view direction.
    pub back: bool,
    /// A: to the left.
    pub left: bool,
    /// D: to the right.
    pub right: bool,
    /// E: along the scene's up axis.
    pub up: bool,
    /// Q: against the scene's up axis.
    pub down: bool,
}

/// Pitch stays this far (radians) from straight up or down, so the view never aligns with the
/// up axis (where the camera basis is undefined).
const PITCH_LIMIT: f32 = 1.55;
/// One scroll step multiplies the speed by this.
const SCROLL_FACTOR: f32 = 1.25;

/// A first-person fly camera. Yaw turns about `up`, pitch tilts towards it.
///
/// ```
/// use glam::Vec3;
/// use sightline_view::{FlyCamera, Movement};
///
/// let mut cam = FlyCamera::new(Vec3::ZERO, Vec3::X, Vec3::Z, 2.0).unwrap();
/// cam.update(&Movement { forward: true, ..Default::default() }, 0.5);
/// assert!((cam.eye - Vec3::X).length() < 1e-5);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    /// Eye position.
    pub eye: Vec3,
    /// The scene's up axis (unit).
    pub up: Vec3,
    /// Speed in scene units per second.
    pub speed: f32,
    /// Radians turned per pixel of mouse motion.
    pub sensitivity: f32,
    yaw: f32,
    pitch: f32,
    /// Horizontal reference axes: yaw 0 looks along `e1`, yaw pi/2 along `e2 = up x e1`.
    e1: Vec3,
    e2: Vec3,
}

impl FlyCamera {
    /// A camera at `eye` looking at `look`, moving at `speed` units per second.
    pub fn new(eye: Vec3, look: Vec3, up: Vec3, speed: f32) -> Result<Self, CameraError> {
        if !eye.is_finite() {
            return Err(CameraError::NotFinite("eye"));
        }
        if !look.is_finite() {
            return Err(CameraError::NotFinite("look-at point"));
        }
        let up = up
            .try_normalize()
            .ok_or(CameraError::NotFinite("up vector"))?;
        let dir = (look - eye)
            .try_normalize()
            .ok_or(CameraError::ZeroViewDirection)?;
        let helper = if up.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let e1 = (helper - up * helper.dot(up)).normalize();
        let e2 = up.cross(e1);
        let pitch = dir
            .dot(up)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-PITCH_LIMIT, PITCH_LIMIT);
        let yaw = dir.dot(e2).atan2(dir.dot(e1));
        Ok(Self {
            eye,
            up,
            speed: if speed.is_finite() && speed > 0.0 {
                speed
            } else {
                1.0
            },
            sensitivity: 0.004,
            yaw,
            pitch,
            e1,
            e2,
        })
    }

    /// The unit view direction.
    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        (self.e1 * cy + self.e2 * sy) * cp + self.up * sp
    }

    /// The unit right direction (horizontal: `forward x up`, normalized).
    pub fn right(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        (self.e1 * cy + self.e2 * sy).cross(self.up).normalize()
    }

    /// Moves for `dt` seconds with the keys of `keys` held: along the view direction (W/S),
    /// sideways (A/D) and along the up axis (E/Q), at `speed`.
    pub fn update(&mut self, keys: &Movement, dt: f32) {
        let axis = |plus: bool, minus: bool| f32::from(u8::from(plus)) - f32::from(u8::from(minus));
        let dir = self.forward() * axis(keys.forward, keys.back)
            + self.right() * axis(keys.right, keys.left)
            + self.up * axis(keys.up, keys.down);
        if let Some(dir) = dir.try_normalize() {
            self.eye += dir * self.speed * dt.max(0.0);
        }
    }

    /// Turns by a mouse motion of `(dx, dy)` pixels: right turns right, down looks down.
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        self.yaw = (self.yaw - dx * self.sensitivity).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch - dy * self.sensitivity).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Changes the speed by `steps` scroll steps (positive: faster), 1.25x per step.
    pub fn scroll(&mut self, steps: f32) {
        if steps.is_finite() {
            self.speed = (self.speed * SCROLL_FACTOR.powf(steps)).clamp(1e-6, 1e9);
        }
    }

    /// The point one unit ahead (for `--look`-style output).
    pub fn look_point(&self) -> Vec3 {
        self.eye + self.forward()
    }

    /// The pinhole camera of this pose.
    pub fn camera(
        &self,
        fov_y_deg: f32,
        width: u32,
        height: u32,
        near: f32,
    ) -> Result<Camera, CameraError> {
        Camera::looking(
            self.eye,
            self.forward(),
            self.up,
            fov_y_deg,
            width,
            height,
            near,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn z_up_camera() -> FlyCamera {
        FlyCamera::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::Z, 2.0).unwrap()
    }

    fn held(f: impl Fn(&mut Movement)) -> Movement {
        let mut m = Movement::default();
        f(&mut m);
        m
    }

    #[test]
    fn new_looks_at_the_look_point() {
        let look = Vec3::new(3.0, -4.0, 1.0);
        let cam = FlyCamera::new(Vec3::ONE, look, Vec3::Z, 1.0).unwrap();
        assert!((cam.forward() - (look - Vec3::ONE).normalize()).length() < 1e-5);
    }

    #[test]
    fn new_with_y_up_looks_at_the_look_point() {
        let cam = FlyCamera::new(Vec3::ZERO, Vec3::new(0.0, 1.0, -3.0), Vec3::Y, 1.0).unwrap();
        assert!((cam.forward() - Vec3::new(0.0, 1.0, -3.0).normalize()).length() < 1e-5);
    }

    #[test]
    fn new_rejects_eye_at_look_point() {
        assert_eq!(
            FlyCamera::new(Vec3::ONE, Vec3::ONE, Vec3::Z, 1.0),
            Err(CameraError::ZeroViewDirection)
        );
    }

    #[test]
    fn w_moves_forward_by_speed_times_time() {
        let mut cam = z_up_camera();
        cam.update(&held(|m| m.forward = true), 1.5);
        assert!((cam.eye - Vec3::new(3.0, 0.0, 0.0)).length() < 1e-5);
    }

    #[test]
    fn s_moves_back() {
        let mut cam = z_up_camera();
        cam.update(&held(|m| m.back = true), 1.0);
        assert!((cam.eye - Vec3::new(-2.0, 0.0, 0.0)).length() < 1e-5);
    }

    #[test]
    fn d_moves_right_and_a_left() {
        // Looking along +x with z up, right is -y (right = forward x up).
        let mut cam = z_up_camera();
        cam.update(&held(|m| m.right = true), 1.0);
        assert!((cam.eye - Vec3::new(0.0, -2.0, 0.0)).length() < 1e-5);
        cam.update(&held(|m| m.left = true), 2.0);
        assert!((cam.eye - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5);
    }

    #[test]
    fn e_moves_up_and_q_down_along_the_scene_up_axis() {
        let mut cam = FlyCamera::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), Vec3::Z, 1.0).unwrap();
        cam.update(&held(|m| m.up = true), 1.0);
        assert!((cam.eye - Vec3::Z).length() < 1e-5);
        cam.update(&held(|m| m.down = true), 3.0);
        assert!((cam.eye + 2.0 * Vec3::Z).length() < 1e-5);
    }

    #[test]
    fn opposite_keys_cancel_and_no_keys_stay() {
        let mut cam = z_up_camera();
        cam.update(
            &held(|m| {
                m.forward = true;
                m.back = true;
            }),
            1.0,
        );
        cam.update(&Movement::default(), 1.0);
        assert_eq!(cam.eye, Vec3::ZERO);
    }

    #[test]
    fn diagonal_moves_at_the_same_speed() {
        let mut cam = z_up_camera();
        cam.update(
            &held(|m| {
                m.forward = true;
                m.right = true;
            }),
            1.0,
        );
        assert!((cam.eye.length() - 2.0).abs() < 1e-5);
    }

    #[test]
    fn mouse_right_turns_right_and_down_looks_down() {
        let mut cam = z_up_camera();
        let right_before = cam.right();
        cam.rotate(100.0, 0.0);
        assert!(cam.forward().dot(right_before) > 0.1);
        let mut cam = z_up_camera();
        cam.rotate(0.0, 100.0);
        assert!(cam.forward().z < -0.1);
    }

    #[test]
    fn pitch_is_clamped_below_vertical() {
        let mut cam = z_up_camera();
        cam.rotate(0.0, -1e6);
        assert!(cam.forward().z < 1.0 && cam.forward().z > 0.99);
        assert!(cam.camera(60.0, 8, 8, 0.1).is_ok());
    }

    #[test]
    fn scroll_changes_speed_both_ways() {
        let mut cam = z_up_camera();
        cam.scroll(1.0);
        assert!((cam.speed - 2.5).abs() < 1e-5);
        cam.scroll(-2.0);
        assert!((cam.speed - 1.6).abs() < 1e-5);
    }

    #[test]
    fn camera_matches_the_pose() {
        let cam = z_up_camera();
        let c = cam.camera(60.0, 64, 32, 0.01).unwrap();
        assert_eq!(c.eye, cam.eye);
        assert!((c.forward - cam.forward()).length() < 1e-6);
        assert!((c.right - cam.right()).length() < 1e-6);
    }
}
