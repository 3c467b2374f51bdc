//! Exact analytic from-point visibility: the visible fragments of every triangle as screen-space
//! polygons, the exact visible set, and analytically anti-aliased images.
//!
//! Based on: Auzinger, Wimmer, Jeschke. Analytic Visibility on the GPU. Eurographics 2013.
//!
//! # Pipeline (one file per step, in the paper's order)
//! 1. `project.rs` — world → view (f64), clipping to the near plane and the frustum's sides,
//!    projection with the mapping of [`sightline_core::camera`], snapping to a 2^-20 px grid.
//! 2. `bin.rs` — listing every polygon in the square bins it overlaps (section 4.3); each bin
//!    processes the parts of edges inside it, and its own border as four extra edges.
//! 3. `intersect.rs` — per edge, the overlap interval with every other polygon of the bin, its
//!    side and depth type (Algorithm 1).
//! 4. `hidden_line.rs` — sort along the edge and prefix scan: the visible parts of each edge
//!    (Algorithm 2).
//! 5. `boundary.rs` — boundary completion: the segments of the regions seen right behind the
//!    visible edges (Algorithm 3).
//! 6. `polygon.rs` — the boundary segments of each triangle's visible region, as convex pieces.
//! 7. `integrate.rs` — the exact box-filtered image (Algorithm 4); `gauss.rs` — the
//!    Gaussian-filtered image (Green's theorem with the window-truncated kernel: each edge is cut
//!    at the window borders, and one quadrature per piece serves every pixel it reaches).
//!
//! Bins run in parallel with `rayon`; inside a bin, edges run one after another.
//!
//! # Input assumptions and what happens when they are violated
//! - Triangles may intersect (walls piercing roofs, interpenetrating props, terrain through
//!   buildings), touch, share edges or vertices, and overlap cyclically. The paper assumes they
//!   do not intersect; here an overlap along which two polygons' depth order flips is split at
//!   the flip, and their projected intersection segment is added as an edge of both
//!   (`crossing.rs`), so each side of it gets the right order. Pairs whose flip exists only
//!   within rounding are counted in [`AnalyticWarnings::unresolved_crossings`] (each side then
//!   keeps the order found there). Nothing panics, every loop is bounded.
//! - Triangles are double-sided; no orientation is needed.
//! - Coplanar overlapping triangles: the lower triangle id is in front (the rasterizer's rule).
//! - Triangles seen exactly edge-on (their plane passes through the eye) cover no area and are
//!   never visible; so are degenerate triangles and those smaller than the snapping grid.
//! - Triangles with out-of-range indices or non-finite corners are skipped and counted in
//!   [`AnalyticWarnings::invalid_triangles`].
//!
//! # Exactness
//! Screen positions are snapped to a grid of 2^-20 px (shared vertices snap identically, so
//! meshes stay watertight). On the snapped polygons every combinatorial decision of the 2D
//! geometry (parallel or not, which side, collinear) is exact (float filter with an `i128`
//! fallback, see `predicates.rs`); positions of intersection points are f64, and depth
//! comparisons are f64 with a tolerance (relative 1e-9 plus what snapping can change; ties are
//! resolved by slope, then by id). Polygons are never clipped to bins, so the result does not
//! depend on the bin size (beyond f64 rounding: 2e-10 px² on the bunny between 8 and 32 px bins).
//!
//! The exact range: the result is exact for the snapped scene, so it can differ from the
//! unsnapped one only where a visible part lies within about a grid unit of an edge (slivers),
//! and where two surfaces are closer than about 2e-9 of their distance (0.2 mm at 100 km). The
//! grid is per pixel: a 1×1 image resolves 2^-20 of the view, 1024² resolves 2^-30, and a model
//! covering a thousandth of a pixel (15 cm seen from 100 km) is as coarse as a 1×1 image.
//! [`visible_fragments`] refuses with [`AnalyticError::OutsideExactRange`] the cameras where
//! the grid unit at the image centre exceeds 2^-17 of the tangent plane (`2 tan(fov_y/2) /
//! (height · 2^20)`: a 1×1 image beyond fov 151.9°) or `tan(fov/2) > 16` on either axis (fov
//! beyond 170.00°, where depth gaps below `1.3e-8 tan(fov/2)` of the distance become ties); for
//! wider views use several cameras ([`Camera::cube_faces`]). See `domain.rs`.
//!
//! ```
//! use glam::Vec3;
//! use sightline_core::scene::SceneBuilder;
//! use sightline_core::Camera;
//! use sightline_point::analytic::{visible_fragments, AnalyticOptions};
//!
//! let mut b = SceneBuilder::new("box");
//! b.add_box(Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 5.0));
//! let scene = b.finish();
//! let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("camera");
//! let result = visible_fragments(&scene, &cam, &AnalyticOptions::default()).expect("valid");
//! // Only the two triangles of the front face (z = 4) are visible.
//! assert_eq!(result.visible.count_ones(..), 2);
//! ```

