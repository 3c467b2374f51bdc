//! From-point visibility from Python: the exact set (analytic hidden-surface removal) and the
//! conservative set (RV streaming visibility), for a camera given like the CLI's.

use glam::Vec3;
use numpy::PyArray1;
use pyo3::prelude::*;
use sightline_core::{default_near, Camera};
use sightline_point::analytic::{visible_fragments, AnalyticOptions};
use sightline_point::rv::{conservative_visible, Guarantee, RvOptions, SceneSource};

use crate::convert::{ids_array, value_error};
use crate::scene::{PyScene, SceneData};

/// The camera of `sightline visible` from its options; defaults as the CLI's (up: the scene's
/// up axis, near: [`sightline_core::near_plane`]'s rule at the eye).
fn camera(
    data: &SceneData,
    eye: [f32; 3],
    look: [f32; 3],
    up: Option<[f32; 3]>,
    fov: f32,
    size: (u32, u32),
    near: Option<f32>,
) -> PyResult<Camera> {
    let up = up.map_or(data.scene.up.vector(), Vec3::from_array);
    let eye = Vec3::from_array(eye);
    let near = near.unwrap_or_else(|| default_near(&data.scene, eye));
    Camera::look_at(eye, Vec3::from_array(look), up, fov, size.0, size.1, near)
        .map_err(|e| value_error(format!("invalid camera: {e}")))
}

/// The ids (uint32, increasing) of the triangles of `scene` with a visible region of positive
/// area from `eye` looking at `look`: the exact from-point visible set (analytic visibility).
///
/// The camera: `eye` and `look` (3 floats each), `up` (default: the scene's up axis), `fov`
/// (vertical field of view in degrees, default 60), `size` (`(width, height)` pixels, default
/// `(1024, 768)`), `near` (the near-plane distance; by default, as the CLI's `--near`, 1/100 of
/// the distance from the eye to the nearest triangle, clamped to the scene's scale).
/// `bin_size`: screen bins of `bin_size` x `bin_size` pixels the analytic method works in
/// (default 16; a speed setting, the result does not depend on it).
///
/// Raises `ValueError` for an invalid camera. The GIL is released while it works.
#[pyfunction]
#[pyo3(signature = (scene, eye, look, up = None, fov = 60.0, size = (1024, 768), near = None,
    bin_size = 16))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn visible_exact<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    eye: [f32; 3],
    look: [f32; 3],
    up: Option<[f32; 3]>,
    fov: f32,
    size: (u32, u32),
    near: Option<f32>,
    bin_size: u32,
) -> PyResult<Bound<'py, PyArray1<u32>>> {
    let data = scene.get().data.clone();
    let cam = camera(&data, eye, look, up, fov, size, near)?;
    let result = py
        .detach(|| {
            visible_fragments(
                &data.scene,
                &cam,
                &AnalyticOptions {
                    bin_size,
                    ..AnalyticOptions::default()
                },
            )
        })
        .map_err(value_error)?;
    Ok(ids_array(py, &result.visible))
}

/// The ids (uint32, increasing) of a conservative visible set of `scene` from `eye` looking
/// at `look`: it never misses a visible triangle, and is computed in at most `memory` bytes
/// (default 256 MiB; the RV method's hard budget).
///
/// The camera: `eye` and `look` (3 floats each), `up` (default: the scene's up axis), `fov`
/// (vertical field of view in degrees, default 60), `size` (`(width, height)` pixels, default
/// `(1024, 768)`), `near` (the near-plane distance; by default, as the CLI's `--near`, 1/100 of
/// the distance from the eye to the nearest triangle, clamped to the scene's scale).
/// `guarantee`: `"area"` (every triangle with a visible region of positive area, the exact
/// set's triangles) or `"samples"` (also those the rasterizer could show on a silhouette they
/// only touch).
///
/// Raises `ValueError` for an invalid camera, guarantee or memory budget.
#[pyfunction]
#[pyo3(signature = (scene, eye, look, up = None, fov = 60.0, size = (1024, 768), near = None,
    memory = 256 << 20, guarantee = "area"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn visible_conservative<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyScene>,
    eye: [f32; 3],
    look: [f32; 3],
    up: Option<[f32; 3]>,
    fov: f32,
    size: (u32, u32),
    near: Option<f32>,
    memory: usize,
    guarantee: &str,
) -> PyResult<Bound<'py, PyArray1<u32>>> {
    let data = scene.get().data.clone();
    let cam = camera(&data, eye, look, up, fov, size, near)?;
    let guarantee = match guarantee {
        "area" => Guarantee::PositiveArea,
        "samples" => Guarantee::AnySample,
        other => {
            return Err(value_error(format!(
                "guarantee must be \"area\" or \"samples\", not {other:?}"
            )))
        }
    };
    let options = RvOptions {
        memory_budget_bytes: memory,
        guarantee,
        ..RvOptions::default()
    };
    let result = py
        .detach(|| conservative_visible(&mut SceneSource::new(&data.scene), &cam, &options))
        .map_err(value_error)?;
    Ok(ids_array(py, &result.visible))
}
