//! World to screen for the masked occlusion buffer and its neighbours: the view transform,
//! projection onto a pixel grid as `[sx, sy, 1/z]`, the clipping of triangles to the near plane
//! and a guard band, and the near-plane classification of boxes that the buffer's box test and
//! the HZB's ([`crate::Hzb`]) share.
//!
//! Based on: Hasselgren, Andersson, Akenine-Möller. Masked Software Occlusion Culling. 2016,
//! section 3 (triangles are clipped to a guard band around the screen, not to its edges, so
//! that only triangles crossing the near plane or reaching far outside the view are clipped;
//! the rasterizer's bounding box does the rest) and depth as `1/z`, affine in screen space.
//! Clipping itself is Sutherland-Hodgman polygon clipping against one plane at a time.

use glam::Vec3;
use sightline_core::{Aabb, Camera};

/// Triangles are clipped to a guard band of this many half-screens around the centre, up to
/// [`GUARD_PX`]. Measured side by side (twenty-fourth session, BENCHMARKS): 8 half-screens
/// instead of 4 send fewer of the large triangles next to the camera through the clipper
/// (czest3ctf frame 1.5-3.4 % faster, the city's 0-2.7 %, random sets unchanged); 16 gained
/// nothing more, 2 and 1.25 cost 5-27 %.
const GUARD: f32 = 8.0;

/// The guard band reaches at most this many pixels from the centre, which keeps screen
/// coordinates of buffers up to 32,768 px wide within 2^15, where `f32` steps are 1/256 px and
/// the spans are accurate to a few hundredths of a pixel, inside the tests' `COVER_MARGIN`; at
/// 1920x1080 (8 half-screens, at most 8,640 px) they are accurate to about 1/100 px. From
/// 4,096 px wide on, the band is this cap: 4 half-screens at 8,192 px (as every width had
/// before the twenty-fourth session), fewer beyond. The AVX2 block kernel counts span ends
/// within a block row in 16 bits (`avx2/blocks.rs`), which holds while the band is at most
/// 65,535 - 64 pixels wide.
const GUARD_PX: f32 = 16_384.0;

/// The guard band in half-screens for a screen `half` pixels from the centre to its edge.
fn guard_half_screens(half: f32) -> f32 {
    GUARD.min(GUARD_PX / half)
}

/// World to screen mapping of a camera onto the buffer's pixel grid.
#[derive(Clone, Copy, Debug)]
pub(super) struct Projector {
    pub eye: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub near: f32,
    /// `sx = kx * vx / vz + cx`, `sy = -ky * vy / vz + cy`.
    pub kx: f32,
    pub ky: f32,
    pub cx: f32,
    pub cy: f32,
    /// The guard band's half-width and half-height per unit of view depth.
    pub guard_x: f32,
    pub guard_y: f32,
    /// `cx + 1` and `cy + 1`: from the centre to a pixel beyond the screen's edges, for
    /// [`Projector::beside_view`].
    pub beyond_x: f32,
    pub beyond_y: f32,
}

/// One occluder or query triangle after the view transform, sorted by what drawing it needs.
pub(super) enum ViewTriangle {
    /// A corner is not finite.
    NotFinite,
    /// Every corner is behind the near plane.
    Behind,
    /// Every corner is in front of the near plane and inside the guard band: the screen
    /// triangle, `[sx, sy, 1/z]` per corner.
    Inside([[f32; 3]; 3]),
    /// It crosses the near plane or the guard band: the view-space corners, to be clipped.
    Clip([Vec3; 3]),
}

