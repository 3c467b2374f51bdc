//! RV's public types: the options of a run, its result and counters, and its errors. A leaf:
//! it imports nothing of `rv`, so the engine's files take their options from here and never
//! from the module's face (`mod.rs`).

use sightline_core::TriangleSet;

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
    ///
    /// [`TriangleSource::rewind`]: super::TriangleSource::rewind
    /// [`TriangleSource::next_wanted`]: super::TriangleSource::next_wanted
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

/// The result of [`conservative_visible`](super::conservative_visible).
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

impl RvOptions {
    /// Checks the options that no run can work with.
    pub(crate) fn check(&self) -> Result<(), RvError> {
        let (bx, by) = self.bins;
        if bx == 0 || by == 0 || bx as usize * by as usize > 1 << 16 {
            return Err(RvError::BadOption(format!(
                "bins {bx}x{by}: need 1..=65536 bins"
            )));
        }
        if self.threads == 0 || self.geometry_threads == 0 {
            return Err(RvError::BadOption(
                "threads and geometry_threads must be at least 1".into(),
            ));
        }
        if self.batch_triangles == 0 || self.ring_batches == 0 {
            return Err(RvError::BadOption(
                "batch_triangles and ring_batches must be at least 1".into(),
            ));
        }
        Ok(())
    }
}
