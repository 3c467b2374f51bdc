//! sightline-cull: run-time occlusion culling with a uniform grid, occlusion-order traversal and
//! occlusion-query scheduling (Seletsky 2013), and a software occlusion buffer backend in the
//! style of Masked Occlusion Culling (Andersson, Hasselgren, Akenine-Möller 2015/2016).
//!
//! Modules, one algorithm each:
//! - [`OcclusionBuffer`] (`masked_occlusion/`): the software masked depth buffer, usable alone.
//! - [`Grid`] (`grid.rs`): the uniform grid of dynamic objects.
//! - [`Traversal`] (`traversal.rs`): occlusion-order traversal of the frustum over the grid.
//! - [`Scheduler`] (`scheduler.rs`): which cells are queried, drawn and depth-pre-passed.
//! - [`OcclusionBackend`] (`backend.rs`): the backend trait and its software implementation.
//! - [`ExtraCauses`] (`diagnose.rs`): why drawn objects are not visible, cause by cause.
//! - [`Hzb`] (`hzb.rs`): a hierarchical depth pyramid (the two-phase baseline's test).
//! - [`simulate()`], [`simulate_methods`] (`simulate.rs`): the per-frame loop over a camera
//!   path, the grid method and the baselines (frustum, stop-and-wait with box or triangle
//!   tests, two-phase HZB), with popping counts.
//! - [`scenes`] (`scenes.rs`): The Grid and Teapot Graveyard with motion and camera paths.
//! - [`bench_sets`] (`bench_sets.rs`): the occlusion buffer's benchmark inputs (random right
//!   triangles of a given leg length at 1920x1080), shared by the bench and `sightline bench
//!   peers`.
#![deny(missing_docs)]

mod backend;
pub mod bench_sets;
mod diagnose;
mod front_to_back;
mod grid;
mod hzb;
mod masked_occlusion;
pub mod scenes;
mod scheduler;
mod sim_method;
mod sim_types;
mod sim_world;
mod simulate;
mod traversal;

pub use backend::{OcclusionBackend, SoftwareBackend};
pub use diagnose::ExtraCauses;
pub use grid::{Grid, GridError, GridShape};
pub use hzb::Hzb;
/// The bench's and the kernel tests' baseline kernels, not part of the supported API.
#[doc(hidden)]
pub use masked_occlusion::BaselineKernel;
pub use masked_occlusion::{Kernel, OcclusionBuffer, COVER_MARGIN, DEPTH_SLACK, TILE_H, TILE_W};
pub use scheduler::{DepthClass, Scheduler, SchedulerConfig};
pub use sim_types::{FrameStats, Method, SimConfig, SimReport};
pub use simulate::{simulate, simulate_methods, simulate_methods_with_cameras, simulate_viewports};
pub use traversal::{can_occlude, frustum_corners, Traversal};
