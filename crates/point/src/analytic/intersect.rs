//! Edge intersections (the paper's Algorithm 1, EDGEINTERSECTIONS): for one edge `e` of a
//! polygon `T`, the interval of `e` that every other polygon of the bin overlaps, on which side
//! of `e` it lies, and whether it occludes `T` there or is occluded by it.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3.1 (Algorithm 1, INTERSECT, ISBEHIND) and section 4.3 (AREOVERLAPPING by
//! quantized bounding boxes).
//!
//! # One-sided coverage
//! The paper intersects `e` with the interior of each triangle. We also keep track of the
//! *side*: a polygon `C` covers the left side of `e` at `e(t)` when it contains the points just
//! left of `e(t)` (`T` itself lies on the left of its counter-clockwise edges). A polygon whose
//! interior `e` crosses covers both sides; a polygon with an edge collinear with `e` covers only
//! one side. This makes shared edges, T-junctions, stacked coplanar edges and the bin border
//! exact without special cases: an occluder only matters on the side where `T` is, and only
//! polygons covering *both* sides can be completed across `e` (a polygon that ends on `e`'s line
//! gets its boundary from its own edge). Edges within [`NEAR_COLLINEAR_GRID`] of collinear at
//! both ends count as collinear, parallel ones included: snapping breaks the collinearity of
//! edges on one 3D line. So do edges within one ulp of the input (`ScreenPoly::collinear_grid`):
//! two f32 copies of one 3D corner, one ulp apart, are one line as far as the input can tell.
//! (The tolerance is the snapping's, so it lives with the snapping in `project.rs`.)
//!
//! [`NEAR_COLLINEAR_GRID`]: super::project::NEAR_COLLINEAR_GRID
//!
//! # Depth order
//! Along an overlap interval the difference `1/z_C - 1/z_T` is affine in the edge parameter
//! (both are planes over the screen), so it is evaluated at the interval's ends (f64, relative
//! tolerance [`DEPTH_TOL`] plus the change of `1/z` that snapping to the grid can cause). When
//! it has one sign the order is that sign; when it changes sign beyond the tolerance the two
//! triangles *intersect*, and the interval is split at the zero of the affine difference into
//! two parts with opposite orders ([`Order::Flips`]; the projected intersection line itself is
//! added as an edge by `crossing.rs`). When it vanishes at the middle the triangles touch along
//! `e` (e.g. a fold at a silhouette) and the order is the one of their depth *slopes* towards
//! the side considered; when that vanishes too they are coplanar and the lower triangle id is in
//! front, the rasterizer's tie rule.

use glam::DVec2;

use super::bin::{BinPoly, Polys};
use super::predicates::{cross, dot, sub, Pt};
use super::project::GRID;

/// Relative tolerance of depth comparisons (1/z differences below it are ties).
pub(crate) const DEPTH_TOL: f64 = 1e-9;

/// Which sides of the edge a polygon covers along its overlap interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Side {
    /// The edge crosses the polygon's interior.
    Both,
    /// The polygon lies on the left of the edge (it has a collinear edge in the same direction).
    Left,
    /// The polygon lies on the right of the edge.
    Right,
}

/// One overlap of an edge with another polygon of the bin: the paper's pair of intersection
/// points `(p0, starting)`, `(p1, ending)` with its type.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Overlap {
    /// Index of the polygon in [`Polys`].
    pub(crate) poly: u32,
    /// Start of the overlap, as a parameter along the edge in `[0, 1]`.
    pub(crate) lo: f64,
    /// End of the overlap (`lo < hi`).
    pub(crate) hi: f64,
    /// Covered sides.
    pub(crate) side: Side,
    /// `occluding` in the paper: the polygon covers the left side and is in front of `T` there.
    pub(crate) occluding: bool,
}

