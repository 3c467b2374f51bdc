//! The occlusion test of a clipped occludee against a bin's occluders: the silhouette test
//! (edge overlap, then crossing parity) and the triangle test (overlap, depth relation, split).
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 (occlusion test, figure 5.10; silhouette test, figures 5.11-5.12; triangle
//! test, figure 5.13), section 6.3.2, and section 7.1.4 (occluder depth bounds).
//!
//! Soundness, in one paragraph: the silhouette of occluder `O` is the sum of its triangles'
//! directed edges with opposite pairs cancelled, and all its triangles have the same screen
//! orientation (see `occluders.rs`), so its winding number around a point is (up to sign) the
//! number of `O`'s triangles covering that point. If no silhouette edge comes within the margin
//! of the occludee `P`, the winding number is constant over `P` grown by the margin; if it is
//! non-zero at one point of `P`, every point of `P` is covered by at least one of `O`'s
//! triangles. (The thesis' half-edges, chapter 5; a parity count would miss points covered an
//! even number of times, as where a patch folds over itself.) If moreover `P` is behind every triangle of `O` that it overlaps, every
//! point of `P` is hidden by some triangle of `O`, and so is every sample the reference
//! rasterizer could take of `P`.
//!
//! Positive-area semantics ([`super::Guarantee::PositiveArea`]) relax two steps where they only
//! concern a set of zero area, the shared boundary of a closed object's back face and the front
//! faces around it:
//! - A silhouette edge within the margin of `P` is allowed when it cannot enter the interior
//!   of `P`'s (unclipped, convex) screen triangle: it *is* one of its edges (the same two
//!   projected corners, bit for bit), or it starts at one of its corners and leaves clearly
//!   outwards (beyond the margin of one of the triangle's edge lines at that corner, scaled for
//!   rotations of both segments). The winding number is then constant over `P`'s open interior,
//!   so a non-zero value at an interior point means the interior is covered.
//! - An occluder triangle `T` that shares one or two corners (bit for bit, in view space) with
//!   `P`'s triangle hides it where it covers it when `P`'s other corners are behind `T`'s plane
//!   by the relative margin: every point of `P` except the shared corner or edge is then
//!   strictly behind that plane (a convex combination with positive weight on a corner behind
//!   it and the rest on the plane); or, the same way, when `T`'s other corners are in front of
//!   `P`'s plane. And `T` need not be tested at all when the two screen triangles meet only at
//!   the shared corners (a line through them has the other corners clearly on either side).
//!
//! The shared corners are the same input vertices projected by the same code, so the exact
//! analytic method sees the same shared boundary: no region of positive area is lost.

use glam::{DVec2, DVec3};

use super::depth::{behind, eye_plane, in_front, occludee_behind, OccluderView, DEPTH_EPS};
use super::occluder::{Edge, Occluder};
use super::occluders::BinState;
use super::overlap::{convex_overlap, inner_point, ray_winding, segment_overlaps, Rect};
use super::projection::Projection;

/// An occludee clipped to a bin, with what the tests need precomputed.
pub(crate) struct Occludee<'a> {
    /// View-space polygon (clipped to the near plane and the bin).
    pub(crate) poly: &'a [DVec3],
    /// Its screen projection.
    pub(crate) screen: &'a [DVec2],
    /// Bounds of `screen`.
    pub(crate) rect: Rect,
    /// View depth bounds.
    pub(crate) zmin: f64,
    pub(crate) zmax: f64,
    /// Eye-positive plane of the unclipped triangle, computed on first use (see `plane`).
    pub(crate) plane: std::cell::OnceCell<Option<[f64; 4]>>,
    /// View-space corners of the unclipped triangle.
    pub(crate) corners: &'a [DVec3; 3],
    /// Screen corners of the unclipped triangle, when it lies wholly in front of the near plane.
    pub(crate) tri_screen: Option<&'a [DVec2; 3]>,
    /// Positive-area semantics (see the module documentation).
    pub(crate) area: bool,
}

