//! The geometry stage on several threads: each reads a batch from the shared stream, projects
//! and bins it, sorts it front to back, and hands the sealed batches to the bin queues in stream
//! order.
//!
//! Based on: Ivanchenko. Massively Parallel Analytic Visibility for Streaming Virtual Reality.
//! 2021, sections 6.1 (many blocks run the geometry stage at once, each on its own input batch)
//! and 6.2 (fetch a batch, project, bin, write to the bin queues), and 7.1.3 (sorted input).
//!
//! Only reading the stream is serial (a `TriangleSource` is a sequential reader); projection,
//! binning and sorting, the bulk of the stage, run in parallel. Batches are pushed in the order
//! their input was read (a ticket per input batch), so every bin sees its triangles in the same
//! order on every run and the visible set does not depend on thread timing.

use std::sync::{Condvar, Mutex, PoisonError};

use sightline_core::atomic_set::AtomicTriangleSet;
use sightline_core::TriangleSet;

use super::frustum_cull::{FrustumCull, RUN};
use super::geometry_stage::{bins_of, project, Batch, BinGrid, ProjTri};
use super::pipeline::Scheduler;
use super::projection::Projection;
use super::source::{SourceTriangle, TriangleSource};
use super::types::{RvError, RvOptions};

/// Counters of the geometry stage.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Produced {
    pub(crate) streamed: u64,
    pub(crate) on_screen: u64,
    pub(crate) entries: u64,
    /// Re-test pass: triangles kept visible untested, all their bins settled.
    pub(crate) settled: u64,
    /// Whether the stream came in id order (`Producers::ids_ascending`; set once per pass).
    pub(crate) ids_ascending: bool,
}

impl Produced {
    /// Adds another geometry thread's counts (all but `ids_ascending`, which is the pass's).
    pub(crate) fn add(&mut self, other: &Produced) {
        self.streamed += other.streamed;
        self.on_screen += other.on_screen;
        self.entries += other.entries;
        self.settled += other.settled;
    }
}

/// The stream, shared by the geometry threads.
struct Reader<'s> {
    source: &'s mut (dyn TriangleSource + Send),
    /// Ticket of the next input batch.
    next_ticket: u64,
    /// The last id of the last batch read.
    last_id: Option<u32>,
    /// The stream ended, failed, or a thread found bad input.
    done: bool,
}

/// Shared state of the geometry threads.
pub(crate) struct Producers<'s> {
    reader: Mutex<Reader<'s>>,
    /// Ticket whose batches may be pushed now.
    turn: Mutex<u64>,
    turn_changed: Condvar,
    error: Mutex<Option<RvError>>,
    bound: u32,
    /// A pipeline thread panicked: turn waits end at once.
    aborted: std::sync::atomic::AtomicBool,
    /// Every id read so far exceeded all ids before it.
    ids_ascending: std::sync::atomic::AtomicBool,
}

impl<'s> Producers<'s> {
    /// Geometry threads reading `source`.
    pub(crate) fn new(source: &'s mut (dyn TriangleSource + Send)) -> Self {
        let bound = source.id_bound();
        Self {
            reader: Mutex::new(Reader {
                source,
                next_ticket: 0,
                last_id: None,
                done: false,
            }),
            turn: Mutex::new(0),
            turn_changed: Condvar::new(),
            error: Mutex::new(None),
            bound,
            aborted: std::sync::atomic::AtomicBool::new(false),
            ids_ascending: std::sync::atomic::AtomicBool::new(true),
        }
    }

