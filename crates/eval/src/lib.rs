//! sightline-eval: how good is a visible set? Ground truth from the reference rasterizer, and
//! the error measures of the from-region visibility literature; and the HTML visibility report
//! built on them (`report`: one self-contained page with a PVS's summary, per-cell table, worst
//! views, convergence plots and cell map), callable from any front end.
#![deny(missing_docs)]

pub mod bench;
pub mod error_regions;
pub mod pixel_error;
pub mod report;

pub use pixel_error::{
    evaluate_cell, evaluate_cell_in, view_errors, CellEvaluation, EvalParams, ViewErrors, ViewMode,
    WorstView,
};
