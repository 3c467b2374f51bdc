//! Intersecting triangles: the projected intersection segment of two polygons whose depth order
//! flips, added as an edge of both, so that each side of it is resolved with the right order.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! sections 3.1-3.2 (edges, hidden-line elimination). The paper assumes triangles that do not
//! intersect; this step is ours, built from the paper's own parts.
//!
//! # How
//! Two polygons `T` and `U` of a bin intersect when their `1/z` planes cross inside both
//! projections. The screen line where the planes are equal, clipped to the intersection of the
//! two convex projections, is the segment `S` (the projection of the 3D intersection segment).
//! On one side of `S`, `T` is in front of `U`; on the other side, `U` is. So `S` is an edge of
//! the part of `T` in front of `U` (directed with that part on its left, like every polygon
//! edge) and, reversed, an edge of the part of `U` in front of `T`. Hidden-line elimination on
//! `S` against the other polygons of the bin gives the parts of `S` where it bounds `T`'s (and,
//! reversed, `U`'s) visible region; no boundary completion is needed along `S`, since its two
//! sides are the two polygons themselves.
//!
//! The other half of the work is in `intersect.rs` and `boundary.rs`: an overlap along which
//! the order of two polygons flips is split at the flip ([`Order::Flips`]), and the pair is
//! recorded. The end points of `S` are those flip points on the edges of `T` and `U`, computed
//! by the same function from the same numbers, so the boundary segments meet bit for bit.
//!
//! # Which pairs
//! Every pair whose order flips inside a bin is found there: an end of `S` inside the bin lies
//! on an edge of `T` or `U` processed in the bin, and a segment `S` crossing the bin's border
//! flips the order of the two polygons along that border edge. `S` itself is computed from the
//! whole polygons, so every bin gets the same segment and clips it to its rectangle.

use glam::DVec2;

use super::bin::{Bin, BinIndex, Polys};
use super::boundary::Segment;
use super::hidden_line::{self, Event};
use super::intersect::{
    collinear_side, depth_of, depth_order, intersect, may_be_in_front, narrow, Counters, Edge,
    Line, Order, Overlap, Side,
};
use super::project::GRID;

/// Flip points closer than this (pixels, a thousandth of a grid unit) are one flip computed
/// twice: the winding-number pieces of `polygon.rs` are blind to a gap this small.
const SAME_FLIP_PX: f64 = 1e-3 / GRID;

/// The segment `a → b` in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CrossingLine {
    /// Start (pixels).
    pub(crate) a: DVec2,
    /// End (pixels).
    pub(crate) b: DVec2,
}

impl Line for CrossingLine {
    fn at_px(&self, t: f64) -> DVec2 {
        self.a + (self.b - self.a) * t
    }
}

impl CrossingLine {
    fn reversed(self) -> Self {
        Self {
            a: self.b,
            b: self.a,
        }
    }

    /// Unit normal pointing to the left (the convention of [`Edge::left_normal`]).
    fn left_normal(&self) -> DVec2 {
        let d = self.b - self.a;
        DVec2::new(-d.y, d.x).normalize_or_zero()
    }

    /// Closed bounding box in grid units, rounded outwards.
    fn bbox(&self) -> [i64; 4] {
        let (lo, hi) = (self.a.min(self.b) * GRID, self.a.max(self.b) * GRID);
        [
            lo.x.floor() as i64,
            lo.y.floor() as i64,
            hi.x.ceil() as i64,
            hi.y.ceil() as i64,
        ]
    }

    /// The parameter interval inside the rectangle `[x0, y0, x1, y1]` (pixels), if any.
    fn clip(&self, rect: [f64; 4]) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let d = self.b - self.a;
        for (p, q) in [
            (-d.x, self.a.x - rect[0]),
            (d.x, rect[2] - self.a.x),
            (-d.y, self.a.y - rect[1]),
            (d.y, rect[3] - self.a.y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else if p < 0.0 {
                lo = lo.max(q / p);
            } else {
                hi = hi.min(q / p);
            }
        }
        (lo < hi).then_some((lo, hi))
    }
}

