//! Whole-algorithm benchmarks, the measuring behind `sightline bench`: each takes a plain
//! options struct (and scenes, cameras or casters the caller made) and returns rows that
//! serialize to the tool's JSON. Progress goes to an optional callback; nothing is printed.

mod common;
mod convergence;
pub mod peer_sets;
mod peers;
mod pvs;
mod raster;
mod rv;
mod share;
mod trace;

pub use common::{BenchError, OnProgress, Progress};
pub use convergence::{convergence_curves, Convergence, ConvergenceSeries, ERROR_FLOOR, FRACTIONS};
pub use peers::{
    bench_occluders, bench_rays, hit_agreement, spawn_moc, CoverageCheck, InProcessCaster,
    OccluderCase, OccluderRow, PeerBenchOptions, PeerError, PeerProcess, RayRow, RaySetCase,
    Timing, HIT_T_TOLERANCE,
};
pub use pvs::{
    bench_pvs_scene, bench_pvs_scene_on, equal_budget_pairs, PvsBenchOptions, PvsRow,
    PvsSceneReport, SecondCaster, PAPER_GVSPP,
};
pub use raster::{bench_raster, RasterRow};
pub use rv::{bench_rv, RvBenchOptions, RvRow};
pub use share::{
    bench_share, cost_at_error, ShareBenchOptions, ShareReport, ShareRow, ShareSpeedup,
    INDEPENDENT, SHARED,
};
pub use trace::{bench_trace, TraceBackend, TraceRays, TraceRow, TRACE_ROUNDS};
