//! `shadenet.write_exr` and `shadenet.read_exr`: multi-layer f32 EXR through the tracer's
//! writer (temporary file + rename) and its bounded reader.

use crate::boundary::{Channels, detached, f32_bytes, f32_values, shadenet_error};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::PathBuf;

/// Writes channels `(name, bytes)`, each `width × height` f32 (rows top to bottom), as one
/// EXR part, atomically. The GIL is released while it encodes and writes.
#[pyfunction]
pub(crate) fn write_exr(
    py: Python<'_>,
    path: PathBuf,
    width: u32,
    height: u32,
    channels: Vec<(String, Bound<'_, PyBytes>)>,
) -> PyResult<()> {
    let n = width as usize * height as usize;
    let channels = channels
        .iter()
        .map(|(name, b)| {
            Ok((
                name.clone(),
                f32_values(b.as_bytes(), n, &format!("channel {name}"))?,
            ))
        })
        .collect::<PyResult<Vec<_>>>()?;
    detached(py, move || {
        shadenet::output::write_exr(&path, width, height, channels).map_err(|e| shadenet_error(&e))
    })
}

/// Reads the first part of an EXR file: `(width, height, [(channel, bytes)])`, channels
/// sorted by name, every sample as f32.
#[pyfunction]
pub(crate) fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(u32, u32, Channels<'py>)> {
    let image = detached(py, move || {
        shadenet::output::read_exr(&path).map_err(|e| shadenet_error(&e))
    })?;
    let channels = image
        .channels
        .iter()
        .map(|(name, data)| (name.clone(), f32_bytes(py, data)))
        .collect();
    Ok((image.width, image.height, channels))
}