    /// Whether every id read exceeded all ids before it: stream order is then id order, which
    /// lets the re-test pass tell which batch of the first pass a triangle came in (see
    /// [`GeometryContext::settled`]).
    pub(crate) fn ids_ascending(&self) -> bool {
        self.ids_ascending
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Records that the stream's ids are not in ascending order.
    fn not_ascending(&self) {
        self.ids_ascending
            .store(false, std::sync::atomic::Ordering::Relaxed);
    }

    /// The first error any thread met, if any.
    pub(crate) fn into_error(self) -> Option<RvError> {
        self.error
            .into_inner()
            .unwrap_or_else(PoisonError::into_inner)
    }

    fn fail(&self, e: RvError) {
        let mut slot = self.error.lock().unwrap_or_else(PoisonError::into_inner);
        if slot.is_none() {
            *slot = Some(e);
        }
        drop(slot);
        self.reader
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .done = true;
    }

    /// Reads the next input batch into `input` (the source may leave out triangles not in
    /// `only`); its ticket, or `None` at the end.
    fn read(
        &self,
        max: usize,
        input: &mut Vec<SourceTriangle>,
        only: Option<&TriangleSet>,
    ) -> Option<u64> {
        let mut r = self.reader.lock().unwrap_or_else(PoisonError::into_inner);
        if r.done || self.aborted.load(std::sync::atomic::Ordering::SeqCst) {
            return None;
        }
        input.clear();
        let got = match only {
            Some(wanted) => r.source.next_wanted(max, input, wanted),
            None => r.source.next_batch(max, input),
        };
        match got {
            Ok(0) => {
                r.done = true;
                None
            }
            Ok(_) => {
                // Across batches here, in order; within a batch by the thread (`run`), outside
                // the lock.
                if let (Some(first), Some(last)) = (input.first(), input.last()) {
                    if r.last_id.is_some_and(|previous| first.id <= previous) {
                        self.not_ascending();
                    }
                    r.last_id = Some(last.id);
                }
                r.next_ticket += 1;
                Some(r.next_ticket - 1)
            }
            Err(e) => {
                drop(r);
                self.fail(e);
                None
            }
        }
    }

    /// A pipeline thread panicked: stop reading and end every turn wait (the panic is
    /// re-raised at the join; nothing produced afterwards is used).
    pub(crate) fn abort(&self) {
        self.aborted
            .store(true, std::sync::atomic::Ordering::SeqCst);
        if let Ok(mut r) = self.reader.try_lock() {
            r.done = true;
        }
        let _turn = self.turn.lock().unwrap_or_else(PoisonError::into_inner);
        self.turn_changed.notify_all();
    }

    fn wait_turn(&self, ticket: u64) {
        let mut t = self.turn.lock().unwrap_or_else(PoisonError::into_inner);
        while *t != ticket && !self.aborted.load(std::sync::atomic::Ordering::SeqCst) {
            t = self
                .turn_changed
                .wait(t)
                .unwrap_or_else(PoisonError::into_inner);
        }
    }

    fn end_turn(&self, ticket: u64) {
        *self.turn.lock().unwrap_or_else(PoisonError::into_inner) = ticket + 1;
        self.turn_changed.notify_all();
    }
}

/// Per-thread buffers of the geometry stage (accounted in `fixed_bytes`).
pub(crate) struct Scratch {
    input: Vec<SourceTriangle>,
    pairs: Vec<(u32, u32)>,
    tri_bins: Vec<u32>,
    tris: Vec<ProjTri>,
    sorting: SealScratch,
}

/// `seal`'s buffers: sort keys, each triangle's first pair, each bin's fill position.
#[derive(Default)]
struct SealScratch {
    keys: Vec<(f64, u32)>,
    starts: Vec<u32>,
    fill: Vec<u32>,
}

impl Scratch {
    /// Buffers for `options`.
    pub(crate) fn new(options: &RvOptions, max_entries: usize, n_bins: usize) -> Self {
        Self {
            input: Vec::with_capacity(options.batch_triangles),
            pairs: Vec::with_capacity(max_entries),
            tri_bins: Vec::with_capacity(n_bins),
            tris: Vec::with_capacity(options.batch_triangles),
            sorting: SealScratch {
                keys: Vec::with_capacity(options.batch_triangles),
                starts: Vec::with_capacity(options.batch_triangles + 1),
                fill: Vec::with_capacity(n_bins),
            },
        }
    }

