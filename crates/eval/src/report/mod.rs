//! The HTML visibility report of `sightline report` and `sightline demo`: one self-contained
//! page (inline CSS, SVG and base64 PNG; no network, no external files) with a PVS's summary,
//! per-cell table, worst views, convergence plots and a map of the view cells.
//!
//! Files: `html` (escaping, tables, page shell), `base64`, `colour` (the map's scale),
//! `plan` (the projection from above and its pixel frame), `footprint` (top-down height map),
//! `map` (cells from above), `plot` (line plots), `metadata` (the bake's records), `evaluate`
//! (pixel error and worst views), `sections` (the parts of a PVS report), `shading` (id colours and the shaded image).

pub(crate) mod base64;
pub mod colour;
pub mod evaluate;
pub(crate) mod footprint;
pub mod html;
pub(crate) mod map;
pub(crate) mod metadata;
pub(crate) mod plan;
pub mod plot;
pub(crate) mod sections;
pub mod shading;

use crate::EvalParams;
use anyhow::Result;
use sightline_core::{Scene, TriangleSet};
use sightline_region::PvsFile;

pub use evaluate::CellOutcome;
pub use html::Section;

/// How a PVS is judged and shown.
#[derive(Clone, Copy, Debug)]
pub struct PvsReportOptions {
    /// The evaluation's viewpoints, views and resolution.
    pub params: EvalParams,
    /// Worst views shown (one per cell, the cells with the most erroneous pixels first).
    pub worst_views: usize,
}

/// A PVS report: its sections and the numbers behind them.
pub struct PvsReport {
    /// Summary, cells, worst views, convergence, map.
    pub sections: Vec<Section>,
    /// Per-cell evaluation, in the file's cell order.
    pub outcomes: Vec<CellOutcome>,
}

/// Evaluates `file` (made for `scene`; the caller checks) and builds its sections.
/// `extra[i]` are further sets for cell `i` judged on the same views (their evaluations come
/// back in `outcomes[i].extra`); `progress(cell, view, views)` reports the evaluation.
pub fn pvs_report(
    scene: &Scene,
    file: &PvsFile,
    pvs_label: &str,
    options: &PvsReportOptions,
    extra: &[Vec<TriangleSet>],
    progress: &dyn Fn(usize, usize, usize),
) -> Result<PvsReport> {
    let outcomes = evaluate::evaluate_cells(scene, file, &options.params, extra, progress)?;
    let worst = evaluate::worst_views(
        scene,
        file,
        &outcomes,
        options.params.resolution,
        options.worst_views,
    );
    let sections = vec![
        sections::summary(scene, file, pvs_label, &options.params, &outcomes),
        sections::cell_table(scene, file, &outcomes),
        sections::worst_views(&worst, options.worst_views)?,
        sections::convergence(file)?,
        sections::cell_map(scene, file)?,
    ];
    Ok(PvsReport { sections, outcomes })
}
