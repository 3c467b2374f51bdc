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
//! gets its boundary from its own edge).
//!
//! # Depth order
//! The input triangles are assumed not to intersect, so along an overlap interval the sign of
//! `1/z_C - 1/z_T` is constant; it is evaluated at the interval's midpoint (f64, relative
//! tolerance [`DEPTH_TOL`] plus the change of `1/z` that snapping to the grid can cause). When it vanishes there the two triangles touch along `e` (e.g. a
//! fold at a silhouette) and the order is the one of their depth *slopes* towards the side
//! considered; when that vanishes too they are coplanar and the lower triangle id is in front,
//! the rasterizer's tie rule. A sign change between the interval's ends means the triangles
//! intersect: the order at the midpoint is used and a warning is counted.

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
    /// Overlaps whose depth order changes along the interval (intersecting input).
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
pub(crate) fn intersect(e: &Edge, c: &[Pt], counters: &mut Counters) -> Option<(f64, f64, Side)> {
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
        if beta.sign == 0 {
            match alpha.sign {
                1 => continue,
                -1 => return None,
                _ => {
                    // Collinear: the polygon lies on the side its interior points to.
                    let this = if dot(edge, e.d) > 0 {
                        Side::Left
                    } else {
                        Side::Right
                    };
                    if side != Side::Both && side != this {
                        return None;
                    }
                    side = this;
                }
            }
        } else {
            let t = -alpha.value / beta.value;
            if beta.sign > 0 {
                lo = lo.max(t);
            } else {
                hi = hi.min(t);
            }
            if lo >= hi {
                return None;
            }
        }
    }
    (lo < hi).then_some((lo, hi, side))
}

/// `1/z` of `plane` at `p` and the magnitude of its terms (for the tolerance).
#[inline]
fn eval(plane: &[f64; 3], p: DVec2) -> (f64, f64) {
    let (x, y) = (plane[0] * p.x, plane[1] * p.y);
    (x + y + plane[2], x.abs() + y.abs() + plane[2].abs())
}

