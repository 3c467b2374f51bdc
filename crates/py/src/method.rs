//! `sightline.Method`: a PVS sampling method by name with its parameters (the options of
//! `sightline pvs bake`), and the method argument of the bake functions (a `Method` or a bare
//! name).

use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sightline_point::rv::{bake_sampler, bake_sampler_for_cells};
use sightline_region::methods::{MethodOverrides, MethodParams};
use sightline_region::Sampler;

use crate::convert::value_error;

/// A sampling method with its parameters (the options of `sightline pvs bake`).
///
/// `Method("gvs++", n_rand=100_000)`; bake functions also take the bare name.
///
/// `Method(name, **parameters)`: each parameter left `None` keeps the method's default; they
/// are `sightline pvs bake`'s flags of the same names.
///
/// `name`: `"gvs++"` (Guided Visibility Sampling++, the default), `"gvs"` (the original
/// GVS), `"rand"` (random rays only), `"raster"` (cube-map rasterization from sample
/// points) or `"conservative"` (RV's from-region set: no rays, no budget, never misses a
/// visible triangle, several times larger; it reads none of the parameters). Parameters:
///
/// - `n_rand`: GVS++/GVS random rays per round (paper: 10,000,000). GVS++ has rounds only
///   with `fixed_rounds`: otherwise each batch of 16,384 rays goes to random, border,
///   reverse or neighbour sampling, whichever found the most new triangles per ray lately.
/// - `n_abs_edge`: GVS++ samples per border-polygon edge (paper: 20).
/// - `delta_abs`: GVS++/GVS border offset, a fraction of the scene diagonal (1e-6).
/// - `n_rs_edge`, `n_rs_area`: GVS++ reverse-sampling origins per cell edge and on the
///   cell surface (paper: 20 each).
/// - `delta`: GVS++/GVS discontinuity threshold, a fraction of the scene diagonal (1e-5).
/// - `termination`: without a budget GVS++/GVS stop once the last 10^7 rays (GVS: the last
///   round) found fewer new triangles than this (paper: 10).
/// - `raster_resolution`: RASTER cube-map face resolution (512).
/// - `fixed_rounds`: GVS++ runs the paper's rounds (sized for a GPU: on a CPU a budget
///   below one round is then spent on random rays alone).
/// - `paper_discontinuities`: GVS++ reverse-samples only the discontinuities at the 9
///   vertices of a border polygon, as the paper does (by default every border sample is
///   searched: it finds what is seen through gaps between found objects, with fewer rays).
///
/// Raises `ValueError` for an unknown name or a parameter out of range.
#[pyclass(module = "sightline", name = "Method", frozen)]
#[derive(Clone)]
pub(crate) struct PyMethod {
    pub(crate) name: String,
    /// The keyword arguments as given (kept for `repr` and pickling).
    options: MethodOverrides,
    pub(crate) params: MethodParams,
}

impl PyMethod {
    fn from_options(name: &str, options: MethodOverrides) -> PyResult<Self> {
        let params = options.params();
        // Validate now so that a bad method fails where it is made, not in a worker.
        bake_sampler(name, &params).map_err(value_error)?;
        Ok(Self {
            name: name.to_string(),
            options,
            params,
        })
    }

    /// A sampler of this method with its parameters.
    pub(crate) fn sampler(&self) -> PyResult<Box<dyn Sampler>> {
        bake_sampler(&self.name, &self.params).map_err(value_error)
    }

    /// [`PyMethod::sampler`] for Quake 3 leaf or cluster cells (`conservative` goes through the
    /// map's portals there).
    pub(crate) fn sampler_for_q3_cells(&self) -> PyResult<Box<dyn Sampler>> {
        bake_sampler_for_cells(&self.name, &self.params, true).map_err(value_error)
    }
}

#[pymethods]
impl PyMethod {
    /// A method by name with optional parameters (see the class documentation).
    // The keywords are the fields of `MethodOverrides`, the list the CLI's flags come from:
    // pyo3 names each keyword after its argument, and the arguments fill the struct by
    // field-init shorthand, so a field without a keyword of its name does not compile (and a
    // keyword without a field is an unused argument, which clippy refuses).
    #[new]
    #[pyo3(signature = (name = "gvs++", *, n_rand = None, n_abs_edge = None, delta_abs = None,
        n_rs_edge = None, n_rs_area = None, delta = None, termination = None,
        raster_resolution = None, fixed_rounds = false, paper_discontinuities = false))]
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
        fixed_rounds: bool,
        paper_discontinuities: bool,
    ) -> PyResult<Self> {
        let options = MethodOverrides {
            n_rand,
            n_abs_edge,
            delta_abs,
            n_rs_edge,
            n_rs_area,
            delta,
            termination,
            raster_resolution,
            fixed_rounds,
            paper_discontinuities,
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
        // Rebuilt through the keyword-free helper below, in the order of the keywords (not
        // MethodOverrides' field order: pickles from earlier versions keep unpickling).
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
            o.fixed_rounds,
            o.paper_discontinuities,
        );
        let ctor = py.get_type::<PyMethod>().getattr("_from_positional")?;
        PyTuple::new(py, [ctor, args.into_pyobject(py)?.into_any()])
    }

    /// Unpickling helper: the constructor's arguments by position.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (name, n_rand, n_abs_edge, delta_abs, n_rs_edge, n_rs_area, delta,
        termination, raster_resolution, fixed_rounds = false, paper_discontinuities = false))]
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
        fixed_rounds: bool,
        paper_discontinuities: bool,
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
            fixed_rounds,
            paper_discontinuities,
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
    pub(crate) fn resolve(&self) -> PyResult<PyMethod> {
        match self {
            MethodArg::Method(m) => Ok(m.get().clone()),
            MethodArg::Name(n) => PyMethod::from_options(n, MethodOverrides::default()),
        }
    }
}
