//! The HTML visibility report of `sightline report` and `sightline demo`: one self-contained
//! page (inline CSS, SVG and base64 PNG; no network, no external files) with a PVS's summary,
//! per-cell table, worst views, convergence plots and a map of the view cells.
//!
//! Files: `html` (escaping, tables, page shell), `base64`, `colour` (the map's scale),
//! `plan` (the projection from above and its pixel frame), `footprint` (top-down height map),
//! `map` (cells from above), `plot` (line plots), `metadata` (the bake's records), `evaluate`
//! (pixel error and worst views), `sections` (the parts of a PVS report), `shading` (id colours and the shaded image),
//! `budgets` (GVS++ against RAND at small equal budgets on a few cells), `error` ([`ReportError`]).

pub(crate) mod base64;
pub mod budgets;
pub mod colour;
pub mod error;
pub mod evaluate;
pub(crate) mod footprint;
pub(crate) mod growth;
pub mod html;
pub(crate) mod map;
pub(crate) mod metadata;
pub mod plan;
pub mod plot;
pub(crate) mod sections;
pub mod shading;

use crate::EvalParams;
use sightline_core::{Scene, TriangleSet};
use sightline_region::PvsFile;

pub use budgets::{BudgetBakes, BudgetOptions, BudgetSummary};
pub use error::ReportError;
pub use evaluate::CellOutcome;
pub use html::Section;
pub use map::convex_hull;
pub use plan::Plan;

/// How a PVS is judged and shown.
#[derive(Clone, Copy, Debug)]
pub struct PvsReportOptions {
    /// The evaluation's viewpoints, views and resolution.
    pub params: EvalParams,
    /// Worst views shown (one per cell, the cells with the most erroneous pixels first).
    pub worst_views: usize,
    /// Rows of the cell table shown before its "show all" toggle (the worst cells).
    pub cell_rows: usize,
}

/// A PVS report: its sections and the numbers behind them.
pub struct PvsReport {
    /// Summary, map, worst views, cells, convergence, equal budgets (when baked).
    pub sections: Vec<Section>,
    /// Per-cell evaluation, in the file's cell order.
    pub outcomes: Vec<CellOutcome>,
    /// GVS++ against RAND at equal budgets, when `budgets` were given.
    pub budgets: Option<BudgetSummary>,
}

/// The cells with erroneous pixels, the largest average error first.
fn with_errors_worst_first(outcomes: &[CellOutcome]) -> Vec<usize> {
    sections::worst_first(outcomes)
        .into_iter()
        .filter(|&i| outcomes[i].eval.avg_error_pixels > 0.0)
        .collect()
}

/// Evaluates `file` (made for `scene`; the caller checks) and builds its sections.
/// `extra[i]` are further sets for cell `i` judged on the same views (their evaluations come
/// back in `outcomes[i].extra`, before those of `budgets`); `budgets` are the sets of the
/// equal-budget comparison ([`budgets::bake_budget_sets`]), judged the same way and shown in
/// their own section; `progress(cell, view, views)` reports the evaluation.
pub fn pvs_report(
    scene: &Scene,
    file: &PvsFile,
    pvs_label: &str,
    options: &PvsReportOptions,
    extra: &[Vec<TriangleSet>],
    budgets: Option<&BudgetBakes>,
    progress: &dyn Fn(usize, usize, usize),
) -> Result<PvsReport, ReportError> {
    // Every cell's extra sets, borrowed: the caller's, then the comparison's.
    let callers = |i: usize| extra.get(i).map_or(&[][..], Vec::as_slice);
    let mut all: Vec<Vec<&TriangleSet>> = (0..file.cells.len())
        .map(|i| callers(i).iter().collect())
        .collect();
    if let Some(b) = budgets {
        for (cell, runs) in &b.cells {
            all[*cell].extend(runs.iter().map(|(_, set)| set));
        }
    }
    let outcomes = evaluate::evaluate_cells(scene, file, &options.params, &all, progress)?;
    let summary = budgets.map(|b| BudgetSummary::new(b, &outcomes, &|i| callers(i).len()));
    let worst = evaluate::worst_views(
        scene,
        file,
        &outcomes,
        options.params.resolution,
        options.worst_views,
    );
    // What a designer looks at first: the summary, where the cells are weak, the worst views;
    // then the per-cell numbers and the curves.
    let mut sections = vec![
        sections::summary(scene, file, pvs_label, &options.params, &outcomes),
        sections::cell_map(scene, file, &outcomes)?,
        sections::worst_views(&worst, options.worst_views)?,
        sections::cell_table(scene, file, &outcomes, options.cell_rows),
        sections::convergence(file, &with_errors_worst_first(&outcomes))?,
    ];
    if let Some(s) = &summary {
        sections.push(budgets::budget_section(s, options.params.resolution)?);
    }
    Ok(PvsReport {
        sections,
        outcomes,
        budgets: summary,
    })
}
