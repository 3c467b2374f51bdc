//! Conservative 2D predicates on projected convex polygons: overlap by separating edges, the
//! overlap of a silhouette edge with a polygon, and the crossing-parity point-in-silhouette test.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 4.4 (convex polygons overlap, eq. 4.9) and chapter 5 (silhouette test: edge
//! overlap, then ray casting with crossing parity after Shimrat 1962).
//!
//! Every predicate errs on the side of "overlaps": two shapes count as separated only when an
//! edge line separates them by more than `margin` pixels. The margin covers the reference
//! rasterizer's snapping (1/256 px at 8x supersampling, i.e. 1/2048 px here) and rounding, so a
//! sample the rasterizer assigns to a shape is always inside that shape grown by the margin.

use glam::DVec2;

/// The default margin in pixels (of the RV camera's image): 8x the rasterizer's worst snapping
/// error at 8x supersampling.
pub(crate) const MARGIN_PX: f64 = 4e-3;

/// Axis-aligned bounding rectangle `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Rect {
    pub(crate) min: DVec2,
    pub(crate) max: DVec2,
}

impl Rect {
    /// The bounds of `points` (must be non-empty for a meaningful rectangle).
    pub(crate) fn of(points: &[DVec2]) -> Self {
        let mut r = Rect {
            min: DVec2::splat(f64::INFINITY),
            max: DVec2::splat(f64::NEG_INFINITY),
        };
        for p in points {
            r.min = r.min.min(*p);
            r.max = r.max.max(*p);
        }
        r
    }

    /// The smallest rectangle holding both.
    pub(crate) fn union(&self, o: &Rect) -> Rect {
        Rect {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True when the rectangles, each grown by `margin`, intersect.
    #[inline]
    pub(crate) fn touches(&self, o: &Rect, margin: f64) -> bool {
        self.min.x <= o.max.x + margin
            && o.min.x <= self.max.x + margin
            && self.min.y <= o.max.y + margin
            && o.min.y <= self.max.y + margin
    }

    /// True when `inner` grown by `margin` lies inside `self`.
    #[inline]
    pub(crate) fn contains(&self, inner: &Rect, margin: f64) -> bool {
        self.min.x <= inner.min.x - margin
            && self.min.y <= inner.min.y - margin
            && self.max.x >= inner.max.x + margin
            && self.max.y >= inner.max.y + margin
    }
}

/// True when the line through `a, b` has every point of `pts` strictly more than `margin` on
/// one side (the side away from `away_from` when given, else either side).
#[inline]
fn separates(a: DVec2, b: DVec2, pts: &[DVec2], margin: f64, own_side: Option<DVec2>) -> bool {
    let d = b - a;
    let len = d.length();
    if len == 0.0 || !len.is_finite() {
        return false;
    }
    // Signed distance of p from the line, positive to the left of a→b, times `len`: compared
    // with the margin times `len`, which saves a division per point (this runs for every edge
    // of every overlap test).
    let scaled = |p: DVec2| d.perp_dot(p - a);
    let m = margin * len;
    match own_side {
        Some(o) => {
            // Separating edge of a convex polygon: the other shape must lie on the side
            // opposite to the polygon's interior point `o`.
            let s = scaled(o);
            if s == 0.0 {
                return false;
            }
            pts.iter().all(|p| scaled(*p) * s.signum() < -m)
        }
        None => pts.iter().all(|p| scaled(*p) > m) || pts.iter().all(|p| scaled(*p) < -m),
    }
}

fn centroid(pts: &[DVec2]) -> DVec2 {
    pts.iter().copied().sum::<DVec2>() / pts.len().max(1) as f64
}

/// Eq. 4.9: convex polygons `p` and `q` overlap unless an edge of one separates them by more
/// than `margin`. Polygons may be given in either orientation; degenerate ones are handled
/// (they simply have fewer separating candidates, which is conservative).
pub(crate) fn convex_overlap(p: &[DVec2], q: &[DVec2], margin: f64) -> bool {
    if p.is_empty() || q.is_empty() {
        return false;
    }
    !(has_separating_edge(p, q, margin) || has_separating_edge(q, p, margin))
}

fn has_separating_edge(p: &[DVec2], q: &[DVec2], margin: f64) -> bool {
    let c = centroid(p);
    (0..p.len()).any(|i| {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        separates(a, b, q, margin, Some(c))
    })
}

/// The silhouette test's edge overlap (chapter 5): does the segment `a b` come within `margin`
/// of convex polygon `p`? The segment is a degenerate convex polygon whose only edge line is its
/// own, so eq. 4.9 needs the segment's line and `p`'s edges.
pub(crate) fn segment_overlaps(a: DVec2, b: DVec2, p: &[DVec2], margin: f64) -> bool {
    if p.is_empty() {
        return false;
    }
    if separates(a, b, p, margin, None) {
        return false;
    }
    !has_separating_edge(p, &[a, b], margin)
}

/// Crossing-parity test (Shimrat 1962): does a ray from `q` towards `+x` cross the segment
/// `a b`? Uses the half-open rule on `y`, so a ray through a shared vertex counts it once and
/// the parity over a closed chain of edges is exact. Only call it when no edge is near `q`.
#[inline]
pub(crate) fn ray_crosses(q: DVec2, a: DVec2, b: DVec2) -> bool {
    if (a.y > q.y) == (b.y > q.y) {
        return false;
    }
    let x = a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y);
    x > q.x
}

/// Signed crossing (winding-number form of [`ray_crosses`]): +1 when the directed edge `a→b`
/// crosses the `+x` ray from `q` going towards `+y`, -1 going towards `-y`, 0 otherwise. Summed
/// over a set of directed edges it is their winding number around `q` (same half-open rule, so
/// exact over closed chains).
#[inline]
pub(crate) fn ray_winding(q: DVec2, a: DVec2, b: DVec2) -> i32 {
    if !ray_crosses(q, a, b) {
        return 0;
    }
    if b.y > a.y {
        1
    } else {
        -1
    }
}

/// A point inside convex polygon `p` (its vertex centroid).
pub(crate) fn inner_point(p: &[DVec2]) -> DVec2 {
    centroid(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x: f64, y: f64, s: f64) -> Vec<DVec2> {
        vec![
            DVec2::new(x, y),
            DVec2::new(x + s, y),
            DVec2::new(x + s, y + s),
            DVec2::new(x, y + s),
        ]
    }

    #[test]
    fn overlap_of_empty_is_false() {
        assert!(!convex_overlap(&[], &square(0.0, 0.0, 1.0), 0.0));
    }

    #[test]
    fn overlap_separated_squares() {
        assert!(!convex_overlap(
            &square(0.0, 0.0, 1.0),
            &square(2.0, 0.0, 1.0),
            1e-3
        ));
    }

    #[test]
    fn overlap_touching_squares_counts() {
        assert!(convex_overlap(
            &square(0.0, 0.0, 1.0),
            &square(1.0, 0.0, 1.0),
            1e-3
        ));
    }

    #[test]
    fn overlap_within_margin_counts() {
        assert!(convex_overlap(
            &square(0.0, 0.0, 1.0),
            &square(1.0005, 0.0, 1.0),
            1e-3
        ));
    }

    #[test]
    fn overlap_diagonal_triangles_separated_by_hypotenuse() {
        let a = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
        ];
        let b = [
            DVec2::new(1.0, 1.0),
            DVec2::new(0.6, 1.0),
            DVec2::new(1.0, 0.6),
        ];
        assert!(!convex_overlap(&a, &b, 1e-3));
    }

