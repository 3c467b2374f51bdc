//! Early rejection of runs of input triangles by their world-space bounding box against the
//! view frustum, before any per-triangle projection.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 6.2 (the geometry stage drops triangles outside the screen); testing a run of
//! consecutive stream triangles by one bounding box is ours (cluster culling in the style of
//! mesh-shader pipelines), beyond the thesis.
//!
//! Streamed scenes are spatially coherent: consecutive triangles come from one object (a
//! building of the streamed city). From a view inside the scene most of it is behind the eye or
//! beside the frustum, and projecting each triangle to find that out was most of the geometry
//! stage. A run whose box lies entirely outside one frustum plane holds no triangle
//! [`project`](super::geometry_stage::project) could keep, so the run is skipped whole.
//!
//! Conservative by construction: the box holds every corner exactly (f32 corners are exact in
//! f64), the planes are the screen grown by the overlap margin plus [`SLACK_PX`] pixels and a
//! near plane at half the near distance, so rounding can never reject a run that the exact
//! per-triangle path would keep (the slack in view units is at least
//! `near / 2 · tan_half_x · 2 · SLACK_PX / width`, orders of magnitude above the rounding of the
//! plane values). A box with a non-finite corner is never rejected.

use glam::{DVec3, Vec3A};

use super::projection::Projection;
use super::source::SourceTriangle;

/// Extra screen margin of the side planes, in pixels (see the module documentation).
pub(crate) const SLACK_PX: f64 = 4.0;

/// Consecutive input triangles tested by one box. Tuned on the streamed city at street level
/// (`rv_stream_once`): smaller runs cull more triangles but cost more boxes.
pub(crate) const RUN: usize = 32;

/// A plane `n · (p - eye) + d >= 0` (inside) in world space.
#[derive(Clone, Copy, Debug)]
struct WorldPlane {
    n: DVec3,
    d: f64,
}

/// The frustum's five planes in world space (the far side is open).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrustumCull {
    eye: DVec3,
    planes: [WorldPlane; 5],
}

impl FrustumCull {
    /// The frustum of `proj` grown by `margin` pixels (plus [`SLACK_PX`]).
    pub(crate) fn new(proj: &Projection, margin: f64) -> Self {
        let g = margin + SLACK_PX;
        let sides = proj.rect_planes(-g, proj.width + g, -g, proj.height + g);
        let near = [0.0, 0.0, 1.0, -0.5 * proj.near];
        // A view-space plane `a x + b y + c z + d` with view = R (p - eye) is the world plane
        // with normal `a right + b up + c forward`.
        let world = |p: [f64; 4]| WorldPlane {
            n: proj.right * p[0] + proj.up * p[1] + proj.forward * p[2],
            d: p[3],
        };
        Self {
            eye: proj.eye,
            planes: [
                world(near),
                world(sides[0]),
                world(sides[1]),
                world(sides[2]),
                world(sides[3]),
            ],
        }
    }

    /// True when no triangle of `tris` can reach the screen (their bounding box lies entirely
    /// outside one plane). False for an empty run.
    pub(crate) fn rejects(&self, tris: &[SourceTriangle]) -> bool {
        if tris.is_empty() {
            return false;
        }
        // In SIMD lanes (`Vec3A`): this loop reads every streamed corner.
        let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for t in tris {
            for c in t.corners {
                let c = Vec3A::from(c);
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        // `min`/`max` may skip or keep NaN corners; such triangles are never visible anyway,
        // and an infinite or NaN box is simply not judged.
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let center = (lo + hi) * 0.5 - self.eye;
        let half = (hi - lo) * 0.5;
        self.planes
            .iter()
            .any(|p| p.n.dot(center) + p.n.abs().dot(half) + p.d < 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::super::geometry_stage::{bins_of, project, BinGrid};
    use super::*;
    use glam::Vec3;
    use sightline_core::Camera;

    fn proj() -> Projection {
        let cam =
            Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 64, 48, 0.1).expect("cam");
        Projection::new(&cam)
    }

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> SourceTriangle {
        SourceTriangle {
            id: 0,
            corners: [a, b, c],
        }
    }

    #[test]
    fn empty_run_is_not_rejected() {
        assert!(!FrustumCull::new(&proj(), 1e-3).rejects(&[]));
    }

    #[test]
    fn run_behind_the_eye_is_rejected() {
        let t = tri(Vec3::new(-1.0, 0.0, 2.0), Vec3::X, Vec3::new(0.0, 1.0, 3.0));
        assert!(FrustumCull::new(&proj(), 1e-3).rejects(&[t]));
    }

    #[test]
    fn run_beside_the_frustum_is_rejected() {
        let t = tri(
            Vec3::new(50.0, 0.0, -5.0),
            Vec3::new(51.0, 0.0, -5.0),
            Vec3::new(50.0, 1.0, -6.0),
        );
        assert!(FrustumCull::new(&proj(), 1e-3).rejects(&[t]));
    }

    #[test]
    fn run_with_one_triangle_in_view_is_kept() {
        let behind = tri(Vec3::new(-1.0, 0.0, 2.0), Vec3::X, Vec3::new(0.0, 1.0, 3.0));
        let ahead = tri(
            Vec3::new(0.0, 0.0, -5.0),
            Vec3::new(0.1, 0.0, -5.0),
            Vec3::new(0.0, 0.1, -5.0),
        );
        assert!(!FrustumCull::new(&proj(), 1e-3).rejects(&[behind, ahead]));
    }

    #[test]
    fn non_finite_run_is_not_rejected() {
        let t = tri(Vec3::new(f32::INFINITY, 0.0, 2.0), Vec3::X, Vec3::Y);
        assert!(!FrustumCull::new(&proj(), 1e-3).rejects(&[t]));
    }

    /// Every triangle just outside the screen edges or the near plane that the exact path would
    /// keep is kept by the box test: a deterministic sweep of small triangles across each
    /// screen border and the near plane.
    #[test]
    fn rejected_triangles_are_never_on_screen() {
        let p = proj();
        let margin = 1e-3;
        let cull = FrustumCull::new(&p, margin);
        let grid = BinGrid {
            nx: 4,
            ny: 4,
            width: p.width,
            height: p.height,
        };
        let (mut rejected, mut kept) = (0, 0);
        for i in 0..400 {
            let s = i as f32 / 400.0;
            // Depths from well behind the near plane to far; lateral positions sweeping across
            // the frustum's side planes.
            let z = -(0.02 + 20.0 * s * s);
            let across = (s * 7.0).fract() * 4.0 - 2.0;
            let size = 0.002 + 0.05 * (s * 13.0).fract();
            for (dx, dy) in [(1.0f32, 0.0f32), (0.0, 1.0), (0.7, 0.7)] {
                let c = Vec3::new(across * dx * -z, across * dy * -z, z);
                let t = tri(
                    c,
                    c + Vec3::new(size, 0.0, 0.0),
                    c + Vec3::new(0.0, size, 0.0),
                );
                let on_screen = project(&t, &p, margin).is_some_and(|(_, pts, n)| {
                    let mut bins = Vec::new();
                    bins_of(&pts[..n], &grid, margin, &mut bins);
                    !bins.is_empty()
                });
                if cull.rejects(&[t]) {
                    rejected += 1;
                    assert!(!on_screen, "rejected a triangle on screen: {t:?}");
                } else if on_screen {
                    kept += 1;
                }
            }
        }
        // The sweep must exercise both sides, or it proves nothing.
        assert!(
            rejected > 100 && kept > 100,
            "rejected {rejected}, kept {kept}"
        );
    }
}
