//! Occluder fusion: a per-bin grid of conservative far-depth bounds, so that a triangle hidden
//! partly by one occluder and partly by another (a wall meeting a ceiling, two buildings side
//! by side) is still found occluded. The thesis tests an occludee against one occluder at a
//! time; this is ours, beyond it.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapter 5 (the occluders and the silhouette test this reuses) and its discussion of
//! missing occluder fusion; the bound per cell is the conservative far depth of hierarchical
//! occlusion maps (Zhang et al. 1997), made exact for the covered region by the silhouette
//! test.
//!
//! Each bin's screen rectangle (grown by the margin) is split into `n x n` cells. A cell gets a
//! bound `far` when some occluder covers the whole cell grown by the margin (no silhouette edge
//! comes within the margin of it, and the silhouette's winding number at its centre is not
//! zero — the argument of `occlusion_test.rs`): every point of the cell is then covered by one
//! of that occluder's triangles touching the cell, so the nearest surface there is no farther
//! than the largest depth of those triangles. Occluders only ever gain triangles, so a bound
//! once valid stays valid and cells keep the minimum over all bounds found. A cell's coverage
//! can only change when a triangle touching it joins an occluder, so only those cells are
//! re-examined. An occludee is hidden when every cell it touches has a bound nearer than its
//! nearest point (by the relative depth margin).
//!
//! Limitation: a cell must lie inside *one* occluder, so fusion works where occluders overlap
//! on screen by at least a cell (a building in front of another, a wall before a wall); two
//! occluders that merely abut, with the seam inside a cell (a ceiling meeting the top of a
//! wall, both unconnected meshes), still fuse nothing along the seam. Measured effect on the
//! test scenes in `docs/BENCHMARKS.md`.
//!
//! Memory: 8 bytes per cell, taken from the occluder pool when the bin's first occluder
//! appears; if the pool is empty the bin simply has no fusion (still conservative).

use glam::DVec2;

use super::depth::DEPTH_EPS;
use super::memory::{release_to, reserve_from, Pool};
use super::occluder::Occluder;
use super::overlap::{convex_overlap, ray_winding, segment_overlaps, Rect};

/// Target cell edge in pixels (the bins' cells are as close to this as the grid allows).
const CELL_PX: f64 = 4.0;
/// Most cells per bin side.
const MAX_CELLS: usize = 16;
/// Occluders with more triangles than this use their overall depth bound instead of the bound
/// of the triangles touching a cell (a cheaper, looser, still valid bound).
const MAX_TRIS_SCANNED: usize = 64;

/// The far-depth grid of one bin.
#[derive(Debug, Default)]
pub(crate) struct FusedDepth {
    /// Cells per side (0 until allocated).
    n: usize,
    /// Row-major bounds; `+inf` where nothing is known.
    far: Vec<f64>,
}

impl FusedDepth {
    /// Cells per side for a bin of `bin` (grown) rectangle.
    fn cells_for(bin: &Rect) -> usize {
        let side = (bin.max - bin.min).max_element();
        ((side / CELL_PX).round() as usize).clamp(1, MAX_CELLS)
    }

    /// The rectangle of cell `(i, j)`.
    fn cell(&self, bin: &Rect, i: usize, j: usize) -> Rect {
        let size = (bin.max - bin.min) / self.n as f64;
        let min = bin.min + size * DVec2::new(i as f64, j as f64);
        Rect {
            min,
            max: min + size,
        }
    }

    /// The cell index range `[lo, hi]` along both axes that `r` overlaps (clamped).
    fn cell_range(&self, bin: &Rect, r: &Rect) -> ([usize; 2], [usize; 2]) {
        let size = (bin.max - bin.min) / self.n as f64;
        let idx =
            // `as` truncates (the floor for non-negative values) and saturates negatives and
            // NaN to 0, without a libm call.
            |v: f64, lo: f64, s: f64| (((v - lo) / s) as usize).min(self.n - 1);
        (
            [
                idx(r.min.x, bin.min.x, size.x),
                idx(r.min.y, bin.min.y, size.y),
            ],
            [
                idx(r.max.x, bin.min.x, size.x),
                idx(r.max.y, bin.min.y, size.y),
            ],
        )
    }

