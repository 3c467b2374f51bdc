//! Visible polygons from boundary segments: the oriented boundary segments of one triangle's
//! visible region in a bin are turned into trapezoids by a vertical slab decomposition with
//! winding numbers, and trapezoids between the same two segments in consecutive slabs are merged.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3 (the output is the set of boundary segments of all visible regions) and section
//! 4.4 (the regions are never built explicitly there; we build them for the API, the SVG and a
//! simple exact box filter).
//!
//! Every segment has its region on the left (`cross(b - a, p - a) > 0`, screen y down), so a
//! segment running towards `+x` has the region below it (larger y) and crossing it downwards
//! adds 1 to the winding number, a segment running towards `-x` subtracts 1. Where the winding
//! number is positive the region is covered. Winding numbers (instead of pairing segments)
//! make the result insensitive to duplicated or cancelling segments.

use glam::DVec2;

use super::boundary::Segment;

/// A convex piece of a visible region (a trapezoid with vertical sides), counter-clockwise.
pub(crate) type Piece = Vec<DVec2>;

/// `y` of the segment `a → b` at `x` (clamped to the segment).
#[inline]
fn y_at(a: DVec2, b: DVec2, x: f64) -> f64 {
    let t = ((x - a.x) / (b.x - a.x)).clamp(0.0, 1.0);
    a.y + t * (b.y - a.y)
}

/// Signed area of a polygon.
pub(crate) fn area(points: &[DVec2]) -> f64 {
    let n = points.len();
    let mut s = 0.0;
    for i in 0..n {
        let (p, q) = (points[i], points[(i + 1) % n]);
        s += p.x * q.y - p.y * q.x;
    }
    0.5 * s
}

/// Decomposes the region bounded by `segments` (all of one polygon) into convex pieces.
pub(crate) fn pieces(segments: &[Segment], out: &mut Vec<Piece>) {
    let mut xs: Vec<f64> = segments.iter().flat_map(|s| [s.1.x, s.2.x]).collect();
    xs.sort_unstable_by(f64::total_cmp);
    xs.dedup();
    // Open trapezoids: (lower segment, upper segment, x start).
    let mut open: Vec<(usize, usize, f64)> = Vec::new();
    let mut next_open = Vec::new();
    let mut spanning: Vec<(f64, usize)> = Vec::new();
    let flush = |(lo, hi, x0): (usize, usize, f64), x1: f64, out: &mut Vec<Piece>| {
        let (s, t) = (&segments[lo], &segments[hi]);
        let mut p = vec![
            DVec2::new(x0, y_at(s.1, s.2, x0)),
            DVec2::new(x1, y_at(s.1, s.2, x1)),
            DVec2::new(x1, y_at(t.1, t.2, x1)),
            DVec2::new(x0, y_at(t.1, t.2, x0)),
        ];
        p.dedup();
        if p.len() > 2 && p.first() == p.last() {
            p.pop();
        }
        if p.len() >= 3 && area(&p) > 0.0 {
            out.push(p);
        }
    };
    for w in xs.windows(2) {
        let (x0, x1) = (w[0], w[1]);
        let xm = 0.5 * (x0 + x1);
        spanning.clear();
        for (k, s) in segments.iter().enumerate() {
            let (a, b) = (s.1, s.2);
            if a.x != b.x && a.x.min(b.x) <= x0 && a.x.max(b.x) >= x1 {
                spanning.push((y_at(a, b, xm), k));
            }
        }
        spanning.sort_unstable_by(|p, q| p.0.total_cmp(&q.0));
        next_open.clear();
        let mut winding = 0i32;
        for i in 0..spanning.len() {
            let k = spanning[i].1;
            let s = &segments[k];
            winding += if s.2.x > s.1.x { 1 } else { -1 };
            if winding > 0 && i + 1 < spanning.len() {
                let k2 = spanning[i + 1].1;
                let start = open
                    .iter()
                    .position(|&(a, b, _)| a == k && b == k2)
                    .map(|j| open.swap_remove(j).2)
                    .unwrap_or(x0);
                next_open.push((k, k2, start));
            }
        }
        for o in open.drain(..) {
            flush(o, x0, out);
        }
        std::mem::swap(&mut open, &mut next_open);
        if let Some(&x_last) = xs.last() {
            if x1 == x_last {
                for o in open.drain(..) {
                    flush(o, x1, out);
                }
            }
        }
    }
}

