//! sightline-region: from-region visibility. View cells, the samplers that compute a
//! potentially visible set (PVS) for a cell, and the `.pvs` file format.
#![deny(missing_docs)]

mod border;
pub mod gvs;
pub mod gvspp;
pub mod pvs_file;
pub mod rand;
mod rays;
pub mod sampler;
pub mod viewcell;

pub use gvs::{Gvs, GvsParams};
pub use gvspp::{GvsPlusPlus, GvsPlusPlusParams};
pub use pvs_file::{CellPvs, PvsError, PvsFile};
pub use rand::RandomSampler;
pub use sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};
pub use viewcell::{CellSurface, Rect, ViewCell, ViewCellError};
