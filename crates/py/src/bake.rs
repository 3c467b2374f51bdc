//! Baking PVSs from Python: one cell, a batch of cells with their global indices (what a
//! distributed worker runs), or a whole list into a `.pvs` in memory.
//!
//! Every cell's seed is `cell_seed(seed, global_index)`, the rule of
//! `sightline_region::bake::bake` and so of `sightline pvs bake`: a cell's set does not depend
//! on which batch or machine bakes it.

use std::time::Duration;

use glam::Vec3;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sightline_core::TriangleSet;
use sightline_region::methods::{sampler, MethodOverrides, MethodParams};
use sightline_region::{Budget, CellContext, PvsFile, Sampler, ViewCell};

use crate::cells::PyViewCell;
use crate::pvs::PyPvs;
use crate::scene::{PyScene, SceneData};
use crate::{ids_array, value_error};

/// A sampling method with its parameters (the options of `sightline pvs bake`).
///
/// `Method("gvs++", n_rand=100_000)`; bake functions also take the bare name.
#[pyclass(module = "sightline", name = "Method", frozen)]
#[derive(Clone)]
pub(crate) struct PyMethod {
    name: String,
    options: MethodOptions,
    params: MethodParams,
}

/// The optional parameters as given (kept for `repr` and pickling).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct MethodOptions {
    n_rand: Option<u64>,
    n_abs_edge: Option<u32>,
    delta_abs: Option<f32>,
    n_rs_edge: Option<u32>,
    n_rs_area: Option<u32>,
    delta: Option<f32>,
    termination: Option<usize>,
    raster_resolution: Option<u32>,
}

impl MethodOptions {
    /// The same mapping from options to parameters as the CLI's `pvs bake`.
    fn params(&self) -> MethodParams {
        MethodOverrides {
            n_rand: self.n_rand,
            n_abs_edge: self.n_abs_edge,
            delta_abs: self.delta_abs,
            n_rs_edge: self.n_rs_edge,
            n_rs_area: self.n_rs_area,
            delta: self.delta,
            termination: self.termination,
            raster_resolution: self.raster_resolution,
        }
        .params()
    }
}

impl PyMethod {
    fn from_options(name: &str, options: MethodOptions) -> PyResult<Self> {
        let params = options.params();
        // Validate now so that a bad method fails where it is made, not in a worker.
        sampler(name, &params).map_err(value_error)?;
        Ok(Self {
            name: name.to_string(),
            options,
            params,
        })
    }

    fn sampler(&self) -> PyResult<Box<dyn Sampler>> {
        sampler(&self.name, &self.params).map_err(value_error)
    }
}

#[pymethods]
impl PyMethod {
    /// A method by name (`gvs++`, `gvs`, `rand`, `raster`) with optional parameters; see
    /// `sightline pvs bake --help` for their meaning.
    #[new]
    #[pyo3(signature = (name = "gvs++", *, n_rand = None, n_abs_edge = None, delta_abs = None,
        n_rs_edge = None, n_rs_area = None, delta = None, termination = None,
        raster_resolution = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        name: &str,
        n_rand: Option<u64>,
        n_abs_edge: Option<u32>,
        delta_abs: Option<f32>,
        n_rs_edge: Option<u32>,
        n_rs_area: Option<u32>,
        delta: Option<f32>,
        termination: Option<usize>,
        raster_resolution: Option<u32>,
    ) -> PyResult<Self> {
        let options = MethodOptions {
            n_rand,
            n_abs_edge,
            delta_abs,
            n_rs_edge,
            n_rs_area,
            delta,
            termination,
            raster_resolution,
        };
        Self::from_options(name, options)
    }

    /// The method's name.
    #[getter]
    fn name(&self) -> String {
        self.name.clone()
    }

    fn __repr__(&self) -> String {
        format!("Method('{}', {:?})", self.name, self.options)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        // Rebuilt through the keyword-free helper below, in the field order of MethodOptions.
        let o = self.options;
        let args = (
            self.name.clone(),
            o.n_rand,
            o.n_abs_edge,
            o.delta_abs,
            o.n_rs_edge,
            o.n_rs_area,
            o.delta,
            o.termination,
            o.raster_resolution,
        );
        let ctor = py.get_type::<PyMethod>().getattr("_from_positional")?;
        PyTuple::new(py, [ctor, args.into_pyobject(py)?.into_any()])
    }

    /// Unpickling helper: the constructor's arguments by position.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (name, n_rand, n_abs_edge, delta_abs, n_rs_edge, n_rs_area, delta,
        termination, raster_resolution))]
    fn _from_positional(
        name: &str,
        n_rand: Option<u64>,
        n_abs_edge: Option<u32>,
        delta_abs: Option<f32>,
        n_rs_edge: Option<u32>,
        n_rs_area: Option<u32>,
        delta: Option<f32>,
        termination: Option<usize>,
        raster_resolution: Option<u32>,
    ) -> PyResult<Self> {
        Self::new(
            name,
            n_rand,
            n_abs_edge,
            delta_abs,
            n_rs_edge,
            n_rs_area,
            delta,
            termination,
            raster_resolution,
        )
    }
}

/// A method argument: a name or a `Method`.
#[derive(FromPyObject)]
pub(crate) enum MethodArg<'py> {
    /// A configured method.
    Method(Bound<'py, PyMethod>),
    /// A bare name with default parameters.
    Name(String),
}

