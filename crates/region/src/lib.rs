//! sightline-region: from-region visibility. View cells, the samplers that compute a
//! potentially visible set (PVS) for a cell, and the `.pvs` file format.
#![deny(missing_docs)]

pub mod pvs_file;
pub mod viewcell;

pub use pvs_file::{CellPvs, PvsError, PvsFile};
pub use viewcell::{CellSurface, Rect, ViewCell, ViewCellError};