    /// Heap bytes of one thread's buffers (input, pairs, its bins, `seal`'s scratch), the
    /// batch it fills and its sealed batch waiting for a ring slot.
    ///
    /// Finished batches are kept for reuse (`Scheduler::take_spare`) instead of freed: a
    /// batch buffer is only allocated when no spare is left, and a spare comes only out of the
    /// ring, so ring, spares and the threads' two batches never hold more than this and the
    /// ring's allowance together.
    pub(crate) fn bytes_for(options: &RvOptions, max_entries: usize, n_bins: usize) -> usize {
        let b = options.batch_triangles;
        b * std::mem::size_of::<SourceTriangle>()
            + max_entries * 8
            + n_bins * 4
            + b * (16 + 4)
            + 4
            + n_bins * 4
            + 2 * Batch::bytes_for(b, max_entries, n_bins)
    }
}

/// What a geometry thread needs that does not change during a run.
pub(crate) struct GeometryContext<'a> {
    pub(crate) proj: &'a Projection,
    /// The frustum test of runs of input triangles.
    pub(crate) cull: &'a FrustumCull,
    pub(crate) grid: &'a BinGrid,
    pub(crate) margin: f64,
    pub(crate) options: &'a RvOptions,
    pub(crate) max_entries: usize,
    pub(crate) sched: &'a Scheduler,
    /// Only triangles in this set go on to projection (the re-test pass: a triangle the first
    /// pass found hidden stays hidden, so it needs no geometry work); `None` keeps all.
    pub(crate) only: Option<&'a TriangleSet>,
    /// Sort batches front to back ([`RvOptions::sort_batches`]; pointless when the occluders
    /// no longer change, as in the re-test pass).
    pub(crate) sort: bool,
    /// Re-test pass over a stream in id order: the bins whose occluders did not change after a
    /// triangle's first-pass test (see [`Settled`]).
    pub(crate) settled: Option<Settled<'a>>,
}

/// What the re-test pass knows of the first pass's bins: per bin, the largest input id of the
/// last batch during which its occluders changed (`None`: never). A triangle the first pass
/// found visible whose id exceeds that in every bin it falls into was tested in each against
/// the final occluders already, in the same order-independent test, so it is visible again:
/// it is marked visible without a second test. Sound only when stream order is id order
/// ([`Producers::ids_ascending`]) and the stream is the same (the rewind contract).
#[derive(Clone, Copy)]
pub(crate) struct Settled<'a> {
    pub(crate) after: &'a [Option<u32>],
    pub(crate) visible: &'a AtomicTriangleSet,
}

