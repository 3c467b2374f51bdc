//! The geometry stage: transform a batch of input triangles to view space, clip them to the
//! near plane, drop those outside the screen, and bin them into screen bins by an overlap test.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 6.2 (project, back-face handling, bounding rectangle then overlap test per
//! bin) and section 6.1 (triangle data stored once, bin queues hold indices).
//!
//! Back faces: the thesis culls them (or flips them to a consistent orientation). sightline's
//! reference rasterizer draws triangles double-sided, so culling a back face could drop a
//! triangle the reference shows (an open mesh seen from behind, a single wall quad): we keep
//! every triangle and only record its facing, so occluders are grown from triangles of one
//! facing (see `occluders.rs`).
//!
//! A triangle that is non-finite or has zero area in 3D is never visible (as in the rasterizer)
//! and is dropped here.

use glam::{DVec2, DVec3};

use super::depth::eye_plane;
use super::overlap::Rect;
use super::projection::{clip, Poly, Projection, MAX_POLY};
use super::source::SourceTriangle;

/// A projected input triangle, stored once per batch; bin queues refer to it by index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ProjTri {
    /// Triangle id.
    pub(crate) id: u32,
    /// View-space corners.
    pub(crate) corners: [DVec3; 3],
    /// Screen corners (meaningful only when `whole_front`).
    pub(crate) screen: [DVec2; 3],
    /// All corners in front of the near plane (no near clipping needed).
    pub(crate) whole_front: bool,
    /// Counter-clockwise on screen (image y down: negative signed area).
    pub(crate) front: bool,
}

impl ProjTri {
    /// Eye-positive plane; `None` when seen edge-on. Computed where it is needed (occluder
    /// triangles, occludees that reach a triangle test), not for every projected triangle.
    pub(crate) fn plane(&self) -> Option<[f64; 4]> {
        eye_plane(self.corners[0], self.corners[1], self.corners[2])
    }
}

/// One batch of projected triangles and its per-bin index lists (counting-sorted by bin).
#[derive(Debug, Default)]
pub(crate) struct Batch {
    pub(crate) tris: Vec<ProjTri>,
    /// `entries[offsets[b]..offsets[b + 1]]` are the indices into `tris` binned to bin `b`.
    pub(crate) offsets: Vec<u32>,
    pub(crate) entries: Vec<u32>,
    /// The largest id of the input batch this batch was built from (see
    /// `producer::Settled`).
    pub(crate) last_input_id: u32,
}

