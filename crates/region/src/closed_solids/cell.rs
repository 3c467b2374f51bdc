//! Whether a view cell lies wholly outside a solid: no triangle of the solid meets the cell's
//! box, and the box's centre is outside (winding number 0, counted along an axis ray).
//! Both tests answer "not known" (the solid is not used for the cell) where rounding could
//! decide them.

use glam::DVec3;

use super::span::span_along;

/// Tolerances relative to the sizes involved (f64 rounding of f32 inputs is about 1e-16).
const RELATIVE_TOLERANCE: f64 = 1e-7;

/// Whether triangle `t` may meet the box `min..max` (separating axis test on the box grown by
/// the tolerance: `false` only when they are surely apart).
pub(crate) fn may_meet_box(t: &[DVec3; 3], min: DVec3, max: DVec3) -> bool {
    let centre = (min + max) * 0.5;
    let scale = (max - min).max_element().max(
        t.iter()
            .map(|p| (*p - centre).abs().max_element())
            .fold(0.0, f64::max),
    );
    let half = (max - min) * 0.5 + DVec3::splat(RELATIVE_TOLERANCE * scale);
    let v = t.map(|p| p - centre);
    let apart_on = |axis: DVec3| {
        let r = half.dot(axis.abs());
        let (lo, hi) = span_along(&v, axis);
        lo > r || hi < -r
    };
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let mut axes = vec![DVec3::X, DVec3::Y, DVec3::Z, edges[0].cross(edges[1])];
    for e in edges {
        axes.extend([DVec3::X.cross(e), DVec3::Y.cross(e), DVec3::Z.cross(e)]);
    }
    !axes.into_iter().any(apart_on)
}

/// The winding number of the oriented closed surface `triangles` (outward when `orientation`
/// is +1) at `point`, counted along the ray from `point` in direction `sign` on `axis`: exits
/// minus entries. `None` when the ray passes within the tolerance of an edge or corner, or
/// `point` lies on a triangle's plane where it crosses.
pub(crate) fn winding_number(
    triangles: impl Iterator<Item = [DVec3; 3]>,
    orientation: f64,
    point: DVec3,
    axis: usize,
    sign: f64,
) -> Option<i64> {
    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut winding = 0i64;
    for t in triangles {
        let p = t.map(|c| (c[u] - point[u], c[w] - point[w]));
        let (lo_u, hi_u) = (
            p[0].0.min(p[1].0).min(p[2].0),
            p[0].0.max(p[1].0).max(p[2].0),
        );
        let (lo_w, hi_w) = (
            p[0].1.min(p[1].1).min(p[2].1),
            p[0].1.max(p[1].1).max(p[2].1),
        );
        let size = (hi_u - lo_u).max(hi_w - lo_w);
        let pad = RELATIVE_TOLERANCE
            * size.max(lo_u.abs().max(hi_u.abs()).max(lo_w.abs().max(hi_w.abs())));
        if lo_u > pad || hi_u < -pad || lo_w > pad || hi_w < -pad {
            continue; // the ray passes beside the triangle's shadow on the plane
        }
        // Edge functions of the origin (the ray) against the projected edges.
        let mut signs = [0i8; 3];
        for k in 0..3 {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            let e = a.0 * b.1 - a.1 * b.0;
            let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
            let reach = (a.0 * a.0 + a.1 * a.1)
                .sqrt()
                .max((b.0 * b.0 + b.1 * b.1).sqrt());
            let tolerance = RELATIVE_TOLERANCE * len * reach.max(len);
            if e.abs() <= tolerance {
                return None; // the ray grazes this edge's line within the shadow's box
            }
            signs[k] = if e > 0.0 { 1 } else { -1 };
        }
        if signs[0] != signs[1] || signs[1] != signs[2] {
            continue;
        }
        let normal = (t[1] - t[0]).cross(t[2] - t[0]) * orientation;
        // The plane's coordinate along the axis at the ray.
        let along = t[0][axis]
            - (normal[u] * (point[u] - t[0][u]) + normal[w] * (point[w] - t[0][w])) / normal[axis];
        let distance = (along - point[axis]) * sign;
        let reach = t
            .iter()
            .map(|c| (*c - point).abs().max_element())
            .fold(0.0, f64::max);
        if distance.abs() <= RELATIVE_TOLERANCE * reach {
            return None;
        }
        if distance > 0.0 {
            winding += if normal[axis] * sign > 0.0 { 1 } else { -1 };
        }
    }
    Some(winding)
}

#[cfg(test)]
mod tests {
    use super::super::embedded::tests::box_triangles;
    use super::*;

    #[test]
    fn the_box_test_tells_apart_meeting_and_separated_triangles() {
        let (min, max) = (DVec3::ZERO, DVec3::ONE);
        let inside = [
            DVec3::splat(0.2),
            DVec3::splat(0.3),
            DVec3::new(0.2, 0.4, 0.3),
        ];
        let across = [
            DVec3::new(-1.0, 0.5, 0.5),
            DVec3::new(2.0, 0.5, 0.4),
            DVec3::new(2.0, 0.6, 0.6),
        ];
        // Beyond the corner (1,1,1), cutting the x, y and z ranges but not the box.
        let beyond_corner = [
            DVec3::new(3.2, 0.0, 0.0),
            DVec3::new(0.0, 3.2, 0.0),
            DVec3::new(0.0, 0.0, 3.2),
        ];
        let far = beyond_corner.map(|p| p + DVec3::splat(5.0));
        assert!(may_meet_box(&inside, min, max));
        assert!(may_meet_box(&across, min, max));
        assert!(!may_meet_box(&beyond_corner, min, max));
        assert!(!may_meet_box(&far, min, max));
    }

    #[test]
    fn the_winding_number_is_one_inside_a_box_and_zero_outside() {
        let cube = box_triangles([0.0; 3], [1.0; 3]);
        let at = |p: DVec3, orientation: f64, axis: usize, sign: f64| {
            winding_number(cube.iter().copied(), orientation, p, axis, sign)
        };
        let inside = DVec3::new(0.3, 0.41, 0.37);
        let outside = DVec3::new(0.3, 0.41, -0.5);
        for axis in 0..3 {
            for sign in [1.0, -1.0] {
                assert_eq!(at(inside, 1.0, axis, sign), Some(1));
                assert_eq!(at(inside, -1.0, axis, sign), Some(-1));
                assert_eq!(at(outside, 1.0, axis, sign), Some(0));
            }
        }
        // A ray along the box's edge plane is refused.
        assert_eq!(at(DVec3::new(0.5, 0.0, -1.0), 1.0, 2, 1.0), None);
    }
}