/// Counters of one bin.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Counters {
    /// Edge–polygon overlaps found (the paper's "edge intersections" count pairs of points).
    pub(crate) intersections: u64,
    /// Predicates decided by the exact fallback.
    pub(crate) exact_fallbacks: u64,
    /// Overlaps whose depth order flips along the interval (intersecting input), split there.
    pub(crate) intersecting: u64,
}

/// A directed edge `a → a + d` of polygon `owner`, or a side of a bin (`owner` = [`NO_OWNER`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Edge {
    /// Index of the owning polygon in [`Polys`].
    pub(crate) owner: u32,
    /// Start point (grid units).
    pub(crate) a: Pt,
    /// Direction (grid units, non-zero).
    pub(crate) d: Pt,
}

/// The owner of the bin's border edges.
pub(crate) const NO_OWNER: u32 = u32::MAX;

impl Edge {
    /// Closed bounding box `[min_x, min_y, max_x, max_y]` (grid units).
    pub(crate) fn bbox(&self) -> [i64; 4] {
        let b = [self.a[0] + self.d[0], self.a[1] + self.d[1]];
        [
            self.a[0].min(b[0]),
            self.a[1].min(b[1]),
            self.a[0].max(b[0]),
            self.a[1].max(b[1]),
        ]
    }

    /// The point at parameter `t`, in pixels.
    pub(crate) fn at_px(&self, t: f64) -> DVec2 {
        DVec2::new(
            (self.a[0] as f64 + t * self.d[0] as f64) / GRID,
            (self.a[1] as f64 + t * self.d[1] as f64) / GRID,
        )
    }

    /// Unit normal pointing to the left side of the edge (screen pixels).
    pub(crate) fn left_normal(&self) -> DVec2 {
        DVec2::new(-self.d[1] as f64, self.d[0] as f64).normalize_or_zero()
    }
}

/// INTERSECT: the parameter interval of `e` (and the covered sides) where polygon `c` covers
/// points on either side of `e`, or `None` (single-point contacts are discarded, as in the
/// paper). Cyrus–Beck over the edges of the convex polygon, with exact parallelism and
/// collinearity decisions.
/// Edges of `c` within `collinear_grid` grid units of `e`'s line at both of `e`'s ends count as
/// collinear with it.
pub(crate) fn intersect(
    e: &Edge,
    c: &[Pt],
    collinear_grid: f64,
    counters: &mut Counters,
) -> Option<(f64, f64, Side)> {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let mut side = Side::Both;
    let n = c.len();
    for i in 0..n {
        let (ci, cj) = (c[i], c[(i + 1) % n]);
        let edge = sub(cj, ci);
        if edge == [0, 0] {
            continue;
        }
        // The polygon's edge function E(t) = alpha + beta t, positive inside.
        let beta = cross(edge, e.d);
        let alpha = cross(edge, sub(e.a, ci));
        counters.exact_fallbacks += u64::from(beta.exact) + u64::from(alpha.exact);
        // Parallel edges a few grid units apart are collinear too (the parallel test alone
        // would make `c` cover both sides of `e` over that sliver).
        let near = near_collinear(alpha.value, beta.value, edge, collinear_grid);
        if beta.sign == 0 || near {
            let alpha_sign = if near { 0 } else { alpha.sign };
            match alpha_sign {
                1 => continue,
                -1 => return None,
                _ => side = collinear_side(side, dot(edge, e.d) > 0)?,
            }
        } else if !narrow(&mut lo, &mut hi, -alpha.value / beta.value, beta.sign > 0) {
            return None;
        }
    }
    (lo < hi).then_some((lo, hi, side))
}

/// A polygon edge collinear with the intersected edge: the polygon lies on the side its
/// interior points to (left when the two run the same way). `None` when an earlier collinear
/// edge put it on the other side (it then covers no side).
#[inline]
pub(crate) fn collinear_side(side: Side, same_direction: bool) -> Option<Side> {
    let this = if same_direction {
        Side::Left
    } else {
        Side::Right
    };
    (side == Side::Both || side == this).then_some(this)
}

