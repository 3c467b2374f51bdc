//! Triangle setup and pixel coverage: fixed-point edge functions with the top-left fill rule,
//! and the per-pixel depth of the triangle's plane.
//!
//! Based on: Pineda. A Parallel Algorithm for Polygon Rasterization. SIGGRAPH 1988 (edge
//! functions); the top-left fill rule of the Direct3D 10+ rasterization rules.
//!
//! Numeric conventions:
//! - Screen positions are snapped to 1/256 pixel (`SUBPIXEL_BITS = 8`, round half away from
//!   zero) and stored as i32; the guard band (see `clip.rs`) bounds them by 2^28.
//! - The centre of pixel `(x, y)` is `(256x + 128, 256y + 128)` in these units, so edge
//!   functions are evaluated *exactly* (i64, |value| < 2^60) at pixel centres.
//! - Triangles are double-sided: setup swaps two corners of a clockwise (screen, y down)
//!   triangle so every triangle has positive area `cross(v1 - v0, v2 - v0) > 0`.
//! - Fill rule (top-left): a pixel centre is covered when every edge function
//!   `E = cross(b - a, p - a)` is `> 0`, or `== 0` on a *top* edge (`dy == 0 && dx > 0`) or a
//!   *left* edge (`dy < 0`). A centre on an edge shared by two triangles (walked in opposite
//!   directions) is then owned by exactly one of them, and a centre on a vertex shared by a
//!   closed fan by exactly one triangle of the fan.
//! - Depth: `1/z` is affine in screen space; it is evaluated in f64 from the plane of the
//!   *unclipped, unsnapped* triangle at the pixel centre and stored as f32 view depth `z`.
//!   The depth test is `z < stored`, and on `z == stored` the lower triangle id wins (the rule of
//!   `trace::BruteForce`), so the result does not depend on the order triangles arrive in.

/// Sub-pixel precision: screen positions are snapped to `1 / (1 << SUBPIXEL_BITS)` pixel.
pub const SUBPIXEL_BITS: u32 = 8;
/// Fixed-point units per pixel.
const ONE: i64 = 1 << SUBPIXEL_BITS;
/// Half a pixel, the offset of a pixel centre.
const HALF: i64 = ONE / 2;

/// Snaps a screen coordinate (in pixels, within the guard band) to fixed point.
#[inline]
pub(crate) fn snap(s: f64) -> i32 {
    (s * ONE as f64).round() as i32
}

/// A triangle ready to rasterize: snapped corners with positive area, the pixel rectangle that
/// may hold covered pixel centres (inclusive, inside the image) and its depth plane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RasterTri {
    /// Corners in fixed point, ordered so that the signed area is positive.
    pub(crate) v: [[i32; 2]; 3],
    /// First and last pixel column.
    pub(crate) x0: u16,
    pub(crate) x1: u16,
    /// First and last pixel row.
    pub(crate) y0: u16,
    pub(crate) y1: u16,
    /// Triangle id in the scene.
    pub(crate) id: u32,
    /// `1/z = inv_z[0] * (x + 0.5) + inv_z[1] * (y + 0.5) + inv_z[2]` at pixel `(x, y)`.
    pub(crate) inv_z: [f64; 3],
}

/// `ceil(a / ONE)` for any sign.
#[inline]
fn div_ceil_one(a: i64) -> i64 {
    -((-a).div_euclid(ONE))
}

/// Sets up one snapped triangle for a `width × height` image. `None` when its snapped area is
/// zero or no pixel centre of the image lies in its bounding box.
pub(crate) fn setup(
    v: [[i32; 2]; 3],
    id: u32,
    inv_z: [f64; 3],
    width: u32,
    height: u32,
) -> Option<RasterTri> {
    let p = |i: usize| (i64::from(v[i][0]), i64::from(v[i][1]));
    let (ax, ay) = p(0);
    let (bx, by) = p(1);
    let (cx, cy) = p(2);
    let area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    if area == 0 {
        return None;
    }
    let v = if area > 0 { v } else { [v[0], v[2], v[1]] };
    let (min_x, max_x) = (ax.min(bx).min(cx), ax.max(bx).max(cx));
    let (min_y, max_y) = (ay.min(by).min(cy), ay.max(by).max(cy));
    // Pixel x is a candidate when its centre ONE*x + HALF lies in [min_x, max_x].
    let x0 = div_ceil_one(min_x - HALF).max(0);
    let x1 = (max_x - HALF).div_euclid(ONE).min(i64::from(width) - 1);
    let y0 = div_ceil_one(min_y - HALF).max(0);
    let y1 = (max_y - HALF).div_euclid(ONE).min(i64::from(height) - 1);
    if x0 > x1 || y0 > y1 {
        return None;
    }
    Some(RasterTri {
        v,
        x0: x0 as u16,
        x1: x1 as u16,
        y0: y0 as u16,
        y1: y1 as u16,
        id,
        inv_z,
    })
}