impl Batch {
    /// Indices of the triangles in bin `bin`.
    pub(crate) fn bin(&self, bin: usize) -> &[u32] {
        match (self.offsets.get(bin), self.offsets.get(bin + 1)) {
            (Some(&a), Some(&b)) => &self.entries[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Heap bytes of a batch of `tris` triangles, `entries` bin entries over `bins` bins.
    pub(crate) fn bytes_for(tris: usize, entries: usize, bins: usize) -> usize {
        tris * std::mem::size_of::<ProjTri>() + (bins + 1) * 4 + entries * 4
    }
}

/// The screen's grid of bins.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinGrid {
    pub(crate) nx: usize,
    pub(crate) ny: usize,
    pub(crate) width: f64,
    pub(crate) height: f64,
}

impl BinGrid {
    /// Number of bins.
    pub(crate) fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Pixel rectangle `(x0, x1, y0, y1)` of bin `b`.
    pub(crate) fn rect(&self, b: usize) -> (f64, f64, f64, f64) {
        let (ix, iy) = (b % self.nx, b / self.nx);
        let (w, h) = (self.width / self.nx as f64, self.height / self.ny as f64);
        (
            ix as f64 * w,
            (ix + 1) as f64 * w,
            iy as f64 * h,
            (iy + 1) as f64 * h,
        )
    }

    fn range(&self, lo: f64, hi: f64, n: usize, extent: f64) -> (usize, usize) {
        let cell = extent / n as f64;
        // `as` truncates (the floor for non-negative values) and saturates negatives and NaN
        // to 0: the floor clamped to the grid, without a libm call.
        let clamp = |v: f64| ((v / cell) as usize).min(n - 1);
        (clamp(lo), clamp(hi))
    }
}

/// Projects one input triangle; `None` when it can never be visible (degenerate, behind the
/// near plane or off screen). Also returns its near-clipped screen polygon.
pub(crate) fn project(
    t: &SourceTriangle,
    proj: &Projection,
    margin: f64,
) -> Option<(ProjTri, [DVec2; MAX_POLY], usize)> {
    let [a, b, c] = t.corners;
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    // The rasterizer's degeneracy rule: exactly zero area in 3D, in f64.
    let (wa, wb, wc) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    if (wb - wa).cross(wc - wa) == DVec3::ZERO {
        return None;
    }
    let corners = [proj.view_of(a), proj.view_of(b), proj.view_of(c)];
    let near = proj.near_plane();
    let whole_front = corners
        .iter()
        .all(|v| super::projection::plane_value(&near, *v) >= 0.0);
    let mut pts = [DVec2::ZERO; MAX_POLY];
    let n = if whole_front {
        // The common case needs no polygon (a 300-byte copy per triangle otherwise).
        for (p, v) in pts.iter_mut().zip(&corners) {
            *p = proj.screen_of(*v);
        }
        3
    } else {
        let poly = clip(&Poly::from_slice(&corners), &near);
        for (i, v) in poly.as_slice().iter().enumerate() {
            pts[i] = proj.screen_of(*v);
        }
        poly.len
    };
    if n == 0 {
        return None;
    }
    let screen_rect = Rect {
        min: DVec2::ZERO,
        max: DVec2::new(proj.width, proj.height),
    };
    if !Rect::of(&pts[..n]).touches(&screen_rect, margin) {
        return None;
    }
    let screen = if whole_front {
        [pts[0], pts[1], pts[2]]
    } else {
        [DVec2::ZERO; 3]
    };
    let area = (screen[1] - screen[0]).perp_dot(screen[2] - screen[0]);
    Some((
        ProjTri {
            id: t.id,
            corners,
            screen,
            whole_front,
            front: area < 0.0,
        },
        pts,
        n,
    ))
}

/// Appends the bins `pts` (a convex screen polygon) overlaps, grown by `margin`, to `out`.
///
/// Row by row: the polygon's part in a bin row's band (grown by the margin) spans an interval
/// of x, and the bins of the row whose grown columns meet it are the ones it overlaps (a convex
/// polygon's slice of a band is convex). This is one pass over the polygon per row instead of
/// an overlap test per bin of the bounding rectangle (the thesis' section 6.2 test), and lists
/// the same bins except where the polygon passes within the margin of a bin's corner
/// diagonally, which it also lists: a superset, so no bin that needs the triangle misses it
/// (whenever the polygon is farther than the margin from a bin along x or y, a bin edge
/// separates them, so the thesis' test rejects the bin too; tested).
pub(crate) fn bins_of(pts: &[DVec2], grid: &BinGrid, margin: f64, out: &mut Vec<u32>) {
    let r = Rect::of(pts);
    let screen = Rect {
        min: DVec2::ZERO,
        max: DVec2::new(grid.width, grid.height),
    };
    if pts.is_empty() || !r.touches(&screen, margin) {
        return;
    }
    let (x0, x1) = grid.range(r.min.x - margin, r.max.x + margin, grid.nx, grid.width);
    let (y0, y1) = grid.range(r.min.y - margin, r.max.y + margin, grid.ny, grid.height);
    let inside = r.min.x - margin >= 0.0
        && r.min.y - margin >= 0.0
        && r.max.x + margin <= grid.width
        && r.max.y + margin <= grid.height;
    if (x0 == x1 && y0 == y1) || (inside && (x0 == x1 || y0 == y1)) {
        // One bin (the common case); or, on the screen, one column (row): a connected polygon
        // spans its bounding rectangle's y (x) range, so it meets every row (column) of it.
        for y in y0..=y1 {
            out.extend((x0..=x1).map(|x| (y * grid.nx + x) as u32));
        }
        return;
    }
    let row_height = grid.height / grid.ny as f64;
    let n = pts.len();
    for y in y0..=y1 {
        let (lo, hi) = (
            y as f64 * row_height - margin,
            (y + 1) as f64 * row_height + margin,
        );
        let (mut xmin, mut xmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            if (lo..=hi).contains(&a.y) {
                xmin = xmin.min(a.x);
                xmax = xmax.max(a.x);
            }
            for line in [lo, hi] {
                if (a.y < line) != (b.y < line) {
                    let x = a.x + (line - a.y) / (b.y - a.y) * (b.x - a.x);
                    xmin = xmin.min(x);
                    xmax = xmax.max(x);
                }
            }
        }
        // Grown by the margin on both sides: the columns' grown bounds, and the rounding of
        // the crossings (far below it). Nothing when this row's part lies beside the screen
        // (the column range is clamped to it).
        let (xmin, xmax) = (xmin - margin, xmax + margin);
        if xmin > xmax || xmax < 0.0 || xmin > grid.width {
            continue;
        }
        let (c0, c1) = grid.range(xmin, xmax, grid.nx, grid.width);
        let (c0, c1) = (c0.max(x0), c1.min(x1));
        out.extend((c0..=c1).map(|x| (y * grid.nx + x) as u32));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::Camera;

    fn proj() -> Projection {
        let cam =
            Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0, 64, 64, 0.1).expect("cam");
        Projection::new(&cam)
    }

    fn grid() -> BinGrid {
        BinGrid {
            nx: 4,
            ny: 4,
            width: 64.0,
            height: 64.0,
        }
    }

    fn tri(corners: [Vec3; 3]) -> SourceTriangle {
        SourceTriangle { id: 0, corners }
    }

    #[test]
    fn degenerate_is_dropped() {
        let t = tri([Vec3::new(0.0, 0.0, -1.0); 3]);
        assert!(project(&t, &proj(), 1e-3).is_none());
    }

    #[test]
    fn behind_camera_is_dropped() {
        let t = tri([
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ]);
        assert!(project(&t, &proj(), 1e-3).is_none());
    }

    #[test]
    fn crossing_near_plane_is_clipped() {
        let t = tri([
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, -3.0),
            Vec3::new(0.0, 1.0, -3.0),
        ]);
        let (p, _, n) = project(&t, &proj(), 1e-3).expect("visible part");
        assert!(!p.whole_front);
        assert!(n >= 3);
    }

    #[test]
    fn small_triangle_lands_in_one_bin() {
        let t = tri([
            Vec3::new(-0.1, -0.1, -1.0),
            Vec3::new(-0.05, -0.1, -1.0),
            Vec3::new(-0.1, -0.05, -1.0),
        ]);
        let (_, pts, n) = project(&t, &proj(), 1e-3).expect("visible");
        let mut bins = Vec::new();
        bins_of(&pts[..n], &grid(), 1e-3, &mut bins);
        assert_eq!(bins.len(), 1);
    }

    #[test]
    fn full_screen_triangle_lands_in_every_bin() {
        let t = tri([
            Vec3::new(-100.0, -100.0, -1.0),
            Vec3::new(100.0, -100.0, -1.0),
            Vec3::new(0.0, 100.0, -1.0),
        ]);
        let (_, pts, n) = project(&t, &proj(), 1e-3).expect("visible");
        let mut bins = Vec::new();
        bins_of(&pts[..n], &grid(), 1e-3, &mut bins);
        assert_eq!(bins.len(), 16);
    }

    /// Row-by-row binning lists every bin the thesis' test (a separating-axis overlap test,
    /// grown by the margin, per bin of the bounding rectangle) lists, and no bin the polygon's
    /// bounds stay clear of: random convex polygons (triangles and clipped pentagons), slivers,
    /// polygons partly or wholly off the grid, corners placed on bin boundaries.
    #[test]
    fn row_binning_lists_every_overlapped_bin() {
        use super::super::overlap::convex_overlap;
        let g = BinGrid {
            nx: 7,
            ny: 5,
            width: 70.0,
            height: 50.0,
        };
        let margin = 4e-3;
        let mut rng = sightline_core::random::SplitMix64::new(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_u64();
        for case in 0..20_000 {
            let mut coord = |extent: f64| {
                let r = next();
                // A third of the coordinates sit exactly on a bin boundary, or a hair off it.
                match r % 3 {
                    0 => (r >> 8) as f64 / u64::MAX as f64 * 256.0 * extent / 200.0 - 5.0,
                    1 => ((r >> 8) % 8) as f64 * 10.0,
                    _ => ((r >> 8) % 8) as f64 * 10.0 + ((r >> 20) % 3) as f64 * 1e-3 - 1e-3,
                }
            };
            let mut pts: Vec<DVec2> = (0..3)
                .map(|_| DVec2::new(coord(70.0), coord(50.0)))
                .collect();
            if case % 4 == 0 {
                // A convex pentagon: the triangle with one corner cut off.
                let (a, b, c) = (pts[0], pts[1], pts[2]);
                pts = vec![a, a.lerp(b, 0.7), b.lerp(c, 0.3), c, c.lerp(a, 0.5)];
            }
            let mut got = Vec::new();
            bins_of(&pts, &g, margin, &mut got);
            let mut unique = got.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), got.len(), "case {case}: a bin listed twice");
            for b in 0..g.len() {
                let (x0, x1, y0, y1) = g.rect(b);
                let rect = [
                    DVec2::new(x0, y0),
                    DVec2::new(x1, y0),
                    DVec2::new(x1, y1),
                    DVec2::new(x0, y1),
                ];
                let listed = got.contains(&(b as u32));
                // (For polygons of zero area the thesis' test lacks the segment's own normal
                // and over-reports; there, every bin holding a corner must be listed.)
                let area = (0..pts.len())
                    .map(|i| pts[i].perp_dot(pts[(i + 1) % pts.len()]))
                    .sum::<f64>()
                    .abs();
                let must = if area > 1e-9 {
                    convex_overlap(&pts, &rect, margin)
                } else {
                    pts.iter()
                        .any(|p| (x0..=x1).contains(&p.x) && (y0..=y1).contains(&p.y))
                };
                if must {
                    assert!(listed, "case {case}: bin {b} missing for {pts:?}");
                }
                // Farther than twice the margin in x or y from the bin: never listed.
                let grown = Rect {
                    min: DVec2::new(x0, y0) - 2.0 * margin,
                    max: DVec2::new(x1, y1) + 2.0 * margin,
                };
                if !Rect::of(&pts).touches(&grown, 0.0) {
                    assert!(!listed, "case {case}: bin {b} listed for {pts:?}");
                }
            }
        }
    }
}
