//! The public types of the analytic visibility (its options, errors, statistics and result,
//! and the filters of its images), and the result's index of pieces by bin. A leaf: the steps
//! and the driver take them from here; `mod.rs` re-exports them.

use std::time::Duration;

use glam::DVec2;
use sightline_core::TriangleSet;

/// The visible area (square pixels) below which a piece is what the 2^-20 px snapping and f64
/// rounding leave along shared edges and intersection lines at ordinary image sizes (measured
/// up to 1e-10 px² on the shared scenes; snapping moves a region's boundary by up to 6.7e-7 px,
/// so a sliver of a few pixels' length reaches 1e-6 px²). [`AnalyticResult::visible`] keeps
/// every positive area (at tiny image sizes whole triangles are smaller than this); RV's
/// positive-area guarantee, and `visible --exact`'s `-o` listing through the CLI's check, are
/// judged against this threshold.
pub const MIN_VISIBLE_AREA_PX2: f64 = 1e-6;

/// The mean thickness (pixels) below which a triangle's visible region is what snapping leaves
/// between two nearly collinear edges: 2 units of the 2^-20 px grid, the tolerance within which
/// edges count as collinear (`project::NEAR_COLLINEAR_GRID`). The mean thickness is the
/// region's area over its extent (the diagonal of its pieces' bounding box): both are the
/// region's own, whatever bins or convex pieces cut it, so the rule does not depend on the bin
/// size (a largest `2 × area / perimeter` per piece did: cut into 1-px bins, a tapered sliver's
/// pieces are up to twice as thick as the whole). Area alone cannot tell such slivers from real
/// pieces: a sliver one grid unit wide and 10 px long has 5e-6 px², above
/// [`MIN_VISIBLE_AREA_PX2`], and how much of it survives depends on where bin borders cut it
/// (measured on a Quake 3 map: 4.6e-7 px² at 1-px bins, 3.5e-6 px² at 16-px bins, 0.2 grid units
/// thick on average). A triangle that shows a real piece and, far from it, a sliver has a large
/// extent: a piece of 1e-4 px² with a sliver 50 px away is 2 grid units thick on average, so
/// real pieces much smaller than that can be left out with their slivers.
pub const MIN_VISIBLE_THICKNESS_PX: f64 = 2.0 / 1_048_576.0;

/// Options of [`visible_fragments`](super::visible_fragments).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyticOptions {
    /// Bin edge length in pixels (1..=4096). Smaller bins mean fewer polygons per bin but more
    /// pieces per triangle; the default was measured on the bunny at 1024² (see the bench).
    pub bin_size: u32,
    /// Remove polygons that are provably hidden everywhere before the exact pipeline (see
    /// `precull.rs`); the result is the same, only faster. Off only to measure or cross-check.
    pub depth_preculling: bool,
}

impl Default for AnalyticOptions {
    fn default() -> Self {
        Self {
            bin_size: 16,
            depth_preculling: true,
        }
    }
}

/// Why the visibility could not be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum AnalyticError {
    /// The camera's fields are not a valid camera (see
    /// [`Camera::looking`](sightline_core::Camera::looking)).
    #[error("invalid camera: {0}")]
    BadCamera(&'static str),
    /// The bin size is outside 1..=4096.
    #[error("bin size {0} is outside 1..=4096")]
    BadBinSize(u32),
    /// The camera is valid but outside the range where the result is exact (see the module
    /// docs, "Exactness"): a field of view beyond 170.00° on either axis, or an image too small
    /// for its field of view.
    #[error("{parameter} is outside the exact range of the analytic visibility: {detail}")]
    OutsideExactRange {
        /// The camera parameter: `field of view`, `horizontal field of view` or `image size`.
        parameter: &'static str,
        /// The value, the exact range, and what to use instead.
        detail: String,
    },
}

/// A convex piece of the visible region of one triangle, in screen pixels (the mapping of
/// [`sightline_core::camera`]: `x` right, `y` down, pixel `(x, y)` covers `[x, x+1) × [y, y+1)`).
#[derive(Clone, Debug, PartialEq)]
pub struct VisiblePolygon {
    /// Triangle id.
    pub triangle: u32,
    /// Corners, counter-clockwise in the y-down sense (`cross(b - a, c - a) > 0`).
    pub points: Vec<DVec2>,
}

/// Input problems found while computing visibility (nothing panics; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AnalyticWarnings {
    /// Triangles skipped for out-of-range indices or non-finite corners.
    pub invalid_triangles: u64,
    /// Intersecting pairs (per bin) whose depth order flips along an edge, but whose
    /// intersection segment could not be built (its end points exist only within rounding).
    pub unresolved_crossings: u64,
}

impl AnalyticWarnings {
    /// Sum of all warnings.
    pub fn total(&self) -> u64 {
        self.invalid_triangles + self.unresolved_crossings
    }
}