/// Bounding boxes at most this many pixels wide are scanned pixel by pixel; wider ones
/// compute each row's covered span with integer divisions (same pixels either way).
const NARROW: i64 = 16;

/// One edge function `E(p) = cross(b - a, p - a) + bias` prepared for stepping over pixels.
#[derive(Clone, Copy, Debug)]
struct Edge {
    /// `E` at the centre of the first pixel of the current row.
    row: i64,
    /// Change of `E` per pixel to the right.
    step_x: i64,
    /// Change of `E` per pixel down.
    step_y: i64,
}

impl Edge {
    /// The edge `a → b` evaluated at the centre of pixel `(x, y)`. The bias is 0 for top and
    /// left edges and -1 otherwise, so "covered" is simply `E + bias >= 0` for all edges.
    #[inline]
    fn new(a: [i32; 2], b: [i32; 2], x: i64, y: i64) -> Self {
        let (ax, ay) = (i64::from(a[0]), i64::from(a[1]));
        let dx = i64::from(b[0]) - ax;
        let dy = i64::from(b[1]) - ay;
        let top_left = dy < 0 || (dy == 0 && dx > 0);
        let bias = if top_left { 0 } else { -1 };
        let px = x * ONE + HALF;
        let py = y * ONE + HALF;
        Self {
            row: dx * (py - ay) - dy * (px - ax) + bias,
            step_x: -dy * ONE,
            step_y: dx * ONE,
        }
    }
}

/// A horizontal band of the frame, `rows` starting at image row `y_start`.
pub(crate) struct Band<'a> {
    /// Image width (row stride).
    pub(crate) width: u32,
    /// First image row of the band.
    pub(crate) y_start: u32,
    /// Triangle ids, row-major.
    pub(crate) ids: &'a mut [u32],
    /// View depths, row-major.
    pub(crate) depth: &'a mut [f32],
}

/// Rasterizes `t` into the rows of `band` it overlaps: depth test `z < stored`, ties to the
/// lower id; depths are clamped to at least `near` (snapping may move a covered centre a
/// fraction of a sub-pixel in front of the near plane).
#[inline]
pub(crate) fn rasterize(t: &RasterTri, band: &mut Band<'_>, near: f32) {
    let rows = (band.ids.len() / band.width.max(1) as usize) as u32;
    let y_first = u32::from(t.y0).max(band.y_start);
    let y_last = u32::from(t.y1).min(band.y_start + rows - 1);
    if y_first > y_last {
        return;
    }
    let (x0, x1) = (i64::from(t.x0), i64::from(t.x1));
    let mut e0 = Edge::new(t.v[0], t.v[1], x0, i64::from(y_first));
    let mut e1 = Edge::new(t.v[1], t.v[2], x0, i64::from(y_first));
    let mut e2 = Edge::new(t.v[2], t.v[0], x0, i64::from(y_first));
    let [a, b, c] = t.inv_z;
    let n = x1 - x0 + 1;
    for y in y_first..=y_last {
        let row_base = ((y - band.y_start) * band.width) as usize;
        let row_c = b * (f64::from(y) + 0.5) + c;
        let mut shade = |x: i64| {
            let inv = a * (x as f64 + 0.5) + row_c;
            if inv > 0.0 {
                let z = ((1.0 / inv) as f32).max(near);
                let i = row_base + x as usize;
                let (zd, id) = (band.depth[i], band.ids[i]);
                if z < zd || (z == zd && t.id < id) {
                    band.depth[i] = z;
                    band.ids[i] = t.id;
                }
            }
        };
        if n <= NARROW {
            // Narrow rows: testing each pixel is cheaper than the span's integer divisions.
            let (mut w0, mut w1, mut w2) = (e0.row, e1.row, e2.row);
            for x in x0..=x1 {
                if (w0 | w1 | w2) >= 0 {
                    shade(x);
                }
                w0 += e0.step_x;
                w1 += e1.step_x;
                w2 += e2.step_x;
            }
        } else if let Some((lo, hi)) = covered_span([&e0, &e1, &e2], n) {
            for x in x0 + lo..=x0 + hi {
                shade(x);
            }
        }
        e0.row += e0.step_y;
        e1.row += e1.step_y;
        e2.row += e2.step_y;
    }
}

/// The pixels `k` in `0..n` of the current row (counted from the row's first candidate pixel)
/// where all three biased edge functions `row + k * step_x` are `>= 0`, as an inclusive range.
/// Exact integer arithmetic: it selects the same pixels as testing every pixel.
#[inline]
fn covered_span(edges: [&Edge; 3], n: i64) -> Option<(i64, i64)> {
    let (mut lo, mut hi) = (0i64, n - 1);
    for e in edges {
        let (r, s) = (e.row, e.step_x);
        if s > 0 {
            // Increasing along the row: k >= ceil(-r / s).
            if r < 0 {
                lo = lo.max((-r + s - 1) / s);
            }
        } else if s < 0 {
            // Decreasing: k <= floor(r / -s).
            if r < 0 {
                return None;
            }
            hi = hi.min(r / -s);
        } else if r < 0 {
            return None;
        }
    }
    (lo <= hi).then_some((lo, hi))
}