/// Depth order of two polygons over the overlap `[lo, hi]` of edge `e`, on the side of `e`
/// given by the unit `normal`: whether `c` (id `id_c`) is in front of `t` (id `id_t`), and
/// whether the order changes along the interval (the triangles intersect).
pub(crate) fn in_front(
    e: &Edge,
    lo: f64,
    hi: f64,
    normal: DVec2,
    c: (&[f64; 3], u32),
    t: (&[f64; 3], u32),
) -> (bool, bool) {
    // Snapping moved the edge by up to 2^-21 px, which changes 1/z by up to that times the
    // planes' gradients: differences below that are ties too.
    let slope = c.0[0].abs() + c.0[1].abs() + t.0[0].abs() + t.0[1].abs();
    let snap_tol = slope / GRID;
    let diff = |s: f64| {
        let p = e.at_px(s);
        let (zc, mc) = eval(c.0, p);
        let (zt, mt) = eval(t.0, p);
        (zc - zt, DEPTH_TOL * (mc + mt) + snap_tol)
    };
    let (d0, t0) = diff(lo);
    let (d1, t1) = diff(hi);
    let crossing = (d0 > t0 && d1 < -t1) || (d0 < -t0 && d1 > t1);
    let (mid, tol) = diff(0.5 * (lo + hi));
    if mid.abs() > tol {
        return (mid > 0.0, crossing);
    }
    // Touching along the edge: compare the slopes of 1/z towards the side.
    let g = (c.0[0] - t.0[0]) * normal.x + (c.0[1] - t.0[1]) * normal.y;
    let g_tol = DEPTH_TOL * (c.0[0].abs() + c.0[1].abs() + t.0[0].abs() + t.0[1].abs());
    if g.abs() > g_tol {
        return (g > 0.0, crossing);
    }
    // Coplanar: the lower id is in front (the rasterizer's rule).
    (c.1 < t.1, crossing)
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
fn may_be_in_front(c: &BinPoly, t: &BinPoly) -> bool {
    let slope = c.plane[0].abs() + c.plane[1].abs() + t.plane[0].abs() + t.plane[1].abs();
    let margin = 1e-6 * (c.inv_z_range[1].abs() + t.inv_z_range[0].abs()) + slope / GRID;
    c.inv_z_range[1] >= t.inv_z_range[0] - margin
}

/// EDGEINTERSECTIONS for one edge: all overlaps with the candidate polygons selected by `pass`
/// (appended to `out`), each classified as occluding (in front of the edge's polygon on its
/// side) or not. Border edges (no owner) get no classification and need [`Pass::All`].
pub(crate) fn edge_intersections(
    polys: &Polys,
    candidates: &[u32],
    e: &Edge,
    pass: Pass,
    counters: &mut Counters,
    out: &mut Vec<Overlap>,
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
        let Some((lo, hi, side)) = intersect(e, polys.verts_of(k), counters) else {
            continue;
        };
        counters.intersections += 1;
        let occluding = match owner {
            Some(owner) if side != Side::Right && in_front_pass => {
                let (front, crossing) =
                    in_front(e, lo, hi, left, (&p.plane, p.id), (&owner.plane, owner.id));
                counters.intersecting += u64::from(crossing);
                front
            }
            _ => false,
        };
        out.push(Overlap {
            poly: k,
            lo,
            hi,
            side,
            occluding,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edge(a: Pt, b: Pt) -> Edge {
        Edge {
            owner: 0,
            a,
            d: sub(b, a),
        }
    }

    const SQUARE: [Pt; 4] = [[0, 0], [10, 0], [10, 10], [0, 10]];

    #[test]
    fn edge_through_square_overlaps_both_sides() {
        let mut c = Counters::default();
        let r = intersect(&edge([-10, 5], [20, 5]), &SQUARE, &mut c);
        let (lo, hi, side) = r.expect("overlap");
        assert!((lo - 1.0 / 3.0).abs() < 1e-12 && (hi - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(side, Side::Both);
    }

    #[test]
    fn collinear_edge_same_direction_covers_left() {
        // Square's bottom edge runs (0,0)->(10,0) with the interior at +y, the left side.
        let mut c = Counters::default();
        let r = intersect(&edge([-5, 0], [5, 0]), &SQUARE, &mut c);
        assert_eq!(r.map(|r| r.2), Some(Side::Left));
        let r = intersect(&edge([5, 0], [-5, 0]), &SQUARE, &mut c);
        assert_eq!(r.map(|r| r.2), Some(Side::Right));
    }

    #[test]
    fn vertex_contact_is_discarded() {
        let mut c = Counters::default();
        assert!(intersect(&edge([-5, 5], [5, -5]), &SQUARE, &mut c).is_none());
    }

    #[test]
    fn separate_edge_misses() {
        let mut c = Counters::default();
        assert!(intersect(&edge([20, 0], [20, 10]), &SQUARE, &mut c).is_none());
    }

    #[test]
    fn coplanar_tie_goes_to_lower_id() {
        let e = edge([0, 0], [10, 0]);
        let plane = [0.0, 0.0, 0.5];
        let n = e.left_normal();
        assert!(in_front(&e, 0.0, 1.0, n, (&plane, 1), (&plane, 2)).0);
        assert!(!in_front(&e, 0.0, 1.0, n, (&plane, 2), (&plane, 1)).0);
    }

    #[test]
    fn nearer_plane_is_in_front() {
        let e = edge([0, 0], [10, 0]);
        let n = e.left_normal();
        let (front, crossing) = in_front(
            &e,
            0.0,
            1.0,
            n,
            (&[0.0, 0.0, 1.0], 5),
            (&[0.0, 0.0, 0.5], 1),
        );
        assert!(front && !crossing);
    }
}