/// One Cyrus–Beck step: the edge function is zero at `t` and grows with `t` (`entering`) or
/// falls; narrows `[lo, hi]` to its positive side. False when nothing is left.
#[inline]
pub(crate) fn narrow(lo: &mut f64, hi: &mut f64, t: f64, entering: bool) -> bool {
    if entering {
        *lo = lo.max(t);
    } else {
        *hi = hi.min(t);
    }
    *lo < *hi
}

/// Whether the line of `edge` (grid units) passes within `tol_grid` grid units of both ends
/// of the edge whose edge function is `alpha + beta t` (`t` in `[0, 1]`).
#[inline]
fn near_collinear(alpha: f64, beta: f64, edge: Pt, tol_grid: f64) -> bool {
    // Squared, to keep a square root out of the innermost loop.
    let (ex, ey) = (edge[0] as f64, edge[1] as f64);
    let tol2 = tol_grid * tol_grid * (ex * ex + ey * ey);
    let end = alpha + beta;
    alpha * alpha <= tol2 && end * end <= tol2
}

/// `1/z` of `plane` at `p` and the magnitude of its terms (for the tolerance).
#[inline]
fn eval(plane: &[f64; 3], p: DVec2) -> (f64, f64) {
    let (x, y) = (plane[0] * p.x, plane[1] * p.y);
    (x + y + plane[2], x.abs() + y.abs() + plane[2].abs())
}

/// A directed segment in screen pixels, parameterised over `[0, 1]`: a polygon's edge, a side
/// of a bin, or the projected intersection line of two polygons (`crossing.rs`).
pub(crate) trait Line {
    /// The point at parameter `t`, in pixels.
    fn at_px(&self, t: f64) -> DVec2;

    /// The end points on the grid when the line is a polygon's edge (to tell it from the
    /// polygons' other edges).
    fn grid_ends(&self) -> Option<(Pt, Pt)> {
        None
    }
}

impl Line for Edge {
    fn at_px(&self, t: f64) -> DVec2 {
        Edge::at_px(self, t)
    }

    fn grid_ends(&self) -> Option<(Pt, Pt)> {
        Some((self.a, [self.a[0] + self.d[0], self.a[1] + self.d[1]]))
    }
}

/// The depth order of two polygons along a part `[lo, hi]` of a line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Order {
    /// One order over the whole part: whether `c` is in front.
    Same(bool),
    /// The polygons intersect: the order flips at parameter `at` (`lo < at < hi`); `c` is in
    /// front before it exactly when `front_before`.
    Flips {
        /// Parameter of the flip.
        at: f64,
        /// Whether `c` is in front on `[lo, at]`.
        front_before: bool,
    },
    /// The planes cross inside the part, but so close to one end that the order there is a
    /// tie: one order over the part, as [`Order::Same`], and yet the pair intersects (a corner
    /// of one polygon on the other's plane, an edge leaving it). Recorded as a crossing pair,
    /// so that the bin builds the intersection segment even where no edge of it sees a flip
    /// beyond the tolerance.
    Crosses(bool),
}

impl Order {
    /// Whether the pair intersects along the part ([`Order::Flips`] or [`Order::Crosses`]).
    pub(crate) fn crosses(self) -> bool {
        matches!(self, Order::Flips { .. } | Order::Crosses(_))
    }

    /// The parts of `[lo, hi]` with one order each: `(lo, hi, c in front)`.
    pub(crate) fn parts(self, lo: f64, hi: f64) -> impl Iterator<Item = (f64, f64, bool)> {
        let parts = match self {
            Order::Same(front) | Order::Crosses(front) => [Some((lo, hi, front)), None],
            Order::Flips { at, front_before } => {
                [Some((lo, at, front_before)), Some((at, hi, !front_before))]
            }
        };
        parts.into_iter().flatten().filter(|p| p.0 < p.1)
    }
}

