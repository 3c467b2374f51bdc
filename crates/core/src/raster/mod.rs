//! The reference software rasterizer (being written).

use crate::camera::Camera;
use crate::scene::Scene;

/// A rendered frame: per-pixel triangle id ([`crate::Hit::NONE`] for background) and view depth.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Triangle id per pixel, row-major, top row first.
    pub ids: Vec<u32>,
    /// View depth per pixel (`f32::INFINITY` for background).
    pub depth: Vec<f32>,
}

/// Renders `scene` from `camera`.
pub fn render(_scene: &Scene, camera: &Camera) -> Frame {
    let n = (camera.width * camera.height) as usize;
    Frame {
        width: camera.width,
        height: camera.height,
        ids: vec![u32::MAX; n],
        depth: vec![f32::INFINITY; n],
    }
}
