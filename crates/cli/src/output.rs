//! Writing results: PNG images (atomically), JSON to stdout, colours for ids.

use std::path::Path;

use anyhow::{Context, Result};
use image::RgbImage;
use sightline_core::atomic_file::write_atomic;
use sightline_core::raster::Frame;
use sightline_core::{Camera, Hit, Scene};

/// Writes `image` as PNG to `path` atomically.
pub(crate) fn save_png(image: &RgbImage, path: &Path) -> Result<()> {
    write_atomic(path, |w| {
        image
            .write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Prints `value` as pretty JSON on stdout.
pub(crate) fn print_json<T: serde::Serialize>(value: &T) -> Result<()> {
    println!("{}", serde_json::to_string_pretty(value)?);
    Ok(())
}

/// A well-spread colour for an integer key (golden-ratio hue walk via an integer hash).
pub(crate) fn id_colour(key: u32) -> [u8; 3] {
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

/// Background colour of images.
const BACKGROUND: [u8; 3] = [24, 26, 32];

/// Triangle-id image: every triangle its own colour.
pub(crate) fn id_image(frame: &Frame) -> RgbImage {
    RgbImage::from_fn(frame.width, frame.height, |x, y| {
        let id = frame.ids[(y * frame.width + x) as usize];
        image::Rgb(if id == Hit::NONE {
            BACKGROUND
        } else {
            id_colour(id)
        })
    })
}

/// Shaded image: object colour times a headlight term |n · v|, so shapes read clearly.
pub(crate) fn shaded_image(frame: &Frame, scene: &Scene, camera: &Camera) -> RgbImage {
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
