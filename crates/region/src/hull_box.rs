//! Exact intersection test between the convex hull of a point set and an axis-aligned box,
//! by GJK on support functions: the two sets intersect exactly when the origin lies in their
//! Minkowski difference, and GJK walks a simplex of that difference towards the origin.
//!
//! Based on: Gilbert, Johnson, Keerthi, "A fast procedure for computing the distance between
//! complex objects in three-dimensional space" (1988), in the closest-point form of Ericson,
//! *Real-Time Collision Detection*, 9.5 (sub-simplex closest points from 5.1.2, 5.1.5, 5.1.6).
//!
//! Computed in f64; sets closer than a tolerance of 1e-9 of the scene size count as
//! intersecting, and a run that does not converge answers "intersecting": callers use this
//! for conservative decisions (which cells an edit may change), where a false "yes" only costs
//! work.

use glam::{DVec3, Vec3};
use sightline_core::geometry::Aabb;

/// True when the convex hull of `points` and the box `b` intersect (touching counts).
/// An empty point set or box intersects nothing.
pub fn hull_intersects_box(points: &[Vec3], b: &Aabb) -> bool {
    if points.is_empty() || b.is_empty() {
        return false;
    }
    let pts: Vec<DVec3> = points.iter().map(|p| p.as_dvec3()).collect();
    let (bmin, bmax) = (b.min.as_dvec3(), b.max.as_dvec3());
    let scale = pts
        .iter()
        .fold(bmin.abs().max(bmax.abs()), |m, p| m.max(p.abs()))
        .max_element()
        .max(1e-30);
    let tol = 1e-9 * scale;
    // Support of hull − box in direction d.
    let support = |d: DVec3| -> DVec3 {
        let mut best = pts[0];
        let mut best_dot = best.dot(d);
        for &p in &pts[1..] {
            let v = p.dot(d);
            if v > best_dot {
                best = p;
                best_dot = v;
            }
        }
        // The box's support in direction -d: its corner most opposite to d.
        let corner = DVec3::new(
            if d.x > 0.0 { bmin.x } else { bmax.x },
            if d.y > 0.0 { bmin.y } else { bmax.y },
            if d.z > 0.0 { bmin.z } else { bmax.z },
        );
        best - corner
    };
    let centroid = pts.iter().copied().sum::<DVec3>() / pts.len() as f64;
    let mut d = centroid - (bmin + bmax) * 0.5;
    if d.length_squared() <= tol * tol {
        d = DVec3::X;
    }
    let mut simplex: Vec<DVec3> = vec![support(d)];
    let mut v = simplex[0];
    for _ in 0..128 {
        let vv = v.length_squared();
        if vv <= tol * tol {
            return true;
        }
        let w = support(-v);
        let len = vv.sqrt();
        // A plane with normal v separates the origin from the difference by more than tol.
        if v.dot(w) > tol * len {
            return false;
        }
        // No progress: v is (numerically) the closest point, within tol of the origin.
        if vv - v.dot(w) <= 1e-12 * vv || simplex.contains(&w) {
            return true;
        }
        simplex.push(w);
        match closest_on_simplex(&simplex) {
            None => return true,
            Some((c, kept)) => {
                v = c;
                simplex = kept;
            }
        }
    }
    true
}

/// The point of the simplex (1 to 4 points) closest to the origin and the smallest
/// sub-simplex holding it; `None` when the origin is inside a tetrahedron.
fn closest_on_simplex(s: &[DVec3]) -> Option<(DVec3, Vec<DVec3>)> {
    match s.len() {
        1 => Some((s[0], s.to_vec())),
        2 => Some(closest_on_segment(s[0], s[1])),
        3 => Some(closest_on_triangle(s[0], s[1], s[2])),
        _ => closest_on_tetrahedron(s[0], s[1], s[2], s[3]),
    }
}

fn closest_on_segment(a: DVec3, b: DVec3) -> (DVec3, Vec<DVec3>) {
    let ab = b - a;
    let denom = ab.length_squared();
    let t = if denom > 0.0 {
        (-a.dot(ab) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    if t <= 0.0 {
        (a, vec![a])
    } else if t >= 1.0 {
        (b, vec![b])
    } else {
        (a + ab * t, vec![a, b])
    }
}

/// Ericson 5.1.5 with the query point at the origin.
fn closest_on_triangle(a: DVec3, b: DVec3, c: DVec3) -> (DVec3, Vec<DVec3>) {
    let (ab, ac) = (b - a, c - a);
    let ap = -a;
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, vec![a]);
    }
    let bp = -b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, vec![b]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (a + ab * t, vec![a, b]);
    }
    let cp = -c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, vec![c]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (a + ac * t, vec![a, c]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * t, vec![b, c]);
    }
    let sum = va + vb + vc;
    if sum.abs() <= f64::MIN_POSITIVE || !sum.is_finite() {
        // Degenerate (collinear) triangle: the best of its edges.
        return [
            closest_on_segment(a, b),
            closest_on_segment(b, c),
            closest_on_segment(a, c),
        ]
        .into_iter()
        .min_by(|x, y| x.0.length_squared().total_cmp(&y.0.length_squared()))
        .unwrap_or((a, vec![a]));
    }
    let (v, w) = (vb / sum, vc / sum);
    (a + ab * v + ac * w, vec![a, b, c])
}