/// One side of a depth comparison: a polygon's `1/z` plane, its id (for coplanar ties), the
/// relative uncertainty of its `1/z` from the f32 input, and its vertices (to tell whether it
/// ends where its plane meets the other's).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Depth<'a> {
    /// `1/z` over screen pixels.
    pub(crate) plane: &'a [f64; 3],
    /// Triangle id.
    pub(crate) id: u32,
    /// Relative uncertainty of `1/z`.
    pub(crate) noise: f64,
    /// Vertices on the grid (empty when unknown).
    pub(crate) verts: &'a [Pt],
    /// Collinearity tolerance of its edges, grid units.
    pub(crate) collinear_grid: f64,
}

/// The [`Depth`] of polygon `k`.
pub(crate) fn depth_of(polys: &Polys, k: u32) -> Depth<'_> {
    let p = &polys.polys[k as usize];
    Depth {
        plane: &p.plane,
        id: p.id,
        noise: p.noise,
        verts: polys.verts_of(k),
        collinear_grid: p.collinear_grid,
    }
}

/// Depth order of two polygons over the part `[lo, hi]` of `line`, on the side of it given by
/// the unit `normal`: whether `c` is in front of `t`, or where the order flips. Differences
/// within the tolerance (relative [`DEPTH_TOL`], the f32 input's noise of either polygon, and
/// what snapping can change) are ties, decided as in [`tie_order`].
pub(crate) fn depth_order(
    line: &impl Line,
    lo: f64,
    hi: f64,
    normal: DVec2,
    c: Depth<'_>,
    t: Depth<'_>,
) -> Order {
    // Snapping moved the edge by up to 2^-21 px, which changes 1/z by up to that times the
    // planes' gradients: differences below that are ties too.
    let slope = c.plane[0].abs() + c.plane[1].abs() + t.plane[0].abs() + t.plane[1].abs();
    let snap_tol = slope / GRID;
    let (rel_c, rel_t) = (DEPTH_TOL + c.noise, DEPTH_TOL + t.noise);
    let diff = |p: DVec2| {
        let (zc, mc) = eval(c.plane, p);
        let (zt, mt) = eval(t.plane, p);
        (zc - zt, rel_c * mc + rel_t * mt + snap_tol)
    };
    let (d0, t0) = diff(line.at_px(lo));
    let (d1, t1) = diff(line.at_px(hi));
    if (d0 > t0 && d1 < -t1) || (d0 < -t0 && d1 > t1) {
        // The difference is affine in the parameter: its zero is exact up to rounding. The
        // same ends give the same `at` wherever the overlap is classified (bit for bit), so
        // the split points of one edge agree between bins and with `crossing.rs`.
        let at = lo + (hi - lo) * (d0 / (d0 - d1));
        if at > lo && at < hi {
            return Order::Flips {
                at,
                front_before: d0 > 0.0,
            };
        }
    }
    // The difference changes sign, beyond the tolerance at one end only: the planes cross
    // near the other end. The polygons intersect there when each has corners on both sides
    // of the other's plane beyond the tolerance; when they only touch (a shared edge or
    // corner, a ledge ending on a wall) one has all its corners on one side.
    let near_flip = d0 * d1 < 0.0 && ((d0.abs() > t0) != (d1.abs() > t1));
    let crosses = |front: bool| {
        if near_flip && straddles(c.verts, &diff) && straddles(t.verts, &diff) {
            Order::Crosses(front)
        } else {
            Order::Same(front)
        }
    };
    let (mid, tol) = diff(line.at_px(0.5 * (lo + hi)));
    if mid.abs() > tol {
        return crosses(mid > 0.0);
    }
    let g_tol = rel_c.max(rel_t) * slope;
    let tie = Tie {
        line,
        normal,
        ends: (d0, mid, d1),
        g_tol,
        diff: &diff,
    };
    crosses(tie_order(&tie, c, t))
}

