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
//! Bins run in parallel with `rayon`; inside a bin, edges run one after another. `driver.rs`
//! runs the steps ([`visible_fragments`], and the images of its result), `types.rs` holds the
//! public types; this file only declares and re-exports them.
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
//! wider views use several cameras ([`Camera::cube_faces`](sightline_core::Camera::cube_faces)).
//! See `domain.rs`.
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
mod driver;
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
mod types;

pub use driver::{antialiased_image, integrate, visible_fragments};
pub use svg::write_svg;
pub use types::{
    AnalyticError, AnalyticOptions, AnalyticResult, AnalyticStats, AnalyticWarnings, Filter,
    VisiblePolygon, MIN_VISIBLE_AREA_PX2, MIN_VISIBLE_THICKNESS_PX,
};
