//! A hierarchical depth buffer (HZB): a pyramid of the farthest depth over `2^k x 2^k` pixel
//! blocks, and a conservative box test that reads at most 3 x 3 texels of the level whose
//! texels are about the size of the box on screen.
//!
//! Based on: Greene, Kass, Miller. Hierarchical Z-Buffer Visibility. SIGGRAPH 1993, section 3
//! (the Z pyramid: each texel the farthest depth of the four below it; a box is hidden when
//! its nearest depth is behind the pyramid's value over its screen rectangle).
//!
//! Level 0 is built from the conservative per-pixel depth of an [`OcclusionBuffer`] (the
//! farthest depth an occluder guarantees at each pixel, infinity where none), so the test
//! inherits its conservativeness: the farthest of conservative depths is conservative. A box
//! is classified against the near plane as the buffer's box test does
//! (`masked_occlusion/project.rs`), but projected with the camera's own `view_to_screen`,
//! which rounds differently from the buffer's projector: the two tests keep their numbers.

use sightline_core::{Aabb, Camera};

use crate::masked_occlusion::project::{screen_bounds, BoxView};
use crate::masked_occlusion::{OcclusionBuffer, DEPTH_SLACK};

/// The depth pyramid. Depths are view depths (larger is farther); infinity is "nothing".
#[derive(Clone, Debug, Default)]
pub struct Hzb {
    /// `levels[k]` has `sizes[k]` texels, row-major.
    levels: Vec<Vec<f32>>,
    sizes: Vec<(u32, u32)>,
}

impl Hzb {
    /// An empty pyramid (every box visible until built).
    pub fn new() -> Self {
        Self::default()
    }

    /// Rebuilds the pyramid from the buffer's per-pixel conservative depth.
    pub fn build(&mut self, buffer: &OcclusionBuffer) {
        let (w, h) = (buffer.width(), buffer.height());
        self.sizes.clear();
        self.sizes.push((w, h));
        let mut level0 = self.levels.first().cloned().unwrap_or_default();
        level0.clear();
        level0.reserve((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                level0.push(buffer.depth_at(x, y).unwrap_or(f32::INFINITY));
            }
        }
        self.levels.truncate(1);
        if self.levels.is_empty() {
            self.levels.push(level0);
        } else {
            self.levels[0] = level0;
        }
        let (mut cw, mut ch) = (w, h);
        while cw > 1 || ch > 1 {
            // Odd sizes round up: the last texel of a row or column covers one source texel,
            // and reads past the edge are clamped to it (max is unchanged by repeats).
            let (nw, nh) = (cw.div_ceil(2), ch.div_ceil(2));
            let src = &self.levels[self.levels.len() - 1];
            let mut dst = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                let (y0, y1) = (2 * y, (2 * y + 1).min(ch - 1));
                for x in 0..nw {
                    let (x0, x1) = (2 * x, (2 * x + 1).min(cw - 1));
                    let at = |xx: u32, yy: u32| src[(yy * cw + xx) as usize];
                    dst.push(at(x0, y0).max(at(x1, y0)).max(at(x0, y1)).max(at(x1, y1)));
                }
            }
            self.levels.push(dst);
            self.sizes.push((nw, nh));
            (cw, ch) = (nw, nh);
        }
    }

    /// True when the box may be visible from `camera` (which must match the buffer the
    /// pyramid was built from): it crosses the near plane, or its nearest depth is in front of
    /// the farthest depth over its (one-pixel widened) screen rectangle. Boxes behind the
    /// camera or off screen are not visible; an unbuilt pyramid sees every box in view.
    pub fn test_box(&self, aabb: &Aabb, camera: &Camera) -> bool {
        let (corners, zmin) = match BoxView::new(aabb, camera.near, |c| camera.to_view(c)) {
            BoxView::NotFinite | BoxView::CrossesNear => return true,
            BoxView::Behind => return false,
            BoxView::InFront { corners, zmin } => (corners, zmin),
        };
        let (x0, y0, x1, y1) = screen_bounds(&corners, |v| camera.view_to_screen(v));
        let Some(&(w, h)) = self.sizes.first() else {
            return true;
        };
        // Pixels whose centres may be covered, widened by one pixel (as the occlusion buffer).
        let px0 = ((x0 - 0.5).ceil() - 1.0).max(0.0);
        let py0 = ((y0 - 0.5).ceil() - 1.0).max(0.0);
        let px1 = ((x1 - 0.5).floor() + 1.0).min(w as f32 - 1.0);
        let py1 = ((y1 - 0.5).floor() + 1.0).min(h as f32 - 1.0);
        if !(px0 <= px1 && py0 <= py1) {
            return false;
        }
        let (px0, py0, px1, py1) = (px0 as u32, py0 as u32, px1 as u32, py1 as u32);
        // The level where the rectangle spans at most 3 texels per axis.
        let mut k = 0;
        while k + 1 < self.levels.len()
            && ((px1 >> k) - (px0 >> k) > 2 || (py1 >> k) - (py0 >> k) > 2)
        {
            k += 1;
        }
        let (lw, _) = self.sizes[k];
        let lvl = &self.levels[k];
        let near = zmin * (1.0 - DEPTH_SLACK);
        for ty in py0 >> k..=py1 >> k {
            for tx in px0 >> k..=px1 >> k {
                if near < lvl[(ty * lw + tx) as usize] {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn wall_hides_box_behind_not_in_front() {
        let cam =
            Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 67, 45, 0.1).expect("camera");
        let mut b = OcclusionBuffer::new(67, 45);
        let (p, q, r, s) = (
            Vec3::new(-50.0, -50.0, -5.0),
            Vec3::new(50.0, -50.0, -5.0),
            Vec3::new(50.0, 50.0, -5.0),
            Vec3::new(-50.0, 50.0, -5.0),
        );
        let mut hzb = Hzb::new();
        let far = Aabb::new(Vec3::new(-1.0, -1.0, -12.0), Vec3::new(1.0, 1.0, -10.0));
        assert!(hzb.test_box(&far, &cam), "unbuilt: visible");
        hzb.build(&b);
        assert!(hzb.test_box(&far, &cam), "empty buffer: visible");
        b.render_occluders(&[p, q, r, p, r, s], &cam);
        hzb.build(&b);
        assert!(!hzb.test_box(&far, &cam));
        let near = Aabb::new(Vec3::new(-1.0, -1.0, -4.0), Vec3::new(1.0, 1.0, -3.0));
        assert!(hzb.test_box(&near, &cam));
        let behind_camera = Aabb::new(Vec3::new(-1.0, -1.0, 3.0), Vec3::new(1.0, 1.0, 4.0));
        assert!(!hzb.test_box(&behind_camera, &cam));
    }
}
