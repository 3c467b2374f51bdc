//! GVS++'s parameters and the constants of its schedule (see the module docs of `gvspp/mod.rs`
//! for why a budgeted bake schedules its rays by yield).
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, section 6 and table 1 (the
//! defaults).

use serde::Serialize;

/// Parameters of GVS++ (defaults: the paper's, section 6 and table 1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GvsPlusPlusParams {
    /// Random rays per round (`n_rand`): with `fixed_rounds` and in the shared-ray bake (the
    /// schedule by yield has no rounds).
    pub n_rand: u64,
    /// Samples along each long edge of the border polygon (`n_ABSEdge`).
    pub n_abs_edge: u32,
    /// Border polygon offset (`Δ_ABS`) as a fraction of the scene diagonal.
    pub delta_abs: f32,
    /// Reverse-sampling origins per view-cell edge (`n_RSEdge`).
    pub n_rs_edge: u32,
    /// Reverse-sampling origins on the view-cell surface (`n_RSArea`).
    pub n_rs_area: u32,
    /// Discontinuity threshold (`Δ`) as a fraction of the scene diagonal.
    pub delta_discontinuity: f32,
    /// Look for discontinuities (section 4.3) at every border sample, the `n_abs_edge` points
    /// on each long edge of the border polygon as well as its 9 vertices (ours; the paper
    /// tests the vertices only). On by default: a building seen through a gap between two
    /// found ones is usually next to neither of the gap's border *vertices*, so the paper's
    /// reverse sampling never aims at the gap (see `gvspp/mod.rs`). `false` is the paper's.
    pub edge_discontinuities: bool,
    /// Without a budget, stop when the batches (or rounds) of the last [`TERMINATION_WINDOW`]
    /// rays found fewer new triangles than this (`T`).
    pub termination_threshold: usize,
    /// Run the paper's rounds (`n_rand` random rays, then the whole exploration queue). Off by
    /// default: each batch of [`YIELD_BATCH`] rays goes to the kind of ray with the best recent
    /// yield, under a budget and to convergence alike (see the module docs).
    pub fixed_rounds: bool,
}

/// Rays per batch of a budgeted bake, each batch of one kind (random, border or reverse): about
/// 3 ms on two cores, so the schedule follows the yields closely at any budget and a batch's
/// parallel cast still amortises its set-up.
pub const YIELD_BATCH: usize = 16_384;

/// The rays over which the termination rule counts new triangles: the paper's round (10^7
/// random rays, plus their exploration).
pub const TERMINATION_WINDOW: u64 = 10_000_000;

impl Default for GvsPlusPlusParams {
    fn default() -> Self {
        Self {
            n_rand: 10_000_000,
            n_abs_edge: 20,
            delta_abs: 1e-6,
            n_rs_edge: 20,
            n_rs_area: 20,
            delta_discontinuity: 1e-5,
            edge_discontinuities: true,
            termination_threshold: 10,
            fixed_rounds: false,
        }
    }
}

impl GvsPlusPlusParams {
    /// Checks that the parameters make sense.
    pub fn validate(&self) -> Result<(), GvsPlusPlusParamsError> {
        if self.n_rand == 0 {
            return Err(GvsPlusPlusParamsError::NoRandomRays);
        }
        if !(self.delta_abs > 0.0 && self.delta_abs < 0.1) {
            return Err(GvsPlusPlusParamsError::DeltaAbs(self.delta_abs));
        }
        if !(self.delta_discontinuity >= 0.0 && self.delta_discontinuity < 0.1) {
            return Err(GvsPlusPlusParamsError::Delta(self.delta_discontinuity));
        }
        if self.n_abs_edge > 10_000 || self.n_rs_edge > 10_000 || self.n_rs_area > 100_000 {
            return Err(GvsPlusPlusParamsError::TooManySamples);
        }
        Ok(())
    }
}

/// Why [`GvsPlusPlusParams`] make no sense.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GvsPlusPlusParamsError {
    /// `n_rand` is 0.
    #[error("n_rand must be >= 1")]
    NoRandomRays,
    /// `delta_abs` is outside (0, 0.1).
    #[error("delta_abs {0} must be in (0, 0.1)")]
    DeltaAbs(f32),
    /// `delta_discontinuity` is outside [0, 0.1).
    #[error("delta {0} must be in [0, 0.1)")]
    Delta(f32),
    /// `n_abs_edge` or `n_rs_edge` is above 10,000, or `n_rs_area` above 100,000.
    #[error("sample counts are implausibly large")]
    TooManySamples,
}

/// Rays the exploration of one triangle costs on average (69 ABS rays at the defaults, plus
/// reverse sampling where its border rays find a discontinuity), for keeping the last chunk of
/// a budgeted paper-round bake within its budget.
pub(crate) const EXPLORE_RAYS_PER_TRIANGLE: f64 = 300.0;

/// Under a budget, the angle between a coarse border sampling's edge samples, seen from the
/// discovery's origin: 3 mrad, about 2 pixels of a 1000² 90° view (the GVS++ paper's evaluation
/// images). Measured on the shared scenes (docs/BENCHMARKS.md): 3 mrad took the dragon's cells
/// from 2.8x to 160x better than RAND at 1M rays.
pub(crate) const ABS_ANGLE_STEP: f32 = 0.003;

/// Triangles processed per ABS batch (each gives 9 + 3 n_ABSEdge rays).
pub(crate) const ABS_CHUNK: usize = 1024;
