//! RV: a conservative from-point visible set computed while the scene streams through, in a
//! fixed memory budget.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021 (master's thesis, TU Graz), chapters 4-6.
//!
//! The scene arrives as a [`TriangleSource`] (an in-memory [`SceneSource`], or a generator such
//! as [`StreamingCity`] that never materialises the scene). A sort-middle pipeline projects and
//! bins triangles into a grid of screen bins (geometry stage, `geometry_stage.rs`, on several
//! threads: `producer.rs`; runs of input triangles wholly outside the frustum are dropped by
//! their bounding box first, `frustum_cull.rs`), and worker
//! threads resolve visibility per bin (visibility stage, `visibility_stage.rs`): each bin keeps
//! occluders made of edge-connected visible triangles (`occluders.rs`), and a triangle is
//! occluded in a bin when it lies inside one occluder's silhouette and behind its triangles
//! (`occlusion_test.rs`). A triangle is visible when it is visible in any bin.
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
mod depth;
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
mod pipeline;
mod producer;
mod projection;
mod source;
mod visibility_stage;

use std::sync::Mutex;
use std::time::Instant;

use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::{Camera, TriangleSet};

pub use city_stream::StreamingCity;
pub use from_region::{conservative_from_region, RegionOptions, RegionResult, RegionStats};
pub use source::{SceneSource, SourceTriangle, TriangleSource};

use frustum_cull::FrustumCull;
use geometry_stage::{Batch, BinGrid};
use memory::Pool;
use occluders::{BinState, Limits};
use pipeline::{merge_stats, AbortOnPanic, Scheduler};
use producer::{GeometryContext, Producers, Scratch};
use projection::Projection;
use visibility_stage::{process, BinContext, StageStats};

/// Parameters of an RV run (the thesis' tunables; defaults suit 256-1024 px images).
#[derive(Clone, Debug, PartialEq)]
pub struct RvOptions {
    /// Heap bytes RV may use in all (see the module documentation).
    pub memory_budget_bytes: usize,
    /// Bins across and down the image.
    pub bins: (u32, u32),
    /// Visibility-stage worker threads.
    pub threads: usize,
    /// Geometry-stage threads (projection and binning; the calling thread is one of them).
    pub geometry_threads: usize,
    /// Triangles per input batch (and per projected batch).
    pub batch_triangles: usize,
    /// Projected batches alive at once (the triangle ring buffer).
    pub ring_batches: usize,
    /// Queued entries a bin needs before a worker takes it outside drain mode.
    pub bin_threshold: usize,
    /// Occluders per bin.
    pub max_occluders_per_bin: usize,
    /// Silhouette edges per bin.
    pub max_edges_per_bin: usize,
    /// Sort each batch front to back (by nearest view depth) before binning. The thesis
    /// (section 7.1.3) finds sorted input gives much smaller sets, as near occluders form
    /// first; sorting within a batch keeps the stream bounded.
    pub sort_batches: bool,
    /// After the stream, stream the scene once more and re-test every triangle the first pass
    /// left visible against the final occluders (beyond the thesis; needs a source that can
    /// [`TriangleSource::rewind`]). Triangles that arrived before their occluders existed are
    /// then found hidden, which an unsorted stream otherwise reports visible. The source is
    /// read twice, but triangles already hidden skip all geometry work (and a source may not
    /// even produce them: [`TriangleSource::next_wanted`]); the memory is the same.
    pub retest_pass: bool,
    /// What "visible" means for the guarantee (see [`Guarantee`]).
    pub guarantee: Guarantee,
    /// The thesis' initialization phase (section 6.3.4): the first work item of each bin is
    /// turned into occluders right away, marked visible without an occlusion test. Faster on
    /// scenes whose first triangles are good occluders, at the cost of overestimation (the
    /// thesis' figures 7.7 and 7.8); the re-test pass then removes most of that cost. Off by
    /// default, as in the thesis' comparisons.
    pub init_phase: bool,
    /// Whether triangles found hidden still join the occluders (beyond the thesis; see
    /// [`HiddenOccluders`]). Off by default: it costs time and, on unsorted streams, memory.
    pub hidden_occluders: HiddenOccluders,
}

/// Which hidden triangles become occluder parts. A hidden triangle is still a surface, so using
/// it as an occluder is as sound as using a visible one; it can connect visible patches into one
/// occluder whose silhouette covers more (a box face partly behind another box), which helps
/// most with the re-test pass. Measured in `docs/BENCHMARKS.md`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HiddenOccluders {
    /// Only visible triangles (the thesis).
    #[default]
    Never,
    /// Hidden triangles grow or merge existing occluders but never start one.
    Joining,
    /// Hidden triangles also start occluders (more occluders: slower, and on an unsorted
    /// stream far hidden ones can crowd out near ones until evicted).
    All,
}

