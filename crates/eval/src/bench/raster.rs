//! Reference rasterizer throughput: frame time and triangles per second of the software
//! rasterizer rendering a whole scene.
//!
//! Method: the same frame rendered several times in a row, the median frame time reported, so
//! a single frame slowed by other load on the machine does not count.

use std::time::Instant;

use serde::Serialize;
use sightline_core::raster::{Frame, Rasterizer};
use sightline_core::{Camera, Hit, Scene};

use super::common::sorted;

/// One scene of `bench raster`.
#[derive(Serialize, Clone, Debug)]
pub struct RasterRow {
    /// The scene's name.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// Image size (square).
    pub size: u32,
    /// Median milliseconds per frame.
    pub median_ms: f64,
    /// Triangles per median second, in millions.
    pub mtriangles_per_second: f64,
    /// Pixels a triangle covers.
    pub visible_pixels: usize,
}

/// Renders `scene` from `camera` (its size: the frame's) `frames` times (at least once) and
/// reports the median frame.
pub fn bench_raster(scene_name: &str, scene: &Scene, camera: &Camera, frames: usize) -> RasterRow {
    let size = camera.width;
    let mut rasterizer = Rasterizer::new(scene);
    let mut frame = Frame::new(camera.width, camera.height);
    let mut times = Vec::with_capacity(frames.max(1));
    for _ in 0..frames.max(1) {
        let t = Instant::now();
        rasterizer.render(camera, None, &mut frame);
        times.push(t.elapsed().as_secs_f64());
    }
    let times = sorted(times);
    let median = times[times.len() / 2];
    RasterRow {
        scene: scene_name.to_string(),
        triangles: scene.triangle_count(),
        size,
        median_ms: median * 1e3,
        mtriangles_per_second: scene.triangle_count() as f64 / median / 1e6,
        visible_pixels: frame.ids.iter().filter(|&&id| id != Hit::NONE).count(),
    }
}
