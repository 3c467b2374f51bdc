//! `sightline.Pvs`: a `.pvs` file in memory (cells, per-cell triangle sets, metadata), read,
//! written atomically, or assembled from id arrays (how distributed bakes merge their batches).

use std::path::PathBuf;

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use sightline_core::TriangleSet;
use sightline_region::{CellPvs, PvsError, PvsFile};

use crate::cells::PyViewCell;
use crate::convert::{ids_array, io_error, value_error};
use crate::scene::PyScene;

/// The PVS of a list of view cells for one scene. Equality (`==`) compares the scene hash,
/// triangle count, cells and sets (and bounds), not the metadata (timings differ between runs).
///
/// `Pvs(scene, cells, sets, metadata=None, bounds=None)` assembles one (as distributed bakes
/// merge their batches): `scene` the `Scene` the sets index, `cells` a list of `ViewCell`,
/// `sets` one integer id array per cell, `metadata` anything `json.dumps` takes, `bounds`
/// (optional) one id array per cell, each a superset of its set: a two-sided file whose
/// cells carry a conservative bound (`Pvs.bound(i)`). Equality also compares the bounds.
/// `Pvs.load(path)` and
/// `Pvs.from_bytes(data)` read a `.pvs` file. A `Pvs` is a sequence of id arrays (`len`,
/// `pvs[i]`, iteration) and pickles.
#[pyclass(module = "sightline", name = "Pvs", frozen)]
pub(crate) struct PyPvs {
    pub file: PvsFile,
    /// The file it was read from (`Pvs.load`), which `report` must not overwrite.
    pub path: Option<PathBuf>,
}

fn pvs_error(e: PvsError) -> PyErr {
    match e {
        PvsError::Io { .. }
        | PvsError::Read(
            sightline_runtime::Error::Io { .. } | sightline_runtime::Error::TooLarge { .. },
        ) => io_error(e),
        _ => value_error(e),
    }
}

/// A set over `triangle_count` ids from an id array; `what` names the array in errors.
fn set_from_ids(
    ids: &Bound<'_, PyAny>,
    triangle_count: usize,
    what: &str,
) -> PyResult<TriangleSet> {
    let np = ids.py().import("numpy")?;
    let arr = np.call_method1("asarray", (ids,))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if ndim != 1 || (kind != "i" && kind != "u") {
        return Err(value_error(format!(
            "{what}: expected a 1-D integer array of triangle ids"
        )));
    }
    let wide = np
        .call_method1("ascontiguousarray", (arr, "int64"))?
        .cast_into::<PyArrayDyn<i64>>()?;
    let wide = wide.readonly();
    let values = wide.as_slice().map_err(value_error)?;
    let mut set = TriangleSet::with_capacity(triangle_count);
    for &v in values {
        if v < 0 || v as u64 >= triangle_count as u64 {
            return Err(value_error(format!(
                "{what}: triangle id {v} is outside 0..{triangle_count}"
            )));
        }
        set.insert(v as usize);
    }
    Ok(set)
}

impl PyPvs {
    /// Cell `i`, or a `ValueError` naming the cell count.
    fn cell(&self, i: usize) -> PyResult<&CellPvs> {
        self.file.cells.get(i).ok_or_else(|| {
            value_error(format!(
                "cell {i} does not exist (the file has {})",
                self.file.cells.len()
            ))
        })
    }

    fn object_table(&self) -> PyResult<&sightline_region::ObjectTable> {
        self.file.objects.as_ref().ok_or_else(|| {
            value_error("this .pvs file has no object table (version 1); bake it again")
        })
    }
}