/// Statistics of one [`visible_fragments`](super::visible_fragments) run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AnalyticStats {
    /// Triangles with a non-empty projection inside the frustum.
    pub triangles_in_frustum: usize,
    /// Bins holding at least one polygon.
    pub bins_filled: usize,
    /// Polygon pieces over all bins (the paper's bin-triangle assignments).
    pub bin_assignments: usize,
    /// Most pieces in one bin.
    pub max_pieces_per_bin: usize,
    /// Edge–polygon overlaps (each is a pair of the paper's edge intersections).
    pub intersections: u64,
    /// Visible edge segments (hidden-line elimination output).
    pub visible_segments: u64,
    /// Segments added by boundary completion.
    pub completion_segments: u64,
    /// Intersecting triangle pairs resolved by their intersection segment, counted per bin
    /// (a pair whose segment crosses several bins counts in each).
    pub crossing_pairs: u64,
    /// Edge overlaps split where the depth order of two intersecting polygons flips.
    pub flipped_overlaps: u64,
    /// 2D predicates decided by the exact fallback.
    pub exact_fallbacks: u64,
    /// Input problems.
    pub warnings: AnalyticWarnings,
    /// Wall time of the whole visibility computation.
    pub visibility_time: Duration,
    /// Part of `visibility_time` spent projecting and clipping.
    pub projection_time: Duration,
    /// Part of `visibility_time` spent binning.
    pub binning_time: Duration,
    /// Polygons in the frustum removed as provably hidden by depth pre-culling.
    pub preculled: usize,
    /// Part of `visibility_time` spent pre-culling.
    pub precull_time: Duration,
}

/// The exact visibility from one camera.
#[derive(Clone, Debug)]
pub struct AnalyticResult {
    /// Triangles whose visible region has a positive area (see [`MIN_VISIBLE_AREA_PX2`] for the
    /// pieces that rounding leaves).
    pub visible: TriangleSet,
    /// Visible regions as convex pieces, grouped by bin (row-major), then by triangle id.
    pub polygons: Vec<VisiblePolygon>,
    /// Statistics.
    pub stats: AnalyticStats,
    /// Visible area per triangle id (square pixels), summed once while `visible` is built (like
    /// `visible`, it describes `polygons` as `visible_fragments` made them).
    pub(super) area: Vec<f64>,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) bin_size: u32,
    pub(super) bins: Vec<BinRange>,
}

impl AnalyticResult {
    /// Bin edge length in pixels that the result was computed with.
    pub fn bin_size(&self) -> u32 {
        self.bin_size
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Visible area (square pixels) per triangle id, over `n` ids (zero past the scene's).
    pub fn visible_area(&self, n: usize) -> Vec<f64> {
        let mut out = self.area.clone();
        out.resize(n, 0.0);
        out
    }

    /// The triangles whose visible area is at least `min_area_px2` and whose visible region is
    /// at least [`MIN_VISIBLE_THICKNESS_PX`] thick on average (over `n` ids); with
    /// [`MIN_VISIBLE_AREA_PX2`], the set without the pieces that rounding leaves along shared
    /// edges and between nearly collinear edges. A `min_area_px2` of 0 or less gives
    /// [`AnalyticResult::visible`] (every positive area, however thin).
    pub fn visible_at_least(&self, n: usize, min_area_px2: f64) -> TriangleSet {
        if min_area_px2 <= 0.0 {
            return self.visible.clone();
        }
        let mut set = TriangleSet::with_capacity(n);
        let thickness = self.visible_thickness(n);
        set.extend(self.visible.ones().filter(|&t| {
            self.area.get(t).is_some_and(|&a| a >= min_area_px2)
                && thickness
                    .get(t)
                    .is_some_and(|&d| d >= MIN_VISIBLE_THICKNESS_PX)
        }));
        set
    }

    /// Mean thickness (pixels) of each triangle's visible region, over `n` ids: its area over
    /// its extent (zero where nothing is visible), the measure of [`MIN_VISIBLE_THICKNESS_PX`].
    pub fn visible_thickness(&self, n: usize) -> Vec<f64> {
        // Derived from the pieces when asked (the listing and its checks), not while
        // `visible_fragments` runs: the extent is one pass over the pieces' corners.
        let mut extent = vec![
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY
            ];
            n
        ];
        for p in &self.polygons {
            if let Some(e) = extent.get_mut(p.triangle as usize) {
                for q in &p.points {
                    *e = [e[0].min(q.x), e[1].min(q.y), e[2].max(q.x), e[3].max(q.y)];
                }
            }
        }
        extent
            .iter()
            .enumerate()
            .map(|(t, &[x0, y0, x1, y1])| {
                let area = self.area.get(t).copied().unwrap_or(0.0);
                let diagonal = (x1 - x0).hypot(y1 - y0);
                if area > 0.0 && diagonal > 0.0 {
                    area / diagonal
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// The reconstruction filter of [`integrate`](fn@super::integrate). Both are weighted area integrals of the value, so
/// the image is linear in it: for shading values, linear light, to be encoded (e.g. with the
/// sRGB transfer function, as `sightline visible --png` does) before being shown as 8-bit.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Filter {
    /// The pixel's unit square.
    Box,
    /// A Gaussian with `σ = radius_px / 3` over the square window of half-width `radius_px`
    /// around the pixel centre, normalised to unit mass (the paper uses radius 2.3 px). At radius
    /// 2.3 it takes 1.3x the box filter's time on a city view, 2.9x on the bunny's sub-pixel
    /// triangles (docs/BENCHMARKS.md).
    Gauss {
        /// Window half-width in pixels (0.1..=16).
        radius_px: f64,
    },
}

/// A bin's pieces for integration: bin origin (pixels), size and the range of its polygons.
#[derive(Clone, Debug)]
pub(crate) struct BinRange {
    /// Left pixel column.
    pub(crate) x: u32,
    /// Top pixel row.
    pub(crate) y: u32,
    /// Range in the result's polygon list.
    pub(crate) polys: std::ops::Range<usize>,
}
