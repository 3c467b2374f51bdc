//! Python bindings of sightline (the `sightline` package, native part `sightline._sightline`).
//!
//! Scenes, view cells, single-cell and batch PVS bakes, `.pvs` files, exact / conservative
//! from-point visibility, and the HTML report of a `.pvs` file (`report`), with numpy arrays
//! in and out. Every long computation releases the GIL (`Python::detach`), so Python threads
//! and Ray actors keep running beside it; bakes run
//! on a thread of their own while the caller's thread watches for Ctrl-C and reports progress
//! (`run`). Paths are `str` or `os.PathLike`; thread counts are capped by the CLI's rule
//! (`sightline_core::threads`), with a `RuntimeWarning`. Errors
//! become `ValueError` (bad input: the Rust message, naming what and where), `OSError`
//! (files that cannot be read or written) or `RuntimeError` (`bake(device="gpu")` without the
//! GPU parts or a Vulkan adapter: `device.rs`).
//!
//! Results equal the CLI's: a cell baked here with seed `s` and global index `i` uses
//! `sightline_region::bake::cell_seed(s, i)`, exactly like `sightline pvs bake`.

mod bake;
mod cells;
mod convert;
mod device;
mod evaluate;
mod method;
mod point;
mod pvs;
mod report;
mod run;
mod scene;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _sightline(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::PyScene>()?;
    m.add_class::<cells::PyViewCell>()?;
    m.add_class::<method::PyMethod>()?;
    m.add_class::<pvs::PyPvs>()?;
    m.add_function(wrap_pyfunction!(cells::grid, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_cell, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_cells, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_q3, m)?)?;
    m.add_function(wrap_pyfunction!(bake::cell_seed, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_fingerprint, m)?)?;
    m.add_function(wrap_pyfunction!(point::visible_exact, m)?)?;
    m.add_function(wrap_pyfunction!(point::visible_conservative, m)?)?;
    m.add_function(wrap_pyfunction!(report::report, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate, m)?)?;
    m.add("METHODS", sightline_region::methods::METHODS.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
