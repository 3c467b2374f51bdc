//! [`CellBatchingCaster`]: casts the rays of several concurrent callers (the cells of a
//! many-cell bake) as one batch, so a GPU caster gets batches large enough to keep it busy.
//!
//! Why: a GVS++ cell casts in batches (of at most 16,384 rays, each of one kind: random, border,
//! reverse or neighbour sampling; with `fixed_rounds`, the paper's rounds, whose exploration
//! steps of a small cell are a few thousand rays of border sampling, a few hundred of reverse
//! sampling). Cast alone, each batch is one GPU submission with its fixed cost (upload,
//! dispatch, fence wait, readback) and the GPU idles while the cell prepares its next one. Here many cells run at once (a pool of
//! [`CellBatchingOptions::cells`] threads, [`CellBatchingCaster::install`]) and their calls
//! meet in one queue; a dispatcher thread concatenates the pending calls and casts them with
//! the inner caster in one call, then hands each caller its slice of the hits.
//!
//! Results: every ray's hit is the inner caster's hit for that ray, whatever it was batched
//! with (the GPU caster's hits do not depend on the batch: `ray_cast.rs`), and each cell's rays
//! depend only on its seed and its own hits (`sightline_region::bake`), so a batched bake
//! gives the per-cell bake's sets exactly.
//!
//! When to dispatch: as soon as as many calls are pending as went into the last batch (the
//! cells that are baking come back with their next batch), or
//! [`CellBatchingOptions::max_rays`] rays are pending, or the oldest pending call has waited
//! [`CellBatchingOptions::linger`] (a cell that finished or is still preparing its batch does
//! not hold the others longer than that). The first batch waits for `cells` calls.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, section 4 (the rounds whose
//! rays are gathered) and section 6 (its GPU casts rounds of 10^7 rays).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use sightline_core::trace::RayCaster;
use sightline_core::{Hit, Ray};

use crate::device::GpuError;

/// How a [`CellBatchingCaster`] gathers calls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CellBatchingOptions {
    /// Callers (cells) run at once by [`CellBatchingCaster::install`], and the calls the
    /// first batch waits for. At least 1; 1 gathers nothing (each call is its own batch).
    pub cells: usize,
    /// Pending rays at which a batch goes at once.
    pub max_rays: usize,
    /// Longest wait of a pending call for others to join it.
    pub linger: Duration,
}

impl Default for CellBatchingOptions {
    /// 16 cells, batches of up to 4M rays (four of the GPU caster's default chunks), 20 ms
    /// linger: on lavapipe (2 cores) a small cell's CPU work between two of its rounds (finding
    /// new triangles, generating the next rays) takes up to a few ms per cell, and 16 cells share
    /// the cores, so the last of them returns within about 20 ms of the first.
    fn default() -> Self {
        Self {
            cells: 16,
            max_rays: 1 << 22,
            linger: Duration::from_millis(20),
        }
    }
}

/// What a [`CellBatchingCaster`] has done: calls gathered and batches cast.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CellBatchingStats {
    /// Calls of [`RayCaster::cast`] (with at least one ray).
    pub calls: u64,
    /// Batches given to the inner caster.
    pub batches: u64,
    /// Rays cast.
    pub rays: u64,
}

/// One caller's rays and where its hits go.
struct Request {
    rays: Vec<Ray>,
    reply: mpsc::SyncSender<Vec<Hit>>,
}

/// The queue the callers and the dispatcher share.
#[derive(Default)]
struct Queue {
    pending: Vec<Request>,
    pending_rays: usize,
    /// When the oldest pending call arrived.
    oldest: Option<Instant>,
    /// Calls the next batch waits for: the size of the last batch.
    expected: usize,
    /// The inner caster panicked: later calls fail at once.
    failed: bool,
    shutdown: bool,
}

