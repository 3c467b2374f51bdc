//! What the benchmarks share: their typed error, their progress messages, and the statistic
//! that ranks repeated timings (sorted, median).
//!
//! Progress is a value handed to an optional callback rather than a line printed here, so a
//! library caller chooses whether and where it goes; its `Display` is the line the
//! `sightline bench` tool prints on stderr.

use std::fmt;

use sightline_core::camera::CameraError;
use sightline_point::rv::RvError;
use sightline_region::ViewCellError;

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A count that must be positive is zero (`what` names it).
    #[error("{what} must be at least 1")]
    Zero {
        /// The option, e.g. "rounds".
        what: &'static str,
    },
    /// A time budget outside 1 ms..=1 h.
    #[error("{0} ms is not a budget between 1 ms and one hour")]
    TimeBudget(u64),
    /// A ray budget outside 1..=10^11.
    #[error("{0} is not a budget between 1 and 10^11 rays")]
    RayBudget(u64),
    /// A cell grid outside 1..=1024 cells per side.
    #[error("a grid of {0} cells per side is not in 1..=1024")]
    Grid(u32),
    /// A `bench share` grid more than one cell high (its cells form one layer).
    #[error("the grid has {0} cells along the scene's up axis: `bench share` bakes one layer of cells (--layer), so that count must be 1")]
    GridHeight(u32),
    /// A cell layer that is not finite or whose bottom is not below its top.
    #[error("the cell layer {0}..{1} is not finite with bottom below top")]
    Layer(f32, f32),
    /// A camera could not be set up.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// View cells could not be made.
    #[error(transparent)]
    ViewCell(#[from] ViewCellError),
    /// RV failed.
    #[error(transparent)]
    Rv(#[from] RvError),
}

/// A benchmark's progress, passed to its callback. `Display` writes the line the CLI prints.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Progress<'a> {
    /// Round `round` (from 1) of `rounds` starts.
    Round {
        /// This round, from 1.
        round: usize,
        /// All rounds.
        rounds: usize,
    },
    /// A scene had no free space for view cells and is skipped.
    NoFreeSpace {
        /// The scene's name.
        scene: &'a str,
    },
    /// View cell `cell` (from 1) of `cells` of a scene starts.
    Cell {
        /// The scene's name.
        scene: &'a str,
        /// This cell, from 1.
        cell: usize,
        /// The scene's cells.
        cells: usize,
    },
    /// The independent GVS++ bake at `budget` rays per cell starts.
    IndependentBake {
        /// Rays per cell.
        budget: u64,
    },
    /// The shared-ray bake at `budget` rays per cell starts.
    SharedBake {
        /// Rays per cell.
        budget: u64,
    },
    /// Round `round` (from 1) of `rounds` of a peer comparison on `what` (a set or scene).
    Peers {
        /// The occluder set or scene.
        what: &'a str,
        /// This round, from 1.
        round: usize,
        /// All rounds.
        rounds: usize,
    },
    /// The evaluation of grid cell `cell`, the `index`-th (from 1) of `count`, starts.
    Evaluating {
        /// The cell's index in the grid.
        cell: usize,
        /// This evaluation, from 1.
        index: usize,
        /// All evaluated cells.
        count: usize,
    },
}

impl fmt::Display for Progress<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Round { round, rounds } => write!(f, "round {round}/{rounds}"),
            Self::NoFreeSpace { scene } => {
                write!(f, "{scene}: found no free space for view cells, skipped")
            }
            Self::Cell { scene, cell, cells } => write!(f, "{scene}: cell {cell}/{cells}"),
            Self::IndependentBake { budget } => {
                write!(f, "independent GVS++, {budget} rays per cell ...")
            }
            Self::SharedBake { budget } => {
                write!(f, "GVS++ with ray sharing, {budget} rays per cell ...")
            }
            Self::Peers {
                what,
                round,
                rounds,
            } => write!(f, "{what}: round {round}/{rounds}"),
            Self::Evaluating { cell, index, count } => {
                write!(f, "evaluating cell {cell} ({index}/{count})")
            }
        }
    }
}

/// The optional progress callback of the benchmarks.
pub type OnProgress<'a> = Option<&'a dyn Fn(&Progress<'_>)>;

/// Calls `on` with `p`, when there is a callback.
pub(crate) fn report(on: OnProgress<'_>, p: Progress<'_>) {
    if let Some(on) = on {
        on(&p);
    }
}

/// `times` sorted ascending, for the median and the extremes (at least one element).
pub(crate) fn sorted(mut times: Vec<f64>) -> Vec<f64> {
    times.sort_by(f64::total_cmp);
    times
}