impl Projector {
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let (tan_x, tan_y) = (camera.tan_half_x(), camera.tan_half_y());
        let (cx, cy) = (width as f32 * 0.5, height as f32 * 0.5);
        Self {
            eye: camera.eye,
            right: camera.right,
            up: camera.up,
            forward: camera.forward,
            near: camera.near,
            kx: cx / tan_x,
            ky: cy / tan_y,
            cx,
            cy,
            guard_x: guard_half_screens(cx) * tan_x,
            guard_y: guard_half_screens(cy) * tan_y,
            beyond_x: cx + 1.0,
            beyond_y: cy + 1.0,
        }
    }

    /// View coordinates `(right, up, forward)` of a world point (`Camera::to_view`'s
    /// arithmetic, inlined).
    #[inline(always)]
    pub fn view(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        Vec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// Screen position and `1/z` of a view point with `z > 0`.
    #[inline(always)]
    pub fn screen(&self, v: Vec3) -> [f32; 3] {
        let r = 1.0 / v.z;
        [self.kx * v.x * r + self.cx, -self.ky * v.y * r + self.cy, r]
    }

    /// True when a view point needs no clipping: in front of the near plane, inside the guard band.
    #[inline(always)]
    pub fn inside_guard(&self, v: Vec3) -> bool {
        v.z >= self.near && v.x.abs() <= self.guard_x * v.z && v.y.abs() <= self.guard_y * v.z
    }

    /// Whether every corner of a view-space triangle lies beyond the same edge of the screen,
    /// a pixel out: then no part of it in front of the near plane reaches a pixel centre, and
    /// an occluder rasterizer can drop it instead of clipping it to nothing. In Quake 3 frames
    /// most triangles that cross the near plane or the guard band lie wholly beside the view
    /// (czest3ctf's frame 150: 137 of 142); the scalar clipper was 6 % of its rendering.
    ///
    /// Each edge is a plane through the eye (`sx < -1` is `kx x + (cx + 1) z < 0` for
    /// `z > 0`), so corners behind the camera are judged by the same test: a triangle in the
    /// half-space has every point there. The occluder kernels all call this, lane by lane with
    /// the same `f32` operations, so they drop the same triangles; dropping an occluder is
    /// conservative in any case (the buffer only gets farther), and the pixel's margin keeps
    /// it to triangles that would draw nothing.
    #[inline(always)]
    pub fn beside_view(&self, v: &[Vec3; 3]) -> bool {
        // Left, right, top, bottom.
        let mut beyond = [true; 4];
        for p in v {
            let (x, y) = (self.kx * p.x, self.ky * p.y);
            let (zx, zy) = (self.beyond_x * p.z, self.beyond_y * p.z);
            beyond[0] &= x + zx < 0.0;
            beyond[1] &= x - zx > 0.0;
            beyond[2] &= y - zy > 0.0;
            beyond[3] &= y + zy < 0.0;
        }
        beyond.contains(&true)
    }

    /// The triangle with world corners `t[0..3]` in view space, sorted by what drawing it
    /// needs (the occluder rasterizers skip the first two kinds, the triangle test calls a
    /// non-finite one visible).
    #[inline(always)]
    pub fn triangle(&self, t: &[Vec3]) -> ViewTriangle {
        let v = [self.view(t[0]), self.view(t[1]), self.view(t[2])];
        if !v.iter().all(|p| p.is_finite()) {
            ViewTriangle::NotFinite
        } else if v.iter().all(|p| p.z < self.near) {
            ViewTriangle::Behind
        } else if v.iter().all(|&p| self.inside_guard(p)) {
            ViewTriangle::Inside([self.screen(v[0]), self.screen(v[1]), self.screen(v[2])])
        } else {
            ViewTriangle::Clip(v)
        }
    }

    /// Clips a view-space triangle to the near plane and the guard band and calls `f` with the
    /// screen triangles of the fan of what is left, in order, until `f` returns true; true when
    /// it did. The occluder rasterizers and the triangle test share it, so that both see the
    /// same pieces.
    pub fn clipped_fan(&self, v: [Vec3; 3], mut f: impl FnMut([[f32; 3]; 3]) -> bool) -> bool {
        let (poly, n) = self.clip(v);
        // Clipped points lie on z = near at the least; clamp the rounding of the lerp.
        let s = |p: Vec3| self.screen(Vec3::new(p.x, p.y, p.z.max(self.near)));
        for i in 1..n.saturating_sub(1) {
            if f([s(poly[0]), s(poly[i]), s(poly[i + 1])]) {
                return true;
            }
        }
        false
    }

    /// Clips a view-space triangle to the near plane and the guard band (Sutherland-Hodgman:
    /// each plane adds at most one vertex, 3 + 5 = 8); the polygon and its vertex count, which
    /// is below 3 when nothing is left.
    fn clip(&self, v: [Vec3; 3]) -> ([Vec3; 9], usize) {
        let mut poly = [Vec3::ZERO; 9];
        let mut next = [Vec3::ZERO; 9];
        poly[..3].copy_from_slice(&v);
        let mut n = 3;
        for plane in self.planes() {
            let dist = |p: Vec3| plane[0] * p.x + plane[1] * p.y + plane[2] * p.z + plane[3];
            // Most triangles cross one or two of the five planes: a plane that every vertex
            // is inside of would copy the polygon unchanged.
            if poly[..n].iter().all(|&p| dist(p) >= 0.0) {
                continue;
            }
            let mut m = 0;
            for i in 0..n {
                // The next vertex without `%`: an integer division per edge was a third of the
                // clipping time.
                let (a, b) = (poly[i], poly[if i + 1 == n { 0 } else { i + 1 }]);
                let (da, db) = (dist(a), dist(b));
                if da >= 0.0 {
                    next[m] = a;
                    m += 1;
                }
                if (da >= 0.0) != (db >= 0.0) {
                    next[m] = a + (b - a) * (da / (da - db));
                    m += 1;
                }
            }
            std::mem::swap(&mut poly, &mut next);
            n = m;
            if n < 3 {
                return (poly, n);
            }
        }
        (poly, n)
    }

    /// The clipping planes in view space (`inside` when `dot >= 0` on `(x, y, z, 1)`).
    fn planes(&self) -> [[f32; 4]; 5] {
        let (gx, gy) = (self.guard_x, self.guard_y);
        [
            [0.0, 0.0, 1.0, -self.near],
            [-1.0, 0.0, gx, 0.0],
            [1.0, 0.0, gx, 0.0],
            [0.0, -1.0, gy, 0.0],
            [0.0, 1.0, gy, 0.0],
        ]
    }
}