struct Shared {
    queue: Mutex<Queue>,
    arrived: Condvar,
    batches: AtomicU64,
    calls: AtomicU64,
    rays: AtomicU64,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A [`RayCaster`] that gathers the closest-hit calls of concurrent callers into batches for an
/// inner caster (see the module documentation). Any-hit calls ([`RayCaster::occluded`]) go to
/// the inner caster directly: GVS++ casts closest hits only.
pub struct CellBatchingCaster {
    inner: Arc<dyn RayCaster>,
    shared: Arc<Shared>,
    dispatcher: Option<JoinHandle<()>>,
    /// The threads that run the cells ([`Self::install`]).
    cells: rayon::ThreadPool,
}

impl CellBatchingCaster {
    /// Gathers calls for `inner`. Starts the dispatcher thread, with its own thread pool for
    /// the inner caster's parallel work (the cells' threads wait on their hits, so that work
    /// cannot run on them), and the pool of `options.cells` threads for the cells.
    pub fn new(inner: Arc<dyn RayCaster>, options: CellBatchingOptions) -> Result<Self, GpuError> {
        if options.cells == 0 {
            return Err(GpuError::ZeroCells);
        }
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue {
                expected: options.cells,
                ..Queue::default()
            }),
            arrived: Condvar::new(),
            batches: AtomicU64::new(0),
            calls: AtomicU64::new(0),
            rays: AtomicU64::new(0),
        });
        let thread_error = |e: std::io::Error| GpuError::Threads(e.to_string());
        let cells = rayon::ThreadPoolBuilder::new()
            .num_threads(options.cells)
            .thread_name(|i| format!("sightline-cell-{i}"))
            .build()
            .map_err(|e| GpuError::Threads(e.to_string()))?;
        let work = rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("sightline-dispatch-{i}"))
            .build()
            .map_err(|e| GpuError::Threads(e.to_string()))?;
        let dispatcher = {
            let (shared, inner) = (shared.clone(), inner.clone());
            std::thread::Builder::new()
                .name("sightline-dispatcher".into())
                .spawn(move || dispatch_loop(&shared, inner.as_ref(), &work, options))
                .map_err(thread_error)?
        };
        Ok(Self {
            inner,
            shared,
            dispatcher: Some(dispatcher),
            cells,
        })
    }

    /// Runs `work` on the pool of `options.cells` threads: a bake's parallel loop over its
    /// cells inside it keeps that many cells, and their calls, in flight.
    pub fn install<R: Send>(&self, work: impl FnOnce() -> R + Send) -> R {
        self.cells.install(work)
    }

    /// Calls, batches and rays so far.
    pub fn stats(&self) -> CellBatchingStats {
        CellBatchingStats {
            calls: self.shared.calls.load(Ordering::Relaxed),
            batches: self.shared.batches.load(Ordering::Relaxed),
            rays: self.shared.rays.load(Ordering::Relaxed),
        }
    }
}

impl RayCaster for CellBatchingCaster {
    /// Queues the rays and waits for their batch. Panics when the inner caster panicked.
    fn cast(&self, rays: &[Ray], hits: &mut [Hit]) {
        assert_eq!(rays.len(), hits.len(), "one hit per ray");
        if rays.is_empty() {
            return;
        }
        let (reply, answer) = mpsc::sync_channel(1);
        {
            let mut queue = self.shared.lock();
            assert!(!queue.failed, "the inner ray caster of a batch panicked");
            queue.pending.push(Request {
                rays: rays.to_vec(),
                reply,
            });
            queue.pending_rays += rays.len();
            queue.oldest.get_or_insert_with(Instant::now);
        }
        self.shared.calls.fetch_add(1, Ordering::Relaxed);
        self.shared.arrived.notify_all();
        // A dropped sender without an answer: the inner caster panicked on this batch.
        let answer = answer
            .recv()
            .unwrap_or_else(|_| panic!("the inner ray caster of a batch panicked"));
        hits.copy_from_slice(&answer);
    }

    fn occluded(&self, rays: &[Ray], out: &mut [bool]) {
        self.inner.occluded(rays, out);
    }
}

impl Drop for CellBatchingCaster {
    fn drop(&mut self) {
        self.shared.lock().shutdown = true;
        self.shared.arrived.notify_all();
        if let Some(d) = self.dispatcher.take() {
            // The dispatcher catches the inner caster's panics; nothing else panics in it.
            let _ = d.join();
        }
    }
}

/// The dispatcher: waits for a batch to be due (module documentation), casts it, answers.
fn dispatch_loop(
    shared: &Shared,
    inner: &dyn RayCaster,
    work: &rayon::ThreadPool,
    options: CellBatchingOptions,
) {
    let mut queue = shared.lock();
    loop {
        if queue.pending.is_empty() {
            if queue.shutdown {
                return;
            }
            queue = shared
                .arrived
                .wait(queue)
                .unwrap_or_else(PoisonError::into_inner);
            continue;
        }
        let full = queue.pending.len() >= queue.expected || queue.pending_rays >= options.max_rays;
        let waited = queue.oldest.map_or(Duration::ZERO, |t| t.elapsed());
        if !full && !queue.shutdown && waited < options.linger {
            let wait = options.linger - waited;
            queue = (shared.arrived.wait_timeout(queue, wait))
                .unwrap_or_else(PoisonError::into_inner)
                .0;
            continue;
        }
        let batch = std::mem::take(&mut queue.pending);
        queue.pending_rays = 0;
        queue.oldest = None;
        queue.expected = batch.len().clamp(1, options.cells);
        drop(queue);
        // Counted before any caller is answered, so a caller that reads the statistics after
        // its call sees its batch.
        shared.batches.fetch_add(1, Ordering::Relaxed);
        let cast = cast_batch(inner, work, batch, |rays| {
            shared.rays.fetch_add(rays, Ordering::Relaxed);
        });
        queue = shared.lock();
        if cast.is_none() {
            // Every caller of the batch was answered with a dropped sender; fail the rest.
            queue.failed = true;
            queue.pending.clear();
            queue.pending_rays = 0;
        }
    }
}