/// The reference a conservative set never misses a triangle of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Guarantee {
    /// Every triangle with a visible region of positive area (the exact analytic set,
    /// `sightline_point::analytic`). A triangle that touches the visible part of the image only
    /// along a line or at a point — a back face meeting a closed object's silhouette along a
    /// shared edge — has no visible area and may be dropped.
    #[default]
    PositiveArea,
    /// Every triangle the reference rasterizer could show at any resolution: also those that
    /// win a pixel-centre depth tie on a shared silhouette edge (stricter, larger sets).
    AnySample,
}

impl Default for RvOptions {
    fn default() -> Self {
        Self {
            memory_budget_bytes: 256 << 20,
            bins: (32, 32),
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            geometry_threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            batch_triangles: 4096,
            ring_batches: 8,
            bin_threshold: 64,
            max_occluders_per_bin: 256,
            max_edges_per_bin: 8192,
            sort_batches: true,
            retest_pass: true,
            guarantee: Guarantee::PositiveArea,
            init_phase: false,
            hidden_occluders: HiddenOccluders::Never,
        }
    }
}

/// Counters of an RV run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RvStats {
    /// Triangles read from the source.
    pub triangles_streamed: u64,
    /// Triangles that survived projection (finite, non-degenerate, on screen).
    pub triangles_on_screen: u64,
    /// (triangle, bin) pairs queued.
    pub bin_entries: u64,
    /// (triangle, bin) pairs tested against occluders (after a re-test pass: the re-test's,
    /// which tests only the triangles the first pass left visible).
    pub bin_tests: u64,
    /// Of those, occluded in their bin.
    pub bin_occluded: u64,
    /// Occluders started, grown, and merges.
    pub occluders_created: u64,
    /// Triangles added to an existing occluder.
    pub occluders_grown: u64,
    /// Triangles that joined two or more occluders.
    pub occluder_merges: u64,
    /// Visible triangles not added to occluders because a pool was full.
    pub pool_full: u64,
    /// Triangle parts found occluded only by several occluders together (occluder fusion,
    /// `fusion.rs`; beyond the thesis).
    pub fused_occluded: u64,
    /// Silhouette and triangle tests run.
    pub silhouette_tests: u64,
    /// Triangle tests run (occludee inside a silhouette).
    pub triangle_tests: u64,
    /// Whether the re-test pass ran ([`RvOptions::retest_pass`] and a rewindable source).
    pub retested: bool,
    /// Triangles visible after the first pass (before the re-test pass).
    pub first_pass_visible: u64,
    /// Of those, triangles the re-test pass kept visible without testing them again: none of
    /// their bins' occluders changed after their first-pass test (only for streams in id
    /// order).
    pub retest_settled: u64,
    /// (triangle, bin) pairs the initialization phase accepted as occluders without a test
    /// ([`RvOptions::init_phase`]).
    pub init_accepted: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// The result of [`conservative_visible`].
#[derive(Clone, Debug)]
pub struct RvResult {
    /// The conservative visible set over ids `0..source.id_bound()`.
    pub visible: TriangleSet,
    /// Accounted peak heap bytes (always at most the budget).
    pub peak_memory_bytes: usize,
    /// Counters.
    pub stats: RvStats,
}

/// Why RV could not run.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum RvError {
    /// The budget does not cover the fixed parts plus a minimal occluder pool.
    #[error("memory budget of {budget} bytes is too small: RV needs at least {needed} bytes with these options (visible set, batch ring, bin queues and a minimal occluder pool)")]
    BudgetTooSmall {
        /// The budget given.
        budget: usize,
        /// The least budget that works with these options.
        needed: usize,
    },
    /// An option is out of range.
    #[error("bad RV option: {0}")]
    BadOption(String),
    /// The source yielded an id at or above its own id bound.
    #[error("triangle id {id} is not below the source's id bound {bound}")]
    IdOutOfRange {
        /// The id.
        id: u32,
        /// The source's bound.
        bound: u32,
    },
    /// The source failed.
    #[error("triangle source failed: {0}")]
    Source(String),
}