/// One geometry thread: reads input batches until the stream ends and pushes their binned,
/// sorted batches in ticket order.
pub(crate) fn run(shared: &Producers<'_>, ctx: &GeometryContext<'_>, s: &mut Scratch) -> Produced {
    let mut out = Produced::default();
    let n_bins = ctx.grid.len();
    while let Some(ticket) = shared.read(ctx.options.batch_triangles, &mut s.input, ctx.only) {
        // The batch's largest id (its last one, in a stream in id order).
        let ascending = s.input.windows(2).all(|w| w[0].id < w[1].id);
        if !ascending {
            shared.not_ascending();
        }
        let last_id = match (ascending, s.input.last()) {
            (true, Some(last)) => last.id,
            _ => s.input.iter().map(|t| t.id).max().unwrap_or(0),
        };
        let mut bad = None;
        'input: for run in s.input.chunks(RUN) {
            // Runs wholly outside the frustum skip projection (`frustum_cull.rs`); a run with a
            // bad id goes the slow way, which reports it.
            if run.iter().all(|t| t.id < shared.bound) {
                // In the re-test pass most runs hold no triangle left to test.
                let none_kept = ctx
                    .only
                    .is_some_and(|only| !run.iter().any(|t| only.contains(t.id as usize)));
                if none_kept || ctx.cull.rejects(run) {
                    out.streamed += run.len() as u64;
                    continue;
                }
            }
            for t in run {
                out.streamed += 1;
                if t.id >= shared.bound {
                    bad = Some(RvError::IdOutOfRange {
                        id: t.id,
                        bound: shared.bound,
                    });
                    break 'input;
                }
                if ctx.only.is_some_and(|only| !only.contains(t.id as usize)) {
                    continue;
                }
                let Some((pt, pts, n)) = project(t, ctx.proj, ctx.margin) else {
                    continue;
                };
                s.tri_bins.clear();
                bins_of(&pts[..n], ctx.grid, ctx.margin, &mut s.tri_bins);
                if s.tri_bins.is_empty() {
                    continue;
                }
                if let Some(settled) = ctx.settled {
                    let after = |b: &u32| settled.after[*b as usize].is_none_or(|a| t.id > a);
                    if s.tri_bins.iter().all(after) {
                        settled.visible.insert(t.id);
                        out.settled += 1;
                        continue;
                    }
                }
                out.on_screen += 1;
                if s.pairs.len() + s.tri_bins.len() > ctx.max_entries
                    || s.tris.len() == ctx.options.batch_triangles
                {
                    // Rare (huge triangles): this input needs more than one batch.
                    let mut batch =
                        seal_scratch(&mut s.tris, &mut s.pairs, &mut s.sorting, ctx, n_bins);
                    batch.last_input_id = last_id;
                    shared.wait_turn(ticket);
                    ctx.sched.push(batch);
                }
                let k = s.tris.len() as u32;
                s.tris.push(pt);
                s.pairs.extend(s.tri_bins.iter().map(|&b| (b, k)));
                out.entries += s.tri_bins.len() as u64;
            }
        }
        let batch = (!s.tris.is_empty())
            .then(|| seal_scratch(&mut s.tris, &mut s.pairs, &mut s.sorting, ctx, n_bins));
        shared.wait_turn(ticket);
        if let Some(mut batch) = batch {
            batch.last_input_id = last_id;
            ctx.sched.push(batch);
        }
        shared.end_turn(ticket);
        if let Some(e) = bad {
            shared.fail(e);
            break;
        }
    }
    out
}

/// Seals a geometry thread's gathered triangles into a batch with this pass's options, reusing
/// the buffers of a finished batch when the scheduler has one.
fn seal_scratch(
    tris: &mut Vec<ProjTri>,
    pairs: &mut Vec<(u32, u32)>,
    sorting: &mut SealScratch,
    ctx: &GeometryContext<'_>,
    n_bins: usize,
) -> Batch {
    let spare = ctx.sched.take_spare();
    let batch_triangles = ctx.options.batch_triangles;
    seal(
        tris,
        pairs,
        sorting,
        spare,
        n_bins,
        batch_triangles,
        ctx.sort,
    )
}

