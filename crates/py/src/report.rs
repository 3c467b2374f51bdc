//! `sightline.report(...)`: the HTML visibility report of `sightline report` for a loaded scene
//! and one of its PVS files: summary, per-cell PVS size and pixel error, worst views,
//! convergence plots, GVS++ against RAND at equal small budgets and a map of the cells, written
//! to `out_dir/index.html` (atomically), with the CLI's `--json` summary returned as a dict.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use sightline_core::atomic_file::write_atomic;
use sightline_core::Scene;
use sightline_eval::report::budgets::bake_budget_sets;
use sightline_eval::report::html::page;
use sightline_eval::report::{pvs_report, BudgetOptions, PvsReport, PvsReportOptions};
use sightline_eval::{EvalParams, ViewMode};
use sightline_region::PvsFile;

use crate::convert::{io_error, value_error};
use crate::pvs::PyPvs;
use crate::scene::PyScene;

/// The largest image size of the evaluation (as `sightline report --size`).
const MAX_SIZE: u32 = 4096;

/// Why the report could not be written: bad input (`ValueError`) or a file (`OSError`).
enum Failure {
    Input(String),
    Io(String),
}

impl From<Failure> for PyErr {
    fn from(f: Failure) -> Self {
        match f {
            Failure::Input(m) => value_error(m),
            Failure::Io(m) => io_error(m),
        }
    }
}

/// Writes the HTML report of `pvs` (made for `scene`) to `index.html` in the folder `out_dir`, as
/// `sightline report` does, and returns its summary (the CLI's `--json`) as a dict.
///
/// - `views`: viewpoints per cell (default 16); `size`: image size in pixels, square, 1 to
///   4096 (default 256); `view_mode`: `"cube"` (six 90-degree faces per viewpoint) or
///   `"random"` (one random 90-degree view); `seed` of the viewpoints and of the comparison's
///   bakes (default 1).
/// - `worst`: worst views shown, one per cell (default 6); `cell_rows`: rows of the cell table
///   shown before its "show all" toggle, the worst cells (default 20).
/// - `budgets`: ray budgets per cell of the GVS++ / RAND comparison at equal budgets (default
///   250k and 1M rays); `None` or `[]` leaves it out; `budget_cells`: cells it bakes (default
///   4, spread over the file).
///
/// Raises `ValueError` for bad arguments, a `pvs` of another scene, or an output that is the
/// scene or `.pvs` file; `OSError` when the page cannot be written.
#[pyfunction]
#[pyo3(signature = (
    scene, pvs, out_dir, views = 16, size = 256, view_mode = "cube", worst = 6, seed = 1,
    budgets = Some(vec![250_000, 1_000_000]), budget_cells = 4, cell_rows = 20
))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn report<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    pvs: &Bound<'py, PyPvs>,
    out_dir: PathBuf,
    views: usize,
    size: u32,
    view_mode: &str,
    worst: usize,
    seed: u64,
    budgets: Option<Vec<u64>>,
    budget_cells: usize,
    cell_rows: usize,
) -> PyResult<Bound<'py, PyAny>> {
    if views == 0 || size == 0 || size > MAX_SIZE {
        return Err(value_error(format!(
            "views must be >= 1 and size in 1..={MAX_SIZE}"
        )));
    }
    let views_mode = match view_mode {
        "cube" => ViewMode::CubeFaces,
        "random" => ViewMode::Random,
        other => {
            return Err(value_error(format!(
                "view_mode must be 'cube' or 'random', not '{other}'"
            )))
        }
    };
    let data = scene.get().data.clone();
    let pvs = pvs.get();
    pvs.file.check_scene(&data.scene).map_err(value_error)?;
    let index = out_dir.join("index.html");
    let pvs_path = pvs.path.as_deref();
    let inputs: Vec<&Path> = [Some(Path::new(&data.scene.source)), pvs_path]
        .into_iter()
        .flatten()
        .collect();
    refuse_overwriting_inputs(&[&out_dir, &index], &inputs)?;
    let options = PvsReportOptions {
        params: EvalParams {
            viewpoints: views,
            resolution: size,
            views: views_mode,
            seed,
        },
        worst_views: worst,
        cell_rows,
    };
    let budget_options = budgets
        .filter(|b| !b.is_empty())
        .map(|budgets| BudgetOptions {
            budgets,
            cells: budget_cells,
            seed,
        });
    if let Some(o) = &budget_options {
        o.validate().map_err(value_error)?;
    }
    let label = pvs_path.map_or_else(
        || "a sightline.Pvs in memory".to_string(),
        |p| p.display().to_string(),
    );
    let job = Job {
        scene: &data.scene,
        file: &pvs.file,
        label: &label,
        options: &options,
        budgets: budget_options.as_ref(),
        index: &index,
    };
    let report = py.detach(|| job.run())?;
    summary(py, &job, &report)
}