/// Smallest occluder pool worth running with.
const MIN_OCCLUDER_POOL: usize = 64 << 10;
/// Allowance for small allocations not tracked individually (thread handles, scheduler
/// bookkeeping, merge scratch).
const SLACK: usize = 64 << 10;

/// The fixed (non-pool) bytes of a run.
fn fixed_bytes(options: &RvOptions, id_bound: u32, max_entries: usize) -> usize {
    let bins = options.bins.0 as usize * options.bins.1 as usize;
    let bitset = (id_bound as usize).div_ceil(64) * 8;
    let batch = Batch::bytes_for(options.batch_triangles, max_entries, bins);
    2 * bitset
        // Per geometry thread: input, pairs, bins, the batch it fills, the sealed batch it holds
        // while waiting for a slot or its turn, and sorting scratch.
        + options.geometry_threads * Scratch::bytes_for(options, max_entries, bins)
        // The ring of queued batches.
        + options.ring_batches * batch
        // Bin queues (deque of batch pointers, counters) and bin states.
        + bins * (64 + options.ring_batches * 8)
        + bins * (std::mem::size_of::<Mutex<BinState>>() + 8)
        + (options.threads + options.geometry_threads) * 1024
        + SLACK
}

fn check(options: &RvOptions) -> Result<(), RvError> {
    let (bx, by) = options.bins;
    if bx == 0 || by == 0 || bx as usize * by as usize > 1 << 16 {
        return Err(RvError::BadOption(format!(
            "bins {bx}x{by}: need 1..=65536 bins"
        )));
    }
    if options.threads == 0 || options.geometry_threads == 0 {
        return Err(RvError::BadOption(
            "threads and geometry_threads must be at least 1".into(),
        ));
    }
    if options.batch_triangles == 0 || options.ring_batches == 0 {
        return Err(RvError::BadOption(
            "batch_triangles and ring_batches must be at least 1".into(),
        ));
    }
    Ok(())
}

/// What one streaming pass over the source shares (the bins' occluder states persist from
/// one pass to the next).
struct Pass<'a> {
    grid: &'a BinGrid,
    options: &'a RvOptions,
    proj: &'a Projection,
    cull: FrustumCull,
    margin: f64,
    limits: &'a Limits,
    max_entries: usize,
    states: &'a [Mutex<BinState>],
    pool: &'a Pool,
}