impl Occludee<'_> {
    /// Eye-positive plane of the unclipped triangle (`None` when seen edge-on); only triangle
    /// tests need it, and most occludees never reach one.
    fn plane(&self) -> Option<&[f64; 4]> {
        self.plane
            .get_or_init(|| eye_plane(self.corners[0], self.corners[1], self.corners[2]))
            .as_ref()
    }
}

/// Counters of the test, for statistics.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TestCounters {
    pub(crate) silhouette_tests: u64,
    pub(crate) triangle_tests: u64,
}

/// True when some occluder of `state` hides all of `p`.
///
/// With the index on, the occluder that hides `p` is moved to the front of the cell it was
/// found in: the next triangles of a bin come from the same surfaces (batches are sorted front
/// to back), so the same occluder is usually tried first. The answer is an `any` over the
/// cell, which no order changes.
pub(crate) fn is_occluded(
    p: &Occludee<'_>,
    state: &mut BinState,
    proj: &Projection,
    margin: f64,
    counters: &mut TestCounters,
) -> bool {
    debug_assert!(margin >= 0.0, "the index needs a non-negative margin");
    if !state.index.active() {
        return state
            .occluders
            .iter()
            .any(|o| occluded_by(p, o, proj, margin, counters));
    }
    // An occluder that hides P has a rectangle containing P's, so it is listed in the cell of
    // P's lower corner (`occluder_index.rs`).
    let (x, y) = state.index.cell_of(p.rect.min);
    let rect_margin = if p.area { 0.0 } else { margin };
    // `occluded_by`'s first filter (`Rect::contains`), on the slot's copy of the occluder's
    // bounds, with P's grown bounds hoisted and the four comparisons combined without
    // branches: most candidates fail it, at unpredictable comparisons.
    let (lo, hi) = (p.rect.min - rect_margin, p.rect.max + rect_margin);
    let hit = state.index.cell(x, y).iter().position(|&slot| {
        let e = state.index.slot(slot);
        let r = &e.rect;
        let contains =
            (r.min.x <= lo.x) & (r.min.y <= lo.y) & (r.max.x >= hi.x) & (r.max.y >= hi.y);
        contains && occluded_by(p, &state.occluders[e.pos as usize], proj, margin, counters)
    });
    if let Some(k) = hit {
        state.index.promote(x, y, k);
    }
    hit.is_some()
}

fn occluded_by(
    p: &Occludee<'_>,
    o: &Occluder,
    proj: &Projection,
    margin: f64,
    counters: &mut TestCounters,
) -> bool {
    // P must lie inside the silhouette, so inside the occluder's bounds (under positive-area
    // semantics P's corners may lie on the silhouette; a failed filter only keeps P visible).
    let rect_margin = if p.area { 0.0 } else { margin };
    if !o.rect.contains(&p.rect, rect_margin) {
        return false;
    }
    // Entirely nearer than every occluder triangle: cannot be hidden by it.
    if p.zmax * (1.0 + DEPTH_EPS) < o.zmin {
        return false;
    }
    counters.silhouette_tests += 1;
    // Silhouette test: no edge overlaps P, and P is inside (non-zero winding number).
    let q = inner_point(p.screen);
    let mut winding = 0i32;
    // P grown by the margin lies in this rectangle; an edge whose bounds miss it cannot come
    // within the margin of P, so the exact (costly) edge overlap test is skipped for it.
    let (lo, hi) = (p.rect.min - margin, p.rect.max + margin);
    let touching_tri = p.tri_screen.filter(|_| p.area);
    for e in &o.edges {
        let (emin, emax) = (e.a.min(e.b), e.a.max(e.b));
        let near = emin.x <= hi.x && emax.x >= lo.x && emin.y <= hi.y && emax.y >= lo.y;
        if near && segment_overlaps(e.a, e.b, p.screen, margin) {
            let allowed =
                touching_tri.is_some_and(|t| stays_on_boundary(e, t, margin) && clear_of(q, e));
            if !allowed {
                return false;
            }
        }
        winding += ray_winding(q, e.a, e.b);
    }
    if winding == 0 {
        return false;
    }
    // Depth bounds: behind the whole occluder, no triangle test needed.
    if p.zmin > o.zmax * (1.0 + DEPTH_EPS) {
        return true;
    }
    // Triangle test: behind every occluder triangle it overlaps.
    counters.triangle_tests += 1;
    o.tris.iter().all(|t| {
        if !t.rect.touches(&p.rect, margin) || !convex_overlap(&t.screen, p.screen, margin) {
            return true;
        }
        if let Some(tri) = touching_tri {
            if interiors_apart_at_shared_corners(tri, &t.screen, margin) {
                return true;
            }
        }
        if p.area && behind_but_shared_corners(p.corners, p.plane(), &t.corners, &t.plane) {
            return true;
        }
        let view = OccluderView {
            corners: &t.corners,
            screen: &t.screen,
            plane: &t.plane,
        };
        occludee_behind(p.poly, p.plane(), &view, proj, margin)
    })
}

