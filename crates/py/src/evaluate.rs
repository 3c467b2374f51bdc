//! `sightline.evaluate`: the pixel error of a PVS per cell, as `sightline eval` measures it
//! (the GVS++ paper's metric), for notebooks and pipelines that judge bakes in Python.

use pyo3::prelude::*;
use serde::Serialize;
use sightline_eval::report::evaluate::{Rejected, Viewpoints};
use sightline_eval::{evaluate_cell_in, CellEvaluation, EvalParams, ViewMode};

use crate::convert::value_error;
use crate::pvs::PyPvs;
use crate::scene::PyScene;

/// The largest image size of the evaluation (as `sightline eval --size`).
const MAX_SIZE: u32 = 8192;

/// One cell's row, as `sightline eval --json` prints it.
#[derive(Serialize)]
struct Row {
    cell: usize,
    #[serde(flatten)]
    evaluation: CellEvaluation,
    rejected_viewpoints: Rejected,
}

/// The pixel error of `pvs` (made for `scene`) per cell, as `sightline eval SCENE PVS --json`
/// measures it: a list of dicts, one per cell evaluated, with the cell's index (`cell`), its
/// `pvs_size`, `avg_error_pixels` (erroneous pixels per view: pixels whose triangle in the
/// full-scene render is missing from the PVS, confirmed by a ray), `max_error_pixels`,
/// `false_negatives` (triangles seen but missing), the other measures of `sightline eval`, and
/// `rejected_viewpoints` (viewpoints left out: inside solid geometry, or outside a Quake 3
/// cell's cluster).
///
/// `views`: viewpoints per cell (default 16); `size`: image size in pixels, square, 1 to 8192
/// (default 256); `view_mode`: `"cube"` (six faces per viewpoint) or `"random"` (one 90-degree
/// view); `seed` of the viewpoints (default 1); `cells`: the cell indices to evaluate (default
/// all).
///
/// Raises `ValueError` for bad arguments, a cell that does not exist, or a `pvs` of another
/// scene. The GIL is released while it works.
#[pyfunction]
#[pyo3(signature = (scene, pvs, views = 16, size = 256, view_mode = "cube", seed = 1, cells = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn evaluate<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    pvs: &Bound<'py, PyPvs>,
    views: usize,
    size: u32,
    view_mode: &str,
    seed: u64,
    cells: Option<Vec<usize>>,
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
    let file = &pvs.get().file;
    file.check_scene(&data.scene).map_err(value_error)?;
    let indices = cells.unwrap_or_else(|| (0..file.cells.len()).collect());
    if let Some(&bad) = indices.iter().find(|&&i| i >= file.cells.len()) {
        return Err(value_error(format!(
            "cell {bad} does not exist (the file has {} cells)",
            file.cells.len()
        )));
    }
    let params = EvalParams {
        viewpoints: views,
        resolution: size,
        views: views_mode,
        seed,
    };
    let rows = py.detach(|| -> Result<Vec<Row>, String> {
        let scene = &data.scene;
        let viewpoints = Viewpoints::of(scene, file, None).map_err(|e| e.to_string())?;
        Ok(indices
            .iter()
            .map(|&i| {
                let cell = &file.cells[i];
                let filter = viewpoints.cell(i);
                let evaluation = evaluate_cell_in(
                    scene,
                    &cell.cell,
                    &|p| filter.allows(p),
                    &[&cell.visible],
                    &params,
                    &|_, _| {},
                )
                .remove(0);
                Row {
                    cell: i,
                    evaluation,
                    rejected_viewpoints: filter.rejected(),
                }
            })
            .collect())
    });
    let rows = rows.map_err(value_error)?;
    let text = serde_json::to_string(&rows).map_err(value_error)?;
    py.import("json")?.call_method1("loads", (text,))
}