/// Ericson 5.1.6: the closest point over the faces whose plane separates the origin from the
/// opposite vertex; `None` when the origin is inside. Faces of a flat tetrahedron (opposite
/// vertex in the plane) are always examined, so a flat one never reports "inside" by mistake.
fn closest_on_tetrahedron(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Option<(DVec3, Vec<DVec3>)> {
    let faces = [(a, b, c, d), (a, c, d, b), (a, d, b, c), (b, d, c, a)];
    let scale = [a, b, c, d]
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    let mut best: Option<(DVec3, Vec<DVec3>)> = None;
    let mut inside = true;
    for (p, q, r, opposite) in faces {
        let n = (q - p).cross(r - p);
        let side_origin = (-p).dot(n);
        let side_opposite = (opposite - p).dot(n);
        let flat = side_opposite.abs() <= 1e-12 * n.length() * scale.max(1e-30);
        if flat || side_origin * side_opposite < 0.0 {
            inside = false;
            let candidate = closest_on_triangle(p, q, r);
            if best
                .as_ref()
                .is_none_or(|b| candidate.0.length_squared() < b.0.length_squared())
            {
                best = Some(candidate);
            }
        }
    }
    if inside {
        None
    } else {
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sightline_core::random::SplitMix64;

    fn unit(r: &mut SplitMix64) -> f32 {
        (r.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn vec(r: &mut SplitMix64, s: f32) -> Vec3 {
        Vec3::new(unit(r) - 0.5, unit(r) - 0.5, unit(r) - 0.5) * 2.0 * s
    }

    #[test]
    fn segment_through_a_box_intersects_it_and_a_box_beside_does_not() {
        let b = Aabb::new(Vec3::new(4.0, -1.0, -1.0), Vec3::new(5.0, 1.0, 1.0));
        let seg = [Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)];
        assert!(hull_intersects_box(&seg, &b));
        let above = [Vec3::new(0.0, 0.0, 1.5), Vec3::new(10.0, 0.0, 1.5)];
        assert!(!hull_intersects_box(&above, &b));
        // Touching counts.
        let touching = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(10.0, 0.0, 1.0)];
        assert!(hull_intersects_box(&touching, &b));
        // A thin diagonal hull passing by the box's corner without touching it.
        let diagonal = [Vec3::new(0.0, 3.0, 0.0), Vec3::new(6.0, -0.1, 3.0)];
        assert!(!hull_intersects_box(&diagonal, &b));
        assert!(!hull_intersects_box(&[], &b));
    }

    #[test]
    fn agrees_with_constructed_intersecting_and_separated_cases() {
        let mut r = SplitMix64::new(7);
        for case in 0..3000 {
            let count = 1 + (r.next_u64() % 11) as usize;
            let points: Vec<Vec3> = (0..count).map(|_| vec(&mut r, 10.0)).collect();
            let half = Vec3::new(unit(&mut r), unit(&mut r), unit(&mut r)) * 3.0 + 0.01;
            if case % 2 == 0 {
                // A box around a convex combination of the points.
                let w: Vec<f32> = (0..count).map(|_| unit(&mut r) + 1e-3).collect();
                let total: f32 = w.iter().sum();
                let q = points.iter().zip(&w).map(|(p, w)| *p * *w).sum::<Vec3>() / total;
                let offset = Vec3::new(unit(&mut r), unit(&mut r), unit(&mut r)) * 1.8 - 0.9;
                let c = q + offset * half;
                let b = Aabb::new(c - half, c + half);
                assert!(hull_intersects_box(&points, &b), "case {case}");
            } else {
                // Points and box on opposite sides of a random plane, with a gap.
                let n = vec(&mut r, 1.0).try_normalize().unwrap_or(Vec3::X);
                let gap = 0.01 + unit(&mut r);
                let top = points.iter().map(|p| p.dot(n)).fold(f32::MIN, f32::max);
                let c0 = vec(&mut r, 10.0);
                let b0 = Aabb::new(c0 - half, c0 + half);
                let corners = (0..8).map(|i| {
                    Vec3::new(
                        if i & 1 == 0 { b0.min.x } else { b0.max.x },
                        if i & 2 == 0 { b0.min.y } else { b0.max.y },
                        if i & 4 == 0 { b0.min.z } else { b0.max.z },
                    )
                });
                let low = corners.map(|p| p.dot(n)).fold(f32::MAX, f32::min);
                let shift = n * (top + gap - low);
                let b = Aabb::new(b0.min + shift, b0.max + shift);
                assert!(!hull_intersects_box(&points, &b), "case {case}");
            }
        }
    }
}
