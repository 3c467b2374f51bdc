//! Faces of solids that another triangle lies on (a building's back wall against its
//! neighbour's front wall, drawn as two walls in one plane) are never removed. Exact
//! arithmetic does not need this: a segment to a back face still crosses its own solid's
//! surface strictly before, whatever lies on the face. It is a margin against f32 rounding:
//! where walls meet walls, edges of several surfaces gather, and near an edge a ray caster's
//! depths tie (see `mod.rs`). On the shared city cells it lowers the set triangles found
//! outside the conservative set (munich 25 -> 16 over six cells, etoile 52 -> 42, fzk_haus
//! 9 -> 5) for bounds 7-8 % larger (munich 3.32x -> 3.58x the sets, etoile 2.29x -> 2.49x).
//!
//! Narrow faces are treated alike (`narrowest_width`, see `mod.rs`): across a rod or wall
//! end thinner than a few centimetres the front and back tie in f32 depth near its edges.
//!
//! A face is *tied* when some other triangle lies within the tie distance of its plane (all
//! three corners) and overlaps it there (no edge normal of either, in the face's plane,
//! separates them beyond rounding). Crossings at an angle and contacts along a
//! line have no area and are left alone.

use glam::DVec3;
use sightline_core::Scene;

use super::span::span_along;
use super::topology::{corners_of, normal_of};

/// Per triangle, whether it is a face of a solid (`in_solid`) that another triangle lies on
/// (see the module documentation); `None` when finding out would take more than
/// `max_pair_tests` precise tests (the caller then trusts no face).
pub(super) fn tied_faces(
    scene: &Scene,
    in_solid: &[bool],
    tie_distance: f64,
    max_pair_tests: usize,
) -> Option<Vec<bool>> {
    let n = scene.triangle_count();
    let pad = DVec3::splat(tie_distance);
    let boxes: Vec<(DVec3, DVec3)> = (0..n as u32)
        .map(|t| {
            let c = corners_of(scene, t);
            (
                c[0].min(c[1]).min(c[2]) - pad,
                c[0].max(c[1]).max(c[2]) + pad,
            )
        })
        .collect();
    let mut order: Vec<u32> = (0..n as u32)
        .filter(|&t| boxes[t as usize].0.is_finite() && boxes[t as usize].1.is_finite())
        .collect();
    order.sort_unstable_by(|&a, &b| boxes[a as usize].0.x.total_cmp(&boxes[b as usize].0.x));
    let mut tied = vec![false; n];
    let mut tests = 0usize;
    for (k, &i) in order.iter().enumerate() {
        let (lo_i, hi_i) = boxes[i as usize];
        let a = corners_of(scene, i);
        for &j in &order[k + 1..] {
            let (lo_j, hi_j) = boxes[j as usize];
            if lo_j.x > hi_i.x {
                break;
            }
            let (solid_i, solid_j) = (in_solid[i as usize], in_solid[j as usize]);
            if !(solid_i || solid_j) || !(lo_i.cmple(hi_j).all() && lo_j.cmple(hi_i).all()) {
                continue;
            }
            tests += 1;
            if tests > max_pair_tests {
                return None;
            }
            let b = corners_of(scene, j);
            if solid_i && lies_on(&b, &a, tie_distance) {
                tied[i as usize] = true;
            }
            if solid_j && lies_on(&a, &b, tie_distance) {
                tied[j as usize] = true;
            }
        }
    }
    Some(tied)
}

/// The triangle's smallest height (twice its area over its longest edge).
pub(super) fn narrowest_width(t: &[DVec3; 3]) -> f64 {
    let longest = (0..3)
        .map(|k| (t[(k + 1) % 3] - t[k]).length())
        .fold(0.0, f64::max);
    if longest > 0.0 {
        normal_of(t).length() / longest
    } else {
        0.0
    }
}

/// Whether triangle `other` lies within `distance` of the plane of `face` and overlaps it
/// there over some area (false only when it surely does not).
fn lies_on(other: &[DVec3; 3], face: &[DVec3; 3], distance: f64) -> bool {
    let n = normal_of(face);
    let length = n.length();
    if length.is_nan() || length <= 0.0 {
        return false;
    }
    let n = n / length;
    if other.iter().any(|p| n.dot(*p - face[0]).abs() > distance) {
        return false;
    }
    // Measured from the face's first corner, where rounding scales with the pair's size.
    let (face_local, other_local) = (face.map(|p| p - face[0]), other.map(|p| p - face[0]));
    let edges = (0..3)
        .map(|k| face[(k + 1) % 3] - face[k])
        .chain((0..3).map(|k| other[(k + 1) % 3] - other[k]));
    for e in edges {
        let m = n.cross(e);
        let m_length = m.length();
        if m_length.is_nan() || m_length <= 0.0 {
            continue;
        }
        let m = m / m_length;
        // Touching along an edge or at a corner (the next triangle of the same wall) is no
        // overlap; any overlap wider than rounding is.
        let ((flo, fhi), (olo, ohi)) = (span_along(&face_local, m), span_along(&other_local, m));
        let rounding = 1e-9 * (fhi - flo).max(ohi - olo);
        if olo >= fhi - rounding || flo >= ohi - rounding {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(p: [[f64; 3]; 3]) -> [DVec3; 3] {
        p.map(DVec3::from_array)
    }

    #[test]
    fn a_triangle_lies_on_a_face_only_in_its_plane_and_over_it() {
        let face = t([[0., 0., 0.], [4., 0., 0.], [0., 4., 0.]]);
        let on = t([[1., 1., 0.001], [5., 1., 0.], [1., 5., -0.001]]);
        let beside = t([[3., 3., 0.], [6., 3., 0.], [3., 6., 0.]]);
        // The next triangle of the same quad, across the shared hypotenuse.
        let next = t([[4., 0., 0.], [4., 4., 0.], [0., 4., 0.]]);
        assert!(!lies_on(&next, &face, 0.01));
        let above = t([[1., 1., 0.5], [5., 1., 0.5], [1., 5., 0.5]]);
        let crossing = t([[1., 1., -1.], [2., 1., 1.], [1., 2., 1.]]);
        assert!(lies_on(&on, &face, 0.01));
        assert!(!lies_on(&on, &face, 0.0001));
        assert!(!lies_on(&beside, &face, 0.01));
        assert!(!lies_on(&above, &face, 0.01));
        assert!(!lies_on(&crossing, &face, 0.01));
    }
}