/// Positive-area semantics: whether silhouette edge `e` cannot enter the open interior of the
/// occludee's screen triangle `tri`: it is one of `tri`'s edges, or it starts at a corner of
/// `tri` and leaves it clearly outwards.
fn stays_on_boundary(e: &Edge, tri: &[DVec2; 3], margin: f64) -> bool {
    let corner = |v: DVec2| tri.iter().position(|&c| c == v);
    match (corner(e.a), corner(e.b)) {
        (Some(i), Some(j)) => i != j,
        (Some(i), None) => leaves_outwards(tri, i, e.b, margin),
        (None, Some(j)) => leaves_outwards(tri, j, e.a, margin),
        (None, None) => false,
    }
}

/// Whether the segment from corner `i` of `tri` to `w` lies clearly outside one of the two
/// edge lines of `tri` at that corner, so it meets the triangle only at the corner.
fn leaves_outwards(tri: &[DVec2; 3], i: usize, w: DVec2, margin: f64) -> bool {
    let (v, a, b) = (tri[i], tri[(i + 1) % 3], tri[(i + 2) % 3]);
    beyond_edge_line(v, a, b, w, margin) || beyond_edge_line(v, b, a, w, margin)
}

/// Whether `w` lies on the other side of the line `v a` from `inside`, farther than the margin
/// grown by `|w - v| / |a - v|`: a perturbation of `a` by the margin turns the line by
/// `margin / |a - v|`, which moves it by that much times `|w - v|` at `w`. Then the whole
/// segment `v w` (but `v`) is strictly on the outer side, however either segment is rounded
/// within the margin.
fn beyond_edge_line(v: DVec2, a: DVec2, inside: DVec2, w: DVec2, margin: f64) -> bool {
    let d = a - v;
    let (la, lw) = (d.length(), (w - v).length());
    if la == 0.0 || lw == 0.0 || !la.is_finite() || !lw.is_finite() {
        return false;
    }
    let side = d.perp_dot(inside - v);
    if side == 0.0 {
        return false;
    }
    let dist = d.perp_dot(w - v) / la * side.signum();
    dist < -margin * (1.0 + lw / la)
}