/// The projected intersection segment of polygons `t` and `u` (indices in [`Polys`]), directed
/// with `t`'s part in front of `u` on its left, or `None` when their planes are parallel or
/// their line of equal depth misses the overlap of the two polygons.
///
/// The segment runs along the line where the `1/z` planes are equal, inside both polygons. Its
/// ends lie on edges of `t` or `u`, where those edges split their overlaps at the flip of the
/// order; it ends exactly at those flip points, so that the boundary segments meet bit for bit.
/// An end through a corner of the overlap (where no edge sees a flip beyond the tolerance) is
/// the end of the line clipped to both polygons.
pub(crate) fn segment(
    polys: &Polys,
    t: u32,
    u: u32,
    counters: &mut Counters,
) -> Option<CrossingLine> {
    let (pt, pu) = (
        &polys.polys[t as usize].plane,
        &polys.polys[u as usize].plane,
    );
    // `1/z_t - 1/z_u = g · p + c` grows along `g`: `t` is in front on that side. The direction
    // with `g` on its left is `(g.y, -g.x)` (left normal `(-d.y, d.x)`).
    let g = DVec2::new(pt[0] - pu[0], pt[1] - pu[1]);
    let c = pt[2] - pu[2];
    if g == DVec2::ZERO || !g.is_finite() || !c.is_finite() {
        return None;
    }
    let dir = DVec2::new(g.y, -g.x).normalize();
    let origin = -c * g / g.length_squared();
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in [t, u] {
        let (l, h) = clip_line(origin, dir, polys.verts_of(k))?;
        (lo, hi) = (lo.max(l), hi.min(h));
    }
    if lo >= hi {
        return None;
    }
    let (mut a, mut b) = (origin + dir * lo, origin + dir * hi);
    // The flip points are where the edges split their overlaps: the segment must end exactly
    // there. (Where the planes are nearly parallel the clipped line is ill-conditioned and
    // may lie 1e-4 px away from them, which would open a crack.)
    let mut flips = flip_points(polys, t, u, counters);
    flips.sort_by(|p, q| p.dot(dir).total_cmp(&q.dot(dir)));
    // Edges of both polygons on one line (both clipped at the image border) flip at one point,
    // computed from different ends, so equal only up to rounding (2e-14 px seen): one flip.
    // Taking the two as the segment's ends would leave a segment of no length.
    flips.dedup_by(|q, p| q.distance(*p) <= SAME_FLIP_PX);
    match flips[..] {
        [] => {}
        [f] => {
            if f.distance(a) <= f.distance(b) {
                a = f;
            } else {
                b = f;
            }
        }
        [first, .., last] => (a, b) = (first, last),
    }
    (a != b).then_some(CrossingLine { a, b })
}

/// The points where the order of `t` and `u` flips along the edges of either, computed exactly
/// as `edge_intersections` computes them (same arguments, same order).
fn flip_points(polys: &Polys, t: u32, u: u32, counters: &mut Counters) -> Vec<DVec2> {
    let mut points = Vec::new();
    for (owner, other) in [(t, u), (u, t)] {
        let verts = polys.verts_of(owner);
        let n = verts.len();
        for j in 0..n {
            let d = super::predicates::sub(verts[(j + 1) % n], verts[j]);
            if d == [0, 0] {
                continue;
            }
            let e = Edge {
                owner,
                a: verts[j],
                d,
            };
            let collinear_grid = polys.polys[owner as usize]
                .collinear_grid
                .max(polys.polys[other as usize].collinear_grid);
            let Some((lo, hi, side)) =
                intersect(&e, polys.verts_of(other), collinear_grid, counters)
            else {
                continue;
            };
            if side == Side::Right {
                continue;
            }
            let order = depth_order(
                &e,
                lo,
                hi,
                e.left_normal(),
                depth_of(polys, other),
                depth_of(polys, owner),
            );
            if let Order::Flips { at, .. } = order {
                points.push(e.at_px(at));
            }
        }
    }
    points
}

/// The parameter interval of the line `origin + s dir` (pixels) inside the convex polygon
/// `verts` (grid units, counter-clockwise), if any.
fn clip_line(origin: DVec2, dir: DVec2, verts: &[[i64; 2]]) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let n = verts.len();
    for i in 0..n {
        let ci = DVec2::new(verts[i][0] as f64, verts[i][1] as f64) / GRID;
        let cj = DVec2::new(verts[(i + 1) % n][0] as f64, verts[(i + 1) % n][1] as f64) / GRID;
        let edge = cj - ci;
        // Inside: cross(edge, p - ci) >= 0, affine in s: alpha + beta s.
        let beta = edge.perp_dot(dir);
        let alpha = edge.perp_dot(origin - ci);
        if beta == 0.0 {
            if alpha < 0.0 {
                return None;
            }
        } else if beta > 0.0 {
            lo = lo.max(-alpha / beta);
        } else {
            hi = hi.min(-alpha / beta);
        }
    }
    (lo < hi).then_some((lo, hi))
}

