//! RV's driver: checks the options, sizes the memory budget, sets up the bins, streams the
//! source once building occluders ([`Pass::run`]) and, for a rewindable source, once more to
//! re-test what the first pass left visible against the final occluders; then gathers the
//! counters.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, chapters 4 (a single pass of the scene through the pipeline) and 6 (the memory of a
//! run: fixed ring and queues, a global occluder pool). The re-test pass is ours, beyond the
//! thesis (see `docs/DESIGN.md`).

use std::sync::Mutex;
use std::time::Instant;

use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::{Camera, TriangleSet};

use super::frustum_cull::FrustumCull;
use super::geometry_stage::{Batch, BinGrid};
use super::memory::Pool;
use super::occluders::{BinState, Limits};
use super::overlap::{Rect, MARGIN_PX};
use super::pass::Pass;
use super::producer::{Produced, Scratch};
use super::projection::Projection;
use super::source::TriangleSource;
use super::test_hooks::TestHooks;
use super::types::{RvError, RvOptions, RvResult, RvStats};
use super::visibility_stage::StageStats;

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

/// [`super::conservative_visible`].
pub(crate) fn conservative_visible(
    source: &mut (dyn TriangleSource + Send),
    camera: &Camera,
    options: &RvOptions,
) -> Result<RvResult, RvError> {
    visible(source, camera, options, TestHooks::NONE)
}

/// [`conservative_visible`], taking the paths `hooks` choose (see `test_hooks.rs`).
fn visible(
    source: &mut (dyn TriangleSource + Send),
    camera: &Camera,
    options: &RvOptions,
    hooks: TestHooks,
) -> Result<RvResult, RvError> {
    options.check()?;
    let start = Instant::now();
    let grid = BinGrid {
        nx: options.bins.0 as usize,
        ny: options.bins.1 as usize,
        width: f64::from(camera.width),
        height: f64::from(camera.height),
    };
    // A triangle can fall into every bin, so a batch must hold at least one full-screen one.
    let max_entries = (options.batch_triangles * 4).max(grid.len());
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
    let margin = MARGIN_PX;
    let limits = Limits {
        max_occluders: options.max_occluders_per_bin,
        max_edges: options.max_edges_per_bin,
        // An equal share of the bin per occluder (4 px² for 32 px bins and 256 occluders).
        min_evicting_area: (grid.width / grid.nx as f64) * (grid.height / grid.ny as f64)
            / options.max_occluders_per_bin.max(1) as f64,
    };
    let states = bin_states(&grid, margin, hooks.index_from());
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
        hooks,
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
        let (retested, retest) =
            retest_pass(&pass, source, &mut visible, bound, produced.ids_ascending)?;
        stats.retest_settled = retested.settled;
        // Occlusion counters are the re-test's; occluder counters stay the first pass's.
        stage.tested = retest.tested;
        stage.occluded = retest.occluded;
        stage.fused_occluded = retest.fused_occluded;
        stage.counters.silhouette_tests += retest.counters.silhouette_tests;
        stage.counters.triangle_tests += retest.counters.triangle_tests;
    }
    for s in &states {
        s.lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clear(&pool);
    }
    count(&mut stats, &produced, &stage);
    stats.seconds = start.elapsed().as_secs_f64();
    Ok(RvResult {
        visible,
        peak_memory_bytes: fixed + pool.peak(),
        stats,
    })
}

/// Empty bin states for `grid`, indexing their occluders from `index_from` of them on (never
/// with `None`).
fn bin_states(grid: &BinGrid, margin: f64, index_from: Option<usize>) -> Vec<Mutex<BinState>> {
    (0..grid.len())
        .map(|b| {
            let Some(from) = index_from else {
                return Mutex::new(BinState::default());
            };
            // The index covers the bin's region (the one its occludees are clipped to).
            let (x0, x1, y0, y1) = grid.rect(b);
            let area = Rect {
                min: glam::DVec2::new(x0 - margin, y0 - margin),
                max: glam::DVec2::new(x1 + margin, y1 + margin),
            };
            Mutex::new(BinState::indexed(&area, from))
        })
        .collect()
}