/// The work of one report, run without the GIL.
struct Job<'a> {
    scene: &'a Scene,
    file: &'a PvsFile,
    label: &'a str,
    options: &'a PvsReportOptions,
    budgets: Option<&'a BudgetOptions>,
    index: &'a Path,
}

impl Job<'_> {
    /// Bakes the comparison (when asked for), evaluates, and writes the page.
    fn run(&self) -> Result<PvsReport, Failure> {
        let input = |e: sightline_eval::report::ReportError| Failure::Input(e.to_string());
        if let Some(dir) = self.index.parent() {
            std::fs::create_dir_all(dir)
                .map_err(|e| Failure::Io(format!("creating {}: {e}", dir.display())))?;
        }
        let bakes = self
            .budgets
            .map(|o| bake_budget_sets(self.scene, self.file, o, &|_, _| {}))
            .transpose()
            .map_err(input)?;
        let report = pvs_report(
            self.scene,
            self.file,
            self.label,
            self.options,
            &[],
            bakes.as_ref(),
            &|_, _, _| {},
        )
        .map_err(input)?;
        let html = page(
            "sightline PVS report",
            &format!(
                "{} view cells of {} ({} triangles), from {}.",
                self.file.cells.len(),
                self.scene.source,
                self.scene.triangle_count(),
                self.label
            ),
            &report.sections,
        );
        write_atomic(self.index, |w| {
            std::io::Write::write_all(w, html.as_bytes())
        })
        .map_err(|e| Failure::Io(format!("writing {}: {e}", self.index.display())))?;
        Ok(report)
    }
}

/// The CLI's `--json` summary as a Python dict.
fn summary<'py>(py: Python<'py>, job: &Job<'_>, report: &PvsReport) -> PyResult<Bound<'py, PyAny>> {
    let cells: Vec<serde_json::Value> = report
        .outcomes
        .iter()
        .enumerate()
        .map(|(i, o)| {
            serde_json::json!({
                "cell": i,
                "pvs_size": o.eval.pvs_size,
                "avg_error_pixels": o.eval.avg_error_pixels,
                "max_error_pixels": o.eval.max_error_pixels,
                "avg_unconfirmed_pixels": o.eval.avg_unconfirmed_pixels,
                "false_negatives": o.eval.false_negatives,
                "rejected_viewpoints": o.rejected,
            })
        })
        .collect();
    let value = serde_json::json!({
        "report": job.index.display().to_string(),
        "scene": job.scene.source,
        "cells": cells,
        "budgets": report.budgets,
    });
    let text = serde_json::to_string(&value).map_err(value_error)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Refuses an output that is one of the inputs (a file that exists): the report replaces its
/// output atomically, so it would replace the scene or `.pvs` file by a page.
fn refuse_overwriting_inputs(outputs: &[&Path], inputs: &[&Path]) -> Result<(), Failure> {
    for output in outputs {
        if let Some(input) = inputs
            .iter()
            .find(|input| input.is_file() && same_file(output, input))
        {
            return Err(Failure::Input(format!(
                "the output {} is the input {}: refusing to overwrite an input; choose another \
                 output directory",
                output.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// True when `a` and `b` are one file: the same device and inode (Unix), or the same canonical
/// path.
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}
