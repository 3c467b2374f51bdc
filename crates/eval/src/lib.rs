//! sightline-eval: how good is a visible set? Ground truth from the reference rasterizer, and
//! the error measures of the from-region visibility literature.
#![deny(missing_docs)]

pub mod bench;
pub mod error_regions;
pub mod pixel_error;

pub use pixel_error::{
    evaluate_cell, evaluate_cell_in, view_errors, CellEvaluation, EvalParams, ViewErrors, ViewMode,
    WorstView,
};
