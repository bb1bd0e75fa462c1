//! `shadenet._native`: the Rust half of the Python package `shadenet` (PyO3, abi3).
//!
//! This crate owns the boundary only: turning Python arguments into the library's types,
//! releasing the GIL while the library compiles, shades and renders, and turning results and
//! errors back into Python objects. Shading and rendering are the `shadenet` facade's; the
//! pure-Python layer (`python/shadenet/__init__.py`) owns numpy.
//!
//! To stay one abi3 wheel for every CPython ≥ 3.9, nothing here knows numpy: arrays cross
//! as `bytes` of little-endian `f32` (or `u32` seeds) with their shapes beside them.
//!
//! Errors: the library's become `ShadenetError` carrying the full chain of causes (outermost
//! first, joined by `: `, as the CLI prints them); bad arguments become `ValueError` /
//! `TypeError`. Work that runs with the GIL released is wrapped in `boundary::detached`, which turns
//! a panic into a `ShadenetError` instead of unwinding into Python.

mod boundary;
mod exr;
mod fragments;
mod material;
mod render;

use boundary::ShadenetError;
use pyo3::prelude::*;

/// The extension module `shadenet._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ShadenetError", m.py().get_type::<ShadenetError>())?;
    m.add_class::<material::NativeMaterial>()?;
    m.add_function(wrap_pyfunction!(material::compile, m)?)?;
    m.add_function(wrap_pyfunction!(fragments::grid, m)?)?;
    m.add_class::<render::NativeRenderer>()?;
    m.add_function(wrap_pyfunction!(render::frame_size, m)?)?;
    m.add_function(wrap_pyfunction!(exr::write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(exr::read_exr, m)?)?;
    m.add("FRAGMENT_FIELDS", fragments::field_table())?;
    Ok(())
}