/// Positive-area semantics: whether screen triangles `p` and `t`, which share one or two
/// corners bit for bit, have disjoint interiors: a line through the shared corners (the shared
/// edge, or an edge line of either triangle at the shared corner) has the other corners of the
/// two triangles clearly on opposite sides. They may then meet only along the shared corner or
/// edge, a set of zero area.
fn interiors_apart_at_shared_corners(p: &[DVec2; 3], t: &[DVec2; 3], margin: f64) -> bool {
    let mut shared = [(0usize, 0usize); 3];
    let mut n = 0;
    for (i, v) in p.iter().enumerate() {
        if let Some(j) = t.iter().position(|w| w == v) {
            shared[n] = (i, j);
            n += 1;
        }
    }
    match n {
        1 => {
            let (i, j) = shared[0];
            let (pa, pb) = (p[(i + 1) % 3], p[(i + 2) % 3]);
            let (ta, tb) = (t[(j + 1) % 3], t[(j + 2) % 3]);
            let v = p[i];
            // One of p's edge lines at v keeps both other corners of t beyond it, or the reverse.
            (beyond_edge_line(v, pa, pb, ta, margin) && beyond_edge_line(v, pa, pb, tb, margin))
                || (beyond_edge_line(v, pb, pa, ta, margin)
                    && beyond_edge_line(v, pb, pa, tb, margin))
                || (beyond_edge_line(v, ta, tb, pa, margin)
                    && beyond_edge_line(v, ta, tb, pb, margin))
                || (beyond_edge_line(v, tb, ta, pa, margin)
                    && beyond_edge_line(v, tb, ta, pb, margin))
        }
        2 => {
            let ((i0, _), (i1, j1)) = (shared[0], shared[1]);
            let (a, b) = (p[i0], p[i1]);
            let p_other = p[3 - i0 - i1];
            let t_other = t[3 - shared[0].1 - j1];
            // The shared edge is the same segment in both: only the other corners can move.
            let d = b - a;
            let len = d.length();
            if len == 0.0 || !len.is_finite() {
                return false;
            }
            let (sp, st) = (d.perp_dot(p_other - a) / len, d.perp_dot(t_other - a) / len);
            (sp > margin && st < -margin) || (sp < -margin && st > margin)
        }
        _ => false,
    }
}

/// Whether the winding test point `q` is safely off the line of an edge that touches the
/// occludee (`q` is inside the occludee, so only a sliver occludee brings it near).
fn clear_of(q: DVec2, e: &Edge) -> bool {
    let d = e.b - e.a;
    let len = d.length();
    len > 0.0 && (d.perp_dot(q - e.a) / len).abs() > 1e-6
}