/// Casts `batch` as one call of `inner` on `work`'s threads, reports the rays cast to
/// `counted`, then sends each caller its hits; the rays cast, or `None` when `inner` panicked
/// (the callers' senders are dropped).
fn cast_batch(
    inner: &dyn RayCaster,
    work: &rayon::ThreadPool,
    batch: Vec<Request>,
    counted: impl FnOnce(u64),
) -> Option<u64> {
    let rays: Vec<Ray> = batch.iter().flat_map(|r| r.rays.iter().copied()).collect();
    let mut hits = vec![Hit::MISS; rays.len()];
    let cast = catch_unwind(AssertUnwindSafe(|| {
        work.install(|| inner.cast(&rays, &mut hits))
    }));
    cast.ok()?;
    counted(rays.len() as u64);
    let mut rest = &hits[..];
    for request in batch {
        let (mine, after) = rest.split_at(request.rays.len());
        rest = after;
        // A caller that stopped waiting (it cannot: it blocks on the answer) loses nothing.
        let _ = request.reply.send(mine.to_vec());
    }
    Some(rays.len() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use sightline_core::random::SplitMix64;
    use sightline_core::scene::SceneBuilder;
    use sightline_core::trace::Bvh;

    fn boxes() -> Arc<Bvh> {
        let mut b = SceneBuilder::new("boxes");
        for i in 0..8 {
            let x = i as f32 * 3.0;
            b.add_box(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 1.0, 1.0));
        }
        Arc::new(Bvh::build(&b.finish()))
    }

    fn random_rays(seed: u64, n: usize) -> Vec<Ray> {
        let mut r = SplitMix64::new(seed);
        let mut unit = || r.next_f32() * 2.0 - 1.0;
        (0..n)
            .map(|_| {
                let origin = Vec3::new(unit() * 12.0 + 12.0, unit() * 4.0, unit() * 4.0);
                let dir = Vec3::new(unit(), unit(), unit()).normalize_or(Vec3::X);
                Ray::new(origin, dir)
            })
            .collect()
    }

    /// A caster that panics on every call.
    struct Broken;

    impl RayCaster for Broken {
        fn cast(&self, _: &[Ray], _: &mut [Hit]) {
            panic!("broken caster");
        }
    }

    fn options(cells: usize, linger: Duration) -> CellBatchingOptions {
        CellBatchingOptions {
            cells,
            linger,
            ..CellBatchingOptions::default()
        }
    }

    #[test]
    fn concurrent_calls_get_the_inner_casters_hits_in_one_batch() {
        let bvh = boxes();
        // A long linger: the first batch waits for all four callers.
        let caster = CellBatchingCaster::new(bvh.clone(), options(4, Duration::from_secs(60)));
        let caster = caster.unwrap();
        let rays: Vec<Vec<Ray>> = (0..4)
            .map(|k| random_rays(k, 100 + 50 * k as usize))
            .collect();
        let hits: Vec<Vec<Hit>> = caster.install(|| {
            use rayon::prelude::*;
            (rays.par_iter().with_max_len(1))
                .map(|r| {
                    let mut h = vec![Hit::MISS; r.len()];
                    caster.cast(r, &mut h);
                    h
                })
                .collect()
        });
        for (r, h) in rays.iter().zip(&hits) {
            let mut expected = vec![Hit::MISS; r.len()];
            bvh.cast(r, &mut expected);
            assert_eq!(*h, expected);
        }
        assert!(hits.iter().flatten().any(|h| h.is_hit()));
        let stats = caster.stats();
        assert_eq!((stats.calls, stats.batches, stats.rays), (4, 1, 700));
    }

    #[test]
    fn a_lone_call_goes_after_the_linger() {
        let bvh = boxes();
        let caster = CellBatchingCaster::new(bvh.clone(), options(8, Duration::from_millis(1)));
        let caster = caster.unwrap();
        let rays = random_rays(9, 64);
        let mut hits = vec![Hit::MISS; rays.len()];
        caster.cast(&rays, &mut hits);
        let mut expected = vec![Hit::MISS; rays.len()];
        bvh.cast(&rays, &mut expected);
        assert_eq!(hits, expected);
        assert_eq!(caster.stats().batches, 1);
    }

    #[test]
    fn an_empty_call_casts_nothing() {
        let caster = CellBatchingCaster::new(boxes(), options(2, Duration::from_millis(1)));
        let caster = caster.unwrap();
        caster.cast(&[], &mut []);
        assert_eq!(caster.stats(), CellBatchingStats::default());
    }

    #[test]
    fn zero_cells_is_an_error() {
        let e = CellBatchingCaster::new(boxes(), options(0, Duration::ZERO)).err();
        assert!(matches!(e, Some(GpuError::ZeroCells)), "{e:?}");
    }

    #[test]
    fn a_panicking_inner_caster_fails_the_caller_and_later_calls() {
        let caster = CellBatchingCaster::new(Arc::new(Broken), options(1, Duration::ZERO));
        let caster = caster.unwrap();
        let rays = random_rays(1, 4);
        for _ in 0..2 {
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                caster.cast(&rays, &mut [Hit::MISS; 4]);
            }));
            assert!(outcome.is_err());
        }
        assert_eq!(caster.stats().rays, 0);
    }
}
