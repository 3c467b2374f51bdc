//! `sightline.ViewCell` and `sightline.grid`: the regions a PVS is baked for.

use glam::Vec3;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sightline_region::ViewCell;

use crate::convert::value_error;

/// An oriented box (or flat rectangle) view cell: centre, orthonormal axes, half extents.
///
/// `ViewCell(center, axes, half_extents)`: `center` (3 floats), `axes` (three orthonormal
/// 3-vectors), `half_extents` (3 floats, each at least 0; one of them 0 makes a flat
/// rectangle). `ViewCell.box(min, max)` makes an axis-aligned box; `ViewCell.parse(spec)` reads
/// the CLI's `--cell` syntax. Raises `ValueError` for axes that are not orthonormal or extents
/// that are negative or not finite.
#[pyclass(module = "sightline", name = "ViewCell", frozen, eq, from_py_object)]
#[derive(Clone, PartialEq)]
pub(crate) struct PyViewCell {
    pub cell: ViewCell,
}

fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

#[pymethods]
impl PyViewCell {
    /// An oriented box from its centre, three orthonormal axes and half extents.
    #[new]
    fn new(center: [f32; 3], axes: [[f32; 3]; 3], half_extents: [f32; 3]) -> PyResult<Self> {
        let cell = ViewCell::oriented(
            vec3(center),
            [vec3(axes[0]), vec3(axes[1]), vec3(axes[2])],
            vec3(half_extents),
        )
        .map_err(value_error)?;
        Ok(Self { cell })
    }

    /// An axis-aligned box from its corners (equal min and max on one axis: a rectangle).
    #[staticmethod]
    #[pyo3(name = "box")]
    fn aabb(min: [f32; 3], max: [f32; 3]) -> PyResult<Self> {
        let (lo, hi) = (vec3(min), vec3(max));
        if lo.cmpgt(hi).any() {
            return Err(value_error(format!(
                "view cell box: min {min:?} must be <= max {max:?} on every axis"
            )));
        }
        let cell = ViewCell::aabb(lo, hi).map_err(value_error)?;
        Ok(Self { cell })
    }

    /// Parses the CLI's `--cell` syntax: `box:MINX,MINY,MINZ,MAXX,MAXY,MAXZ` or `point:X,Y,Z,R`.
    #[staticmethod]
    fn parse(spec: &str) -> PyResult<Self> {
        let cell = ViewCell::parse(spec).map_err(value_error)?;
        Ok(Self { cell })
    }

    /// Centre, float32 array of 3.
    #[getter]
    fn center<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_vec(py, self.cell.center.to_array().to_vec())
    }

    /// The three axes as a tuple of 3-tuples.
    #[getter]
    fn axes(&self) -> [[f32; 3]; 3] {
        self.cell.axes.map(|a| a.to_array())
    }

    /// Half extents along the axes, float32 array of 3.
    #[getter]
    fn half_extents<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f32>> {
        PyArray1::from_vec(py, self.cell.half_extents.to_array().to_vec())
    }

    /// True for a flat rectangle.
    #[getter]
    fn is_flat(&self) -> bool {
        self.cell.is_flat()
    }

    /// True when `point` is inside or on the cell.
    fn contains(&self, point: [f32; 3]) -> bool {
        self.cell.contains(vec3(point))
    }

    fn __repr__(&self) -> String {
        let c = &self.cell;
        format!(
            "ViewCell(center={:?}, axes={:?}, half_extents={:?})",
            c.center.to_array(),
            c.axes.map(|a| a.to_array()),
            c.half_extents.to_array()
        )
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let c = &self.cell;
        let args = (
            c.center.to_array(),
            c.axes.map(|a| a.to_array()),
            c.half_extents.to_array(),
        );
        PyTuple::new(
            py,
            [
                py.get_type::<PyViewCell>().into_any(),
                args.into_pyobject(py)?.into_any(),
            ],
        )
    }
}

/// A regular grid of axis-aligned cells filling the box from `min` to `max` (3 floats each):
/// `counts` is `(nx, ny, nz)`, cells per axis (each at least 1), listed x fastest (the order
/// of the CLI's `--grid`). Raises `ValueError` for bounds that are not finite or not ordered.
#[pyfunction]
pub(crate) fn grid(min: [f32; 3], max: [f32; 3], counts: [u32; 3]) -> PyResult<Vec<PyViewCell>> {
    let (lo, hi) = (vec3(min), vec3(max));
    if !lo.is_finite() || !hi.is_finite() || lo.cmpgt(hi).any() {
        return Err(value_error(format!(
            "grid bounds {min:?}..{max:?}: need finite min <= max on every axis"
        )));
    }
    if counts.iter().any(|&n| n == 0 || n > 4096) {
        return Err(value_error(format!(
            "grid counts {counts:?} must be whole numbers in 1..=4096"
        )));
    }
    let cells = ViewCell::grid(lo, hi, counts).map_err(value_error)?;
    Ok(cells.into_iter().map(|cell| PyViewCell { cell }).collect())
}
