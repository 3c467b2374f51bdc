//! Ray sharing: GVS++ for many view cells at once, where every ray cast for one cell also
//! counts for every other cell it passes through.
//!
//! Based on: Bittner, Mattausch, Wonka, Havran, Wimmer. Adaptive Global Visibility Sampling.
//! ACM TOG 28(3), 2009 (a ray contributes to all view cells it intersects), as proposed for
//! GVS++ in Koch, Wimmer. Guided Visibility Sampling++. 2021, section 7; the per-cell phases are
//! GVS++'s (sections 4.1–4.4, see `gvspp/`).
//!
//! A ray is cast forward to its closest hit and (random rays, see below) also backward, in the
//! reversed direction, to the closest hit behind its origin. The segment between the two hits is
//! empty, so from every point `P` of it both end triangles are visible (the path from `P` to
//! either end lies inside the segment). For every cell whose volume the segment crosses (found
//! with `segment_cells.rs`), a point `P` of the crossing that lies in the cell's free space
//! becomes the origin of a discovery for that cell: both end triangles enter its PVS *by
//! construction*, never by proximity or guesswork. A hit-nothing end makes the segment unbounded
//! on that side and contributes no triangle.
//!
//! Schedule, by default by yield (`bake/by_yield.rs`): in every step each cell that is still
//! going picks the kind of its next batch (random, border, its refinement, reverse or neighbour
//! sampling) by its own recent yields, as a single-cell GVS++ bake does; all cells' batches are
//! cast together and shared; each cell counts the new triangles its own rays found for its
//! yields and its termination rule (without a budget: fewer than `T` new triangles over its
//! last 10^7 rays, with nothing waiting). Random rays are also cast backward, in the reversed
//! direction (a second random-like ray through the cell for one more cast); guided rays are
//! cast forward only (their backward half would be an untargeted ray at the price of a
//! targeted one) and shared too. By default a cell explores the triangles its own rays hit
//! (once each) and only *adds* those it receives to its PVS; `explore_shared` also explores
//! received triangles, from their crossing point. With a budget (per cell, counted on the rays
//! a cell casts itself, backward casts included), cells sample until their own budget is spent
//! and still receive other cells' rays for free.
//!
//! With `fixed_rounds`, the paper's rounds of GVS++ (`n_rand` random rays each, `bake.rs`):
//! (1) random sampling, `n_rand` rays from each cell that has not converged, each also cast
//! backward; (2) exploration: every cell takes the next `ABS_CHUNK` triangles of its queue,
//! casts their ABS rays from the discovery's origin (which lies in the cell), then RS rays from
//! its own reverse origins for the discontinuities of its own border rays, exactly what the
//! per-cell sampler does in rounds (both step the same per-cell state, `gvspp/cell.rs`); (3)
//! termination per cell: a cell whose round found fewer than `T` new triangles (from any cell's
//! rays) stops random sampling (the rule over that round alone) but still explores what its own
//! rays hit. In rounds, with `backward = false` and without `explore_shared`, every cell casts
//! exactly the rays of its independent GVS++ bake in rounds and its set can only grow by
//! sharing (tested).
//!
//! Rounds were the only schedule until the eighteenth session. Once the independent bakes were
//! scheduled by yield, they beat the shared rounds at street level (the shared bake needed
//! more rays for equal error, 0.6x); shared by yield it needs 1.1-1.5x fewer again
//! (docs/BENCHMARKS.md).
//!
//! Determinism: rays are generated, cast and turned into contributions in parallel but collected
//! in ray order; each cell then inserts its contributions in that order. Batch sizes depend only
//! on the state, never on the thread count, so a seed gives the same sets on any machine.
//!
//! # Layout
//! `types.rs` the parameters, progress reports and result; `bake.rs` the bake, its casting and
//! sharing, and the schedule in rounds, stepping one GVS++ state per cell (`gvspp/cell.rs`, the
//! per-cell sampler's too); `bake/by_yield.rs` the schedule by yield; `free_segment.rs` what a
//! ray's free segment shows to the cells it crosses.

mod bake;
#[cfg(test)]
mod fixtures;
mod free_segment;
mod types;

pub use bake::bake_shared;
pub use types::{ShareParams, SharedBake, SharedProgress};