/// A depth difference within the tolerance along a part of a line.
struct Tie<'a, L: Line, D: Fn(DVec2) -> (f64, f64)> {
    line: &'a L,
    normal: DVec2,
    /// The difference at the part's start, middle and end.
    ends: (f64, f64, f64),
    g_tol: f64,
    /// The difference and its tolerance at a point.
    diff: &'a D,
}

/// Whether `c` is in front of `t` where their depths tie along the line.
///
/// The rule must depend on the pair and the place, not on the line that asks: another edge of
/// either polygon may look at the same sliver, and two answers that disagree there leave a
/// region with no boundary (each hides the other). With `L` the line where the two planes meet:
/// 1. Coplanar up to the input's precision: the lower id is in front (the rasterizer's rule).
/// 2. The line lies on `L` (a fold, a shared edge; within the snapping of collinear edges):
///    the two touch along it, and the slopes of `1/z` towards the side decide.
/// 3. Off `L` (within the input's noise), the sign of the difference is the order at the line,
///    and the slopes give the order beyond `L`. When they agree, that is the answer.
/// 4. When they disagree, `L` lies between the line and the side asked about. If either
///    polygon ends at `L` (an edge of it lies on `L`: a ledge leaving a wall), the other side
///    of `L` is outside it and only the order at the line counts: the sign decides, the same
///    answer the edge on `L` gets by rule 2 on its side.
/// 5. Otherwise the sliver between the line and `L` (within the input's noise) is taken as
///    part of the side: the slopes decide, as if the line were on `L`.
fn tie_order<L: Line, D: Fn(DVec2) -> (f64, f64)>(
    tie: &Tie<'_, L, D>,
    c: Depth<'_>,
    t: Depth<'_>,
) -> bool {
    let grad = DVec2::new(c.plane[0] - t.plane[0], c.plane[1] - t.plane[1]);
    if grad.x.abs() + grad.y.abs() <= tie.g_tol {
        return c.id < t.id;
    }
    let (d0, mid, d1) = tie.ends;
    let g = grad.dot(tie.normal);
    let beyond = if g.abs() > tie.g_tol {
        Some(g > 0.0)
    } else {
        None
    };
    let contact = c.collinear_grid.max(t.collinear_grid) / GRID * grad.length();
    let on_l = d0.abs() <= contact && d1.abs() <= contact;
    let signed = if mid != 0.0 { mid } else { d0 + d1 };
    let here = if signed != 0.0 {
        Some(signed > 0.0)
    } else {
        None
    };
    match (beyond, here) {
        (Some(b), _) if on_l => b,
        (Some(b), Some(h)) if b == h => b,
        (Some(b), Some(h)) => {
            let skip = tie.line.grid_ends();
            if ends_on(c.verts, skip, tie.diff) || ends_on(t.verts, skip, tie.diff) {
                h
            } else {
                b
            }
        }
        (None, Some(h)) => h,
        (Some(b), None) => b,
        (None, None) => c.id < t.id,
    }
}

/// Whether the polygon `verts` has corners on both sides of the line where the depth
/// difference `diff` vanishes, beyond its tolerance.
fn straddles(verts: &[Pt], diff: &impl Fn(DVec2) -> (f64, f64)) -> bool {
    let px = |v: Pt| DVec2::new(v[0] as f64, v[1] as f64) / GRID;
    let (mut above, mut below) = (false, false);
    for &v in verts {
        let (d, tol) = diff(px(v));
        above |= d > tol;
        below |= d < -tol;
    }
    above && below
}

/// Whether one of the edges of the polygon `verts` (other than `skip`, either direction) lies
/// on the line where the depth difference `diff` vanishes: within its tolerance at both ends.
fn ends_on(verts: &[Pt], skip: Option<(Pt, Pt)>, diff: &impl Fn(DVec2) -> (f64, f64)) -> bool {
    let px = |v: Pt| DVec2::new(v[0] as f64, v[1] as f64) / GRID;
    let n = verts.len();
    (0..n).any(|j| {
        let (a, b) = (verts[j], verts[(j + 1) % n]);
        if a == b || skip.is_some_and(|(p, q)| (a, b) == (p, q) || (a, b) == (q, p)) {
            return false;
        }
        let ((da, ta), (db, tb)) = (diff(px(a)), diff(px(b)));
        da.abs() <= ta && db.abs() <= tb
    })
}