/// Clips a convex polygon to the rectangle `[x0, x1] × [y0, y1]` (pixels, Sutherland–Hodgman).
pub(crate) fn clip_to_rect(poly: &[DVec2], rect: [f64; 4]) -> Vec<DVec2> {
    let mut a: Vec<DVec2> = poly.to_vec();
    let mut b = Vec::with_capacity(a.len() + 4);
    let planes = [
        (0, rect[0], true),
        (0, rect[2], false),
        (1, rect[1], true),
        (1, rect[3], false),
    ];
    for (axis, bound, above) in planes {
        b.clear();
        let coord = |p: DVec2| if axis == 0 { p.x } else { p.y };
        let inside = |p: DVec2| {
            if above {
                coord(p) >= bound
            } else {
                coord(p) <= bound
            }
        };
        let n = a.len();
        for i in 0..n {
            let (c, d) = (a[i], a[(i + 1) % n]);
            if inside(c) {
                b.push(c);
            }
            if inside(c) != inside(d) {
                let t = (bound - coord(c)) / (coord(d) - coord(c));
                let mut p = c + (d - c) * t;
                if axis == 0 {
                    p.x = bound;
                } else {
                    p.y = bound;
                }
                b.push(p);
            }
        }
        std::mem::swap(&mut a, &mut b);
        if a.len() < 3 {
            a.clear();
            return a;
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Segment {
        (0, DVec2::new(a.0, a.1), DVec2::new(b.0, b.1))
    }

    #[test]
    fn no_segments_gives_no_pieces() {
        let mut out = Vec::new();
        pieces(&[], &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn square_is_one_piece() {
        // Counter-clockwise in the y-down sense: (0,0) → (2,0) → (2,2) → (0,2).
        let s = [
            seg((0.0, 0.0), (2.0, 0.0)),
            seg((2.0, 0.0), (2.0, 2.0)),
            seg((2.0, 2.0), (0.0, 2.0)),
            seg((0.0, 2.0), (0.0, 0.0)),
        ];
        let mut out = Vec::new();
        pieces(&s, &mut out);
        assert_eq!(out.len(), 1);
        assert!((area(&out[0]) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn square_with_hole_has_right_area() {
        let s = [
            seg((0.0, 0.0), (4.0, 0.0)),
            seg((4.0, 0.0), (4.0, 4.0)),
            seg((4.0, 4.0), (0.0, 4.0)),
            seg((0.0, 4.0), (0.0, 0.0)),
            // Hole, clockwise.
            seg((1.0, 1.0), (1.0, 2.0)),
            seg((1.0, 2.0), (2.0, 2.0)),
            seg((2.0, 2.0), (2.0, 1.0)),
            seg((2.0, 1.0), (1.0, 1.0)),
        ];
        let mut out = Vec::new();
        pieces(&s, &mut out);
        let total: f64 = out.iter().map(|p| area(p)).sum();
        assert!((total - 15.0).abs() < 1e-12, "{total}");
    }

    #[test]
    fn triangle_is_one_piece() {
        let s = [
            seg((0.0, 0.0), (3.0, 1.0)),
            seg((3.0, 1.0), (1.0, 3.0)),
            seg((1.0, 3.0), (0.0, 0.0)),
        ];
        let mut out = Vec::new();
        pieces(&s, &mut out);
        let total: f64 = out.iter().map(|p| area(p)).sum();
        assert!((total - 4.0).abs() < 1e-12, "{total}");
    }
}
