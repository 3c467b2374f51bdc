//! GVS++: guided visibility sampling with fixed-rate adaptive border sampling and view-cell
//! reverse sampling.
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. Proc. ACM CGIT 4(1), 2021:
//! random sampling (section 4.1), adaptive border sampling with a fixed number of samples per
//! border-polygon edge (4.2), discontinuity detection and reverse sampling from points spread
//! over the view cell (4.3), the exploration queue and the termination rule (4.4).
//!
//! One round: `n_rand` random rays; every newly found triangle enters the queue with the ray
//! that found it; the queue is drained by ABS (rays from that ray's origin to the 9 vertices of
//! the triangle's enlarged border polygon and to `n_abs_edge` points on each of its three long
//! edges), and each border *vertex* ray that hits something closer than its target (by more
//! than Δ) or nothing at all marks a discontinuity, handled by RS: rays from the cell's corners,
//! `n_rs_edge` points per cell edge and `n_rs_area` Halton points on the cell surface to the
//! target, skipping origins whose segment to the target passes through the occluder (the paper
//! projects the occluder onto the cell plane and tests the sample points against the projected
//! triangle; the segment test is the same predicate and also works on all six faces of a box).
//! New triangles from ABS and RS enter the queue too. When the queue is empty, the round ends;
//! without a ray or time budget, sampling stops once the most recent rounds that together cast
//! at least [`TERMINATION_WINDOW`] rays found fewer than `T` new triangles. With a budget, rounds
//! continue until it is spent (so comparisons at equal rays are fair).
//!
//! # Batches by yield (not the paper's schedule)
//! The paper casts `n_rand` = 10^7 random rays per round, sized for a GPU that casts them in
//! milliseconds, then drains the whole queue, reverse-sampling every discontinuity as border
//! sampling finds it. On a CPU (5-7 M rays/s on two cores) the first round alone spends any
//! budget up to 1.5 s, and even with small rounds reverse sampling took most of a small budget
//! at a poor yield. A bake therefore has no rounds: every batch of
//! [`YIELD_BATCH`] rays goes to random, border or reverse sampling, whichever found the most new
//! triangles per ray in its recent batches, each kind keeping at least a tenth of the rays while
//! it has work; border sampling first spaces its edge samples 3 mrad apart and refines to the
//! paper's 20 per edge later, as a kind of its own (`by_yield.rs` says why and what it
//! measured); a fifth kind aims at the corners of found triangles' unfound neighbours, for
//! triangles that show only a sliver (`neighbours.rs`). `fixed_rounds` restores the
//! paper's rounds. Under `--rays` or `--time` the budget ends the bake; without one, the
//! termination rule does, counted over batches instead of rounds: fewer than `T` = 10 new
//! triangles in the batches of the last [`TERMINATION_WINDOW`] = 10^7 rays (the paper's rule at
//! its round size), with nothing waiting for exploration. Until the eighteenth session bakes to
//! convergence kept the paper's rounds; by yield they have fewer error pixels on 9 of 36
//! measured cells and more on 1, with fewer rays on five of six scenes (`by_yield.rs`). In the
//! paper's rounds (`fixed_rounds`, and the shared-ray bake) the rule counts whole rounds over
//! the same window, so that a small `n_rand` does not stop a bake early.
//!
//! # Discontinuities at every border sample (ours)
//! The paper looks for discontinuities only on the rays to the 9 *vertices* of a border
//! polygon. In an open city what the cell sees through a gap between two buildings lies
//! behind the gap, and the found triangles around it are large facades and roofs whose border
//! vertices are metres away from the gap: reverse sampling aimed at those vertices passes the
//! gap by, and only random rays through the gap find what it shows (measured on a generated
//! open city: a facade seen from 3 % of a cell, through a gap 10 mrad wide, was the cell's
//! largest error, 38 of its 54 error pixels in 600 views, for GVS++ and RAND alike). With
//! `edge_discontinuities` (the default) every border sample, the `n_abs_edge` points on each
//! long edge as well as the vertices, is searched, so reverse sampling also aims along the
//! edges that cross the gap. It reverse-samples several times as many discontinuities, and
//! converged bakes still cast fewer rays in all (they find more early, so the termination rule
//! holds sooner). `edge_discontinuities: false` is the paper's.
//!
//! Distances: the paper gives Δ_ABS = 0.001 in scene units of km-scale scenes; here both
//! distances are fractions of the scene's bounding-box diagonal (`delta_abs` 1e-6 ≈ 1 mm on a
//! 1 km scene), so the defaults work on a bunny and on a city alike.
//!
//! # Layout
//! `params.rs` the parameters and the schedule's constants; `neighbours.rs` neighbour
//! sampling (ours) over `crate::adjacency`; `cell.rs` one cell's state (random
//! sequence, reverse origins, queue, waiting discontinuities, counters, termination), stepped by
//! the drivers: `sampler.rs`, the per-cell sampler in the paper's rounds, `by_yield.rs`, the
//! per-cell sampler under a budget, and the shared-ray bake (`ray_sharing/`); `guided_rays.rs`
//! the ABS, discontinuity and RS rays. The queue, the counters and the
//! termination rule are the skeleton GVS shares (`guided.rs`).

mod by_yield;
mod cell;
mod guided_rays;
mod neighbours;
mod params;
mod sampler;

pub(crate) use by_yield::{guided_batch, Kind, YieldScheduler};
pub(crate) use cell::{GvsppCell, Rounds};
pub use params::{GvsPlusPlusParams, GvsPlusPlusParamsError, TERMINATION_WINDOW, YIELD_BATCH};
pub use sampler::GvsPlusPlus;