/// The re-test pass (beyond the thesis): streams the rewound `source` against the final
/// occluders and narrows `visible` (the first pass's set, ids below `bound`) to the triangles
/// it finds visible too. `ids_ascending` says whether the first pass's stream came in id
/// order. Returns the pass's geometry and visibility counters.
fn retest_pass(
    pass: &Pass<'_>,
    source: &mut (dyn TriangleSource + Send),
    visible: &mut TriangleSet,
    bound: u32,
    ids_ascending: bool,
) -> Result<(Produced, StageStats), RvError> {
    let retest_all = pass.hooks.retest_all();
    let second = AtomicTriangleSet::new(bound as usize);
    // Both passes are conservative, so is their intersection. (The re-test alone can keep a
    // triangle the first pass hid: an occluder that hid it may since have merged with one
    // whose silhouette edges now pass over it.) The re-test does not change the occluders, so
    // each triangle's outcome depends on that triangle alone: a triangle the first pass hid is
    // left out of the intersection whatever the re-test says, and is skipped before any
    // geometry work (most of a large scene: 95 % of the streamed city at street level).
    let only = (!retest_all).then_some(&*visible);
    // Where each bin's occluders last changed, in ids (meaningful when the stream is in id
    // order); the re-test of `retest_all` tests everything.
    let changed_up_to: Vec<Option<u32>> = pass
        .states
        .iter()
        .map(|s| {
            s.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .changed_up_to
        })
        .collect();
    let settled = (ids_ascending && !retest_all).then_some(&changed_up_to[..]);
    let counts = pass.run(source, &second, false, only, settled)?;
    if retest_all {
        let hidden_now: Vec<usize> = visible
            .ones()
            .filter(|&id| !second.contains(id as u32))
            .collect();
        for id in hidden_now {
            visible.set(id, false);
        }
    } else {
        // `second` holds only triangles of `visible`: it is the intersection (the first set
        // goes before the second is copied out, as the memory accounting counts two sets).
        drop(std::mem::take(visible));
        *visible = second.to_set();
    }
    Ok(counts)
}

