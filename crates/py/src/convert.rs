//! What the bindings share: Rust errors as Python exceptions, and numpy arrays in and out
//! (checked shapes and dtypes, indices range-checked rather than wrapped).

use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyIOError, PyValueError};
use pyo3::prelude::*;
use sightline_core::TriangleSet;

/// The values of a contiguous integer array (already converted to `T`) as `i128`, which holds
/// every `i64` and `u64` so range checks see the true value.
fn widened<'py, T>(array: Bound<'py, PyAny>) -> PyResult<Vec<i128>>
where
    T: numpy::Element + Copy + Into<i128>,
{
    let a = array.cast_into::<numpy::PyArrayDyn<T>>()?;
    let ro = a.readonly();
    Ok(ro
        .as_slice()
        .map_err(value_error)?
        .iter()
        .map(|&v| v.into())
        .collect())
}

/// A `ValueError` carrying `e`'s message.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// An `OSError` carrying `e`'s message.
pub(crate) fn io_error(e: impl std::fmt::Display) -> PyErr {
    PyIOError::new_err(e.to_string())
}

/// The ids of `set` as a numpy `uint32` array, in increasing order.
pub(crate) fn ids_array<'py>(py: Python<'py>, set: &TriangleSet) -> Bound<'py, PyArray1<u32>> {
    let ids: Vec<u32> = set.ones().map(|i| i as u32).collect();
    PyArray1::from_vec(py, ids)
}

/// A numpy array of `f32` with three columns (any float or int dtype is converted), checked
/// for shape. `what` names the argument in errors.
pub(crate) fn rows_f32(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f32; 3]>> {
    let np = obj.py().import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, "float32"))
        .map_err(|e| value_error(format!("{what}: not convertible to a float32 array: {e}")))?;
    let arr = arr.cast_into::<numpy::PyArrayDyn<f32>>()?;
    let shape = arr.shape().to_vec();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(value_error(format!(
            "{what}: expected shape (n, 3), got {shape:?}"
        )));
    }
    let ro = arr.readonly();
    let flat = ro.as_slice().map_err(value_error)?;
    Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

/// A numpy integer array with three columns as `u32` rows: negative values and values past
/// `u32::MAX` are errors (never wrapped), floats are refused.
pub(crate) fn rows_u32(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[u32; 3]>> {
    let np = obj.py().import("numpy")?;
    let arr = np.call_method1("asarray", (obj,))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(value_error(format!(
            "{what}: expected shape (m, 3), got {shape:?}"
        )));
    }
    if kind != "i" && kind != "u" {
        return Err(value_error(format!(
            "{what}: expected an integer array, got dtype kind '{kind}'"
        )));
    }
    // Through int64/uint64 first so that range checks see the real values.
    let wide_dtype = if kind == "i" { "int64" } else { "uint64" };
    let wide = np.call_method1("ascontiguousarray", (arr, wide_dtype))?;
    let mut rows = Vec::with_capacity(shape[0]);
    let values: Vec<i128> = if kind == "i" {
        widened::<i64>(wide)?
    } else {
        widened::<u64>(wide)?
    };
    for (i, c) in values.chunks_exact(3).enumerate() {
        let mut row = [0u32; 3];
        for (slot, &v) in row.iter_mut().zip(c) {
            *slot = u32::try_from(v).map_err(|_| {
                value_error(format!(
                    "{what}: row {i} has index {v}, outside 0..={}",
                    u32::MAX
                ))
            })?;
        }
        rows.push(row);
    }
    Ok(rows)
}