/// Coverage-count mode: adds 1 to `counts` for every pixel centre `t` covers (no depth test).
pub(crate) fn count_coverage(t: &RasterTri, width: u32, counts: &mut [u32]) {
    let (x0, x1) = (i64::from(t.x0), i64::from(t.x1));
    let y0 = i64::from(t.y0);
    let mut e0 = Edge::new(t.v[0], t.v[1], x0, y0);
    let mut e1 = Edge::new(t.v[1], t.v[2], x0, y0);
    let mut e2 = Edge::new(t.v[2], t.v[0], x0, y0);
    let n = x1 - x0 + 1;
    for y in t.y0..=t.y1 {
        let row = y as usize * width as usize;
        if let Some((lo, hi)) = covered_span([&e0, &e1, &e2], n) {
            for x in x0 + lo..=x0 + hi {
                counts[row + x as usize] += 1;
            }
        }
        debug_assert!(
            (0..n).all(|k| {
                let inside = [&e0, &e1, &e2].iter().all(|e| e.row + k * e.step_x >= 0);
                inside
                    == covered_span([&e0, &e1, &e2], n).is_some_and(|(lo, hi)| lo <= k && k <= hi)
            }),
            "span differs from per-pixel edge tests"
        );
        e0.row += e0.step_y;
        e1.row += e1.step_y;
        e2.row += e2.step_y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fixed-point position of pixel coordinate `p` (in pixels).
    fn fx(x: f64, y: f64) -> [i32; 2] {
        [snap(x), snap(y)]
    }

    /// Which pixels of a `w × h` image triangle `v` covers.
    fn covered(v: [[i32; 2]; 3], w: u32, h: u32) -> Vec<u32> {
        let mut counts = vec![0; (w * h) as usize];
        if let Some(t) = setup(v, 0, [0.0, 0.0, 1.0], w, h) {
            count_coverage(&t, w, &mut counts);
        }
        counts
    }

    #[test]
    fn centre_on_left_edge_is_covered() {
        // Left edge x = 1.5 passes through the centre of pixel (1, 1).
        let c = covered([fx(1.5, 0.0), fx(1.5, 4.0), fx(4.0, 2.0)], 4, 4);
        assert_eq!(c[4 + 1], 1);
    }

    #[test]
    fn centre_on_right_edge_is_not_covered() {
        // Right edge x = 2.5 passes through the centre of pixel (2, 1).
        let c = covered([fx(2.5, 0.0), fx(2.5, 4.0), fx(0.0, 2.0)], 4, 4);
        assert_eq!(c[4 + 2], 0);
        assert_eq!(c[4 + 1], 1);
    }

    #[test]
    fn centre_on_top_edge_is_covered() {
        // Horizontal top edge y = 1.5 through the centre of pixel (1, 1), interior below.
        let c = covered([fx(0.0, 1.5), fx(4.0, 1.5), fx(2.0, 4.0)], 4, 4);
        assert_eq!(c[4 + 1], 1);
    }

    #[test]
    fn centre_on_bottom_edge_is_not_covered() {
        // Horizontal bottom edge y = 1.5, interior above.
        let c = covered([fx(0.0, 1.5), fx(4.0, 1.5), fx(2.0, -2.0)], 4, 4);
        assert_eq!(c[4 + 1], 0);
        assert_eq!(c[1], 1);
    }

    #[test]
    fn winding_does_not_matter() {
        let a = [fx(0.2, 0.3), fx(3.7, 1.1), fx(1.4, 3.9)];
        let b = [a[0], a[2], a[1]];
        assert_eq!(covered(a, 4, 4), covered(b, 4, 4));
        assert!(covered(a, 4, 4).contains(&1));
    }

    #[test]
    fn shared_diagonal_through_centres_covered_once() {
        // The diagonal of the square [0,4]² passes through every pixel centre (i+.5, i+.5).
        let (p, q, r, s) = (fx(0.0, 0.0), fx(4.0, 0.0), fx(4.0, 4.0), fx(0.0, 4.0));
        let a = covered([p, q, r], 4, 4);
        let b = covered([p, r, s], 4, 4);
        for i in 0..16 {
            assert_eq!(a[i] + b[i], 1, "pixel {i}");
        }
    }

    #[test]
    fn zero_area_triangle_is_skipped() {
        let v = [fx(0.0, 0.0), fx(1.0, 1.0), fx(2.0, 2.0)];
        assert!(setup(v, 0, [0.0; 3], 4, 4).is_none());
    }

    #[test]
    fn triangle_between_centres_is_skipped() {
        let v = [fx(0.6, 0.6), fx(1.4, 0.6), fx(0.6, 1.4)];
        assert!(setup(v, 0, [0.0; 3], 4, 4).is_none());
    }
}
