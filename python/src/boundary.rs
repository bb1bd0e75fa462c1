//! What crosses the boundary: the `ShadenetError` exception, errors as Python exceptions,
//! work run with the GIL released (panics caught), and `f32` arrays as little-endian bytes.

use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;

pyo3::create_exception!(
    shadenet,
    ShadenetError,
    PyException,
    "An error from shadenet: a missing or malformed file, a network that does not link, a \
     back end that cannot start. The message is the full chain of causes, outermost first."
);

/// Layers crossing to Python: `(name, channel names, f32 bytes)` each.
pub(crate) type Layers<'py, C> = Vec<(String, Vec<C>, Bound<'py, PyBytes>)>;

/// EXR channels crossing to Python: `(name, f32 bytes)` each.
pub(crate) type Channels<'py> = Vec<(String, Bound<'py, PyBytes>)>;

/// A library error as a [`ShadenetError`] carrying its chain of causes.
pub(crate) fn shadenet_error(e: &dyn std::error::Error) -> PyErr {
    ShadenetError::new_err(shadenet::graph::error_chain(e))
}

/// A [`ShadenetError`] with this message.
pub(crate) fn shadenet_msg(message: impl Into<String>) -> PyErr {
    ShadenetError::new_err(message.into())
}

/// A `ValueError` with this message.
pub(crate) fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// Runs `work` with the GIL released; a panic inside it becomes a [`ShadenetError`] naming
/// it an internal error, never an unwind across the FFI boundary.
pub(crate) fn detached<T: Send>(
    py: Python<'_>,
    work: impl FnOnce() -> PyResult<T> + Send,
) -> PyResult<T> {
    py.detach(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)).unwrap_or_else(|p| {
            let what = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(shadenet_msg(format!(
                "internal error (a bug in shadenet, please report it): {what}"
            )))
        })
    })
}

/// `f32` values as the little-endian bytes the Python layer reads with numpy.
pub(crate) fn f32_bytes<'py>(py: Python<'py>, values: &[f32]) -> Bound<'py, PyBytes> {
    let mut bytes = Vec::with_capacity(values.len() * 4);
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    PyBytes::new(py, &bytes)
}

/// Little-endian `f32` bytes as values; `what` names the argument when the length is not a
/// multiple of 4 or not `expect` values.
pub(crate) fn f32_values(bytes: &[u8], expect: usize, what: &str) -> PyResult<Vec<f32>> {
    if bytes.len() != expect * 4 {
        return Err(value_error(format!(
            "{what}: {} bytes, expected {expect} f32 values ({} bytes)",
            bytes.len(),
            expect * 4
        )));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}