#[pymethods]
impl PyPvs {
    /// A PVS for `scene` from cells and one id array per cell; `bounds`, one id array per
    /// cell, gives each cell a conservative bound (a superset of its set).
    #[new]
    #[pyo3(signature = (scene, cells, sets, metadata = None, bounds = None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, PyScene>,
        cells: Vec<PyViewCell>,
        sets: Vec<Bound<'_, PyAny>>,
        metadata: Option<&Bound<'_, PyAny>>,
        bounds: Option<Vec<Bound<'_, PyAny>>>,
    ) -> PyResult<Self> {
        if cells.len() != sets.len() {
            return Err(value_error(format!(
                "{} cells but {} sets",
                cells.len(),
                sets.len()
            )));
        }
        if let Some(b) = bounds.as_ref().filter(|b| b.len() != cells.len()) {
            return Err(value_error(format!(
                "{} cells but {} bounds",
                cells.len(),
                b.len()
            )));
        }
        let metadata = match metadata {
            None => serde_json::Value::Null,
            Some(m) => {
                let text: String = py.import("json")?.call_method1("dumps", (m,))?.extract()?;
                serde_json::from_str(&text).map_err(value_error)?
            }
        };
        let data = &scene.get().data;
        let mut file = PvsFile::for_scene(&data.scene, metadata);
        let n = data.scene.triangle_count();
        for (i, (cell, ids)) in cells.into_iter().zip(&sets).enumerate() {
            let visible = set_from_ids(ids, n, &format!("set of cell {i}"))?;
            let bound = match &bounds {
                Some(b) => {
                    let bound = set_from_ids(&b[i], n, &format!("bound of cell {i}"))?;
                    if !visible.is_subset(&bound) {
                        return Err(value_error(format!(
                            "the bound of cell {i} lacks triangles of its set: a bound is a \
                             superset"
                        )));
                    }
                    Some(bound)
                }
                None => None,
            };
            file.cells.push(CellPvs {
                cell: cell.cell,
                visible,
                bound,
            });
        }
        Ok(Self { file, path: None })
    }

    /// Reads a `.pvs` file (errors name the file and the byte offset of a problem).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let file = py.detach(|| PvsFile::load(&path)).map_err(pvs_error)?;
        Ok(Self {
            file,
            path: Some(path),
        })
    }

    /// Parses `.pvs` bytes.
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Self> {
        let file = PvsFile::read(data).map_err(pvs_error)?;
        Ok(Self { file, path: None })
    }

    /// Writes the file atomically (a temporary file renamed into place).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.file.save(&path)).map_err(pvs_error)
    }

    /// The `.pvs` bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let mut out = Vec::new();
        self.file.write(&mut out).map_err(pvs_error)?;
        Ok(PyBytes::new(py, &out))
    }

    /// Raises `ValueError` when the file was made for another scene.
    fn check_scene(&self, scene: &Bound<'_, PyScene>) -> PyResult<()> {
        self.file
            .check_scene(&scene.get().data.scene)
            .map_err(value_error)
    }

    /// Geometry hash of the scene the sets index.
    #[getter]
    fn scene_hash(&self) -> u64 {
        self.file.scene_hash
    }

    /// Triangle count of that scene.
    #[getter]
    fn triangle_count(&self) -> u32 {
        self.file.triangle_count
    }

    /// The metadata (method, seed, budget, statistics) as Python objects.
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = serde_json::to_string(&self.file.metadata).map_err(value_error)?;
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The view cells.
    #[getter]
    fn cells(&self) -> Vec<PyViewCell> {
        self.file
            .cells
            .iter()
            .map(|c| PyViewCell { cell: c.cell })
            .collect()
    }

    /// The triangle ids of cell `i` (uint32, increasing).
    fn visible<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let c = self.cell(i)?;
        Ok(ids_array(py, &c.visible))
    }

    /// Whether every cell carries a conservative bound (`pvs bake --bound`, `bake(bound=True)`).
    #[getter]
    fn has_bounds(&self) -> bool {
        self.file.has_bounds()
    }

    /// The conservative bound of cell `i` (uint32, increasing): a superset of `visible(i)`
    /// that misses no visible triangle. Raises `ValueError` when the file has no bounds.
    fn bound<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let c = self.cell(i)?;
        let bound = c.bound.as_ref().ok_or_else(|| {
            value_error("this .pvs file has no conservative bounds; bake it with bound=True")
        })?;
        Ok(ids_array(py, bound))
    }

    /// Number of objects in the object table (0 for a version-1 file, which has none).
    #[getter]
    fn object_count(&self) -> usize {
        self.file.objects.as_ref().map_or(0, |t| t.objects.len())
    }

    /// The objects' names, in id order (a list of str; see docs/objects.md per format).
    #[getter]
    fn object_names(&self) -> Vec<String> {
        self.file.objects.as_ref().map_or_else(Vec::new, |t| {
            t.objects.iter().map(|o| o.name.clone()).collect()
        })
    }

    /// The object id of every triangle (uint32 array of length `triangle_count`); raises
    /// `ValueError` for a version-1 file.
    fn object_of_triangle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let table = self.object_table()?;
        Ok(PyArray1::from_slice(py, &table.object_of_triangle))
    }

    /// The triangle ranges of every object as an (R, 3) uint32 array of rows
    /// `(object, first triangle, end triangle)`, in triangle order: object `o` owns the
    /// triangles `first..end` of its rows.
    fn object_ranges<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<u32>>> {
        let table = self.object_table()?;
        let mut rows = Vec::new();
        let mut first = 0u32;
        for (object, count) in table.runs() {
            rows.push(vec![object, first, first + count]);
            first += count;
        }
        if rows.is_empty() {
            return Ok(numpy::PyArray2::zeros(py, [0, 3], false));
        }
        numpy::PyArray2::from_vec2(py, &rows).map_err(value_error)
    }

    /// Object bounds as two (K, 3) float32 arrays `(min, max)` (an object without triangles
    /// has min +inf and max -inf).
    #[allow(clippy::type_complexity)]
    fn object_bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        Bound<'py, numpy::PyArray2<f32>>,
        Bound<'py, numpy::PyArray2<f32>>,
    )> {
        let table = self.object_table()?;
        let rows = |f: &dyn Fn(&sightline_region::PvsObject) -> [f32; 3]| {
            let v: Vec<f32> = table.objects.iter().flat_map(f).collect();
            PyArray1::from_vec(py, v).reshape([table.objects.len(), 3])
        };
        let min = rows(&|o| o.bounds_min.to_array())?;
        let max = rows(&|o| o.bounds_max.to_array())?;
        Ok((min, max))
    }

    /// The object ids visible from cell `i` (uint32, increasing): an object is visible when
    /// any of its triangles is. Raises `ValueError` for a version-1 file.
    fn visible_objects<'py>(
        &self,
        py: Python<'py>,
        i: usize,
    ) -> PyResult<Bound<'py, PyArray1<u32>>> {
        self.object_table()?;
        let set = self.file.visible_objects(i).ok_or_else(|| {
            value_error(format!(
                "cell {i} does not exist (the file has {})",
                self.file.cells.len()
            ))
        })?;
        Ok(ids_array(py, &set))
    }

    /// The object ids of every cell.
    fn object_sets<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyArray1<u32>>>> {
        self.object_table()?;
        Ok((0..self.file.cells.len())
            .filter_map(|i| self.file.visible_objects(i))
            .map(|s| ids_array(py, &s))
            .collect())
    }

    /// The triangle ids of every cell.
    fn sets<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray1<u32>>> {
        self.file
            .cells
            .iter()
            .map(|c| ids_array(py, &c.visible))
            .collect()
    }

    fn __len__(&self) -> usize {
        self.file.cells.len()
    }

    /// `pvs[i]`: the triangle ids of cell `i` (uint32, increasing), with Python's negative
    /// indices (`pvs[-1]` is the last cell); `IndexError` outside the cells.
    fn __getitem__<'py>(&self, py: Python<'py>, i: isize) -> PyResult<Bound<'py, PyArray1<u32>>> {
        let n = self.file.cells.len();
        let index = if i < 0 { i + n as isize } else { i };
        let cell = usize::try_from(index)
            .ok()
            .and_then(|k| self.file.cells.get(k))
            .ok_or_else(|| {
                pyo3::exceptions::PyIndexError::new_err(format!(
                    "cell index {i} is out of range (the file has {n} cells)"
                ))
            })?;
        Ok(ids_array(py, &cell.visible))
    }

    /// `for ids in pvs`: the triangle ids of each cell in turn, as `pvs.sets()` lists them.
    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let sets = pyo3::types::PyList::new(py, self.sets(py))?;
        sets.as_any().try_iter().map(|it| it.into_any())
    }

    /// Pickling (multiprocessing, Ray): the `.pvs` bytes, read back with `Pvs.from_bytes`
    /// (the file it was loaded from, if any, is not carried).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyTuple>> {
        let from_bytes = py.get_type::<PyPvs>().getattr("from_bytes")?;
        (from_bytes, (self.to_bytes(py)?,)).into_pyobject(py)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        match other.cast::<PyPvs>() {
            Ok(o) => {
                let (a, b) = (&self.file, &o.get().file);
                a.scene_hash == b.scene_hash
                    && a.triangle_count == b.triangle_count
                    && a.cells == b.cells
            }
            Err(_) => false,
        }
    }

    fn __repr__(&self) -> String {
        let source = match &self.path {
            Some(p) => format!(" from {:?}", p.display().to_string()),
            None => String::new(),
        };
        format!(
            "<sightline.Pvs: {} cells over {} triangles of scene {:#018x}{source}>",
            self.file.cells.len(),
            self.file.triangle_count,
            self.file.scene_hash,
        )
    }
}