mod bin;
mod boundary;
mod crossing;
mod domain;
mod gauss;
mod hidden_line;
mod integrate;
mod intersect;
mod pipeline;
mod polygon;
mod precull;
mod predicates;
mod project;
mod svg;

use std::time::{Duration, Instant};

use glam::DVec2;
use rayon::prelude::*;
use sightline_core::{Camera, Scene, TriangleSet};

use bin::{bin_polygons, BinGrid, Polys};
use integrate::BinRange;
use pipeline::{process_bin, BinOutput};
use project::{project_triangle, Projected, Projection};

pub use svg::write_svg;

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
/// edges count as collinear (`intersect::NEAR_COLLINEAR_GRID`). The mean thickness is the
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

/// Options of [`visible_fragments`].
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
    /// The camera's fields are not a valid camera (see [`Camera::looking`]).
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

/// Statistics of one [`visible_fragments`] run.
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
    area: Vec<f64>,
    width: u32,
    height: u32,
    bin_size: u32,
    bins: Vec<BinRange>,
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

/// The reconstruction filter of [`integrate`]. Both are weighted area integrals of the value, so
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

fn check_camera(c: &Camera) -> Result<(), AnalyticError> {
    if !(c.eye.is_finite() && c.forward.is_finite() && c.up.is_finite() && c.right.is_finite()) {
        return Err(AnalyticError::BadCamera("non-finite position or basis"));
    }
    if c.width == 0 || c.height == 0 || c.width > 16384 || c.height > 16384 {
        return Err(AnalyticError::BadCamera("image size outside 1..=16384"));
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(AnalyticError::BadCamera("field of view outside (0, 180)"));
    }
    if !(c.near > 0.0 && c.near.is_finite()) {
        return Err(AnalyticError::BadCamera(
            "near plane not positive and finite",
        ));
    }
    if c.forward.length_squared() < 0.5 || c.right.length_squared() < 0.5 {
        return Err(AnalyticError::BadCamera(
            "basis vectors are not unit length",
        ));
    }
    domain::check(c)
}

/// The exact visible fragments of `scene` seen from `camera`: for every triangle, convex
/// polygons covering exactly its visible region inside the image (however small), and the set
/// of triangles with a visible region of positive area. See the module docs for the assumptions.
pub fn visible_fragments(
    scene: &Scene,
    camera: &Camera,
    options: &AnalyticOptions,
) -> Result<AnalyticResult, AnalyticError> {
    let start = Instant::now();
    check_camera(camera)?;
    if options.bin_size == 0 || options.bin_size > 4096 {
        return Err(AnalyticError::BadBinSize(options.bin_size));
    }
    let proj = Projection::new(camera);
    let n = scene.triangles.len();
    let projected: Vec<Projected> = (0..n as u32)
        .into_par_iter()
        .map(|id| project_triangle(scene, &proj, id))
        .collect();
    let mut stats = AnalyticStats::default();
    let mut polys = Vec::new();
    for p in projected {
        match p {
            Projected::Poly(p) => polys.push(p),
            Projected::Empty => {}
            Projected::Invalid => stats.warnings.invalid_triangles += 1,
        }
    }
    stats.triangles_in_frustum = polys.len();
    stats.projection_time = start.elapsed();
    if options.depth_preculling {
        let (kept, culled) = precull::cull_hidden(polys, camera.width, camera.height);
        polys = kept;
        stats.preculled = culled;
    }
    stats.precull_time = start.elapsed() - stats.projection_time;
    let grid = BinGrid::new(camera.width, camera.height, options.bin_size);
    let polys = Polys::new(polys);
    let bins = bin_polygons(&polys, grid);
    stats.binning_time = start.elapsed() - stats.projection_time - stats.precull_time;
    stats.bins_filled = bins.len();
    stats.bin_assignments = bins.iter().map(|b| b.members.len()).sum();
    stats.max_pieces_per_bin = bins.iter().map(|b| b.members.len()).max().unwrap_or(0);
    let outputs: Vec<BinOutput> = bins.par_iter().map(|b| process_bin(&polys, b)).collect();
    let mut area = vec![0.0f64; n];
    let mut polygons = Vec::new();
    let mut ranges = Vec::with_capacity(bins.len());
    for (bin, o) in bins.iter().zip(outputs) {
        stats.intersections += o.counters.intersections;
        stats.exact_fallbacks += o.counters.exact_fallbacks;
        stats.flipped_overlaps += o.counters.intersecting;
        stats.crossing_pairs += o.crossing_pairs;
        stats.warnings.unresolved_crossings += o.unresolved_pairs;
        stats.visible_segments += o.visible_segments;
        stats.completion_segments += o.completion_segments;
        let first = polygons.len();
        for p in o.pieces {
            if let Some(a) = area.get_mut(p.triangle as usize) {
                *a += polygon::area(&p.points);
            }
            polygons.push(p);
        }
        ranges.push(BinRange {
            x: bin.x * options.bin_size,
            y: bin.y * options.bin_size,
            polys: first..polygons.len(),
        });
    }
    let mut visible = TriangleSet::with_capacity(n);
    visible.extend((0..n).filter(|&t| area[t] > 0.0));
    stats.visibility_time = start.elapsed();
    Ok(AnalyticResult {
        visible,
        polygons,
        stats,
        area,
        width: camera.width,
        height: camera.height,
        bin_size: options.bin_size,
        bins: ranges,
    })
}

