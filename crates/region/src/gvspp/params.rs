//! GVS++'s parameters and the constants of its round schedule (see the module docs of
//! `gvspp/mod.rs` for why rounds are adaptive under a budget).
//!
//! Based on: Koch, Wimmer. Guided Visibility Sampling++. 2021, section 6 and table 1 (the
//! defaults).

use serde::Serialize;

/// Parameters of GVS++ (defaults: the paper's, section 6 and table 1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GvsPlusPlusParams {
    /// Random rays per round (`n_rand`).
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
    /// Stop when the rounds of the last [`TERMINATION_WINDOW`] rays found fewer new triangles
    /// than this (`T`).
    pub termination_threshold: usize,
    /// Every round casts `n_rand` random rays (the paper). Off by default: under a budget,
    /// rounds start at [`FIRST_ROUND`] rays and grow (see the module docs).
    pub fixed_rounds: bool,
}

/// Random rays in the first round of an adaptive bake: about 2 ms on two cores, so that border
/// and reverse sampling start at once however small the budget.
pub const FIRST_ROUND: u64 = 16_384;

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

/// Under a budget, the most exploration rays a round casts, as a multiple of its random rays.
/// Measured at 1M and 4M rays on free-space cells of etoile, munich and fzk_haus (`bench pvs
/// --ray-budgets`, docs/BENCHMARKS.md): 0.5 left the queue mostly unexplored (etoile 5.4x
/// better than RAND at 4M rays, fzk_haus 12x); 2, 4 and 8 were within noise of each other
/// (etoile 33x, fzk_haus 98-243x), 4 the best on munich (3.8x) and at 1M rays.
pub const EXPLORE_SHARE: f64 = 4.0;

/// Rays the exploration of one triangle costs on average (69 ABS rays at the defaults, plus
/// reverse sampling where its border rays find a discontinuity), for sizing chunks to a share.
pub(crate) const EXPLORE_RAYS_PER_TRIANGLE: f64 = 300.0;

/// Triangles processed per ABS batch (each gives 9 + 3 n_ABSEdge rays).
pub(crate) const ABS_CHUNK: usize = 1024;
