//! Whether a candidate solid's surface meets itself anywhere but along the corners and edges
//! its triangles share: a surface that cuts through itself (a footprint drawn as a bow tie,
//! two building parts merged through each other) encloses space more than once or with the
//! wrong hand, and the rule "behind a face is inside" fails for it.
//!
//! Every test here is conservative in one direction only: "may meet" whenever rounding leaves
//! doubt, so a surface is called embedded only when no pair of its triangles can meet.

use glam::DVec3;

use super::span::span_along;

/// Tolerances relative to the size of the pair of triangles tested (f64 rounding of their
/// f32 corners is about 1e-16 of it).
const RELATIVE_TOLERANCE: f64 = 1e-7;

/// Tolerance on sines of angles between unit vectors.
const ANGULAR_TOLERANCE: f64 = 1e-9;

/// Below this sine two planes through a shared corner are treated as one.
const COPLANAR_SINE: f64 = 1e-6;

/// Whether the surface of `triangles` (corners in f64) may meet itself improperly; also
/// `true` when checking it would take more than `max_pair_tests` precise pair tests.
pub(super) fn may_meet_itself(triangles: &[[DVec3; 3]], max_pair_tests: usize) -> bool {
    let boxes: Vec<(DVec3, DVec3)> = triangles
        .iter()
        .map(|t| {
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            let pad = RELATIVE_TOLERANCE * (hi - lo).max_element();
            (lo - DVec3::splat(pad), hi + DVec3::splat(pad))
        })
        .collect();
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_unstable_by(|&a, &b| boxes[a].0.x.total_cmp(&boxes[b].0.x));
    let mut tests = 0usize;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if boxes[j].0.x > boxes[i].1.x {
                break;
            }
            let overlap = boxes[i].0.cmple(boxes[j].1).all() && boxes[j].0.cmple(boxes[i].1).all();
            if !overlap {
                continue;
            }
            tests += 1;
            if tests > max_pair_tests || may_meet_improperly(&triangles[i], &triangles[j]) {
                return true;
            }
        }
    }
    false
}

