//! `sightline.Scene`: a validated triangle scene, loaded from a file or procedural spec or built
//! from numpy arrays, with its BVH built once on first use and shared by every later call.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use glam::Vec3;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use sightline_core::scene::{self, LoadError, LoadOptions};
use sightline_core::trace::Bvh;
use sightline_core::validate::validate;
use sightline_core::{Object, Scene, UpAxis};

use crate::convert::{io_error, rows_f32, rows_u32, value_error};

/// A scene and its lazily built BVH, shared between Python objects and released threads.
pub(crate) struct SceneData {
    pub scene: Scene,
    bvh: OnceLock<Bvh>,
}

impl SceneData {
    /// Wraps a scene that passed validation.
    fn new(scene: Scene) -> Self {
        Self {
            scene,
            bvh: OnceLock::new(),
        }
    }

    /// The BVH, built on the first call (call without the GIL: it takes a while).
    pub fn bvh(&self) -> &Bvh {
        self.bvh.get_or_init(|| Bvh::build(&self.scene))
    }
}

/// A triangle scene. Triangle ids are row indices of `triangles`.
///
/// Build one with `Scene.load(spec)` (a file or `procedural:NAME?seed=S&size=N`, as the CLI's
/// SCENE argument) or `Scene.from_arrays(vertices, triangles)`. Both reject unusable scenes
/// (empty, NaN coordinates, out-of-range indices) with a `ValueError`.
#[pyclass(module = "sightline", name = "Scene", frozen)]
pub(crate) struct PyScene {
    pub data: Arc<SceneData>,
}

fn checked(scene: Scene, what: &str) -> PyResult<PyScene> {
    validate(&scene)
        .check()
        .map_err(|e| value_error(format!("{what}: {e}")))?;
    Ok(PyScene {
        data: Arc::new(SceneData::new(scene)),
    })
}

fn parse_up(up: &str) -> PyResult<UpAxis> {
    UpAxis::parse(up).ok_or_else(|| value_error(format!("up axis '{up}': use 'x', 'y' or 'z'")))
}

/// What `Scene.load` takes: a `str` is a spec (a path or `procedural:...`); any other
/// `os.PathLike` (e.g. `pathlib.Path`) is a file, even one whose name starts `procedural:`.
#[derive(FromPyObject)]
pub(crate) enum SceneSpecArg {
    /// A CLI-style spec.
    Spec(String),
    /// A file path.
    Path(PathBuf),
}

#[pymethods]
impl PyScene {
    /// Loads a scene file (.obj, .ply, .gltf, .glb, .stl, .bsp, optionally .gz) or generates
    /// a procedural one (`procedural:city?seed=1&size=20000`). `spec` is a `str` (a path or a
    /// procedural spec, as the CLI's SCENE argument) or an `os.PathLike` (always a file).
    #[staticmethod]
    #[pyo3(signature = (spec, patch_subdivisions = 4))]
    fn load(py: Python<'_>, spec: SceneSpecArg, patch_subdivisions: u32) -> PyResult<Self> {
        if patch_subdivisions > 64 {
            return Err(value_error(format!(
                "patch_subdivisions {patch_subdivisions} is above the maximum of 64"
            )));
        }
        let options = LoadOptions {
            patch_subdivisions,
            ..LoadOptions::default()
        };
        let (loaded, what) = match &spec {
            SceneSpecArg::Spec(spec) => (py.detach(|| scene::open(spec, &options)), spec.clone()),
            SceneSpecArg::Path(path) => (
                py.detach(|| scene::load_file(path, &options)),
                path.display().to_string(),
            ),
        };
        let scene = loaded.map_err(|e| match e {
            LoadError::Io { .. } => io_error(e),
            _ => value_error(e),
        })?;
        checked(scene, &what)
    }

    /// A scene from vertices (float, shape (n, 3)) and triangles (integer, shape (m, 3),
    /// indices into vertices). All triangles form one object named `source`.
    #[staticmethod]
    #[pyo3(signature = (vertices, triangles, source = "arrays", up = "z"))]
    fn from_arrays(
        vertices: &Bound<'_, PyAny>,
        triangles: &Bound<'_, PyAny>,
        source: &str,
        up: &str,
    ) -> PyResult<Self> {
        let positions: Vec<Vec3> = rows_f32(vertices, "vertices")?
            .into_iter()
            .map(Vec3::from_array)
            .collect();
        let triangles = rows_u32(triangles, "triangles")?;
        let scene = Scene {
            object_of_triangle: vec![0; triangles.len()],
            objects: vec![Object::named(source)],
            positions,
            triangles,
            up: parse_up(up)?,
            source: source.to_string(),
            bsp: None,
            load_warnings: Vec::new(),
        };
        checked(scene, source)
    }

    /// Number of triangles.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.data.scene.triangle_count()
    }

    /// Number of vertices.
    #[getter]
    fn vertex_count(&self) -> usize {
        self.data.scene.positions.len()
    }

    /// Vertex positions, float32 array of shape (n, 3) (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let p = &self.data.scene.positions;
        let flat: Vec<f32> = p.iter().flat_map(|v| v.to_array()).collect();
        let a = Array2::from_shape_vec((p.len(), 3), flat).map_err(value_error)?;
        Ok(a.into_pyarray(py))
    }

    /// Triangles, uint32 array of shape (m, 3) (a copy); row i is triangle id i.
    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u32>>> {
        let t = &self.data.scene.triangles;
        let flat: Vec<u32> = t.iter().flatten().copied().collect();
        let a = Array2::from_shape_vec((t.len(), 3), flat).map_err(value_error)?;
        Ok(a.into_pyarray(py))
    }

    /// Bounding box as two float32 arrays `(min, max)`.
    #[getter]
    fn bounds<'py>(
        &self,
        py: Python<'py>,
    ) -> (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>) {
        let b = self.data.scene.bounds();
        (
            PyArray1::from_vec(py, b.min.to_array().to_vec()),
            PyArray1::from_vec(py, b.max.to_array().to_vec()),
        )
    }

    /// The 64-bit geometry hash that `.pvs` files store.
    #[getter]
    fn geometry_hash(&self) -> u64 {
        self.data.scene.geometry_hash()
    }

    /// Where the scene came from.
    #[getter]
    fn source(&self) -> String {
        self.data.scene.source.clone()
    }

    /// The up axis, `"y"` or `"z"`.
    #[getter]
    fn up(&self) -> &'static str {
        match self.data.scene.up {
            UpAxis::X => "x",
            UpAxis::Y => "y",
            UpAxis::Z => "z",
        }
    }

    fn __len__(&self) -> usize {
        self.data.scene.triangle_count()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene('{}', {} triangles, {} vertices)",
            self.data.scene.source,
            self.data.scene.triangle_count(),
            self.data.scene.positions.len()
        )
    }

    /// Pickles as its arrays (so it can be sent to other processes).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let ctor = py.get_type::<PyScene>().getattr("from_arrays")?;
        let args = (
            self.vertices(py)?,
            self.triangles(py)?,
            self.source(),
            self.up(),
        );
        PyTuple::new(py, [ctor, args.into_pyobject(py)?.into_any()])
    }
}