impl Pass<'_> {
    /// Streams `source` once through the sort-middle pipeline, marking visible triangles in
    /// `visible`; with `build`, visible triangles also grow the occluders (the thesis' single
    /// pass), without it they are only tested against the occluders as they stand.
    ///
    /// With `only`, triangles outside that set are read but skip all further work (their
    /// bits in `visible` stay clear).
    ///
    /// With `settled` (the re-test pass over a stream in id order), triangles none of whose
    /// bins changed after their first-pass test are marked visible untested
    /// (`producer::Settled`).
    fn run(
        &self,
        source: &mut (dyn TriangleSource + Send),
        visible: &AtomicTriangleSet,
        build: bool,
        only: Option<&TriangleSet>,
        settled: Option<&[Option<u32>]>,
    ) -> Result<(producer::Produced, StageStats), RvError> {
        let (grid, options, margin) = (self.grid, self.options, self.margin);
        let n_bins = grid.len();
        let sched = Scheduler::new(grid, options.ring_batches, options.bin_threshold);
        let mut stage = StageStats::default();
        let producers = Producers::new(source);
        let gctx = GeometryContext {
            proj: self.proj,
            cull: &self.cull,
            grid,
            margin,
            options,
            max_entries: self.max_entries,
            sched: &sched,
            only,
            sort: options.sort_batches && build,
            settled: settled.map(|after| producer::Settled { after, visible }),
        };
        let produced = std::thread::scope(|scope| {
            let workers: Vec<_> = (0..options.threads)
                .map(|_| {
                    let (sched, states, pool, limits, proj) =
                        (&sched, self.states, self.pool, self.limits, self.proj);
                    let producers = &producers;
                    scope.spawn(move || {
                        let stop_producers = || producers.abort();
                        let _guard = AbortOnPanic {
                            sched,
                            also: Some(&stop_producers),
                        };
                        let mut st = StageStats::default();
                        while let Some(work) = sched.take() {
                            #[cfg(test)]
                            if options.batch_triangles == tests::PANIC_BATCH {
                                panic!("injected worker panic");
                            }
                            let (x0, x1, y0, y1) = grid.rect(work.bin);
                            let ctx = BinContext {
                                proj,
                                planes: proj.rect_planes(
                                    x0 - margin,
                                    x1 + margin,
                                    y0 - margin,
                                    y1 + margin,
                                ),
                                bin_rect: overlap::Rect {
                                    min: glam::DVec2::new(x0 - margin, y0 - margin),
                                    max: glam::DVec2::new(x1 + margin, y1 + margin),
                                },
                                margin,
                                area: options.guarantee == Guarantee::PositiveArea,
                                limits,
                                pool,
                                visible,
                                build,
                                init: false,
                                hidden: options.hidden_occluders,
                            };
                            {
                                let mut state = states[work.bin]
                                    .lock()
                                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                                // The thesis' initialization phase: the bin's first work
                                // item becomes occluders untested (first pass only).
                                let mut ctx = ctx;
                                ctx.init = options.init_phase && build && !state.initialized;
                                state.initialized = true;
                                for batch in &work.batches {
                                    let list = batch.bin(work.bin);
                                    for (i, &k) in list.iter().enumerate() {
                                        // A bin's triangles lie scattered over the batch: ask
                                        // for the next one while this one is processed.
                                        if let Some(&next) = list.get(i + 1) {
                                            sightline_core::prefetch::prefetch(
                                                &batch.tris[next as usize],
                                            );
                                        }
                                        let before = state.changes;
                                        process(&batch.tris[k as usize], &ctx, &mut state, &mut st);
                                        if state.changes != before {
                                            state.changed_up_to = Some(batch.last_input_id);
                                        }
                                    }
                                }
                            }
                            sched.done(work);
                        }
                        st
                    })
                })
                .collect();
            let helpers: Vec<_> = (1..options.geometry_threads)
                .map(|_| {
                    let (producers, gctx) = (&producers, &gctx);
                    scope.spawn(move || {
                        let stop_producers = || producers.abort();
                        let _guard = AbortOnPanic {
                            sched: gctx.sched,
                            also: Some(&stop_producers),
                        };
                        let mut scratch = Scratch::new(options, self.max_entries, n_bins);
                        producer::run(producers, gctx, &mut scratch)
                    })
                })
                .collect();
            let stop_producers = || producers.abort();
            let guard = AbortOnPanic {
                sched: &sched,
                also: Some(&stop_producers),
            };
            let mut scratch = Scratch::new(options, self.max_entries, n_bins);
            let mut produced = producer::run(&producers, &gctx, &mut scratch);
            drop(scratch);
            for h in helpers {
                match h.join() {
                    Ok(p) => {
                        produced.streamed += p.streamed;
                        produced.on_screen += p.on_screen;
                        produced.entries += p.entries;
                        produced.settled += p.settled;
                    }
                    Err(panic) => {
                        sched.finish_input();
                        std::panic::resume_unwind(panic)
                    }
                }
            }
            sched.finish_input();
            for w in workers {
                match w.join() {
                    Ok(st) => merge_stats(&mut stage, &st),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
            drop(guard);
            produced
        });
        let mut produced = produced;
        produced.ids_ascending = producers.ids_ascending();
        if let Some(e) = producers.into_error() {
            return Err(e);
        }
        Ok((produced, stage))
    }
}

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
    visible_with(source, camera, options, false, Some(INDEX_FROM))
}

/// Occluders a bin must have before it indexes them (`occluder_index.rs`): fewer are scanned
/// as fast without the index's upkeep.
const INDEX_FROM: usize = 32;