impl MethodArg<'_> {
    fn resolve(&self) -> PyResult<PyMethod> {
        match self {
            MethodArg::Method(m) => Ok(m.get().clone()),
            MethodArg::Name(n) => PyMethod::from_options(n, MethodOptions::default()),
        }
    }
}

/// The budget from `rays` / `time_ms`; both absent lets the method stop by its own rule.
fn budget(rays: Option<u64>, time_ms: Option<u64>) -> PyResult<Budget> {
    if rays == Some(0) || time_ms == Some(0) {
        return Err(value_error("rays and time_ms must be positive"));
    }
    Ok(Budget {
        max_rays: rays,
        max_time: time_ms.map(Duration::from_millis),
    })
}

/// Runs `work` on a pool of `threads` threads (all cores when `None`).
fn with_threads<T: Send>(
    threads: Option<usize>,
    work: impl FnOnce() -> T + Send,
) -> Result<T, String> {
    match threads {
        None => Ok(work()),
        Some(0) => Err("threads must be >= 1".to_string()),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| format!("cannot start {n} threads: {e}"))?;
            Ok(pool.install(work))
        }
    }
}

/// Bakes `cells` (with global indices `indices`) one after the other, as the bake driver does.
fn bake_batch(
    data: &SceneData,
    cells: &[ViewCell],
    indices: &[usize],
    sampler: &dyn Sampler,
    budget: &Budget,
    seed: u64,
) -> Vec<TriangleSet> {
    let bvh = data.bvh();
    // The CLI's free-space test for plain (non-Quake-3-leaf) cells: the whole cell.
    let inside = |_: Vec3| true;
    cells
        .iter()
        .zip(indices)
        .map(|(cell, &index)| {
            let ctx = CellContext {
                scene: &data.scene,
                caster: bvh,
                cell,
                seed: sightline_region::bake::cell_seed(seed, index),
                free_space: Some(&inside),
            };
            sampler.sample(&ctx, budget, &|_| {}).visible
        })
        .collect()
}

/// The seed `sightline pvs bake --seed SEED` gives the cell at `index`.
#[pyfunction]
pub(crate) fn cell_seed(seed: u64, index: usize) -> u64 {
    sightline_region::bake::cell_seed(seed, index)
}

/// Bakes one cell: the ids of its potentially visible triangles (uint32, increasing).
/// `index` is the cell's position in the whole bake (it picks the cell's seed).
#[pyfunction]
#[pyo3(signature = (scene, cell, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, index = 0, time_ms = None, threads = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake_cell<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cell: PyViewCell,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    index: usize,
    time_ms: Option<u64>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray1<u32>>> {
    let sets = bake_cells(
        py,
        scene,
        vec![cell],
        method,
        rays,
        seed,
        Some(vec![index]),
        time_ms,
        threads,
    )?;
    sets.into_iter()
        .next()
        .ok_or_else(|| value_error("internal: no result for the cell"))
}

/// Bakes a batch of cells: one id array per cell. `indices` are the cells' global indices in
/// the whole bake (default `0..len(cells)`); they pick each cell's seed.
#[pyfunction]
#[pyo3(signature = (scene, cells, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, indices = None, time_ms = None, threads = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake_cells<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    indices: Option<Vec<usize>>,
    time_ms: Option<u64>,
    threads: Option<usize>,
) -> PyResult<Vec<Bound<'py, PyArray1<u32>>>> {
    let method = method.resolve()?;
    let sampler = method.sampler()?;
    let budget = budget(rays, time_ms)?;
    let indices = indices.unwrap_or_else(|| (0..cells.len()).collect());
    if indices.len() != cells.len() {
        return Err(value_error(format!(
            "indices has {} entries for {} cells",
            indices.len(),
            cells.len()
        )));
    }
    let cells: Vec<ViewCell> = cells.into_iter().map(|c| c.cell).collect();
    let data = scene.get().data.clone();
    let sampler = sampler.as_ref();
    let sets = py
        .detach(|| {
            with_threads(threads, || {
                bake_batch(&data, &cells, &indices, sampler, &budget, seed)
            })
        })
        .map_err(value_error)?;
    Ok(sets.iter().map(|s| ids_array(py, s)).collect())
}

/// Bakes `cells` on this machine with the bake driver of `sightline pvs bake`: a `Pvs` whose
/// cells and sets equal the CLI's for the same scene, cells, method, budget and seed.
#[pyfunction]
#[pyo3(signature = (scene, cells, method = MethodArg::Name("gvs++".into()), rays = None,
    seed = 1, time_ms = None, threads = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn bake<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    cells: Vec<PyViewCell>,
    method: MethodArg<'py>,
    rays: Option<u64>,
    seed: u64,
    time_ms: Option<u64>,
    threads: Option<usize>,
) -> PyResult<PyPvs> {
    let method = method.resolve()?;
    let sampler = method.sampler()?;
    let budget = budget(rays, time_ms)?;
    let cells: Vec<ViewCell> = cells.into_iter().map(|c| c.cell).collect();
    let data = scene.get().data.clone();
    let sampler = sampler.as_ref();
    let extra = serde_json::json!({
        "parameters": format!("{:?}", method.params),
        "via": "python",
    });
    let file: PvsFile = py
        .detach(|| {
            with_threads(threads, || {
                sightline_region::bake::bake(
                    &data.scene,
                    data.bvh(),
                    &cells,
                    sampler,
                    &|_, _| true,
                    &budget,
                    seed,
                    extra,
                    &|_, _| {},
                    &mut |_, _| {},
                )
            })
        })
        .map_err(value_error)?;
    Ok(PyPvs { file })
}