/// The image of `result` filtered with `filter`: pixel `(x, y)` (row-major, top row first) is
/// the integral of `value(triangle)` over the visible polygons against the filter centred on the
/// pixel: for [`Filter::Box`] exactly the sum of value × area inside the pixel's square, for
/// [`Filter::Gauss`] to 3e-8 of value × the window's mass (see `gauss.rs`). A radius outside
/// 0.1..=16 is clamped, a non-finite one replaced by the paper's 2.3 px. The result is linear in
/// `value` (see [`Filter`]).
pub fn integrate(
    result: &AnalyticResult,
    filter: Filter,
    value: impl Fn(u32) -> f32 + Sync,
) -> Vec<f32> {
    match filter {
        Filter::Box => integrate::box_image(
            result.width,
            result.height,
            result.bin_size,
            &result.bins,
            &result.polygons,
            &value,
        ),
        Filter::Gauss { radius_px } => gauss::gauss_image(
            result.width,
            result.height,
            &result.bins,
            &result.polygons,
            if radius_px.is_finite() {
                radius_px.clamp(0.1, 16.0)
            } else {
                2.3
            },
            &value,
        ),
    }
}

/// A grey anti-aliased image of `result`: every triangle is shaded flat with a headlight,
/// `0.1 + 0.9 |cos θ|` (θ between its normal and the ray to its centroid), background 0; the
/// values are linear light (see [`Filter`]).
/// `scene` and `camera` must be the ones `result` was computed for.
pub fn antialiased_image(
    result: &AnalyticResult,
    scene: &Scene,
    camera: &Camera,
    filter: Filter,
) -> Vec<f32> {
    let shade: Vec<f32> = (0..scene.triangles.len())
        .map(|id| {
            let corners = scene.triangles[id].map(|i| scene.positions.get(i as usize).copied());
            let [Some(a), Some(b), Some(c)] = corners else {
                return 0.0;
            };
            let n = (b - a).cross(c - a).normalize_or_zero();
            let v = ((a + b + c) / 3.0 - camera.eye).normalize_or_zero();
            0.1 + 0.9 * n.dot(v).abs()
        })
        .collect();
    integrate(result, filter, |id| {
        shade.get(id as usize).copied().unwrap_or(0.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn camera() -> Camera {
        Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 32, 32, 0.1).expect("camera")
    }

    #[test]
    fn empty_scene_sees_nothing() {
        let r = visible_fragments(&Scene::default(), &camera(), &AnalyticOptions::default())
            .expect("valid");
        assert_eq!(r.visible.count_ones(..), 0);
        assert!(r.polygons.is_empty());
        let img = integrate(&r, Filter::Box, |_| 1.0);
        assert!(img.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn empty_result_gives_black_images() {
        let scene = Scene::default();
        let r = visible_fragments(&scene, &camera(), &AnalyticOptions::default()).expect("valid");
        let img = antialiased_image(&r, &scene, &camera(), Filter::Box);
        assert!(img.len() == 32 * 32 && img.iter().all(|&v| v == 0.0));
        let img = integrate(
            &r,
            Filter::Gauss {
                radius_px: f64::NAN,
            },
            |_| 1.0,
        );
        assert!(img.len() == 32 * 32 && img.iter().all(|&v| v == 0.0));
        assert_eq!(r.visible_area(0), Vec::<f64>::new());
    }

    #[test]
    fn zero_bin_size_is_error() {
        let r = visible_fragments(
            &Scene::default(),
            &camera(),
            &AnalyticOptions {
                bin_size: 0,
                ..AnalyticOptions::default()
            },
        );
        assert_eq!(r.err(), Some(AnalyticError::BadBinSize(0)));
    }

    #[test]
    fn broken_camera_is_error() {
        let mut c = camera();
        c.width = 0;
        let r = visible_fragments(&Scene::default(), &c, &AnalyticOptions::default());
        assert!(matches!(r, Err(AnalyticError::BadCamera(_))));
        let mut c = camera();
        c.eye.x = f32::NAN;
        let r = visible_fragments(&Scene::default(), &c, &AnalyticOptions::default());
        assert!(matches!(r, Err(AnalyticError::BadCamera(_))));
    }
}