/// A box against the near plane, from the view depths of its 8 corners.
pub(crate) enum BoxView {
    /// A corner's depth is not finite: the box test must call it visible.
    NotFinite,
    /// Entirely behind the near plane.
    Behind,
    /// Crossing the near plane: the box test calls it visible.
    CrossesNear,
    /// Entirely in front: the corners in view space and the nearest depth (the minimum view
    /// depth over a box is at a corner).
    InFront { corners: [Vec3; 8], zmin: f32 },
}

impl BoxView {
    /// The box's corners through `to_view` (the buffer's projector or the camera's own view
    /// transform, which compute the same) against the near plane at depth `near`.
    #[inline(always)]
    pub(crate) fn new(aabb: &Aabb, near: f32, to_view: impl Fn(Vec3) -> Vec3) -> Self {
        let mut zmin = f32::INFINITY;
        let mut zmax = f32::NEG_INFINITY;
        let mut corners = aabb.corners();
        for v in corners.iter_mut() {
            *v = to_view(*v);
            zmin = zmin.min(v.z);
            zmax = zmax.max(v.z);
        }
        if !(zmin.is_finite() && zmax.is_finite()) {
            BoxView::NotFinite
        } else if zmax < near {
            BoxView::Behind
        } else if zmin < near {
            BoxView::CrossesNear
        } else {
            BoxView::InFront { corners, zmin }
        }
    }
}

/// The screen rectangle `(x0, y0, x1, y1)` of view points through `to_screen` (their bounds;
/// `f32::min` / `max` pass over NaN, and with no number at all the rectangle is empty,
/// `x0 = +inf > x1 = -inf`).
#[inline(always)]
pub(crate) fn screen_bounds(
    corners: &[Vec3; 8],
    to_screen: impl Fn(Vec3) -> (f32, f32),
) -> (f32, f32, f32, f32) {
    let (mut x0, mut y0, mut x1, mut y1) = (
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    );
    for &v in corners {
        let (sx, sy) = to_screen(v);
        x0 = x0.min(sx);
        x1 = x1.max(sx);
        y0 = y0.min(sy);
        y1 = y1.max(sy);
    }
    (x0, y0, x1, y1)
}