    /// Re-examines the cells that `changed` (the rectangle of a triangle that just joined `o`)
    /// touches: those `o` now covers get `o`'s bound there.
    pub(crate) fn update(
        &mut self,
        o: &Occluder,
        changed: &Rect,
        bin: &Rect,
        margin: f64,
        pool: &Pool,
    ) {
        if self.n == 0 {
            let n = Self::cells_for(bin);
            if !reserve_from(&mut self.far, n * n, pool) {
                return;
            }
            self.far.resize(n * n, f64::INFINITY);
            self.n = n;
        }
        if !changed.touches(bin, margin) {
            return;
        }
        let (lo, hi) = self.cell_range(bin, changed);
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                let cell = self.cell(bin, i, j);
                if !o.rect.contains(&cell, margin) {
                    continue;
                }
                let at = j * self.n + i;
                let bound = occluder_far_over(o, &cell, margin);
                if bound < self.far[at] && covers(o, &cell, margin) {
                    self.far[at] = bound;
                }
            }
        }
    }

    /// True when every cell that convex polygon `screen` (bounds `rect`, nearest depth `zmin`)
    /// touches has a bound nearer than `zmin`.
    pub(crate) fn hides(
        &self,
        screen: &[DVec2],
        rect: &Rect,
        zmin: f64,
        bin: &Rect,
        margin: f64,
    ) -> bool {
        // Every point of the polygon must lie in the grid (it is clipped to the grown bin;
        // rounding may put it a hair outside, which the cells' margin covers).
        if self.n == 0 || !bin.contains(rect, -0.5 * margin) {
            return false;
        }
        let grown = Rect {
            min: rect.min - margin,
            max: rect.max + margin,
        };
        let (lo, hi) = self.cell_range(bin, &grown);
        for j in lo[1]..=hi[1] {
            for i in lo[0]..=hi[0] {
                if zmin > self.far[j * self.n + i] * (1.0 + DEPTH_EPS) {
                    continue;
                }
                // Not hidden here: fine only if the polygon does not really reach the cell.
                let c = self.cell(bin, i, j);
                let corners = [
                    c.min,
                    DVec2::new(c.max.x, c.min.y),
                    c.max,
                    DVec2::new(c.min.x, c.max.y),
                ];
                if convex_overlap(&corners, screen, margin) {
                    return false;
                }
            }
        }
        true
    }

    /// Returns the grid's memory to `pool`.
    pub(crate) fn clear(&mut self, pool: &Pool) {
        release_to(&mut self.far, pool);
        self.n = 0;
    }
}

/// Whether `o`'s triangles cover every point of `cell` grown by `margin`.
fn covers(o: &Occluder, cell: &Rect, margin: f64) -> bool {
    let corners = [
        cell.min,
        DVec2::new(cell.max.x, cell.min.y),
        cell.max,
        DVec2::new(cell.min.x, cell.max.y),
    ];
    let (lo, hi) = (cell.min - margin, cell.max + margin);
    let centre = 0.5 * (cell.min + cell.max);
    let mut winding = 0;
    for e in &o.edges {
        let (emin, emax) = (e.a.min(e.b), e.a.max(e.b));
        let near = emin.x <= hi.x && emax.x >= lo.x && emin.y <= hi.y && emax.y >= lo.y;
        if near && segment_overlaps(e.a, e.b, &corners, margin) {
            return false;
        }
        winding += ray_winding(centre, e.a, e.b);
    }
    winding != 0
}

/// The largest view depth of `o`'s triangles that can cover points of `cell` grown by
/// `margin`.
fn occluder_far_over(o: &Occluder, cell: &Rect, margin: f64) -> f64 {
    if o.tris.len() > MAX_TRIS_SCANNED {
        return o.zmax;
    }
    let far = o
        .tris
        .iter()
        .filter(|t| t.rect.touches(cell, margin))
        .map(|t| {
            t.corners
                .iter()
                .map(|c| c.z)
                .fold(f64::NEG_INFINITY, f64::max)
        })
        .fold(f64::NEG_INFINITY, f64::max);
    // A covered cell is touched by some triangle; if none is found, claim nothing.
    if far.is_finite() {
        far
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fusion with occluders the bin state builds is tested beside the visibility stage,
    /// which feeds the grid (`visibility_stage.rs`).
    #[test]
    fn empty_grid_hides_nothing() {
        let g = FusedDepth::default();
        let bin = Rect {
            min: DVec2::ZERO,
            max: DVec2::splat(16.0),
        };
        let p = [
            DVec2::new(1.0, 1.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(1.0, 2.0),
        ];
        assert!(!g.hides(&p, &Rect::of(&p), 100.0, &bin, 4e-3));
    }
}
