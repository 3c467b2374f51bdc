//! The enlarged border polygon of adaptive border sampling (Wonka et al. 2006; Koch & Wimmer
//! 2021, section 4.2 and figure 2): the triangle grown by `delta` in its own plane, as nine
//! vertices — at each corner, the ends of the two offset edges and a point on the corner's
//! bisector.

use glam::Vec3;

/// The nine border vertices of triangle `p` grown by `delta`, in order around it: for corner
/// `i`, `[p_i + δ m_(i-1), p_i + δ b_i, p_i + δ m_i]`, where `m_i` is the outward in-plane
/// normal of edge `i` (from `p_i` to `p_(i+1)`) and `b_i` the corner's outward bisector. The
/// long edges of the polygon (indices 2→3, 5→6, 8→0) run parallel to the triangle's edges.
pub(crate) fn border_polygon(p: [Vec3; 3], delta: f32) -> [Vec3; 9] {
    let normal = (p[1] - p[0]).cross(p[2] - p[0]);
    let m: [Vec3; 3] =
        std::array::from_fn(|i| (p[(i + 1) % 3] - p[i]).cross(normal).normalize_or_zero());
    std::array::from_fn(|k| {
        let corner = k / 3;
        let previous_edge = m[(corner + 2) % 3];
        let next_edge = m[corner];
        let offset = match k % 3 {
            0 => previous_edge,
            1 => (previous_edge + next_edge).normalize_or_zero(),
            _ => next_edge,
        };
        p[corner] + offset * delta
    })
}

/// The targets of the border *vertex* rays: the [`border_polygon`] with each offset-edge end
/// pushed a further `δ/4` along its corner's outward bisector.
///
/// Why: at a right-angled corner (grids, brushes, buildings: most corners) `p_i + δ m_(i-1)`
/// lies exactly on the extension of edge `i`, which is where the seam to the neighbouring
/// triangles runs. When that seam is a T-junction, the f32 rounding leaves a crack along it,
/// and a ray aimed at a point on the seam passes through and finds what lies behind the wall
/// (`exploration_rays_do_not_leak_through_cracks_between_triangles`). The push moves every
/// target off the lines of the triangle's edges by at least `δ/6`, far wider than such
/// cracks, and keeps it outside the triangle.
pub(crate) fn vertex_targets(p: [Vec3; 3], delta: f32) -> [Vec3; 9] {
    let mut targets = border_polygon(p, delta);
    for corner in 0..3 {
        let bisector = (targets[3 * corner + 1] - p[corner]).normalize_or_zero();
        for k in [3 * corner, 3 * corner + 2] {
            targets[k] += bisector * (0.25 * delta);
        }
    }
    targets
}

/// The long edges of the border polygon as (start, end) vertex indices.
pub(crate) const LONG_EDGES: [(usize, usize); 3] = [(2, 3), (5, 6), (8, 0)];

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

    fn inside(p: Vec3) -> bool {
        p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0
    }

    #[test]
    fn border_vertices_lie_outside_at_distance_delta() {
        for winding in [TRI, [TRI[0], TRI[2], TRI[1]]] {
            let poly = border_polygon(winding, 0.01);
            for (k, v) in poly.iter().enumerate() {
                assert!(!inside(*v), "vertex {k} {v} is inside the triangle");
                assert!(v.z.abs() < 1e-7, "vertex {k} left the plane");
                let nearest = winding[k / 3];
                assert!((v.distance(nearest) - 0.01).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn vertex_targets_stay_off_the_lines_of_the_edges() {
        // A right angle at corner 0: the plain border vertices lie on the edges' extensions.
        let poly = border_polygon(TRI, 0.01);
        assert!(poly[0].y.abs() < 1e-9 || poly[0].x.abs() < 1e-9);
        for winding in [TRI, [TRI[0], TRI[2], TRI[1]]] {
            for (k, v) in vertex_targets(winding, 0.01).iter().enumerate() {
                assert!(!inside(*v), "target {k} {v} is inside the triangle");
                assert!(v.z.abs() < 1e-7, "target {k} left the plane");
                // Distance to each edge's line (the lines x = 0, y = 0, x + y = 1).
                let lines = [v.x.abs(), v.y.abs(), (v.x + v.y - 1.0).abs() / 2f32.sqrt()];
                let nearest = lines.into_iter().fold(f32::INFINITY, f32::min);
                assert!(
                    nearest >= 0.01 / 6.0,
                    "target {k} {v} is {nearest} off an edge line"
                );
            }
        }
    }

    #[test]
    fn long_edges_are_parallel_to_triangle_edges() {
        let poly = border_polygon(TRI, 0.01);
        for (i, (a, b)) in LONG_EDGES.iter().enumerate() {
            let edge = TRI[(i + 1) % 3] - TRI[i];
            let long = poly[*b] - poly[*a];
            assert!(edge.cross(long).length() < 1e-6);
            assert!(edge.dot(long) > 0.0);
        }
    }
}
