//! Convergence curves for `bench pvs --plot`: average erroneous pixels against rays for every
//! sampler on one cell. Only the data; drawing it is the caller's (the CLI's SVG plot).
//!
//! Method: each sampler runs at 1/16, 1/8, 1/4, 1/2 and 1 times the rays the first sampler
//! (GVS++) needs to converge, and all resulting sets are judged on the same views, so the
//! curves differ only by sampler and ray count. Errors are floored at [`ERROR_FLOOR`] so a
//! log scale can show a zero error.

use serde::Serialize;
use sightline_core::TriangleSet;
use sightline_region::{Budget, CellContext, CellResult, ConvergencePoint, Sampler};

use crate::pixel_error::{evaluate_cell, EvalParams};

/// The fractions of the converged ray count each sampler runs at.
pub const FRACTIONS: [f64; 5] = [1.0 / 16.0, 0.125, 0.25, 0.5, 1.0];

/// The error a zero error is drawn at on a log scale.
pub const ERROR_FLOOR: f64 = 1e-3;

/// One sampler's curve.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct ConvergenceSeries {
    /// The sampler's name (`gvs++`, `rand`, ...).
    pub method: &'static str,
    /// (rays, at least 1; average erroneous pixels per view, at least [`ERROR_FLOOR`]), one
    /// per fraction in [`FRACTIONS`].
    pub points: Vec<(f64, f64)>,
}

/// The curves of all samplers on one cell.
#[derive(Serialize, Clone, Debug, PartialEq)]
pub struct Convergence {
    /// One series per sampler, in the order given.
    pub series: Vec<ConvergenceSeries>,
}

impl Convergence {
    /// The smallest and largest ray count of all points.
    pub fn ray_range(&self) -> (f64, f64) {
        self.points()
            .fold((f64::MAX, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)))
    }

    /// The largest error of all points, at least 1.
    pub fn max_error(&self) -> f64 {
        self.points().fold(1.0f64, |a, p| a.max(p.1))
    }

    fn points(&self) -> impl Iterator<Item = &(f64, f64)> {
        self.series.iter().flat_map(|s| &s.points)
    }
}

/// The convergence curves of `samplers` on `ctx`'s cell (the first sets the ray counts).
pub fn convergence_curves(
    ctx: &CellContext<'_>,
    samplers: &[&dyn Sampler],
    eval: &EvalParams,
) -> Convergence {
    let none = &|_: &ConvergencePoint| {};
    let Some(first) = samplers.first() else {
        return Convergence { series: Vec::new() };
    };
    let converged = first.sample(ctx, &Budget::default(), none);
    let mut runs: Vec<(&'static str, CellResult)> = Vec::new();
    for s in samplers {
        for f in FRACTIONS {
            let budget = Budget::rays(((converged.rays as f64 * f) as u64).max(1));
            runs.push((s.name(), s.sample(ctx, &budget, none)));
        }
    }
    let sets: Vec<&TriangleSet> = runs.iter().map(|(_, r)| &r.visible).collect();
    let evaluations = evaluate_cell(ctx.scene, ctx.cell, &sets, eval, &|_, _| {});
    let series = samplers
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let at = k * FRACTIONS.len()..(k + 1) * FRACTIONS.len();
            let points = runs[at.clone()]
                .iter()
                .zip(&evaluations[at])
                .map(|((_, r), e)| (r.rays.max(1) as f64, e.avg_error_pixels.max(ERROR_FLOOR)))
                .collect();
            ConvergenceSeries {
                method: s.name(),
                points,
            }
        })
        .collect();
    Convergence { series }
}
