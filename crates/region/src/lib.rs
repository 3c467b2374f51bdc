//! sightline-region: from-region visibility. View cells, the samplers that compute a
//! potentially visible set (PVS) for a cell, and the `.pvs` file format.
#![deny(missing_docs)]

pub mod adjacency;
pub mod bake;
mod border;
pub mod bound;
pub mod bsp_portals;
pub mod cell_sources;
pub mod checkpoint;
pub mod closed_solids;
mod guided;
pub mod gvs;
pub mod gvspp;
pub mod hull_box;
pub mod incremental;
pub mod merge_similar;
pub mod methods;
pub mod occupancy;
mod pvs_encoding;
pub mod pvs_file;
pub mod pvs_objects;
pub mod rand;
pub mod raster_sampler;
pub mod ray_sharing;
mod rays;
pub mod reachable;
pub mod rebake;
pub mod sampler;
pub mod segment_cells;
pub mod shards;
pub mod shrunk_occluders;
pub mod viewcell;
pub mod walkable;

pub use gvs::{Gvs, GvsParams};
pub use gvspp::{GvsPlusPlus, GvsPlusPlusParams, GvsPlusPlusParamsError};
pub use pvs_file::{CellPvs, EncodedSet, ObjectTable, PvsError, PvsFile, PvsObject};
pub use rand::RandomSampler;
pub use raster_sampler::RasterSampler;
pub use sampler::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};
pub use viewcell::{CellSurface, Rect, ViewCell, ViewCellError};