/// Which candidates [`edge_intersections`] considers, by depth range against the edge's owner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Pass {
    /// Every candidate.
    All,
    /// Candidates whose depth range reaches in front of the owner's farthest point: the only
    /// possible occluders, enough for hidden-line elimination.
    MaybeInFront,
    /// The others: entirely behind the owner, so never occluding (no depth test needed); only
    /// needed for boundary completion when the edge is visible.
    Behind,
}

/// Whether polygon `c` may be in front of polygon `t` somewhere (by their `1/z` ranges; the
/// margin covers rounding and snapping, so the test is conservative).
#[inline]
pub(crate) fn may_be_in_front(c: &BinPoly, t: &BinPoly) -> bool {
    let slope = c.plane[0].abs() + c.plane[1].abs() + t.plane[0].abs() + t.plane[1].abs();
    let margin = 1e-6 * (c.inv_z_range[1].abs() + t.inv_z_range[0].abs()) + slope / GRID;
    c.inv_z_range[1] >= t.inv_z_range[0] - margin
}

/// EDGEINTERSECTIONS for one edge: all overlaps with the candidate polygons selected by `pass`
/// (appended to `out`), each classified as occluding (in front of the edge's polygon on its
/// side) or not; an overlap along which the order flips is split in two, and the pair of
/// polygons (owner, other) is appended to `crossings`. Border edges (no owner) get no
/// classification and need [`Pass::All`].
pub(crate) fn edge_intersections(
    polys: &Polys,
    candidates: &[u32],
    e: &Edge,
    pass: Pass,
    counters: &mut Counters,
    out: &mut Vec<Overlap>,
    crossings: &mut Vec<(u32, u32)>,
) {
    let ebox = e.bbox();
    let owner = polys.polys.get(e.owner as usize);
    let left = e.left_normal();
    for &k in candidates {
        let p = &polys.polys[k as usize];
        // AREOVERLAPPING: closed bounding boxes (a collinear edge touches only the border).
        if k == e.owner
            || p.bbox[0] > ebox[2]
            || p.bbox[2] < ebox[0]
            || p.bbox[1] > ebox[3]
            || p.bbox[3] < ebox[1]
        {
            continue;
        }
        let in_front_pass = match (pass, owner) {
            (Pass::All, _) | (_, None) => true,
            (Pass::MaybeInFront, Some(t)) => {
                if !may_be_in_front(p, t) {
                    continue;
                }
                true
            }
            (Pass::Behind, Some(t)) => {
                if may_be_in_front(p, t) {
                    continue;
                }
                false
            }
        };
        let collinear_grid =
            owner.map_or(p.collinear_grid, |t| t.collinear_grid.max(p.collinear_grid));
        let Some((lo, hi, side)) = intersect(e, polys.verts_of(k), collinear_grid, counters) else {
            continue;
        };
        counters.intersections += 1;
        let order = match owner {
            Some(_) if side != Side::Right && in_front_pass => depth_order(
                e,
                lo,
                hi,
                left,
                depth_of(polys, k),
                depth_of(polys, e.owner),
            ),
            _ => Order::Same(false),
        };
        if order.crosses() {
            counters.intersecting += 1;
            crossings.push((e.owner, k));
        }
        for (lo, hi, occluding) in order.parts(lo, hi) {
            out.push(Overlap {
                poly: k,
                lo,
                hi,
                side,
                occluding,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::project::NEAR_COLLINEAR_GRID;
    use super::*;

    fn edge(a: Pt, b: Pt) -> Edge {
        Edge {
            owner: 0,
            a,
            d: sub(b, a),
        }
    }

    fn plain(plane: &[f64; 3], id: u32) -> Depth<'_> {
        Depth {
            plane,
            id,
            noise: 0.0,
            verts: &[],
            collinear_grid: NEAR_COLLINEAR_GRID,
        }
    }

    const SQUARE: [Pt; 4] = [[0, 0], [10, 0], [10, 10], [0, 10]];

    #[test]
    fn edge_through_square_overlaps_both_sides() {
        let mut c = Counters::default();
        let r = intersect(
            &edge([-10, 5], [20, 5]),
            &SQUARE,
            NEAR_COLLINEAR_GRID,
            &mut c,
        );
        let (lo, hi, side) = r.expect("overlap");
        assert!((lo - 1.0 / 3.0).abs() < 1e-12 && (hi - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(side, Side::Both);
    }

    #[test]
    fn collinear_edge_same_direction_covers_left() {
        // Square's bottom edge runs (0,0)->(10,0) with the interior at +y, the left side.
        let mut c = Counters::default();
        let r = intersect(&edge([-5, 0], [5, 0]), &SQUARE, NEAR_COLLINEAR_GRID, &mut c);
        assert_eq!(r.map(|r| r.2), Some(Side::Left));
        let r = intersect(&edge([5, 0], [-5, 0]), &SQUARE, NEAR_COLLINEAR_GRID, &mut c);
        assert_eq!(r.map(|r| r.2), Some(Side::Right));
    }

    #[test]
    fn vertex_contact_is_discarded() {
        let mut c = Counters::default();
        assert!(intersect(
            &edge([-5, 5], [5, -5]),
            &SQUARE,
            NEAR_COLLINEAR_GRID,
            &mut c
        )
        .is_none());
    }

    #[test]
    fn separate_edge_misses() {
        let mut c = Counters::default();
        assert!(intersect(
            &edge([20, 0], [20, 10]),
            &SQUARE,
            NEAR_COLLINEAR_GRID,
            &mut c
        )
        .is_none());
    }

    #[test]
    fn coplanar_tie_goes_to_lower_id() {
        let e = edge([0, 0], [10, 0]);
        let plane = [0.0, 0.0, 0.5];
        let n = e.left_normal();
        assert_eq!(
            depth_order(&e, 0.0, 1.0, n, plain(&plane, 1), plain(&plane, 2)),
            Order::Same(true)
        );
        assert_eq!(
            depth_order(&e, 0.0, 1.0, n, plain(&plane, 2), plain(&plane, 1)),
            Order::Same(false)
        );
    }

    #[test]
    fn nearer_plane_is_in_front() {
        let e = edge([0, 0], [10, 0]);
        let n = e.left_normal();
        let order = depth_order(
            &e,
            0.0,
            1.0,
            n,
            plain(&[0.0, 0.0, 1.0], 5),
            plain(&[0.0, 0.0, 0.5], 1),
        );
        assert_eq!(order, Order::Same(true));
    }

    #[test]
    fn crossing_planes_flip_at_their_intersection() {
        // Along the edge x = 0..10 px (grid units scaled away), c's 1/z rises through t's
        // constant 1/z at x = 2.5 px: c is behind before, in front after.
        let e = edge([0, 0], [10 * GRID as i64, 0]);
        let n = e.left_normal();
        let c = [0.4, 0.0, -1.0];
        let t = [0.0, 0.0, 0.0];
        let order = depth_order(&e, 0.0, 1.0, n, plain(&c, 1), plain(&t, 2));
        let Order::Flips { at, front_before } = order else {
            panic!("expected a flip, got {order:?}");
        };
        assert!((at - 0.25).abs() < 1e-12 && !front_before, "{order:?}");
        let parts: Vec<_> = order.parts(0.0, 1.0).collect();
        assert_eq!(parts, vec![(0.0, at, false), (at, 1.0, true)]);
    }
}
