//! The images of a rendered frame that the report shows and the CLI writes: colours for ids
//! (objects, triangles) and the shaded image (object colour under a headlight).
//!
//! Colours are 8-bit codes chosen as stored (sRGB codes, untagged).

use image::RgbImage;
use sightline_core::raster::Frame;
use sightline_core::{Camera, Hit, Scene};

/// A well-spread colour for an integer key (golden-ratio hue walk via an integer hash).
pub fn id_colour(key: u32) -> [u8; 3] {
    let mut h = key.wrapping_mul(0x9e37_79b9) ^ 0x5bd1_e995;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    [
        (h & 0xff) as u8 | 0x30,
        ((h >> 8) & 0xff) as u8 | 0x30,
        ((h >> 16) & 0xff) as u8 | 0x30,
    ]
}

/// Background colour of images (pixels where no triangle was hit).
pub const BACKGROUND: [u8; 3] = [24, 26, 32];

/// Shaded image: object colour times a headlight term |n · v|, so shapes read clearly.
pub fn shaded_image(frame: &Frame, scene: &Scene, camera: &Camera) -> RgbImage {
    RgbImage::from_fn(frame.width, frame.height, |x, y| {
        let id = frame.ids[(y * frame.width + x) as usize];
        if id == Hit::NONE || id as usize >= scene.triangles.len() {
            return image::Rgb(BACKGROUND);
        }
        let [a, b, c] = scene.triangle(id);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let view = camera.pixel_ray(x, y).dir.normalize_or_zero();
        let light = 0.25 + 0.75 * normal.dot(view).abs();
        let base = id_colour(scene.object_of_triangle[id as usize]);
        image::Rgb(
            base.map(|c| (0.35 * 255.0 + 0.65 * c as f32).min(255.0) as u8)
                .map(|c| (c as f32 * light).round().clamp(0.0, 255.0) as u8),
        )
    })
}
