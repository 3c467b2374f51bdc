//! Benchmark inputs for the occlusion buffer, shared by the criterion bench
//! (`benches/occlusion.rs`), `sightline bench peers` and its export for the peer harnesses
//! (Intel's Masked Occlusion Culling), so that every side rasterizes exactly the same
//! triangles: random right triangles of a given leg length in pixels at 1920x1080, and the
//! 20-pixel query boxes of the box-test bench; and the occluders the culling simulation draws
//! in one frame of a scene ([`frame_occluders`]), a real occluder set.
//!
//! Why right triangles with fixed legs: the cost of a software rasterizer per triangle grows
//! with its screen size (more tiles to cover), so the leg length is the knob that moves the
//! workload from set-up bound (10 px) to fill bound (100 px). Depths are random (5..50) so
//! that triangles overlap in both orders.

use glam::Vec3;
use sightline_core::random::SplitMix64;
use sightline_core::{Aabb, Camera};

use crate::backend::{OcclusionBackend, SoftwareBackend};
use crate::grid::GridError;
use crate::scenes::CullScene;
use crate::sim_types::{Method, SimConfig};
use crate::simulate::simulate_methods_with_cameras;

/// Width of the bench image.
pub const WIDTH: u32 = 1920;
/// Height of the bench image.
pub const HEIGHT: u32 = 1080;
/// Triangles per occluder set.
pub const TRIANGLES: usize = 100_000;
/// The leg lengths, in pixels, that the bench and `sightline bench peers` measure.
pub const LEGS_PX: [f32; 4] = [10.0, 25.0, 50.0, 100.0];

/// The bench camera: at the origin looking down `-Z` with `+Y` up, 60 degrees vertical field
/// of view, [`WIDTH`] x [`HEIGHT`], near plane 0.1.
pub fn camera() -> Camera {
    Camera {
        eye: Vec3::ZERO,
        forward: Vec3::NEG_Z,
        up: Vec3::Y,
        right: Vec3::X,
        fov_y_deg: 60.0,
        width: WIDTH,
        height: HEIGHT,
        near: 0.1,
    }
}

/// The world point seen at continuous screen position `(sx, sy)` at view depth `z`
/// (the inverse of [`Camera::view_to_screen`] for any camera).
pub fn unproject(cam: &Camera, sx: f32, sy: f32, z: f32) -> Vec3 {
    let u = (2.0 * sx / cam.width as f32 - 1.0) * cam.tan_half_x();
    let v = (1.0 - 2.0 * sy / cam.height as f32) * cam.tan_half_y();
    cam.eye + (cam.forward + cam.right * u + cam.up * v) * z
}

/// `n` right triangles (three corners each, flat) whose legs are `leg_px` pixels long on
/// `cam`'s screen, along `+x` and `+y` from a random corner, entirely inside the screen (when
/// `leg_px` is below its size), at random view depths in `5..50` (the corners' depths differ by
/// 0.1 % so the triangles are not parallel to the screen). Deterministic for a seed.
pub fn right_triangles(cam: &Camera, n: usize, leg_px: f32, seed: u64) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(seed);
    let (w, h) = (cam.width as f32, cam.height as f32);
    let leg = leg_px.clamp(0.0, w.min(h));
    let mut out = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let sx = rng.range_f32(0.0, w - leg);
        let sy = rng.range_f32(0.0, h - leg);
        let z = rng.range_f32(5.0, 50.0);
        out.push(unproject(cam, sx, sy, z));
        out.push(unproject(cam, sx + leg, sy, z * 1.001));
        out.push(unproject(cam, sx, sy + leg, z * 0.999));
    }
    out
}

/// The occluder set of the bench for one leg length: [`TRIANGLES`] triangles on [`camera`],
/// seed 1 (the seed the bench has always used).
pub fn occluder_set(leg_px: f32) -> (Vec<Vec3>, Camera) {
    let cam = camera();
    (right_triangles(&cam, TRIANGLES, leg_px, 1), cam)
}

/// `n` query boxes of about 20x20 pixels at view depths 40..100, random screen positions.
pub fn query_boxes(cam: &Camera, n: usize) -> Vec<Aabb> {
    let mut rng = SplitMix64::new(2);
    let (w, h) = (cam.width as f32, cam.height as f32);
    (0..n)
        .map(|_| {
            let sx = rng.range_f32(0.0, w - 20.0);
            let sy = rng.range_f32(0.0, h - 20.0);
            let z = rng.range_f32(40.0, 100.0);
            let a = unproject(cam, sx, sy, z);
            let b = unproject(cam, sx + 20.0, sy + 20.0, z + 1.0);
            Aabb::new(a.min(b), a.max(b))
        })
        .collect()
}

/// The occluder triangles (three corners each, in drawing order) that the grid method of the
/// culling simulation ([`crate::simulate_methods_with_cameras`], `config` with popping not
/// measured) renders into its software buffer in frame `frame`, with frame `f` seen by
/// `camera_of(f)`: a real occluder set of a scene, for the rasterizer benches. Frames before
/// it run too (the grid method's choices depend on earlier frames' query results). Empty when
/// `frame` has no camera.
pub fn frame_occluders(
    scene: &CullScene,
    camera_of: &dyn Fn(u32) -> Option<Camera>,
    config: &SimConfig,
    frame: u32,
) -> Result<Vec<Vec3>, GridError> {
    let config = SimConfig {
        frames: frame + 1,
        measure_popping: false,
        diagnose: false,
        ..*config
    };
    let mut recorder = Recorder {
        inner: SoftwareBackend::new(config.width, config.height),
        frames_begun: 0,
        frame: frame + 1,
        triangles: Vec::new(),
    };
    simulate_methods_with_cameras(scene, camera_of, &mut recorder, &config, &[Method::Grid])?;
    Ok(recorder.triangles)
}

/// The software backend, recording what is drawn in one frame (the `frame`-th begun, from 1).
struct Recorder {
    inner: SoftwareBackend,
    frames_begun: u32,
    frame: u32,
    triangles: Vec<Vec3>,
}

impl OcclusionBackend for Recorder {
    fn begin_frame(&mut self, camera: &Camera) {
        self.frames_begun += 1;
        self.inner.begin_frame(camera);
    }
    fn draw_depth(&mut self, triangles: &[Vec3]) {
        if self.frames_begun == self.frame {
            self.triangles.extend_from_slice(triangles);
        }
        self.inner.draw_depth(triangles);
    }
    fn query(&mut self, tag: u32, aabb: &Aabb) {
        self.inner.query(tag, aabb);
    }
    fn test_now(&mut self, aabb: &Aabb) -> Option<bool> {
        self.inner.test_now(aabb)
    }
    fn test_object_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        self.inner.test_object_now(aabb, triangles)
    }
    fn begin_retest(&mut self, occluders: &[Vec3]) {
        self.inner.begin_retest(occluders);
    }
    fn retest_now(&mut self, aabb: &Aabb, triangles: &[Vec3]) -> Option<bool> {
        self.inner.retest_now(aabb, triangles)
    }
    fn take_results(&mut self, out: &mut Vec<(u32, bool)>) {
        self.inner.take_results(out);
    }
}
