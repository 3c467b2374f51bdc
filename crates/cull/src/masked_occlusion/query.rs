//! The queries of the masked occlusion buffer: boxes, screen rectangles at a depth, and an
//! object's own triangles, each conservative (it may call a hidden thing visible, never the
//! reverse), and the conservative depth of a pixel.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016
//! (the occludee test: a screen rectangle at the occludee's nearest depth against the tiles'
//! reference and working layers, tile by tile); Andersson, Hasselgren, Akenine-Möller. Masked
//! Depth Culling for Graphics Hardware. 2015, section 3 (what the two layers guarantee). The
//! triangle test is ours: the same tile test per pixel of a triangle's widened coverage, at
//! the nearest depth of its plane over each pixel's widening (see
//! [`OcclusionBuffer::test_triangles`](super::OcclusionBuffer::test_triangles)).

use glam::Vec3;
use sightline_core::{Aabb, Camera};

use super::constants::{COVER_MARGIN, DEPTH_SLACK, TILE_H, TILE_W};
use super::project::{ceil_i, floor_i, screen_bounds, BoxView, Projector, ViewTriangle};
use super::tiles::Tiles;

/// Pixel centres under a widened screen triangle's bounding box.
enum CentreRange {
    /// A corner is not finite: the caller must stay conservative.
    NotFinite,
    /// No pixel centre of the image.
    Empty,
    /// Inclusive `(col0, col1, row0, row1)`.
    Pixels((i32, i32, i32, i32)),
}

impl Tiles {
    /// [`OcclusionBuffer::test_box`](super::OcclusionBuffer::test_box).
    pub fn test_box(&self, aabb: &Aabb, camera: &Camera) -> bool {
        let proj = Projector::new(camera, self.width, self.height);
        let (corners, zmin) = match BoxView::new(aabb, proj.near, |c| proj.view(c)) {
            BoxView::NotFinite | BoxView::CrossesNear => return true,
            BoxView::Behind => return false,
            BoxView::InFront { corners, zmin } => (corners, zmin),
        };
        let (x0, y0, x1, y1) = screen_bounds(&corners, |v| {
            let [sx, sy, _] = proj.screen(v);
            (sx, sy)
        });
        // Pixel centres in [x0, x1] widened by one pixel on each side (see the module docs of
        // the buffer).
        let px0 = (x0 - 0.5).ceil() - 1.0;
        let px1 = (x1 - 0.5).floor() + 2.0;
        let py0 = (y0 - 0.5).ceil() - 1.0;
        let py1 = (y1 - 0.5).floor() + 2.0;
        let clamp_x = |v: f32| v.clamp(0.0, self.width as f32) as u32;
        let clamp_y = |v: f32| v.clamp(0.0, self.height as f32) as u32;
        self.test_rect_depth(clamp_x(px0), clamp_y(py0), clamp_x(px1), clamp_y(py1), zmin)
    }

    /// [`OcclusionBuffer::test_rect_depth`](super::OcclusionBuffer::test_rect_depth): tile by
    /// tile, a tile skipped when its reference layer is nearer than the depth.
    pub fn test_rect_depth(&self, x0: u32, y0: u32, x1: u32, y1: u32, nearest_depth: f32) -> bool {
        let (x1, y1) = (x1.min(self.width), y1.min(self.height));
        if x0 >= x1 || y0 >= y1 {
            return false;
        }
        if nearest_depth.is_nan() || nearest_depth <= 0.0 {
            return true;
        }
        let r = (1.0 / nearest_depth) * (1.0 + DEPTH_SLACK);
        for ty in y0 / TILE_H..=(y1 - 1) / TILE_H {
            let rlo = y0.saturating_sub(ty * TILE_H).min(TILE_H);
            let rhi = (y1 - ty * TILE_H).min(TILE_H);
            let rows = ((1u64 << (TILE_W * rhi)) - (1u64 << (TILE_W * rlo))) as u32;
            for tx in x0 / TILE_W..=(x1 - 1) / TILE_W {
                let t = self.tile(tx, ty);
                if r < t.z0 {
                    continue;
                }
                let clo = x0.saturating_sub(tx * TILE_W).min(TILE_W);
                let chi = (x1 - tx * TILE_W).min(TILE_W);
                let cols = (1u32 << chi) - (1u32 << clo);
                let q = cols.wrapping_mul(0x0101_0101) & rows;
                if q & !t.mask != 0 || r >= t.z1 {
                    return true;
                }
            }
        }
        false
    }

