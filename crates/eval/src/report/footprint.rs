//! The scene's footprint seen from above: every triangle projected onto the ground plane and
//! rasterized at pixel centres, keeping the highest surface per pixel (a height map), shaded
//! light grey (higher is darker) so the map's coloured cells stay readable on top of it.

use image::RgbImage;
use sightline_core::Scene;

use super::plan::{MapFrame, Plan};

/// Grey of the lowest surface and of the highest (empty pixels are white).
const LOW_GREY: f64 = 236.0;
const HIGH_GREY: f64 = 150.0;

/// The highest surface under each pixel centre of `frame` (`NaN` where there is none),
/// row-major from the top-left.
pub(crate) fn height_map(scene: &Scene, plan: &Plan, frame: &MapFrame) -> Vec<f64> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let mut heights = vec![f64::NAN; w * h];
    for t in 0..scene.triangle_count() {
        let corners = scene.triangle(t as u32);
        let p = corners.map(|c| {
            let (x, y) = frame.pixel_of(plan.project(c));
            (x, y, plan.height(c))
        });
        // Twice the signed area; a wall seen edge-on covers no pixel centre.
        let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[2].0 - p[0].0) * (p[1].1 - p[0].1);
        if area.abs() < 1e-12 || !area.is_finite() {
            continue;
        }
        let xmin = p.iter().map(|q| q.0).fold(f64::INFINITY, f64::min);
        let xmax = p.iter().map(|q| q.0).fold(f64::NEG_INFINITY, f64::max);
        let ymin = p.iter().map(|q| q.1).fold(f64::INFINITY, f64::min);
        let ymax = p.iter().map(|q| q.1).fold(f64::NEG_INFINITY, f64::max);
        // Pixel (i, j) has its centre at (i + 0.5, j + 0.5).
        let x0 = (xmin - 0.5).ceil().max(0.0) as usize;
        let x1 = ((xmax - 0.5).floor()).min(w as f64 - 1.0);
        let y0 = (ymin - 0.5).ceil().max(0.0) as usize;
        let y1 = ((ymax - 0.5).floor()).min(h as f64 - 1.0);
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        for j in y0..=y1 as usize {
            let py = j as f64 + 0.5;
            for i in x0..=x1 as usize {
                let px = i as f64 + 0.5;
                // Barycentric weights (inside when all have the sign of the area).
                let w0 = ((p[1].0 - px) * (p[2].1 - py) - (p[2].0 - px) * (p[1].1 - py)) / area;
                let w1 = ((p[2].0 - px) * (p[0].1 - py) - (p[0].0 - px) * (p[2].1 - py)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * p[0].2 + w1 * p[1].2 + w2 * p[2].2;
                let slot = &mut heights[j * w + i];
                if slot.is_nan() || z > *slot {
                    *slot = z;
                }
            }
        }
    }
    heights
}

/// The height map as a light grey image.
pub(crate) fn footprint_image(scene: &Scene, plan: &Plan, frame: &MapFrame) -> RgbImage {
    let heights = height_map(scene, plan, frame);
    let (lo, hi) = heights
        .iter()
        .filter(|h| !h.is_nan())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &h| {
            (a.min(h), b.max(h))
        });
    let span = (hi - lo).max(1e-9);
    RgbImage::from_fn(frame.width, frame.height, |x, y| {
        let h = heights[(y * frame.width + x) as usize];
        let g = if h.is_nan() {
            255.0
        } else {
            LOW_GREY + (HIGH_GREY - LOW_GREY) * ((h - lo) / span)
        };
        let g = g.round().clamp(0.0, 255.0) as u8;
        image::Rgb([g, g, g])
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::scene::{SceneBuilder, UpAxis};

    fn two_boxes() -> Scene {
        let mut b = SceneBuilder::new("boxes");
        b.add_box(Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 10.0, 1.0));
        b.add_box(Vec3::new(2.0, 2.0, 0.0), Vec3::new(4.0, 4.0, 5.0));
        let mut s = b.finish();
        s.up = UpAxis::Z;
        s
    }

    fn frame() -> MapFrame {
        MapFrame::new([0.0, 0.0], [10.0, 10.0], 100, 100, 0.0)
    }

    #[test]
    fn empty_scene_has_no_heights() {
        let s = SceneBuilder::new("empty").finish();
        let h = height_map(&s, &Plan::new(UpAxis::Z), &frame());
        assert!(h.iter().all(|v| v.is_nan()));
    }

    #[test]
    fn tower_top_is_highest_and_ground_covers_the_rest() {
        let s = two_boxes();
        let f = frame();
        let h = height_map(&s, &Plan::new(UpAxis::Z), &f);
        let at = |u: f64, v: f64| {
            let (x, y) = f.pixel_of([u, v]);
            h[y as usize * f.width as usize + x as usize]
        };
        assert_eq!(at(3.0, 3.0), 5.0);
        assert_eq!(at(8.0, 8.0), 1.0);
        assert!(h.iter().all(|v| !v.is_nan()), "the base covers the map");
    }

    #[test]
    fn image_is_darker_on_the_tower() {
        let s = two_boxes();
        let f = frame();
        let img = footprint_image(&s, &Plan::new(UpAxis::Z), &f);
        let (tx, ty) = f.pixel_of([3.0, 3.0]);
        let (gx, gy) = f.pixel_of([8.0, 8.0]);
        let tower = img.get_pixel(tx as u32, ty as u32)[0];
        let ground = img.get_pixel(gx as u32, gy as u32)[0];
        assert!(tower < ground, "{tower} vs {ground}");
    }
}