/// The corners two triangles share (bit-identical), as (index in `a`, index in `b`), with
/// their count (3 or more only for a repeated triangle), and the tolerance of their tests
/// (relative to the pair's size).
fn shared_corners(a: &[DVec3; 3], b: &[DVec3; 3]) -> ([(usize, usize); 3], usize, f64) {
    let mut shared = [(0usize, 0usize); 3];
    let mut count = 0;
    for (i, p) in a.iter().enumerate() {
        for (j, q) in b.iter().enumerate() {
            if p == q {
                shared[count.min(2)] = (i, j);
                count += 1;
            }
        }
    }
    let (lo, hi) = a
        .iter()
        .chain(b)
        .fold((a[0], a[0]), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    (shared, count, RELATIVE_TOLERANCE * (hi - lo).max_element())
}

/// Whether two non-degenerate triangles may meet anywhere but at corners they share exactly
/// (bit-identical) and along an edge they share exactly.
pub(super) fn may_meet_improperly(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let (shared, count, tolerance) = shared_corners(a, b);
    match count {
        0 => meet_apart(a, b, tolerance),
        1 => meet_beyond_corner(a, b, shared[0]),
        2 => fold_over_edge(a, b, shared[0], shared[1], tolerance),
        _ => true, // the same triangle twice
    }
}

/// Whether two triangles sharing exactly one edge (bit-identical corners) fold onto each
/// other across it (or may, under rounding): the wall two abutting buildings of different
/// heights both stand on.
pub(super) fn fold_onto_each_other(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let (shared, count, tolerance) = shared_corners(a, b);
    count != 2 || fold_over_edge(a, b, shared[0], shared[1], tolerance)
}

fn unit_normal(t: &[DVec3; 3]) -> DVec3 {
    (t[1] - t[0]).cross(t[2] - t[0]).normalize()
}

/// Two triangles sharing an edge meet elsewhere only when they fold onto each other: the same
/// plane, on the same side of the edge.
fn fold_over_edge(
    a: &[DVec3; 3],
    b: &[DVec3; 3],
    (i0, j0): (usize, usize),
    (i1, j1): (usize, usize),
    tolerance: f64,
) -> bool {
    let (a_other, b_other) = (a[3 - i0 - i1], b[3 - j0 - j1]);
    let (e0, e1) = (a[i0], a[i1]);
    let n = unit_normal(a);
    if n.dot(b_other - e0).abs() > tolerance {
        return false; // the planes meet only along the edge's line
    }
    let across = n.cross(e1 - e0);
    let (sa, sb) = (across.dot(a_other - e0), across.dot(b_other - e0));
    sa * sb >= 0.0 || sb.abs() <= tolerance * across.length()
}

/// Whether unit direction `w` in the plane of the wedge `u` (apex directions, normal `n` with
/// `u[0] x u[1]` along it) is inside the wedge or within the tolerance of its sides.
fn in_wedge(u: &[DVec3; 2], n: DVec3, w: DVec3) -> bool {
    u[0].cross(w).dot(n) >= -ANGULAR_TOLERANCE && w.cross(u[1]).dot(n) >= -ANGULAR_TOLERANCE
}

/// Two triangles sharing one corner `v` meet elsewhere only when their wedges at `v` share a
/// direction: along the line where their planes cross, or anywhere when they are coplanar.
fn meet_beyond_corner(a: &[DVec3; 3], b: &[DVec3; 3], (i, j): (usize, usize)) -> bool {
    let wedge = |t: &[DVec3; 3], k: usize| {
        let v = t[k];
        [
            (t[(k + 1) % 3] - v).normalize(),
            (t[(k + 2) % 3] - v).normalize(),
        ]
    };
    let (ua, mut ub) = (wedge(a, i), wedge(b, j));
    let na = ua[0].cross(ua[1]).normalize();
    let nb = ub[0].cross(ub[1]).normalize();
    let line = na.cross(nb);
    if line.length() <= COPLANAR_SINE {
        // One plane: the wedges overlap when a side of one lies in (or on) the other (both
        // wedges turned the same way round `na`).
        if nb.dot(na) < 0.0 {
            ub.swap(0, 1);
        }
        return ub.iter().any(|&w| in_wedge(&ua, na, w))
            || ua.iter().any(|&w| in_wedge(&ub, na, w));
    }
    let d = line.normalize();
    (in_wedge(&ua, na, d) && in_wedge(&ub, nb, d))
        || (in_wedge(&ua, na, -d) && in_wedge(&ub, nb, -d))
}

/// The unit vector along `u x v`, `None` when the two are (nearly) parallel.
fn cross_axis(u: DVec3, v: DVec3) -> Option<DVec3> {
    let c = u.cross(v);
    let length = c.length();
    (length > 1e-12 * u.length() * v.length()).then(|| c / length)
}

/// Two triangles with no shared corner: apart when some axis separates them by more than
/// the tolerance (the separating axis theorem: the triangles' normals, the cross products of
/// their edges, and each edge's normal within its triangle's plane for coplanar pairs). An
/// axis that separates their projections separates the triangles whatever the rounding of
/// the axis, so only the margin guards the f64 arithmetic.
fn meet_apart(a: &[DVec3; 3], b: &[DVec3; 3], tolerance: f64) -> bool {
    let origin = a[0];
    let (a, b) = (a.map(|p| p - origin), b.map(|p| p - origin));
    let ea = [a[1] - a[0], a[2] - a[1], a[0] - a[2]];
    let eb = [b[1] - b[0], b[2] - b[1], b[0] - b[2]];
    let (na, nb) = (ea[0].cross(ea[1]), eb[0].cross(eb[1]));
    let mut axes: Vec<DVec3> = Vec::with_capacity(17);
    axes.extend([na.normalize(), nb.normalize()]);
    for u in ea {
        axes.extend(eb.iter().filter_map(|&v| cross_axis(u, v)));
        axes.extend(cross_axis(na, u));
    }
    axes.extend(eb.iter().filter_map(|&v| cross_axis(nb, v)));
    !axes.into_iter().any(|m| {
        let ((alo, ahi), (blo, bhi)) = (span_along(&a, m), span_along(&b, m));
        blo > ahi + tolerance || alo > bhi + tolerance
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn t(p: [[f64; 3]; 3]) -> [DVec3; 3] {
        p.map(DVec3::from_array)
    }

    #[test]
    fn triangles_sharing_an_edge_meet_only_when_folded() {
        let a = t([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
        let flat = t([[1., 0., 0.], [0., 0., 0.], [0., -1., 0.]]);
        let bent = t([[1., 0., 0.], [0., 0., 0.], [0., 0., 1.]]);
        let folded = t([[1., 0., 0.], [0., 0., 0.], [0.5, 0.5, 0.]]);
        assert!(!may_meet_improperly(&a, &flat));
        assert!(!may_meet_improperly(&a, &bent));
        assert!(may_meet_improperly(&a, &folded));
    }

    #[test]
    fn triangles_sharing_a_corner_meet_when_their_wedges_share_a_direction() {
        let a = t([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]]);
        // A fan neighbour across a gap, coplanar: apart.
        let fan = t([[0., 0., 0.], [-1., -0.1, 0.], [-0.1, -1., 0.]]);
        // Coplanar and overlapping.
        let over = t([[0., 0., 0.], [1., 1., 0.], [-1., 2., 0.]]);
        // Upright through a's interior along the diagonal.
        let through = t([[0., 0., 0.], [1., 1., -1.], [1., 1., 1.]]);
        // Upright, outside a (along the negative diagonal).
        let beside = t([[0., 0., 0.], [-1., -1., -1.], [-1., -1., 1.]]);
        assert!(!may_meet_improperly(&a, &fan));
        assert!(may_meet_improperly(&a, &over));
        assert!(may_meet_improperly(&a, &through));
        assert!(!may_meet_improperly(&a, &beside));
    }

    #[test]
    fn triangles_apart_meet_when_they_cross_or_touch() {
        let a = t([[0., 0., 0.], [2., 0., 0.], [0., 2., 0.]]);
        let piercing = t([[0.5, 0.5, -1.], [0.6, 0.5, 1.], [0.5, 0.6, 1.]]);
        let above = t([[0.5, 0.5, 0.1], [0.6, 0.5, 1.], [0.5, 0.6, 1.]]);
        let touching = t([[0.5, 0.5, 0.], [0.6, 0.5, 1.], [0.5, 0.6, 1.]]);
        let coplanar_apart = t([[3., 0., 0.], [4., 0., 0.], [3., 1., 0.]]);
        let coplanar_over = t([[0.5, 0.5, 0.], [4., 0.5, 0.], [0.5, 4., 0.]]);
        // Crossing planes, but the crossing segments miss each other.
        let wide_miss = t([[5., 5., -1.], [6., 5., 1.], [5., 6., 1.]]);
        assert!(may_meet_improperly(&a, &piercing));
        assert!(!may_meet_improperly(&a, &above));
        assert!(may_meet_improperly(&a, &touching));
        assert!(!may_meet_improperly(&a, &coplanar_apart));
        assert!(may_meet_improperly(&a, &coplanar_over));
        assert!(!may_meet_improperly(&a, &wide_miss));
    }

    #[test]
    fn a_closed_box_does_not_meet_itself_and_two_boxes_through_each_other_do() {
        let cube = box_triangles([0.0; 3], [1.0; 3]);
        assert!(!may_meet_itself(&cube, 1 << 20));
        // Two boxes through each other.
        let mut two = cube.clone();
        two.extend(box_triangles([0.5; 3], [1.5; 3]));
        assert!(may_meet_itself(&two, 1 << 20));
        // The pair budget: too few tests is "may meet".
        assert!(may_meet_itself(&cube, 3));
    }

    /// The 12 triangles of a box, wound outwards.
    pub(crate) fn box_triangles(min: [f64; 3], max: [f64; 3]) -> Vec<[DVec3; 3]> {
        let c = |i: usize| {
            DVec3::new(
                if i & 1 == 0 { min[0] } else { max[0] },
                if i & 2 == 0 { min[1] } else { max[1] },
                if i & 4 == 0 { min[2] } else { max[2] },
            )
        };
        // Faces as corner quads, counter-clockwise seen from outside.
        let faces = [
            [0, 2, 3, 1], // z min
            [4, 5, 7, 6], // z max
            [0, 1, 5, 4], // y min
            [2, 6, 7, 3], // y max
            [0, 4, 6, 2], // x min
            [1, 3, 7, 5], // x max
        ];
        faces
            .iter()
            .flat_map(|f| [[c(f[0]), c(f[1]), c(f[2])], [c(f[0]), c(f[2]), c(f[3])]])
            .collect()
    }
}
