//! Exact 2D predicates on grid coordinates: an ε-prefilter in double precision with an exact
//! integer fallback for the close decisions.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013,
//! section 3.1 (ε-prefiltered parallelism queries after Frankel, Nussbaum, Sack 2004).
//!
//! Every screen position is an integer on the grid of `project::GRID` units per pixel, below
//! 2^34 in magnitude, so differences are below 2^35 and exact in `f64`. A cross product
//! `ux * vy - uy * vx` of such differences is then evaluated in `f64`: when both products are
//! below 2^53 they are exact and so is the result (the common case: short edges near each
//! other); otherwise its error is at most `2^-52 * (|ux vy| + |uy vx|)` (two rounded products,
//! one rounded difference, each half an ulp), and when the float result is larger than
//! [`FILTER`] times that sum its sign is certain, else it is recomputed exactly in `i128`
//! (products below 2^70).

/// A point or vector on the grid.
pub(crate) type Pt = [i64; 2];

/// Relative error bound of the float filter (4 ulps: twice the worst case, for safety).
const FILTER: f64 = 4.0 * f64::EPSILON;

/// Integers below this are exact in `f64`.
const EXACT_F64: f64 = 9_007_199_254_740_992.0;

/// A cross product evaluated with the filter: its sign is exact, its value is the float
/// approximation (relative error below 1e-15), and `exact` records whether the fallback ran.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cross {
    /// -1, 0 or 1: the exact sign.
    pub(crate) sign: i8,
    /// The value, to double precision.
    pub(crate) value: f64,
    /// True when the `i128` fallback decided the sign.
    pub(crate) exact: bool,
}

/// `u × v = ux * vy - uy * vx` with an exact sign.
#[inline]
pub(crate) fn cross(u: Pt, v: Pt) -> Cross {
    let p = u[0] as f64 * v[1] as f64;
    let q = u[1] as f64 * v[0] as f64;
    let r = p - q;
    // Products below 2^53 are exact integers, and so is their difference: the sign is exact.
    // (Inside a bin this is the common case; shared vertices and edges give exact zeros.)
    if p.abs() < EXACT_F64 && q.abs() < EXACT_F64 {
        return Cross {
            sign: if r > 0.0 {
                1
            } else if r < 0.0 {
                -1
            } else {
                0
            },
            value: r,
            exact: false,
        };
    }
    if r.abs() > FILTER * (p.abs() + q.abs()) {
        return Cross {
            sign: if r > 0.0 { 1 } else { -1 },
            value: r,
            exact: false,
        };
    }
    let e = i128::from(u[0]) * i128::from(v[1]) - i128::from(u[1]) * i128::from(v[0]);
    Cross {
        sign: e.signum() as i8,
        value: e as f64,
        exact: true,
    }
}

/// `a - b`.
#[inline]
pub(crate) fn sub(a: Pt, b: Pt) -> Pt {
    [a[0] - b[0], a[1] - b[1]]
}

/// `a · b` exactly.
#[inline]
pub(crate) fn dot(a: Pt, b: Pt) -> i128 {
    i128::from(a[0]) * i128::from(b[0]) + i128::from(a[1]) * i128::from(b[1])
}

/// Twice the signed area of a polygon (positive when counter-clockwise in the
/// `cross(b - a, c - a) > 0` sense), exactly.
pub(crate) fn twice_area(verts: &[Pt]) -> i128 {
    let n = verts.len();
    if n < 3 {
        return 0;
    }
    let o = verts[0];
    (1..n - 1)
        .map(|k| {
            let (u, v) = (sub(verts[k], o), sub(verts[k + 1], o));
            i128::from(u[0]) * i128::from(v[1]) - i128::from(u[1]) * i128::from(v[0])
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn cross_of_parallel_vectors_is_exactly_zero() {
        let u = [(1 << 30) - 1, (1 << 29) + 7];
        let v = [2 * u[0], 2 * u[1]];
        let c = cross(u, v);
        assert_eq!(c.sign, 0);
        assert!(c.exact);
    }

    #[test]
    fn cross_of_nearly_parallel_vectors_uses_fallback() {
        // ux vy - uy vx = 1 while each product is about 2^60: the float filter cannot decide.
        let u = [1i64 << 30, (1 << 30) - 1];
        let v = [(1i64 << 30) + 1, 1 << 30];
        let c = cross(u, v);
        assert_eq!(c.sign, 1);
        assert!(c.exact);
    }

    #[test]
    fn empty_polygon_has_zero_area() {
        assert_eq!(twice_area(&[]), 0);
    }

    proptest! {
        #[test]
        fn cross_sign_matches_exact(
            a in -(1i64 << 31)..(1i64 << 31),
            b in -(1i64 << 31)..(1i64 << 31),
            c in -(1i64 << 31)..(1i64 << 31),
            d in -(1i64 << 31)..(1i64 << 31),
        ) {
            let exact = (i128::from(a) * i128::from(d) - i128::from(b) * i128::from(c)).signum();
            prop_assert_eq!(i128::from(cross([a, b], [c, d]).sign), exact);
        }
    }
}
