//! One shared measure of the closed-solids tests: the interval a triangle covers along an axis
//! (separating-axis tests in `embedded` and `cell`, the coplanar sweep in `ties`).
//! Its own file so that the three siblings share it without importing the module root.

use glam::DVec3;

/// The interval a triangle's corners span along `axis` (measured from the origin).
pub(super) fn span_along(t: &[DVec3; 3], axis: DVec3) -> (f64, f64) {
    t.iter()
        .map(|p| axis.dot(*p))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        })
}