/// Counting-sorts a batch's (bin, triangle) pairs into a [`Batch`], each bin's triangles front
/// to back when `sort` (in stream order otherwise); resets the buffers. `spare`, a finished
/// batch, lends its buffers (no allocation, and no fresh pages to fault in, per batch).
fn seal(
    tris: &mut Vec<ProjTri>,
    pairs: &mut Vec<(u32, u32)>,
    s: &mut SealScratch,
    spare: Option<Batch>,
    n_bins: usize,
    batch_triangles: usize,
    sort: bool,
) -> Batch {
    let (mut next_tris, mut offsets, mut entries) = match spare {
        Some(b) => (b.tris, b.offsets, b.entries),
        None => (Vec::with_capacity(batch_triangles), Vec::new(), Vec::new()),
    };
    next_tris.clear();
    let batch_tris = std::mem::replace(tris, next_tris);
    // Counting sort of the pairs by bin.
    offsets.clear();
    offsets.resize(n_bins + 1, 0);
    for &(b, _) in pairs.iter() {
        offsets[b as usize + 1] += 1;
    }
    for i in 0..n_bins {
        offsets[i + 1] += offsets[i];
    }
    // Each bin's next free position, then (once filled) its end.
    let fill = &mut s.fill;
    fill.clear();
    fill.extend_from_slice(&offsets[..n_bins]);
    entries.clear();
    entries.resize(pairs.len(), 0);
    let mut place = |b: u32, k: u32| {
        let slot = &mut fill[b as usize];
        entries[*slot as usize] = k;
        *slot += 1;
    };
    if sort {
        // Keys computed once: the nearest view depth of each triangle.
        let keys = &mut s.keys;
        keys.clear();
        keys.extend(batch_tris.iter().enumerate().map(|(i, t)| {
            let z = t.corners[0].z.min(t.corners[1].z).min(t.corners[2].z);
            (z, i as u32)
        }));
        keys.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // Triangle k's pairs are `pairs[starts[k]..starts[k + 1]]` (they were pushed triangle
        // by triangle). Placing them front to back makes every bin's list front to back (the
        // counting sort is stable), with no sort per bin and no reordering of the triangles.
        let starts = &mut s.starts;
        starts.clear();
        starts.resize(batch_tris.len() + 1, 0);
        for &(_, k) in pairs.iter() {
            starts[k as usize + 1] += 1;
        }
        for i in 0..batch_tris.len() {
            starts[i + 1] += starts[i];
        }
        for &(_, k) in keys.iter() {
            let own = &pairs[starts[k as usize] as usize..starts[k as usize + 1] as usize];
            for &(b, _) in own {
                place(b, k);
            }
        }
    } else {
        for &(b, k) in pairs.iter() {
            place(b, k);
        }
    }
    pairs.clear();
    Batch {
        tris: batch_tris,
        offsets,
        entries,
        last_input_id: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sorted seal lists every (bin, triangle) pair once, each bin's entries front to back.
    #[test]
    fn sorted_seal_keeps_every_pair_front_to_back() {
        use glam::{DVec2, DVec3};
        let n_bins = 5;
        let options = RvOptions {
            batch_triangles: 64,
            ..RvOptions::default()
        };
        let mut s = Scratch::new(&options, 256, n_bins);
        let mut want = Vec::new();
        for k in 0..40u32 {
            // Depths out of order, with ties.
            let z = f64::from((k * 7) % 13) + 1.0;
            s.tris.push(ProjTri {
                id: 100 + k,
                corners: [DVec3::new(0.0, 0.0, z); 3],
                screen: [DVec2::ZERO; 3],
                whole_front: true,
                front: true,
            });
            for b in 0..n_bins as u32 {
                if (k + b) % 3 != 0 {
                    s.pairs.push((b, k));
                    want.push((b, 100 + k));
                }
            }
        }
        // A spare from an earlier, larger batch lends its buffers.
        let spare = Batch {
            tris: Vec::with_capacity(64),
            offsets: vec![9; n_bins + 1],
            entries: vec![7; 300],
            last_input_id: 0,
        };
        let batch = seal(
            &mut s.tris,
            &mut s.pairs,
            &mut s.sorting,
            Some(spare),
            n_bins,
            64,
            true,
        );
        assert!(s.tris.is_empty() && s.pairs.is_empty(), "buffers reset");
        assert_eq!(batch.offsets[n_bins] as usize, batch.entries.len());
        let z = |i: u32| batch.tris[i as usize].corners[0].z;
        let mut got = Vec::new();
        for b in 0..n_bins {
            // Front to back; equal depths in stream order.
            let list = batch.bin(b);
            assert!(list
                .windows(2)
                .all(|w| z(w[0]) < z(w[1]) || (z(w[0]) == z(w[1]) && w[0] < w[1])));
            got.extend(list.iter().map(|&i| (b as u32, batch.tris[i as usize].id)));
        }
        got.sort_unstable();
        want.sort_unstable();
        assert_eq!(got, want);
    }
}