/// Cyrus–Beck of `line` against the convex polygon `verts` (grid units) in f64: the parameter
/// interval where it covers points on either side of the line, and the sides covered (as in
/// [`intersect`], whose exact predicates need grid end points; the segment's end points are
/// not on the grid).
fn intersect_line(line: &CrossingLine, verts: &[[i64; 2]]) -> Option<(f64, f64, Side)> {
    let (a, d) = (line.a * GRID, (line.b - line.a) * GRID);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut side = Side::Both;
    let n = verts.len();
    for i in 0..n {
        let ci = DVec2::new(verts[i][0] as f64, verts[i][1] as f64);
        let cj = DVec2::new(verts[(i + 1) % n][0] as f64, verts[(i + 1) % n][1] as f64);
        let edge = cj - ci;
        if edge == DVec2::ZERO {
            continue;
        }
        let beta = edge.perp_dot(d);
        let alpha = edge.perp_dot(a - ci);
        if beta == 0.0 {
            if alpha > 0.0 {
                continue;
            }
            if alpha < 0.0 {
                return None;
            }
            side = collinear_side(side, edge.dot(d) > 0.0)?;
        } else if !narrow(&mut lo, &mut hi, -alpha / beta, beta > 0.0) {
            return None;
        }
    }
    (lo < hi).then_some((lo, hi, side))
}

/// Work space of [`bound_regions`].
#[derive(Default)]
pub(crate) struct CrossingScratch {
    candidates: Vec<u32>,
    overlaps: Vec<Overlap>,
    events: Vec<Event>,
    visible: Vec<(f64, f64)>,
}

/// Adds the boundary segments that the intersection of `t` and `u` gives inside `bin` (whose
/// rectangle in pixels is `rect_px`): the visible parts of the segment, for `t` on its front
/// side and, reversed, for `u`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn bound_regions(
    polys: &Polys,
    bin: &Bin,
    rect_px: [f64; 4],
    index: &mut BinIndex,
    (t, u): (u32, u32),
    counters: &mut Counters,
    scratch: &mut CrossingScratch,
    out: &mut Vec<Segment>,
) -> bool {
    let Some(line) = segment(polys, t, u, counters) else {
        return false;
    };
    for (front, back, line) in [(t, u, line), (u, t, line.reversed())] {
        let Some(range) = line.clip(rect_px) else {
            continue;
        };
        index.query(bin, line.bbox(), &mut scratch.candidates);
        let owner = &polys.polys[front as usize];
        let left = line.left_normal();
        scratch.overlaps.clear();
        for &k in &scratch.candidates {
            // The pair itself: each is the other's far side along `S`, never its occluder.
            if k == front || k == back {
                continue;
            }
            let p = &polys.polys[k as usize];
            if !may_be_in_front(p, owner) {
                continue;
            }
            let Some((lo, hi, side)) = intersect_line(&line, polys.verts_of(k)) else {
                continue;
            };
            if side == Side::Right {
                continue;
            }
            counters.intersections += 1;
            let order = depth_order(
                &line,
                lo,
                hi,
                left,
                depth_of(polys, k),
                depth_of(polys, front),
            );
            for (lo, hi, occluding) in order.parts(lo, hi) {
                scratch.overlaps.push(Overlap {
                    poly: k,
                    lo,
                    hi,
                    side,
                    occluding,
                });
            }
        }
        hidden_line::visible_intervals(
            &scratch.overlaps,
            range,
            &mut scratch.events,
            &mut scratch.visible,
        );
        for &(s, e) in &scratch.visible {
            out.push((front, line.at_px(s), line.at_px(e)));
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_keeps_the_part_inside() {
        let l = CrossingLine {
            a: DVec2::new(-1.0, 0.5),
            b: DVec2::new(3.0, 0.5),
        };
        let (lo, hi) = l.clip([0.0, 0.0, 2.0, 1.0]).expect("inside");
        assert!((lo - 0.25).abs() < 1e-15 && (hi - 0.75).abs() < 1e-15);
        assert!(l.clip([0.0, 1.0, 2.0, 2.0]).is_none());
    }

    #[test]
    fn line_through_square_covers_both_sides() {
        let g = GRID as i64;
        let square = [[0, 0], [10 * g, 0], [10 * g, 10 * g], [0, 10 * g]];
        let l = CrossingLine {
            a: DVec2::new(-10.0, 5.0),
            b: DVec2::new(20.0, 5.0),
        };
        let (lo, hi, side) = intersect_line(&l, &square).expect("overlap");
        assert!((lo - 1.0 / 3.0).abs() < 1e-12 && (hi - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(side, Side::Both);
    }
}