/// [`conservative_visible`]; with `retest_all`, the re-test pass re-tests every triangle and
/// intersects (the earlier behaviour, kept to check that skipping gives the same set); bins
/// index their occluders once they have `index_from` of them, or never (scanning them all, kept
/// to check that the index gives the same set).
fn visible_with(
    source: &mut (dyn TriangleSource + Send),
    camera: &Camera,
    options: &RvOptions,
    retest_all: bool,
    index_from: Option<usize>,
) -> Result<RvResult, RvError> {
    check(options)?;
    let start = Instant::now();
    let grid = BinGrid {
        nx: options.bins.0 as usize,
        ny: options.bins.1 as usize,
        width: f64::from(camera.width),
        height: f64::from(camera.height),
    };
    let n_bins = grid.len();
    // A triangle can fall into every bin, so a batch must hold at least one full-screen one.
    let max_entries = (options.batch_triangles * 4).max(n_bins);
    let bound = source.id_bound();
    let fixed = fixed_bytes(options, bound, max_entries);
    let needed = fixed + MIN_OCCLUDER_POOL;
    if options.memory_budget_bytes < needed {
        return Err(RvError::BudgetTooSmall {
            budget: options.memory_budget_bytes,
            needed,
        });
    }
    let pool = Pool::new(options.memory_budget_bytes - fixed);
    let proj = Projection::new(camera);
    let margin = overlap::MARGIN_PX;
    let limits = Limits {
        max_occluders: options.max_occluders_per_bin,
        max_edges: options.max_edges_per_bin,
        // An equal share of the bin per occluder (4 px² for 32 px bins and 256 occluders).
        min_evicting_area: (grid.width / grid.nx as f64) * (grid.height / grid.ny as f64)
            / options.max_occluders_per_bin.max(1) as f64,
    };
    let states: Vec<Mutex<BinState>> = (0..n_bins)
        .map(|b| {
            let Some(from) = index_from else {
                return Mutex::new(BinState::default());
            };
            // The index covers the bin's region (the one its occludees are clipped to).
            let (x0, x1, y0, y1) = grid.rect(b);
            let area = overlap::Rect {
                min: glam::DVec2::new(x0 - margin, y0 - margin),
                max: glam::DVec2::new(x1 + margin, y1 + margin),
            };
            Mutex::new(BinState::indexed(&area, from))
        })
        .collect();
    let pass = Pass {
        grid: &grid,
        options,
        proj: &proj,
        cull: FrustumCull::new(&proj, margin),
        margin,
        limits: &limits,
        max_entries,
        states: &states,
        pool: &pool,
    };
    let mut stats = RvStats::default();
    let first = AtomicTriangleSet::new(bound as usize);
    let (produced, mut stage) = pass.run(source, &first, true, None, None)?;
    stats.first_pass_visible = first.count() as u64;
    // The memory accounting's two bitsets: the concurrent set being filled and the returned
    // set (here the first pass's result, narrowed by the re-test).
    let mut visible = first.to_set();
    drop(first);
    if options.retest_pass && source.rewind()? {
        stats.retested = true;
        let second = AtomicTriangleSet::new(bound as usize);
        // Both passes are conservative, so is their intersection. (The re-test alone can
        // keep a triangle the first pass hid: an occluder that hid it may since have merged
        // with one whose silhouette edges now pass over it.) The re-test does not change the
        // occluders, so each triangle's outcome depends on that triangle alone: a triangle
        // the first pass hid is left out of the intersection whatever the re-test says, and
        // is skipped before any geometry work (most of a large scene: 95 % of the streamed
        // city at street level).
        let only = (!retest_all).then_some(&visible);
        // Where each bin's occluders last changed, in ids (meaningful when the stream is in
        // id order); the re-test of `retest_all` tests everything.
        let changed_up_to: Vec<Option<u32>> = states
            .iter()
            .map(|s| {
                s.lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner)
                    .changed_up_to
            })
            .collect();
        let settled = (produced.ids_ascending && !retest_all).then_some(&changed_up_to[..]);
        let (retested, retest) = pass.run(source, &second, false, only, settled)?;
        stats.retest_settled = retested.settled;
        if retest_all {
            let hidden_now: Vec<usize> = visible
                .ones()
                .filter(|&id| !second.contains(id as u32))
                .collect();
            for id in hidden_now {
                visible.set(id, false);
            }
        } else {
            // `second` holds only triangles of `visible`: it is the intersection.
            drop(visible);
            visible = second.to_set();
        }
        // Occlusion counters are the re-test's; occluder counters stay the first pass's.
        stage.tested = retest.tested;
        stage.occluded = retest.occluded;
        stage.fused_occluded = retest.fused_occluded;
        stage.counters.silhouette_tests += retest.counters.silhouette_tests;
        stage.counters.triangle_tests += retest.counters.triangle_tests;
    }
    let (streamed, on_screen, entries) = (produced.streamed, produced.on_screen, produced.entries);
    for s in &states {
        s.lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clear(&pool);
    }
    stats.triangles_streamed = streamed;
    stats.triangles_on_screen = on_screen;
    stats.bin_entries = entries;
    stats.bin_tests = stage.tested;
    stats.bin_occluded = stage.occluded;
    stats.occluders_created = stage.occluders_created;
    stats.occluders_grown = stage.occluders_grown;
    stats.occluder_merges = stage.occluder_merges;
    stats.pool_full = stage.pool_full;
    stats.fused_occluded = stage.fused_occluded;
    stats.init_accepted = stage.init_accepted;
    stats.silhouette_tests = stage.counters.silhouette_tests;
    stats.triangle_tests = stage.counters.triangle_tests;
    stats.seconds = start.elapsed().as_secs_f64();
    Ok(RvResult {
        visible,
        peak_memory_bytes: fixed + pool.peak(),
        stats,
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use sightline_core::scene::SceneBuilder;

    use super::*;

    /// `batch_triangles` value that makes a worker panic (test builds only).
    pub(super) const PANIC_BATCH: usize = 7777;

    /// Runs `f` on a thread and fails the test if it has not finished within a minute.
    fn finishes_in_time<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(60))
            .expect("the pipeline hung after a thread panicked")
    }

    /// A source that panics on its fourth batch (in whichever geometry thread reads it).
    struct PanickingSource {
        batches: u32,
    }

    impl TriangleSource for PanickingSource {
        fn id_bound(&self) -> u32 {
            1 << 20
        }

        fn next_batch(
            &mut self,
            max: usize,
            out: &mut Vec<SourceTriangle>,
        ) -> Result<usize, RvError> {
            self.batches += 1;
            assert!(self.batches < 4, "injected source panic");
            let base = (self.batches - 1) * max as u32;
            for i in 0..max as u32 {
                let x = (i % 64) as f32 * 0.1 - 3.0;
                let y = (i / 64 % 64) as f32 * 0.1 - 3.0;
                let z = 5.0 + (i / 4096) as f32;
                out.push(SourceTriangle {
                    id: base + i,
                    corners: [
                        Vec3::new(x, y, z),
                        Vec3::new(x + 0.1, y, z),
                        Vec3::new(x, y + 0.1, z),
                    ],
                });
            }
            Ok(max)
        }

        fn rewind(&mut self) -> Result<bool, RvError> {
            Ok(false)
        }
    }

    /// A panic in a visibility worker or in a geometry thread (here, inside the source) must
    /// reach the caller as a panic, never leave the other threads waiting forever.
    #[test]
    fn a_panicking_thread_stops_the_pipeline() {
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("cam");
        for (batch, geometry_threads) in [(PANIC_BATCH, 1), (PANIC_BATCH, 2), (256, 1), (256, 2)] {
            let options = RvOptions {
                bins: (4, 4),
                threads: 2,
                geometry_threads,
                batch_triangles: batch,
                ring_batches: 2,
                ..RvOptions::default()
            };
            let outcome = finishes_in_time(move || {
                std::panic::catch_unwind(move || {
                    let mut source = PanickingSource { batches: 0 };
                    conservative_visible(&mut source, &cam, &options).is_ok()
                })
                .is_err()
            });
            assert!(
                outcome,
                "batch {batch}, {geometry_threads} geometry threads: no panic"
            );
        }
    }

    /// Runs RV twice, re-testing only the first pass's visible triangles and re-testing all;
    /// asserts both give the same set and returns it.
    fn same_with_and_without_skipping(
        source: &mut (dyn TriangleSource + Send),
        cam: &Camera,
        options: &RvOptions,
    ) -> RvResult {
        let all = visible_with(source, cam, options, true, Some(INDEX_FROM)).expect("runs");
        source.rewind().expect("rewinds");
        let skipping = visible_with(source, cam, options, false, Some(INDEX_FROM)).expect("runs");
        assert!(skipping.stats.retested && all.stats.retested);
        if skipping.visible != all.visible {
            let a: Vec<usize> = all.visible.ones().collect();
            let b: Vec<usize> = skipping.visible.ones().collect();
            eprintln!(
                "all {a:?}\nskipping {b:?}\nsettled {} first {} {}",
                skipping.stats.retest_settled,
                skipping.stats.first_pass_visible,
                all.stats.first_pass_visible
            );
        }
        assert_eq!(skipping.visible, all.visible);
        assert_eq!(
            skipping.stats.first_pass_visible,
            all.stats.first_pass_visible
        );
        assert_eq!(
            skipping.stats.triangles_streamed,
            all.stats.triangles_streamed
        );
        skipping
    }

    #[test]
    fn retest_skipping_hidden_matches_retesting_all_streamed_city() {
        // Street level in a city whose far blocks stream before the near walls.
        let eye = Vec3::new(-6.0, -6.0, 2.0);
        let cam = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 128, 128, 0.1).expect("cam");
        for guarantee in [Guarantee::PositiveArea, Guarantee::AnySample] {
            let options = RvOptions {
                bins: (8, 8),
                threads: 2,
                geometry_threads: 2,
                batch_triangles: 512,
                guarantee,
                ..RvOptions::default()
            };
            let mut city = StreamingCity::new(1, 40_000);
            let r = same_with_and_without_skipping(&mut city, &cam, &options);
            // The re-test must have hidden something, or the comparison proves nothing.
            assert!(
                (r.visible.count_ones(..) as u64) < r.stats.first_pass_visible,
                "re-test hid nothing: {} of {}",
                r.visible.count_ones(..),
                r.stats.first_pass_visible
            );
        }
    }

    #[test]
    fn settled_bins_skip_retests_and_keep_the_set_aerial_city() {
        // Over the city, with few occluders per bin: bins fill, and the visible roofs that
        // arrive after the last change of their bins (later roofs cannot join a full bin
        // unless nearer) are kept untested.
        let mut city = StreamingCity::new(1, 40_000);
        let h = city.half_extent();
        let cam = Camera::look_at(
            Vec3::new(-h, -h, 120.0),
            Vec3::ZERO,
            Vec3::Z,
            60.0,
            128,
            128,
            0.1,
        )
        .expect("cam");
        for guarantee in [Guarantee::PositiveArea, Guarantee::AnySample] {
            let options = RvOptions {
                bins: (8, 8),
                threads: 2,
                geometry_threads: 2,
                batch_triangles: 512,
                max_occluders_per_bin: 8,
                guarantee,
                ..RvOptions::default()
            };
            city.rewind().expect("rewinds");
            let r = same_with_and_without_skipping(&mut city, &cam, &options);
            assert!(
                r.stats.retest_settled > r.stats.first_pass_visible / 4,
                "{} of {} re-tests skipped",
                r.stats.retest_settled,
                r.stats.first_pass_visible
            );
        }
    }

    /// A stream whose ids do not come in ascending order (the scene read back to front).
    struct Reversed<'a>(SceneSource<'a>, &'a sightline_core::Scene);

    impl TriangleSource for Reversed<'_> {
        fn id_bound(&self) -> u32 {
            self.0.id_bound()
        }
        fn next_batch(
            &mut self,
            max: usize,
            out: &mut Vec<SourceTriangle>,
        ) -> Result<usize, RvError> {
            let start = out.len();
            let n = self.0.next_batch(max, out)?;
            let bound = self.id_bound();
            for t in &mut out[start..] {
                t.id = bound - 1 - t.id;
                t.corners = self.1.triangle(t.id);
            }
            Ok(n)
        }
        fn rewind(&mut self) -> Result<bool, RvError> {
            self.0.rewind()
        }
    }

    #[test]
    fn no_retest_is_skipped_when_ids_are_not_in_stream_order() {
        let scene = far_boxes_then_wall();
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("cam");
        let options = RvOptions {
            bins: (4, 4),
            batch_triangles: 16,
            ..RvOptions::default()
        };
        let mut ordered = SceneSource::new(&scene);
        let forward = same_with_and_without_skipping(&mut ordered, &cam, &options);
        let mut reversed = Reversed(SceneSource::new(&scene), &scene);
        let backward = same_with_and_without_skipping(&mut reversed, &cam, &options);
        assert_eq!(backward.stats.retest_settled, 0);
        // The wall (last in id order) streams first backwards: the boxes are hidden in pass 1.
        assert!(backward.stats.first_pass_visible < forward.stats.first_pass_visible);
    }

    /// Runs RV with the occluder index and with linear scans; asserts the same visible sets
    /// and occluder histories.
    fn same_with_and_without_index(
        source: &mut (dyn TriangleSource + Send),
        cam: &Camera,
        options: &RvOptions,
    ) -> RvResult {
        let linear = visible_with(source, cam, options, false, None).expect("runs");
        source.rewind().expect("rewinds");
        // Indexed from the first occluder, and from a few (built while the bin fills).
        let mut last = None;
        for from in [0, 5] {
            let indexed = visible_with(source, cam, options, false, Some(from)).expect("runs");
            source.rewind().expect("rewinds");
            same_result(&indexed, &linear);
            last = Some(indexed);
        }
        last.expect("ran")
    }

    fn same_result(indexed: &RvResult, linear: &RvResult) {
        let (a, b) = (&indexed.stats, &linear.stats);
        assert_eq!(indexed.visible, linear.visible);
        assert_eq!(a.first_pass_visible, b.first_pass_visible);
        assert_eq!(
            (a.occluders_created, a.occluders_grown, a.occluder_merges),
            (b.occluders_created, b.occluders_grown, b.occluder_merges)
        );
        assert_eq!(
            (a.bin_tests, a.bin_occluded, a.fused_occluded, a.pool_full),
            (b.bin_tests, b.bin_occluded, b.fused_occluded, b.pool_full)
        );
    }

    /// Every guarantee, with and without hidden occluders, single pass and with the re-test.
    fn index_variants(base: &RvOptions) -> Vec<RvOptions> {
        let mut v = Vec::new();
        for guarantee in [Guarantee::PositiveArea, Guarantee::AnySample] {
            for hidden_occluders in [HiddenOccluders::Never, HiddenOccluders::All] {
                for retest_pass in [false, true] {
                    v.push(RvOptions {
                        guarantee,
                        hidden_occluders,
                        retest_pass,
                        ..base.clone()
                    });
                }
            }
        }
        v
    }

    #[test]
    fn occluder_index_matches_linear_scan_streamed_city() {
        let eye = Vec3::new(-6.0, -6.0, 2.0);
        let cam = Camera::look_at(eye, eye + Vec3::X, Vec3::Z, 60.0, 128, 128, 0.1).expect("cam");
        let base = RvOptions {
            bins: (4, 4),
            threads: 2,
            geometry_threads: 2,
            batch_triangles: 512,
            ..RvOptions::default()
        };
        for options in index_variants(&base) {
            let mut city = StreamingCity::new(1, 20_000);
            let r = same_with_and_without_index(&mut city, &cam, &options);
            // Occluders merged and hid triangles, or the comparison proves little.
            assert!(r.stats.occluder_merges > 0 && r.stats.bin_occluded > 0);
        }
    }

    #[test]
    fn occluder_index_matches_linear_scan_scenes() {
        // Rows of small boxes receding from the camera (many small occluders per bin), and a
        // few large boxes hiding and overlapping each other (occluders spanning many cells).
        let mut rows = SceneBuilder::new("rows of boxes");
        for i in 0..12 {
            for j in 0..5 {
                let (x, z) = (-2.0 + j as f32, 2.0 + 1.5 * i as f32);
                rows.add_box(Vec3::new(x, -1.0, z), Vec3::new(x + 0.6, -0.2, z + 0.6));
            }
        }
        let mut big = SceneBuilder::new("overlapping boxes");
        for i in 0..6 {
            let f = i as f32;
            big.add_box(
                Vec3::new(-3.0 + 0.7 * f, -1.5 + 0.3 * f, 3.0 + f),
                Vec3::new(-1.0 + 0.9 * f, 1.0 + 0.2 * f, 3.5 + 1.3 * f),
            );
        }
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 96, 96, 0.1).expect("cam");
        for (name, scene) in [("rows", rows.finish()), ("big", big.finish())] {
            for sort_batches in [true, false] {
                let base = RvOptions {
                    bins: (3, 3),
                    threads: 2,
                    geometry_threads: 1,
                    batch_triangles: 16,
                    sort_batches,
                    ..RvOptions::default()
                };
                for options in index_variants(&base) {
                    let r =
                        same_with_and_without_index(&mut SceneSource::new(&scene), &cam, &options);
                    assert!(r.stats.bin_occluded > 0, "{name}: nothing hidden");
                }
            }
        }
    }

    /// Four boxes (ids 0..48), then a wall in front of them (ids 48..60), seen from the origin
    /// along +z.
    fn far_boxes_then_wall() -> sightline_core::Scene {
        let mut b = SceneBuilder::new("far boxes, then a wall");
        for i in 0..4 {
            let x = -1.5 + i as f32;
            b.add_box(Vec3::new(x, -0.4, 8.0), Vec3::new(x + 0.8, 0.4, 9.0));
        }
        b.add_box(Vec3::new(-3.0, -2.0, 4.0), Vec3::new(3.0, 2.0, 4.5));
        b.finish()
    }

    #[test]
    fn retest_skipping_hidden_matches_retesting_all_small_scene() {
        // Far boxes first, the wall hiding them last, unsorted: only the re-test hides them.
        let scene = far_boxes_then_wall();
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 64, 0.1).expect("cam");
        let options = RvOptions {
            bins: (4, 4),
            threads: 2,
            geometry_threads: 1,
            batch_triangles: 8,
            sort_batches: false,
            ..RvOptions::default()
        };
        let r = same_with_and_without_skipping(&mut SceneSource::new(&scene), &cam, &options);
        assert!((r.visible.count_ones(..) as u64) < r.stats.first_pass_visible);
        // The wall's front face (the last box's -z face) stays visible.
        assert!(r.visible.count_ones(48..) > 0);
    }
}
