//! Convex polygons ("windings", as the Quake tools call them) in f64, and the two cuts the
//! portal builder and the portal flow need: keeping one side of a plane, and splitting by one.

use glam::DVec3;

/// A plane `n · x = d` (`n` unit length); its front is `n · x - d > 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Plane {
    pub(crate) normal: DVec3,
    pub(crate) dist: f64,
}

impl Plane {
    pub(crate) fn distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) - self.dist
    }

    pub(crate) fn flipped(&self) -> Plane {
        Plane {
            normal: -self.normal,
            dist: -self.dist,
        }
    }
}

/// A large square on `plane`, `half` from its centre to each side: the start of every portal.
pub(crate) fn base_winding(plane: &Plane, half: f64) -> Vec<DVec3> {
    let n = plane.normal;
    // Any direction not parallel to n.
    let a = if n.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
    let u = n.cross(a).normalize() * half;
    let v = n.cross(u);
    let c = n * plane.dist;
    vec![c - u - v, c + u - v, c + u + v, c - u + v]
}

/// The part of `poly` with `plane.distance(x) >= -slack` (a positive slack keeps a sliver more:
/// the conservative side for everything this module serves). Empty when nothing is left.
pub(crate) fn keep_front(poly: &[DVec3], plane: &Plane, slack: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (plane.distance(a) + slack, plane.distance(b) + slack);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    if out.len() < 3 {
        out.clear();
    }
    out
}

/// Where `poly` lies against `plane`, within `eps`.
pub(crate) enum Side {
    Front,
    Back,
    /// Every corner within `eps` of the plane.
    On,
    /// Corners on both sides.
    Both,
}

pub(crate) fn side(poly: &[DVec3], plane: &Plane, eps: f64) -> Side {
    let (mut front, mut back) = (false, false);
    for &p in poly {
        let d = plane.distance(p);
        front |= d > eps;
        back |= d < -eps;
    }
    match (front, back) {
        (true, true) => Side::Both,
        (true, false) => Side::Front,
        (false, true) => Side::Back,
        (false, false) => Side::On,
    }
}

/// Twice the area of `poly` (a planar convex polygon).
pub(crate) fn double_area(poly: &[DVec3]) -> f64 {
    let mut sum = DVec3::ZERO;
    for i in 1..poly.len().saturating_sub(1) {
        sum += (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);
    }
    sum.length()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeping_a_side_cuts_a_square_in_half_and_slack_keeps_a_sliver() {
        let plane = Plane {
            normal: DVec3::Z,
            dist: 0.0,
        };
        let square = base_winding(&plane, 1.0);
        assert!((double_area(&square) - 8.0).abs() < 1e-12);
        let cut = Plane {
            normal: DVec3::X,
            dist: 0.0,
        };
        let half = keep_front(&square, &cut, 0.0);
        assert!((double_area(&half) - 4.0).abs() < 1e-12);
        assert!(half.iter().all(|p| p.x >= 0.0));
        let past = Plane {
            normal: DVec3::X,
            dist: 1.5,
        };
        assert!(keep_front(&square, &past, 0.0).is_empty());
        // A slack reaching past the edge keeps the whole edge's sliver.
        assert!(!keep_front(&square, &past, 0.6).is_empty());
        assert!(matches!(side(&square, &plane, 1e-9), Side::On));
        assert!(matches!(side(&square, &cut, 1e-9), Side::Both));
        assert!(matches!(side(&half, &cut.flipped(), 1e-9), Side::Back));
    }
}