/// `floor` as an integer without a libm call (`f32::floor` needs SSE4.1 to inline); values
/// beyond `i32` saturate, which the callers clamp anyway.
#[inline(always)]
pub(super) fn floor_i(x: f32) -> i32 {
    let i = x as i32;
    i - i32::from(x < i as f32)
}

/// `ceil` as an integer, see [`floor_i`].
#[inline(always)]
pub(super) fn ceil_i(x: f32) -> i32 {
    let i = x as i32;
    i + i32::from(x > i as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guard_band_keeps_screen_coordinates_below_two_to_the_fifteen() {
        for width in [64u32, 640, 1920, 3840, 4096, 8192, 16_384, 32_768] {
            let half = width as f32 * 0.5;
            let band = guard_half_screens(half);
            // The farthest screen coordinate inside the band.
            assert!(
                half + band * half <= 32_768.0,
                "{width}: {band} half-screens"
            );
            // Common sizes get the full band; the band never cuts into the screen.
            if width <= 3840 {
                assert_eq!(band, GUARD, "{width}");
            }
            assert!(band >= 1.0, "{width}: {band} half-screens");
        }
    }

    /// `beside_view` drops only triangles whose clipped pieces reach no pixel centre (so the
    /// rasterizers would draw nothing of them), corners behind the camera included, and it
    /// drops every triangle in front of the camera whose corners project a pixel and a half
    /// beyond one edge.
    #[test]
    fn triangles_beside_the_view_clip_to_pieces_that_reach_no_pixel_centre() {
        let (w, h) = (320u32, 180u32);
        let cam = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 70.0, w, h, 0.1).unwrap();
        let proj = Projector::new(&cam, w, h);
        let mut rng = sightline_core::random::SplitMix64::new(3);
        let (mut dropped, mut dropped_behind, mut missed) = (0, 0, 0);
        for i in 0..40_000 {
            let size = [0.5, 5.0, 40.0][i % 3];
            let c = Vec3::new(
                rng.range_f32(-80.0, 80.0),
                rng.range_f32(-80.0, 80.0),
                rng.range_f32(-10.0, 40.0),
            );
            let v: [Vec3; 3] = std::array::from_fn(|_| {
                c + Vec3::new(
                    rng.range_f32(-size, size),
                    rng.range_f32(-size, size),
                    rng.range_f32(-size, size),
                )
            });
            // The pieces' extent on screen.
            let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
            proj.clipped_fan(v, |s| {
                for p in s {
                    for k in 0..2 {
                        (lo[k], hi[k]) = (lo[k].min(p[k]), hi[k].max(p[k]));
                    }
                }
                false
            });
            let reaches_no_centre =
                hi[0] < 0.5 || lo[0] > w as f32 - 0.5 || hi[1] < 0.5 || lo[1] > h as f32 - 0.5;
            // Every corner in front and projected a pixel and a half beyond one edge.
            let corners = v.map(|p| proj.screen(p));
            let beyond = |f: &dyn Fn(&[f32; 3]) -> bool| corners.iter().all(f);
            let far_beyond = v.iter().all(|p| p.z > proj.near)
                && (beyond(&|p| p[0] < -1.5)
                    || beyond(&|p| p[0] > w as f32 + 1.5)
                    || beyond(&|p| p[1] < -1.5)
                    || beyond(&|p| p[1] > h as f32 + 1.5));
            if proj.beside_view(&v) {
                assert!(reaches_no_centre, "{v:?}: pieces in {lo:?}..{hi:?}");
                dropped += 1;
                dropped_behind += usize::from(v.iter().any(|p| p.z < 0.0));
            } else if far_beyond {
                missed += 1;
            }
        }
        assert!(
            dropped > 10_000 && dropped_behind > 1_000,
            "{dropped} {dropped_behind}"
        );
        assert_eq!(missed, 0);
    }
}
