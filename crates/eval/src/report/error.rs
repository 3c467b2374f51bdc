//! Why a report could not be built: [`ReportError`], the error of every fallible function of
//! `report`.

use sightline_region::reachable::ReachError;

/// Why a report, or a part of one, could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// The plotting library failed to draw a plot.
    #[error("drawing plot: {0}")]
    Plot(String),
    /// An image could not be encoded as PNG.
    #[error("encoding a PNG image: {0}")]
    Png(#[from] image::ImageError),
    /// The Quake 3 reachable space the bake recorded could not be built again (for the
    /// viewpoints of the evaluation, or the ray origins of the equal-budget bakes).
    #[error(transparent)]
    Reach(#[from] ReachError),
    /// The equal-budget comparison was given no budgets, or too many.
    #[error("equal-budget comparison: {given} budgets given, 1 to {max} allowed")]
    BudgetCount {
        /// Budgets given.
        given: usize,
        /// The most allowed, [`super::budgets::MAX_BUDGETS`].
        max: usize,
    },
    /// A budget of the equal-budget comparison is 0 or too large.
    #[error("equal-budget comparison: budget {rays} rays is outside 1..={max}")]
    BudgetOutOfRange {
        /// The budget given.
        rays: u64,
        /// The largest allowed, [`super::budgets::MAX_BUDGET_RAYS`].
        max: u64,
    },
    /// The budgets of the equal-budget comparison do not increase.
    #[error("equal-budget comparison: budgets must increase ({0:?})")]
    BudgetsNotIncreasing(Vec<u64>),
    /// The equal-budget comparison was asked for no cells.
    #[error("equal-budget comparison: at least one cell is needed")]
    NoBudgetCells,
}
