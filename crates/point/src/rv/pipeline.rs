//! The sort-middle pipeline on CPU threads: geometry threads (the caller and helpers, see
//! `producer.rs`) run the geometry stage over the stream, worker threads run the visibility
//! stage per bin, connected by bounded bin queues.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, section 6.1 (megakernel, bin queues, triangle ring buffer with reference counts) and
//! 6.1.1 (scheduling: a bin is locked by one worker at a time, fullest bin first, a threshold
//! below which workers prefer to wait for more input, a drain mode once input ends, and no new
//! geometry work while the queues could overflow).
//!
//! Mapping to the thesis, and simplifications:
//! - The triangle ring buffer is a ring of at most `ring_batches` projected batches. A batch is
//!   shared by reference count (`Arc`) among the bins it was binned into and freed when the
//!   last bin has processed it; the producer blocks while the ring is full. Reference counts
//!   are per batch, not per triangle.
//! - Geometry runs on `geometry_threads` threads, visibility on `threads` workers: a fixed split
//!   instead of every block choosing a stage; batches enter the queues in stream order. When the producer is blocked on a full ring the
//!   workers ignore the threshold (the thesis' drain mode), so the pipeline cannot stall.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

use super::geometry_stage::{Batch, BinGrid};

/// Scheduler state shared by the producer and the workers.
#[derive(Debug)]
struct Queues {
    /// Per bin: the batches with entries in it, oldest first.
    queues: Vec<VecDeque<Arc<Batch>>>,
    /// Per bin: queued triangle entries.
    pending: Vec<usize>,
    /// Per bin: a worker holds it.
    busy: Vec<bool>,
    /// Batches alive (queued or being processed).
    in_flight: usize,
    /// The stream has ended.
    input_done: bool,
    /// The producer waits for ring space.
    producer_blocked: bool,
    /// A thread panicked: everyone stops waiting (the panic is re-raised at the join).
    aborted: bool,
}

/// The bin queues and their scheduling (see the module documentation).
#[derive(Debug)]
pub(crate) struct Scheduler {
    state: Mutex<Queues>,
    changed: Condvar,
    /// Finished batches kept for their buffers (`take_spare`), at most `ring_batches`.
    spares: Mutex<Vec<Batch>>,
    ring_batches: usize,
    threshold: usize,
}

fn lock(m: &Mutex<Queues>) -> MutexGuard<'_, Queues> {
    // A worker that panicked leaves consistent counters behind (it panics outside the lock).
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Work handed to a worker: one bin and the batches queued for it.
pub(crate) struct Work {
    pub(crate) bin: usize,
    pub(crate) batches: VecDeque<Arc<Batch>>,
}

impl Scheduler {
    /// Queues for `grid`, at most `ring_batches` batches alive, visibility threshold
    /// `threshold` entries per bin.
    pub(crate) fn new(grid: &BinGrid, ring_batches: usize, threshold: usize) -> Self {
        let n = grid.len();
        Self {
            state: Mutex::new(Queues {
                queues: (0..n).map(|_| VecDeque::new()).collect(),
                pending: vec![0; n],
                busy: vec![false; n],
                in_flight: 0,
                input_done: false,
                producer_blocked: false,
                aborted: false,
            }),
            changed: Condvar::new(),
            spares: Mutex::new(Vec::with_capacity(ring_batches)),
            ring_batches,
            threshold,
        }
    }

    /// Producer: enqueues `batch` into every bin it has entries for, first waiting while the
    /// ring is full.
    pub(crate) fn push(&self, batch: Batch) {
        let n_bins = batch.offsets.len().saturating_sub(1);
        let batch = Arc::new(batch);
        let mut s = lock(&self.state);
        while s.in_flight >= self.ring_batches {
            if s.aborted {
                return;
            }
            s.producer_blocked = true;
            self.changed.notify_all();
            s = self.changed.wait(s).unwrap_or_else(PoisonError::into_inner);
        }
        s.producer_blocked = false;
        let mut used = false;
        for b in 0..n_bins {
            let k = batch.bin(b).len();
            if k > 0 {
                s.queues[b].push_back(Arc::clone(&batch));
                s.pending[b] += k;
                used = true;
            }
        }
        if used {
            s.in_flight += 1;
        }
        // Drop the producer's reference while holding the lock: no worker can have taken this
        // batch yet, so the last reference is always a queue's and `done` sees it.
        drop(batch);
        drop(s);
        self.changed.notify_all();
    }

    /// Producer: the stream has ended (drain mode).
    pub(crate) fn finish_input(&self) {
        lock(&self.state).input_done = true;
        self.changed.notify_all();
    }

    /// Worker: waits for the fullest free bin with enough work (any work in drain mode);
    /// `None` when everything is done.
    pub(crate) fn take(&self) -> Option<Work> {
        let mut s = lock(&self.state);
        loop {
            if s.aborted {
                return None;
            }
            let drain = s.input_done || s.producer_blocked;
            let threshold = if drain { 1 } else { self.threshold };
            let mut best: Option<usize> = None;
            for b in 0..s.pending.len() {
                if !s.busy[b]
                    && s.pending[b] >= threshold
                    && !matches!(best, Some(c) if s.pending[c] >= s.pending[b])
                {
                    best = Some(b);
                }
            }
            if let Some(bin) = best {
                s.busy[bin] = true;
                s.pending[bin] = 0;
                let batches = std::mem::take(&mut s.queues[bin]);
                return Some(Work { bin, batches });
            }
            if s.input_done && s.in_flight == 0 {
                return None;
            }
            s = self.changed.wait(s).unwrap_or_else(PoisonError::into_inner);
        }
    }

    /// Producer: a finished batch whose buffers can be reused, if any.
    pub(crate) fn take_spare(&self) -> Option<Batch> {
        self.spares
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop()
    }

    /// A thread panicked: wake every waiting thread and make all waits end, so the pipeline
    /// stops instead of waiting forever for work the panicked thread will never finish.
    pub(crate) fn abort(&self) {
        lock(&self.state).aborted = true;
        self.changed.notify_all();
    }

    /// Worker: done with `work`'s bin; drops its batch references and frees finished batches
    /// (their ring slots; their buffers are kept as spares).
    pub(crate) fn done(&self, work: Work) {
        let mut freed = 0;
        for batch in work.batches {
            // The last reference frees the batch (the ring slot).
            if let Some(finished) = Arc::into_inner(batch) {
                freed += 1;
                let mut spares = self.spares.lock().unwrap_or_else(PoisonError::into_inner);
                if spares.len() < self.ring_batches {
                    spares.push(finished);
                }
            }
        }
        let mut s = lock(&self.state);
        s.busy[work.bin] = false;
        s.in_flight -= freed;
        drop(s);
        self.changed.notify_all();
    }
}

/// Calls [`Scheduler::abort`] (and `also`) when dropped during a panic: hold one in every
/// pipeline thread.
pub(crate) struct AbortOnPanic<'a> {
    pub(crate) sched: &'a Scheduler,
    pub(crate) also: Option<&'a dyn Fn()>,
}

impl Drop for AbortOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.sched.abort();
            if let Some(f) = self.also {
                f();
            }
        }
    }
}