/// Copies the passes' counters into `stats`.
fn count(stats: &mut RvStats, produced: &Produced, stage: &StageStats) {
    stats.triangles_streamed = produced.streamed;
    stats.triangles_on_screen = produced.on_screen;
    stats.bin_entries = produced.entries;
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
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use sightline_core::scene::SceneBuilder;

    use super::*;
    use crate::rv::city_stream::StreamingCity;
    use crate::rv::source::{SceneSource, SourceTriangle};
    use crate::rv::types::{Guarantee, HiddenOccluders};

    /// Runs `f` on a thread and fails the test if it has not finished within a minute.
    fn finishes_in_time<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(60))
            .expect("the pipeline hung after a thread panicked")
    }

    /// A source that panics on its fourth batch (in whichever geometry thread reads it), or,
    /// without `panics`, ends after its sixth.
    struct PanickingSource {
        batches: u32,
        panics: bool,
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
            if self.panics {
                assert!(self.batches < 4, "injected source panic");
            } else if self.batches > 6 {
                return Ok(0);
            }
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
        // One panic at a time, so that the one the caller sees is known: a worker's (the
        // source does not panic) or the source's.
        for (panic_in_worker, geometry_threads) in [(true, 1), (true, 2), (false, 1), (false, 2)] {
            let options = RvOptions {
                bins: (4, 4),
                threads: 2,
                geometry_threads,
                batch_triangles: 256,
                ring_batches: 2,
                ..RvOptions::default()
            };
            let hooks = TestHooks {
                panic_in_worker,
                ..TestHooks::NONE
            };
            let message = finishes_in_time(move || {
                let panic = std::panic::catch_unwind(move || {
                    let mut source = PanickingSource {
                        batches: 0,
                        panics: !panic_in_worker,
                    };
                    visible(&mut source, &cam, &options, hooks).is_ok()
                })
                .err()?;
                panic.downcast_ref::<&str>().map(|m| m.to_string())
            });
            let expected = if panic_in_worker {
                "injected worker panic"
            } else {
                "injected source panic"
            };
            assert_eq!(
                message.as_deref(),
                Some(expected),
                "{geometry_threads} geometry threads"
            );
        }
    }

    /// The re-test pass re-tests every triangle and intersects afterwards.
    const RETEST_ALL: TestHooks = TestHooks {
        retest_all: true,
        ..TestHooks::NONE
    };

    /// Bins never index their occluders.
    const LINEAR_SCANS: TestHooks = TestHooks {
        index_from: None,
        ..TestHooks::NONE
    };

    /// Bins index their occluders from `from` of them on.
    fn indexed_from(from: usize) -> TestHooks {
        TestHooks {
            index_from: Some(from),
            ..TestHooks::NONE
        }
    }

    /// Runs RV twice, re-testing only the first pass's visible triangles and re-testing all;
    /// asserts both give the same set and returns it.
    fn same_with_and_without_skipping(
        source: &mut (dyn TriangleSource + Send),
        cam: &Camera,
        options: &RvOptions,
    ) -> RvResult {
        let all = visible(source, cam, options, RETEST_ALL).expect("runs");
        source.rewind().expect("rewinds");
        let skipping = visible(source, cam, options, TestHooks::NONE).expect("runs");
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
        let linear = visible(source, cam, options, LINEAR_SCANS).expect("runs");
        source.rewind().expect("rewinds");
        // Indexed from the first occluder, and from a few (built while the bin fills).
        let mut last = None;
        for from in [0, 5] {
            let indexed = visible(source, cam, options, indexed_from(from)).expect("runs");
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

    fn camera(city: &StreamingCity) -> Camera {
        let h = city.half_extent();
        Camera::look_at(
            Vec3::new(-h, -h, 30.0),
            Vec3::ZERO,
            Vec3::Z,
            60.0,
            64,
            64,
            0.1,
        )
        .expect("camera")
    }

    #[test]
    fn more_geometry_threads_give_the_same_set() {
        let run = |g: usize| {
            let mut city = StreamingCity::new(2, 20_000);
            let cam = camera(&city);
            let o = RvOptions {
                geometry_threads: g,
                threads: 2,
                batch_triangles: 256,
                bins: (8, 8),
                ..RvOptions::default()
            };
            conservative_visible(&mut city, &cam, &o).expect("runs")
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(a.visible, b.visible);
        assert_eq!(a.stats.triangles_streamed, b.stats.triangles_streamed);
    }

    /// Yields one good batch, then an id past its bound.
    struct Bad(u32);

    impl TriangleSource for Bad {
        fn id_bound(&self) -> u32 {
            10
        }
        fn next_batch(
            &mut self,
            _max: usize,
            out: &mut Vec<SourceTriangle>,
        ) -> Result<usize, RvError> {
            self.0 += 1;
            let id = if self.0 == 1 { 0 } else { 99 };
            out.push(SourceTriangle {
                id,
                corners: [
                    Vec3::new(0.0, 0.0, 5.0),
                    Vec3::new(1.0, 0.0, 5.0),
                    Vec3::new(0.0, 1.0, 5.0),
                ],
            });
            Ok(1)
        }
    }

    #[test]
    fn bad_id_is_reported_with_several_threads() {
        let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 32, 32, 0.1).expect("cam");
        let o = RvOptions {
            geometry_threads: 3,
            bins: (2, 2),
            ..RvOptions::default()
        };
        let r = conservative_visible(&mut Bad(0), &cam, &o);
        assert_eq!(r.err(), Some(RvError::IdOutOfRange { id: 99, bound: 10 }));
    }
}
