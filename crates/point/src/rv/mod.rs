//! RV: a conservative from-point visible set computed while the scene streams through, in a
//! fixed memory budget.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021 (master's thesis, TU Graz), chapters 4-6.
//!
//! The scene arrives as a [`TriangleSource`] (an in-memory [`SceneSource`], or a generator such
//! as [`StreamingCity`] that never materialises the scene). A sort-middle pipeline (one pass
//! over the stream: `pass.rs`) projects and bins triangles into a grid of screen bins
//! (geometry stage, `geometry_stage.rs`, on several threads: `producer.rs`; runs of input
//! triangles wholly outside the frustum are dropped by their bounding box first,
//! `frustum_cull.rs`), and worker threads resolve visibility per bin (visibility stage,
//! `visibility_stage.rs`): each bin keeps occluders made of edge-connected visible triangles
//! (`occluder.rs`, built by `occluders.rs`), and a triangle is occluded in a bin when it lies
//! inside one occluder's silhouette and behind its triangles (`occlusion_test.rs`). A triangle
//! is visible when it is visible in any bin. The driver (`driver.rs`) sizes the memory, runs
//! the pass that builds the occluders and a re-test pass, and gathers the counters.
//!
//! This file is the module's face: the engine's files take the public types from `types.rs`,
//! never from here.
//!
//! # Guarantee
//! With [`Guarantee::PositiveArea`] (the default) RV never misses a triangle with a visible
//! region of positive area (the exact set of [`crate::analytic`]); with
//! [`Guarantee::AnySample`] it never misses a triangle that the reference rasterizer
//! (`sightline_core::raster`) shows at any resolution of the same camera, which adds the
//! triangles that touch the visible image only along a line (a back face meeting a closed
//! object's silhouette on a shared edge can win a pixel-centre depth tie there). Either way
//! every predicate errs towards "overlaps" by a screen margin and towards "in front" by a
//! relative depth margin (see `overlap.rs`, `depth.rs`), coplanar and intersecting triangles are
//! never called occluded, and full pools keep triangles visible. The only difference: under
//! positive-area semantics a silhouette edge that *is* an edge of the occludee, or leaves one of
//! its corners outwards, may touch it, and an occluder triangle that shares corners with the
//! occludee may meet it there in depth (`occlusion_test.rs`); both touch a set of zero area.
//! Triangles are double-sided, as in the rasterizer. Degenerate (zero-area or non-finite)
//! triangles are never reported visible.
//!
//! # Memory
//! [`RvOptions::memory_budget_bytes`] bounds the heap RV allocates: the visible set (two bits
//! per id bound: the concurrent set and the returned copy), the source buffer, a ring of
//! projected batches, the bin queues, and a shared occluder pool that takes the rest
//! (`memory.rs`). [`RvResult::peak_memory_bytes`] is the accounted high-water mark. Memory
//! held by the source itself (e.g. an in-memory scene) is the caller's and not counted.
//!
//! ```
//! use glam::Vec3;
//! use sightline_core::scene::SceneBuilder;
//! use sightline_core::Camera;
//! use sightline_point::rv::{conservative_visible, RvOptions, SceneSource};
//!
//! let mut b = SceneBuilder::new("two boxes");
//! b.add_box(Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 5.0)); // in front
//! b.add_box(Vec3::new(-0.5, -0.5, 8.0), Vec3::new(0.5, 0.5, 9.0)); // hidden behind it
//! let scene = b.finish();
//! let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("camera");
//! let options = RvOptions { bins: (4, 4), ..RvOptions::default() };
//! let result = conservative_visible(&mut SceneSource::new(&scene), &cam, &options)
//!     .expect("fits the budget");
//! // The near face (z = 4) of the front box is visible, nothing of the box behind it.
//! let near_face = (0..12).filter(|&t| scene.triangle(t).iter().all(|p| p.z == 4.0));
//! assert!(near_face.clone().count() == 2);
//! assert!(near_face.into_iter().all(|t| result.visible.contains(t as usize)));
//! assert!((12..24).all(|t| !result.visible.contains(t)));
//! assert!(result.peak_memory_bytes <= options.memory_budget_bytes);
//! ```

mod city_stream;
mod cube_depth;
mod depth;
mod driver;
mod edge_map;
mod from_region;
mod frustum_cull;
mod fusion;
mod geometry_stage;
mod memory;
mod occluder;
mod occluder_index;
mod occluders;
mod occlusion_test;
mod overlap;
mod pass;
mod pipeline;
mod producer;
mod projection;
mod region_fusion;
mod region_sampler;
mod source;
mod test_hooks;
mod types;
mod visibility_stage;

use sightline_core::Camera;

pub use city_stream::StreamingCity;
pub use from_region::{
    conservative_from_region, RegionOptions, RegionResult, RegionStats, DEFAULT_FUSION_RESOLUTION,
    DEFAULT_FUSION_SPLITS, DEFAULT_MAX_OCCLUDERS, MAX_FUSION_RESOLUTION, MAX_FUSION_SPLITS,
    MAX_OCCLUDERS,
};
pub use region_sampler::{
    bake_sampler, bake_sampler_for_cells, BakeMethodError, ConservativeSampler, PortalCache,
    SceneCache, SolidFusion, BAKE_METHODS, CONSERVATIVE, REFUSED,
};
pub use source::{SceneSource, SourceTriangle, TriangleSource};
pub use types::{Guarantee, HiddenOccluders, RvError, RvOptions, RvResult, RvStats};

/// Computes a conservative visible set of `source`'s triangles from `camera` (see the module
/// documentation for the guarantee and the memory accounting).
///
/// The source is read by whichever geometry thread needs the next batch (one at a time), so it
/// must be `Send`.
pub fn conservative_visible(
    source: &mut (dyn TriangleSource + Send),
    camera: &Camera,
    options: &RvOptions,
) -> Result<RvResult, RvError> {
    driver::conservative_visible(source, camera, options)
}