    /// [`OcclusionBuffer::depth_at`](super::OcclusionBuffer::depth_at).
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let t = self.tile(x / TILE_W, y / TILE_H);
        let bit = 1u32 << ((y % TILE_H) * TILE_W + x % TILE_W);
        let r = if t.mask & bit != 0 { t.z1 } else { t.z0 };
        Some(if r > 0.0 { 1.0 / r } else { f32::INFINITY })
    }

    /// [`OcclusionBuffer::covers_pixel_centre`](super::OcclusionBuffer::covers_pixel_centre).
    pub fn covers_pixel_centre(&self, triangles: &[Vec3], camera: &Camera) -> bool {
        let proj = Projector::new(camera, self.width, self.height);
        self.any_screen_triangle(triangles, &proj, |s| {
            self.screen_triangle_covers_centre(s, COVER_MARGIN)
        })
    }

    /// [`OcclusionBuffer::test_triangles`](super::OcclusionBuffer::test_triangles) with the
    /// coverage widened by `widen` pixels.
    pub fn test_triangles_widened(&self, triangles: &[Vec3], camera: &Camera, widen: f32) -> bool {
        let proj = Projector::new(camera, self.width, self.height);
        self.any_screen_triangle(triangles, &proj, |s| {
            self.screen_triangle_covers_centre(s, COVER_MARGIN)
        }) && self.any_screen_triangle(triangles, &proj, |s| self.test_screen_triangle(s, widen))
    }

    /// True when `f` holds for some screen triangle (`[sx, sy, 1/z]` per corner) of the
    /// triangles clipped to the near plane and the guard band, or some corner is not finite.
    fn any_screen_triangle(
        &self,
        triangles: &[Vec3],
        proj: &Projector,
        mut f: impl FnMut([[f32; 3]; 3]) -> bool,
    ) -> bool {
        for t in triangles.chunks_exact(3) {
            match proj.triangle(t) {
                ViewTriangle::NotFinite => return true,
                ViewTriangle::Behind => {}
                ViewTriangle::Inside(s) => {
                    if f(s) {
                        return true;
                    }
                }
                // Clipped to the near plane and the guard band, then fanned out (as the
                // occluder rasterizers do).
                ViewTriangle::Clip(v) => {
                    if proj.clipped_fan(v, &mut f) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The pixel centres (inclusive columns and rows, clamped to the image) inside the
    /// bounding box of screen triangle `p` (`[sx, sy, 1/z]` per corner) grown by `margin`.
    fn widened_centres(&self, p: [[f32; 3]; 3], margin: f32) -> CentreRange {
        let xmin = p[0][0].min(p[1][0]).min(p[2][0]) - margin;
        let xmax = p[0][0].max(p[1][0]).max(p[2][0]) + margin;
        let ymin = p[0][1].min(p[1][1]).min(p[2][1]) - margin;
        let ymax = p[0][1].max(p[1][1]).max(p[2][1]) + margin;
        if !(xmin.is_finite() && xmax.is_finite() && ymin.is_finite() && ymax.is_finite()) {
            return CentreRange::NotFinite;
        }
        let col0 = ceil_i(xmin - 0.5).max(0);
        let col1 = floor_i(xmax - 0.5).min(self.width as i32 - 1);
        let row0 = ceil_i(ymin - 0.5).max(0);
        let row1 = floor_i(ymax - 0.5).min(self.height as i32 - 1);
        if col0 > col1 || row0 > row1 {
            CentreRange::Empty
        } else {
            CentreRange::Pixels((col0, col1, row0, row1))
        }
    }

    /// True when the screen triangle, widened by `margin` pixels, contains a pixel centre of
    /// the image. Row by row: each edge bounds the row's span from one side.
    fn screen_triangle_covers_centre(&self, p: [[f32; 3]; 3], margin: f32) -> bool {
        let (col0, col1, row0, row1) = match self.widened_centres(p, margin) {
            CentreRange::NotFinite => return true,
            CentreRange::Empty => return false,
            CentreRange::Pixels(r) => r,
        };
        let (d1x, d1y) = (p[1][0] - p[0][0], p[1][1] - p[0][1]);
        let (d2x, d2y) = (p[2][0] - p[0][0], p[2][1] - p[0][1]);
        let area = d1x * d2y - d1y * d2x;
        // Too thin to orient reliably in `f32`: its widened bounding box holds a centre.
        if area.is_nan() || area.abs() < 1e-2 {
            return true;
        }
        let q = if area > 0.0 { p } else { [p[0], p[2], p[1]] };
        for y in row0..=row1 {
            let fy = y as f32 + 0.5;
            let (mut lo, mut hi) = (col0 as f32 + 0.5, col1 as f32 + 0.5);
            for i in 0..3 {
                let (a, b) = (q[i], q[(i + 1) % 3]);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                // E(x) = dx (y - ay) - dy (x - ax) + margin (|dx| + |dy|) >= 0.
                let c = dx * (fy - a[1]) + dy * a[0] + margin * (dx.abs() + dy.abs());
                if dy > 0.0 {
                    hi = hi.min(c / dy);
                } else if dy < 0.0 {
                    lo = lo.max(c / dy);
                } else if c < 0.0 {
                    hi = f32::NEG_INFINITY;
                }
            }
            if lo <= hi && ceil_i(lo - 0.5) <= floor_i(hi - 0.5) {
                return true;
            }
        }
        false
    }

    /// One screen triangle (`[sx, sy, 1/z]` per corner) against the buffer: true when some
    /// pixel of its coverage widened by `widen` pixels is not covered by a nearer occluder.
    fn test_screen_triangle(&self, p: [[f32; 3]; 3], widen: f32) -> bool {
        let (col0, col1, row0, row1) = match self.widened_centres(p, widen) {
            CentreRange::NotFinite => return true,
            CentreRange::Empty => return false,
            CentreRange::Pixels(r) => r,
        };
        let r_corner = p[0][2].max(p[1][2]).max(p[2][2]);
        let (d1x, d1y, d1r) = (p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]);
        let (d2x, d2y, d2r) = (p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]);
        let area = d1x * d2y - d1y * d2x;
        // Below a pixel of area the orientation and the depth gradient are unreliable in
        // `f32`: the widened bounding box at the nearest corner's depth stands for the sliver
        // (`test_rect_depth` adds the slack).
        if area.is_nan() || area.abs() < 1.0 {
            return self.test_rect_depth(
                col0 as u32,
                row0 as u32,
                col1 as u32 + 1,
                row1 as u32 + 1,
                1.0 / r_corner,
            );
        }
        let r_near = r_corner * (1.0 + DEPTH_SLACK);
        // Counter-clockwise in y-down screen space as `area > 0`: interior where every edge
        // function is >= 0. Widening moves each edge outward by `widen` pixels in both axes
        // (the Minkowski sum with a square, together with the widened bounding box).
        let q = if area > 0.0 { p } else { [p[0], p[2], p[1]] };
        let mut ex = [0.0f32; 3];
        let mut ey = [0.0f32; 3];
        let mut ec = [0.0f32; 3];
        for i in 0..3 {
            let (a, b) = (q[i], q[(i + 1) % 3]);
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            // E(x, y) = dx (y - ay) - dy (x - ax) + widen (|dx| + |dy|)
            ex[i] = -dy;
            ey[i] = dx;
            ec[i] = dy * a[0] - dx * a[1] + widen * (dx.abs() + dy.abs());
        }
        // 1/z over the screen: r = r0 + ra (x - x0) + rb (y - y0); a pixel stands for the
        // pixels within `widen` of it, so its depth is the plane's nearest over that square.
        let ra = (d1r * d2y - d2r * d1y) / area;
        let rb = (d2r * d1x - d1r * d2x) / area;
        let margin = widen * (ra.abs() + rb.abs());
        let plane = |x: f32, y: f32| p[0][2] + ra * (x - p[0][0]) + rb * (y - p[0][1]) + margin;
        let r_at = |x: f32, y: f32| (plane(x, y) * (1.0 + DEPTH_SLACK)).min(r_near);
        for ty in row0 as u32 / TILE_H..=row1 as u32 / TILE_H {
            let ya = (ty * TILE_H).max(row0 as u32);
            let yb = (ty * TILE_H + TILE_H - 1).min(row1 as u32);
            for tx in col0 as u32 / TILE_W..=col1 as u32 / TILE_W {
                let xa = (tx * TILE_W).max(col0 as u32);
                let xb = (tx * TILE_W + TILE_W - 1).min(col1 as u32);
                let t = self.tile(tx, ty);
                // The plane is affine: its nearest value over the tile's pixels is at a corner.
                let (fxa, fxb) = (xa as f32 + 0.5, xb as f32 + 0.5);
                let (fya, fyb) = (ya as f32 + 0.5, yb as f32 + 0.5);
                let r_tile = r_at(fxa, fya)
                    .max(r_at(fxb, fya))
                    .max(r_at(fxa, fyb))
                    .max(r_at(fxb, fyb));
                if r_tile < t.z0 {
                    continue;
                }
                for y in ya..=yb {
                    let fy = y as f32 + 0.5;
                    for x in xa..=xb {
                        let fx = x as f32 + 0.5;
                        let inside = (0..3).all(|i| ex[i] * fx + ey[i] * fy + ec[i] >= 0.0);
                        if !inside {
                            continue;
                        }
                        let bit = 1u32 << ((y % TILE_H) * TILE_W + x % TILE_W);
                        let stored = if t.mask & bit != 0 { t.z1 } else { t.z0 };
                        if r_at(fx, fy) >= stored {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use sightline_core::{Aabb, Camera};

    use super::super::OcclusionBuffer;

    fn camera(w: u32, h: u32) -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, w, h, 0.1).expect("camera")
    }

    fn wall(z: f32, half: f32) -> Vec<Vec3> {
        let a = Vec3::new(-half, -half, z);
        let b = Vec3::new(half, -half, z);
        let c = Vec3::new(half, half, z);
        let d = Vec3::new(-half, half, z);
        vec![a, b, c, a, c, d]
    }

    fn unit_box_at(z: f32) -> Aabb {
        Aabb::new(Vec3::new(-0.5, -0.5, z - 0.5), Vec3::new(0.5, 0.5, z + 0.5))
    }

    #[test]
    fn empty_buffer_sees_every_box_in_view() {
        let b = OcclusionBuffer::new(64, 48);
        assert!(b.test_box(&unit_box_at(-10.0), &camera(64, 48)));
        assert_eq!(b.depth_at(3, 3), Some(f32::INFINITY));
    }

    #[test]
    fn empty_occluder_list_changes_nothing() {
        let mut b = OcclusionBuffer::new(64, 48);
        b.render_occluders(&[], &camera(64, 48));
        assert!(b.same_contents(&OcclusionBuffer::new(64, 48)));
    }

    #[test]
    fn full_screen_wall_hides_box_behind_and_not_in_front() {
        let cam = camera(61, 37);
        let mut b = OcclusionBuffer::new(61, 37);
        b.render_occluders(&wall(-5.0, 100.0), &cam);
        assert!(!b.test_box(&unit_box_at(-8.0), &cam));
        assert!(b.test_box(&unit_box_at(-3.0), &cam));
        // Straddling the wall: its near face is in front.
        assert!(b.test_box(&unit_box_at(-5.2), &cam));
        let d = b.depth_at(30, 18).expect("inside");
        assert!((d - 5.0).abs() < 1e-3, "{d}");
    }

    #[test]
    fn box_behind_camera_or_off_screen_is_not_visible() {
        let cam = camera(64, 64);
        let b = OcclusionBuffer::new(64, 64);
        assert!(!b.test_box(&unit_box_at(10.0), &cam));
        let side = Aabb::new(Vec3::new(100.0, 0.0, -2.0), Vec3::new(101.0, 1.0, -1.0));
        assert!(!b.test_box(&side, &cam));
    }

    #[test]
    fn box_crossing_near_plane_is_visible() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        b.render_occluders(&wall(-1.0, 100.0), &cam);
        assert!(b.test_box(&unit_box_at(0.0), &cam));
    }

    #[test]
    fn wall_crossing_near_plane_is_clipped_and_still_occludes() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        // A slanted wall z = -10 - 0.15 y: it fills the view and its lower corners lie
        // behind the camera.
        let (p, q, r, s) = (
            Vec3::new(-100.0, -100.0, 5.0),
            Vec3::new(100.0, -100.0, 5.0),
            Vec3::new(100.0, 100.0, -25.0),
            Vec3::new(-100.0, 100.0, -25.0),
        );
        b.render_occluders(&[p, q, r, p, r, s], &cam);
        assert!(!b.test_box(&unit_box_at(-30.0), &cam));
    }

    #[test]
    fn small_hole_keeps_box_visible() {
        let cam = camera(64, 64);
        let mut b = OcclusionBuffer::new(64, 64);
        // A wall with a 0.4-wide square hole in the middle (four quads around it).
        let z = -5.0;
        let quad = |x0: f32, y0: f32, x1: f32, y1: f32| {
            let (a, bb, c, d) = (
                Vec3::new(x0, y0, z),
                Vec3::new(x1, y0, z),
                Vec3::new(x1, y1, z),
                Vec3::new(x0, y1, z),
            );
            vec![a, bb, c, a, c, d]
        };
        let mut tris = quad(-50.0, -50.0, 50.0, -0.2);
        tris.extend(quad(-50.0, 0.2, 50.0, 50.0));
        tris.extend(quad(-50.0, -0.2, -0.2, 0.2));
        tris.extend(quad(0.2, -0.2, 50.0, 0.2));
        b.render_occluders(&tris, &cam);
        assert!(b.test_box(&unit_box_at(-10.0), &cam));
        let far_side = Aabb::new(Vec3::new(2.0, 2.0, -12.0), Vec3::new(3.0, 3.0, -10.0));
        assert!(!b.test_box(&far_side, &cam));
    }

    #[test]
    fn empty_rect_is_not_visible() {
        let b = OcclusionBuffer::new(16, 16);
        assert!(!b.test_rect_depth(5, 5, 5, 9, 1.0));
        assert!(b.test_rect_depth(0, 0, 16, 16, 1.0));
    }

    #[test]
    fn clear_forgets_occluders() {
        let cam = camera(32, 32);
        let mut b = OcclusionBuffer::new(32, 32);
        b.render_occluders(&wall(-5.0, 100.0), &cam);
        b.clear();
        assert!(b.test_box(&unit_box_at(-8.0), &cam));
    }
}
