//! The occlusion test of a clipped occludee against a bin's occluders: the silhouette test
//! (edge overlap, then crossing parity) and the triangle test (overlap, depth relation, split).
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 (occlusion test, figure 5.10; silhouette test, figures 5.11-5.12; triangle
//! test, figure 5.13), section 6.3.2, and section 7.1.4 (occluder depth bounds).
//!
//! Soundness, in one paragraph: the silhouette of occluder `O` is the sum of its triangles'
//! directed edges with opposite pairs cancelled, and all its triangles have the same screen
//! orientation (see `occluders.rs`), so its winding number around a point is (up to sign) the
//! number of `O`'s triangles covering that point. If no silhouette edge comes within the margin
//! of the occludee `P`, the winding number is constant over `P` grown by the margin; if it is
//! non-zero at one point of `P`, every point of `P` is covered by at least one of `O`'s
//! triangles. (The thesis' half-edges, chapter 5; a parity count would miss points covered an
//! even number of times, as where a patch folds over itself.) If moreover `P` is behind every triangle of `O` that it overlaps, every
//! point of `P` is hidden by some triangle of `O`, and so is every sample the reference
//! rasterizer could take of `P`.

use glam::DVec2;

use super::depth::{occludee_behind, OccluderView, DEPTH_EPS};
use super::occluders::{BinState, Occluder};
use super::overlap::{convex_overlap, inner_point, ray_winding, segment_overlaps, Rect};
use super::projection::{Poly, Projection};

/// An occludee clipped to a bin, with what the tests need precomputed.
pub(crate) struct Occludee<'a> {
    /// View-space polygon (clipped to the near plane and the bin).
    pub(crate) poly: &'a Poly,
    /// Its screen projection.
    pub(crate) screen: &'a [DVec2],
    /// Bounds of `screen`.
    pub(crate) rect: Rect,
    /// View depth bounds.
    pub(crate) zmin: f64,
    pub(crate) zmax: f64,
    /// Eye-positive plane of the unclipped triangle.
    pub(crate) plane: Option<&'a [f64; 4]>,
}

/// Counters of the test, for statistics.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct TestCounters {
    pub(crate) silhouette_tests: u64,
    pub(crate) triangle_tests: u64,
}

/// True when some occluder of `state` hides all of `p`.
pub(crate) fn is_occluded(
    p: &Occludee<'_>,
    state: &BinState,
    proj: &Projection,
    margin: f64,
    counters: &mut TestCounters,
) -> bool {
    state
        .occluders
        .iter()
        .any(|o| occluded_by(p, o, proj, margin, counters))
}

fn occluded_by(
    p: &Occludee<'_>,
    o: &Occluder,
    proj: &Projection,
    margin: f64,
    counters: &mut TestCounters,
) -> bool {
    // P must lie inside the silhouette, so inside the occluder's bounds.
    if !o.rect.contains(&p.rect, margin) {
        return false;
    }
    // Entirely nearer than every occluder triangle: cannot be hidden by it.
    if p.zmax * (1.0 + DEPTH_EPS) < o.zmin {
        return false;
    }
    counters.silhouette_tests += 1;
    // Silhouette test: no edge overlaps P, and P is inside (non-zero winding number).
    let q = inner_point(p.screen);
    let mut winding = 0i32;
    // P grown by the margin lies in this rectangle; an edge whose bounds miss it cannot come
    // within the margin of P, so the exact (costly) edge overlap test is skipped for it.
    let (lo, hi) = (p.rect.min - margin, p.rect.max + margin);
    for e in &o.edges {
        let (emin, emax) = (e.a.min(e.b), e.a.max(e.b));
        let near = emin.x <= hi.x && emax.x >= lo.x && emin.y <= hi.y && emax.y >= lo.y;
        if near && segment_overlaps(e.a, e.b, p.screen, margin) {
            return false;
        }
        winding += ray_winding(q, e.a, e.b);
    }
    if winding == 0 {
        return false;
    }
    // Depth bounds: behind the whole occluder, no triangle test needed.
    if p.zmin > o.zmax * (1.0 + DEPTH_EPS) {
        return true;
    }
    // Triangle test: behind every occluder triangle it overlaps.
    counters.triangle_tests += 1;
    o.tris.iter().all(|t| {
        if !t.rect.touches(&p.rect, margin) || !convex_overlap(&t.screen, p.screen, margin) {
            return true;
        }
        let view = OccluderView {
            corners: &t.corners,
            screen: &t.screen,
            plane: &t.plane,
        };
        occludee_behind(p.poly, p.plane, &view, proj, margin)
    })
}
