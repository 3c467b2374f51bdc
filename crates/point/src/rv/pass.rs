//! One streaming pass over the source through the sort-middle pipeline: geometry threads
//! (the caller and `geometry_threads - 1` helpers, `producer.rs`) project and bin the stream,
//! visibility workers ([`Pass::bin_worker`]) take bins from the queues (`pipeline.rs`) and run
//! the visibility stage on their triangles (`visibility_stage.rs`). The bins' occluder states
//! live beyond the pass, so a second pass (the re-test) sees the first one's occluders.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, sections 6.1 (megakernel: geometry and visibility work over bin queues) and 6.3
//! (a bin is processed by one worker at a time, its triangles in stream order).
//!
//! A panic in any thread stops all of them ([`AbortOnPanic`]) and reaches the caller as a
//! panic.

use std::sync::Mutex;

use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::TriangleSet;

use super::frustum_cull::FrustumCull;
use super::geometry_stage::BinGrid;
use super::memory::Pool;
use super::occluders::{BinState, Limits};
use super::overlap::Rect;
use super::pipeline::{AbortOnPanic, Scheduler, Work};
use super::producer::{self, GeometryContext, Produced, Producers, Scratch};
use super::projection::Projection;
use super::source::TriangleSource;
use super::test_hooks::TestHooks;
use super::types::{Guarantee, RvError, RvOptions};
use super::visibility_stage::{process, BinContext, StageStats};

/// What one streaming pass over the source shares (the bins' occluder states persist from
/// one pass to the next).
pub(crate) struct Pass<'a> {
    pub(crate) grid: &'a BinGrid,
    pub(crate) options: &'a RvOptions,
    pub(crate) proj: &'a Projection,
    pub(crate) cull: FrustumCull,
    pub(crate) margin: f64,
    pub(crate) limits: &'a Limits,
    pub(crate) max_entries: usize,
    pub(crate) states: &'a [Mutex<BinState>],
    pub(crate) pool: &'a Pool,
    pub(crate) hooks: TestHooks,
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
    pub(crate) fn run(
        &self,
        source: &mut (dyn TriangleSource + Send),
        visible: &AtomicTriangleSet,
        build: bool,
        only: Option<&TriangleSet>,
        settled: Option<&[Option<u32>]>,
    ) -> Result<(Produced, StageStats), RvError> {
        let options = self.options;
        let sched = Scheduler::new(self.grid, options.ring_batches, options.bin_threshold);
        let mut stage = StageStats::default();
        let producers = Producers::new(source);
        let gctx = GeometryContext {
            proj: self.proj,
            cull: &self.cull,
            grid: self.grid,
            margin: self.margin,
            options,
            max_entries: self.max_entries,
            sched: &sched,
            only,
            sort: options.sort_batches && build,
            settled: settled.map(|after| producer::Settled { after, visible }),
        };
        let mut produced = std::thread::scope(|scope| {
            let (sched, producers, gctx) = (&sched, &producers, &gctx);
            let workers: Vec<_> = (0..options.threads)
                .map(|_| scope.spawn(move || self.bin_worker(sched, producers, visible, build)))
                .collect();
            let helpers: Vec<_> = (1..options.geometry_threads)
                .map(|_| scope.spawn(move || self.geometry_thread(producers, gctx)))
                .collect();
            // The calling thread is a geometry thread too.
            let mut produced = self.geometry_thread(producers, gctx);
            // Held while joining: a panic re-raised here still stops the other threads.
            let stop_producers = || producers.abort();
            let guard = AbortOnPanic {
                sched,
                also: Some(&stop_producers),
            };
            for h in helpers {
                match h.join() {
                    Ok(p) => produced.add(&p),
                    Err(panic) => {
                        sched.finish_input();
                        std::panic::resume_unwind(panic)
                    }
                }
            }
            sched.finish_input();
            for w in workers {
                match w.join() {
                    Ok(st) => stage.add(&st),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
            drop(guard);
            produced
        });
        produced.ids_ascending = producers.ids_ascending();
        if let Some(e) = producers.into_error() {
            return Err(e);
        }
        Ok((produced, stage))
    }

    /// A geometry thread: reads, projects and bins batches until the stream ends (a panic
    /// stops the pipeline).
    fn geometry_thread(&self, producers: &Producers<'_>, gctx: &GeometryContext<'_>) -> Produced {
        let stop_producers = || producers.abort();
        let _guard = AbortOnPanic {
            sched: gctx.sched,
            also: Some(&stop_producers),
        };
        let mut scratch = Scratch::new(self.options, self.max_entries, self.grid.len());
        producer::run(producers, gctx, &mut scratch)
    }

    /// A visibility worker: takes the fullest ready bin from the queues and runs the
    /// visibility stage on its queued triangles, until the queues are done; returns its
    /// counters (a panic stops the pipeline).
    fn bin_worker(
        &self,
        sched: &Scheduler,
        producers: &Producers<'_>,
        visible: &AtomicTriangleSet,
        build: bool,
    ) -> StageStats {
        let stop_producers = || producers.abort();
        let _guard = AbortOnPanic {
            sched,
            also: Some(&stop_producers),
        };
        let mut st = StageStats::default();
        while let Some(work) = sched.take() {
            self.hooks.worker_took_work();
            self.process_bin(&work, visible, build, &mut st);
            sched.done(work);
        }
        st
    }

    /// Runs the visibility stage on the triangles `work` holds for its bin, in stream order,
    /// under the bin's lock.
    fn process_bin(
        &self,
        work: &Work,
        visible: &AtomicTriangleSet,
        build: bool,
        st: &mut StageStats,
    ) {
        let (options, margin) = (self.options, self.margin);
        let (x0, x1, y0, y1) = self.grid.rect(work.bin);
        let mut ctx = BinContext {
            proj: self.proj,
            planes: self
                .proj
                .rect_planes(x0 - margin, x1 + margin, y0 - margin, y1 + margin),
            bin_rect: Rect {
                min: glam::DVec2::new(x0 - margin, y0 - margin),
                max: glam::DVec2::new(x1 + margin, y1 + margin),
            },
            margin,
            area: options.guarantee == Guarantee::PositiveArea,
            limits: self.limits,
            pool: self.pool,
            visible,
            build,
            init: false,
            hidden: options.hidden_occluders,
        };
        let mut state = self.states[work.bin]
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // The thesis' initialization phase: the bin's first work item becomes occluders
        // untested (first pass only).
        ctx.init = options.init_phase && build && !state.initialized;
        state.initialized = true;
        for batch in &work.batches {
            let list = batch.bin(work.bin);
            for (i, &k) in list.iter().enumerate() {
                // A bin's triangles lie scattered over the batch: ask for the next one while
                // this one is processed.
                if let Some(&next) = list.get(i + 1) {
                    sightline_core::prefetch::prefetch(&batch.tris[next as usize]);
                }
                let before = state.changes;
                process(&batch.tris[k as usize], &ctx, &mut state, st);
                if state.changes != before {
                    state.changed_up_to = Some(batch.last_input_id);
                }
            }
        }
    }
}
