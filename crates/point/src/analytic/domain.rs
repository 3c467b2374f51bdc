//! The camera domain of exact visibility: the cameras for which the snapped, depth-tolerant
//! computation of this module still resolves what the camera's own (f32) mapping resolves, and
//! the error that refuses the others with the range and an alternative.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013. The
//! paper works on the GPU in single precision and states no range; the limits here are ours,
//! derived from the two approximations of this implementation (see the module docs, "Exactness"):
//!
//! - **Snapping.** Screen positions are snapped to `1 / GRID` px (2^-20 px). In the tangent plane
//!   of the view (`x / z`, `y / z`), a grid unit at the image centre is
//!   `2 tan(fov_y / 2) / (height · GRID)` (the same horizontally, since `tan(fov_x / 2)` scales
//!   with the aspect). A small image or a field of view near 180° makes it coarse: at fov
//!   179.9999° and 1024 px it is 2e-3, and the bunny of the tests shrinks into a few hundred grid
//!   units around the centre, losing 15,790 of its 24,876 ray-visible triangles. The domain keeps
//!   the unit at most [`MAX_GRID_STEP`] = 2^-17 (7.6e-6, 1.6 arcseconds): a 1×1 image up to fov
//!   151.9°, 4 px and more up to the field-of-view limit.
//! - **Depth.** The `1/z` planes are evaluated over pixel coordinates from the image corner, so
//!   their terms grow with `tan(fov / 2)` and cancel at the centre; depth differences below the
//!   pipeline's relative tolerance of those terms are ties (decided by slope, then by id). For a
//!   surface tilted by 45° the smallest resolved gap is about `1.3e-8 · tan(fov / 2)` of the
//!   distance (measured: 9.5e-7 at fov 179°, 1.2e-4 at 179.99°; at fov ≤ 170° it is below the f32
//!   spacing of the coordinates, 6e-8). The domain keeps `tan(fov / 2) <=` [`MAX_TAN_HALF`] = tan 85°
//!   on both axes (fov ≤ 170°), where that gap stays within a few f32 spacings (2e-7).
//!
//! What the camera alone cannot show, and so is documented rather than refused: geometry that
//! covers only a tiny part of a pixel (a 15 cm model seen from 100 km) is as coarse on the grid
//! as a whole scene in a 1×1 image, and depth gaps below about 2e-9 of the distance (0.2 mm at
//! 100 km) are ties wherever the camera is.

use sightline_core::Camera;

use super::project::GRID;
use super::types::AnalyticError;

/// Largest `tan(fov / 2)`, vertically and horizontally (fov 170°: at 172.8° the bunny test
/// still missed one triangle after the tie tolerance took the f32 input's precision in).
pub(crate) const MAX_TAN_HALF: f64 = 11.430_052_302_761_343; // tan 85°

/// Largest grid unit in the tangent plane at the image centre (2^-17).
pub(crate) const MAX_GRID_STEP: f64 = 1.0 / 131_072.0;

/// The field of view (degrees) whose half-angle tangent is `t`.
fn fov_deg(t: f64) -> f64 {
    2.0 * t.atan().to_degrees()
}