    #[test]
    fn segment_through_square_overlaps() {
        let s = square(0.0, 0.0, 1.0);
        assert!(segment_overlaps(
            DVec2::new(-1.0, 0.5),
            DVec2::new(2.0, 0.5),
            &s,
            1e-3
        ));
        assert!(!segment_overlaps(
            DVec2::new(-1.0, 2.0),
            DVec2::new(2.0, 2.5),
            &s,
            1e-3
        ));
        // Collinear with an edge line but beyond the square's end.
        assert!(!segment_overlaps(
            DVec2::new(2.0, 0.0),
            DVec2::new(3.0, 0.0),
            &s,
            1e-3
        ));
    }

    #[test]
    fn parity_inside_square_is_odd() {
        let s = square(0.0, 0.0, 1.0);
        let q = DVec2::new(0.5, 0.5);
        let n = (0..4)
            .filter(|&i| ray_crosses(q, s[i], s[(i + 1) % 4]))
            .count();
        assert_eq!(n % 2, 1);
        let q = DVec2::new(-0.5, 0.5);
        let n = (0..4)
            .filter(|&i| ray_crosses(q, s[i], s[(i + 1) % 4]))
            .count();
        assert_eq!(n % 2, 0);
    }

    #[test]
    fn winding_counts_overlapping_squares() {
        // Two same-orientation squares over q: winding 2 (parity would say "outside").
        let (a, b) = (square(0.0, 0.0, 1.0), square(0.2, 0.2, 1.0));
        let q = DVec2::new(0.5, 0.5);
        let w: i32 = (0..4)
            .map(|i| ray_winding(q, a[i], a[(i + 1) % 4]) + ray_winding(q, b[i], b[(i + 1) % 4]))
            .sum();
        assert_eq!(w.abs(), 2);
    }
}