/// Positive-area semantics: whether occludee triangle `p` shares one or two corners with
/// occluder triangle `t` (bit for bit) and is otherwise behind it: its other corners are
/// behind `t`'s plane by the relative margin (eq. 4.11, first half), or `t`'s other corners
/// are in front of `p`'s plane by it (second half). Then every point of `p` but the shared
/// corner or edge is behind `t`'s plane, or every point of `t` but those is in front of `p`'s,
/// and either way `t` hides `p` wherever it covers it except there.
fn behind_but_shared_corners(
    p: &[DVec3; 3],
    p_plane: Option<&[f64; 4]>,
    t: &[DVec3; 3],
    t_plane: &[f64; 4],
) -> bool {
    let shared = p.iter().filter(|v| t.contains(v)).count();
    if shared != 1 && shared != 2 {
        return false;
    }
    p.iter().all(|v| t.contains(v) || behind(t_plane, *v))
        || p_plane.is_some_and(|pp| t.iter().all(|u| p.contains(u) || in_front(pp, *u)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rv::depth::eye_plane;

    const M: f64 = 1e-3;

    fn v(x: f64, y: f64) -> DVec2 {
        DVec2::new(x, y)
    }

    fn tri() -> [DVec2; 3] {
        [v(0.0, 0.0), v(10.0, 0.0), v(0.0, 10.0)]
    }

    #[test]
    fn an_edge_of_the_occludee_stays_on_its_boundary() {
        let t = tri();
        assert!(stays_on_boundary(&Edge { a: t[0], b: t[1] }, &t, M));
        // Either direction.
        assert!(stays_on_boundary(&Edge { a: t[2], b: t[1] }, &t, M));
    }

    #[test]
    fn an_edge_leaving_a_corner_outwards_stays_on_the_boundary() {
        let t = tri();
        assert!(stays_on_boundary(
            &Edge {
                a: t[0],
                b: v(-5.0, -1.0)
            },
            &t,
            M
        ));
        assert!(stays_on_boundary(
            &Edge {
                a: v(12.0, -3.0),
                b: t[1]
            },
            &t,
            M
        ));
    }

    #[test]
    fn an_edge_entering_the_interior_does_not() {
        let t = tri();
        // From a corner into the triangle.
        assert!(!stays_on_boundary(
            &Edge {
                a: t[0],
                b: v(3.0, 3.0)
            },
            &t,
            M
        ));
        // Touching no corner at all (crossing it).
        assert!(!stays_on_boundary(
            &Edge {
                a: v(-1.0, 5.0),
                b: v(5.0, -1.0)
            },
            &t,
            M
        ));
        // Leaving a corner outwards, but within the (scaled) margin of an edge line: the
        // rounding of either segment could put it inside.
        let grazing = Edge {
            a: t[0],
            b: v(10.0, -1e-4),
        };
        assert!(!stays_on_boundary(&grazing, &t, M));
    }

    #[test]
    fn triangles_on_either_side_of_a_shared_edge_are_apart() {
        let p = tri();
        let across = [v(10.0, 0.0), v(0.0, 10.0), v(10.0, 10.0)];
        assert!(interiors_apart_at_shared_corners(&p, &across, M));
        // Folded back over the same side: they overlap.
        let folded = [v(10.0, 0.0), v(0.0, 10.0), v(2.0, 2.0)];
        assert!(!interiors_apart_at_shared_corners(&p, &folded, M));
    }

    #[test]
    fn triangles_sharing_a_corner_are_apart_only_when_a_line_separates_them() {
        let p = tri();
        let beside = [v(0.0, 0.0), v(-5.0, 1.0), v(-1.0, 8.0)];
        assert!(interiors_apart_at_shared_corners(&p, &beside, M));
        let overlapping = [v(0.0, 0.0), v(5.0, 1.0), v(-1.0, 8.0)];
        assert!(!interiors_apart_at_shared_corners(&p, &overlapping, M));
        // No shared corner: never claimed apart here.
        let elsewhere = [v(20.0, 0.0), v(30.0, 0.0), v(20.0, 10.0)];
        assert!(!interiors_apart_at_shared_corners(&p, &elsewhere, M));
    }

    /// A unit cube seen from (3, 2.5, 2) in view coordinates: the eye at the origin, the cube
    /// ahead along +z.
    fn corner(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x - 0.5, y - 0.5, z + 3.0)
    }

    #[test]
    fn a_back_face_sharing_an_edge_lies_behind_the_front_face() {
        // Front face z = 0 (nearest), back face x = 1 sharing the edge x = 1, z = 0.
        let front = [
            corner(0.0, 0.0, 0.0),
            corner(1.0, 0.0, 0.0),
            corner(1.0, 1.0, 0.0),
        ];
        let side = [
            corner(1.0, 0.0, 0.0),
            corner(1.0, 1.0, 0.0),
            corner(1.0, 1.0, 1.0),
        ];
        let fp = eye_plane(front[0], front[1], front[2]).expect("plane");
        let sp = eye_plane(side[0], side[1], side[2]);
        assert!(behind_but_shared_corners(&side, sp.as_ref(), &front, &fp));
        // The same triangle is not behind itself (three shared corners: a tie).
        assert!(!behind_but_shared_corners(&front, Some(&fp), &front, &fp));
        // In front of it: the front face is not behind the side face.
        let spl = sp.expect("plane");
        assert!(!behind_but_shared_corners(&front, Some(&fp), &side, &spl));
    }

    #[test]
    fn no_shared_corner_is_left_to_the_general_test() {
        let near = [
            corner(0.0, 0.0, 0.0),
            corner(1.0, 0.0, 0.0),
            corner(1.0, 1.0, 0.0),
        ];
        let far = near.map(|c| c + DVec3::new(0.0, 0.0, 5.0));
        let np = eye_plane(near[0], near[1], near[2]).expect("plane");
        assert!(!behind_but_shared_corners(&far, None, &near, &np));
    }
}