/// Whether `camera` (already a valid camera) is inside the exact domain; the error names the
/// parameter, the exact range and what to use instead.
pub(crate) fn check(camera: &Camera) -> Result<(), AnalyticError> {
    // The tangents the projection uses: the camera's f32 values, widened.
    let ty = f64::from(camera.tan_half_y());
    let tx = f64::from(camera.tan_half_x());
    let (w, h) = (camera.width, camera.height);
    if !(camera.tan_half_y().is_normal() && camera.tan_half_x().is_normal() && tx > 0.0 && ty > 0.0)
    {
        return Err(AnalyticError::OutsideExactRange {
            parameter: "field of view",
            detail: format!(
                "fov {}° at {w}x{h} px gives tan(fov/2) = {ty:e} vertically and {tx:e} \
                 horizontally, not positive normal f32 numbers; use a field of view of at least \
                 1e-30°",
                camera.fov_y_deg
            ),
        });
    }
    if ty > MAX_TAN_HALF {
        return Err(AnalyticError::OutsideExactRange {
            parameter: "field of view",
            detail: format!(
                "fov {}° (tan(fov/2) = {ty:.4e}) is above the exact limit of {:.2}° \
                 (tan(fov/2) <= {MAX_TAN_HALF}): beyond it depth gaps below about \
                 1.3e-8 * tan(fov/2) of the distance become ties and the scene shrinks onto the \
                 snapping grid at the image centre; for a wider view use several cameras, e.g. \
                 the six 90° faces of Camera::cube_faces, and unite their visible sets",
                camera.fov_y_deg,
                fov_deg(MAX_TAN_HALF)
            ),
        });
    }
    if tx > MAX_TAN_HALF {
        return Err(AnalyticError::OutsideExactRange {
            parameter: "horizontal field of view",
            detail: format!(
                "a {w}x{h} px image at fov {}° sees {:.4}° horizontally (tan = {tx:.4e}), above \
                 the exact limit of {:.2}° (tan <= {MAX_TAN_HALF}); use a less wide image or a \
                 smaller fov (at most {:.4}° at this aspect), or several cameras side by side \
                 (e.g. Camera::cube_faces) and unite their visible sets",
                camera.fov_y_deg,
                fov_deg(tx),
                fov_deg(MAX_TAN_HALF),
                fov_deg(MAX_TAN_HALF * f64::from(h) / f64::from(w))
            ),
        });
    }
    let step = 2.0 * ty / (f64::from(h) * GRID);
    if step > MAX_GRID_STEP {
        // The smallest height (same aspect) and the widest fov at this height that fit.
        let min_height = (2.0 * ty / (MAX_GRID_STEP * GRID)).ceil();
        let max_fov = fov_deg(MAX_GRID_STEP * GRID * f64::from(h) / 2.0);
        return Err(AnalyticError::OutsideExactRange {
            parameter: "image size",
            detail: format!(
                "at {w}x{h} px and fov {}° the 2^-20 px snapping grid spans {step:.2e} of the \
                 tangent plane at the image centre, above the exact limit 2^-17 (7.6e-6); use an \
                 image at least {min_height} px high (same aspect), or a fov of at most \
                 {max_fov:.2}° at this height",
                camera.fov_y_deg
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera(fov: f32, w: u32, h: u32) -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, fov, w, h, 0.1).expect("camera")
    }

    #[test]
    fn ordinary_cameras_are_inside() {
        for (fov, w, h) in [
            (60.0, 1024, 768),
            (90.0, 1, 1),
            (151.0, 1, 1),
            (169.0, 4, 4),
            (169.9, 16384, 16384),
            (1e-3, 16384, 1),
        ] {
            assert_eq!(check(&camera(fov, w, h)), Ok(()), "{fov} {w}x{h}");
        }
    }

    fn refused(fov: f32, w: u32, h: u32) -> (&'static str, String) {
        match check(&camera(fov, w, h)) {
            Err(AnalyticError::OutsideExactRange { parameter, detail }) => (parameter, detail),
            other => panic!("{fov} {w}x{h}: {other:?}"),
        }
    }

    #[test]
    fn wide_fields_of_view_are_refused_with_the_limit_and_cube_faces() {
        for fov in [173.0, 179.999, 179.9999] {
            let (parameter, detail) = refused(fov, 1024, 1024);
            assert_eq!(parameter, "field of view");
            assert!(
                detail.contains("170.00°") && detail.contains("cube_faces"),
                "{detail}"
            );
        }
        let (parameter, detail) = refused(60.0, 16384, 1);
        assert_eq!(parameter, "horizontal field of view");
        assert!(detail.contains("170.00°"), "{detail}");
    }

    #[test]
    fn tiny_images_at_wide_fields_of_view_are_refused_with_the_smallest_size() {
        let (parameter, detail) = refused(160.0, 1, 1);
        assert_eq!(parameter, "image size");
        // tan(80°) = 5.67: at least 2 px high, or at most 151.93° at 1 px.
        assert!(
            detail.contains("at least 2 px") && detail.contains("151.93°"),
            "{detail}"
        );
        assert_eq!(check(&camera(160.0, 2, 2)), Ok(()));
    }
}
