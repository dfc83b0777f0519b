//! Values between Python and the library: errors as Python exceptions (with the command
//! line's messages), records and reports as Python objects, geometries from what Python
//! gives.

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use ssl::localize::ErrorKind;
use ssl::stream::InputError;
use ssl::{AnalysisError, Geometry, GeometryError};
use std::path::PathBuf;

pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// An I/O failure as `OSError` (`FileNotFoundError` for a missing file), the message
/// as the command line says it.
pub fn os_error(io: &std::io::Error, message: String) -> PyErr {
    match io.kind() {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A recording's error: a file that cannot be opened or read is an `OSError`; what
/// its samples or the options are wrong in is a `ValueError`.
pub fn analysis_error(e: &AnalysisError) -> PyErr {
    match &e.kind {
        ErrorKind::Input(InputError::Open(io) | InputError::Io(io) | InputError::Read(io)) => {
            os_error(io, e.to_string())
        }
        ErrorKind::Input(InputError::Directory) => PyOSError::new_err(e.to_string()),
        _ => value_error(e),
    }
}

fn geometry_error(e: GeometryError) -> PyErr {
    match &e {
        GeometryError::Read { error, .. } => os_error(error, e.to_string()),
        _ => value_error(e),
    }
}

/// `value` as Python objects, through its JSON form (so arrays are lists and numbers
/// are what a JSON result holds).
pub fn to_python<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_value(value).map_err(value_error)?;
    Ok(pythonize::pythonize(py, &json)?)
}

/// A geometry from a TOML path, a dict of the file's form, or a list of positions (m),
/// with the name results give it.
pub fn geometry_of(given: &Bound<'_, PyAny>) -> PyResult<(Geometry, String)> {
    if given.is_instance_of::<PyDict>() {
        let value: toml::Value =
            pythonize::depythonize(given).map_err(|e| value_error(format!("geometry: {e}")))?;
        let text = toml::to_string(&value).map_err(|e| value_error(format!("geometry: {e}")))?;
        let g =
            // The TOML's lines are not the dict's: its message alone.
            Geometry::from_toml_str(&text).map_err(|e| match e {
                GeometryError::Toml { message, .. } => value_error(format!("geometry: {message}")),
                e => value_error(format!("geometry: {e}")),
            })?;
        return Ok((g, "<dict>".into()));
    }
    if given.is_instance_of::<PyList>() {
        let positions: Vec<[f64; 3]> = given.extract().map_err(|_| {
            value_error("geometry: positions must be M rows of 3 numbers (x, y, z in metres)")
        })?;
        let g = Geometry::from_positions(&positions)
            .map_err(|e| value_error(format!("geometry: {e}")))?;
        return Ok((g, "<positions>".into()));
    }
    let path: PathBuf = given.extract().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(
            "geometry must be a TOML file's path, a dict of its form, or (M, 3) positions in metres",
        )
    })?;
    let g = Geometry::from_file(&path).map_err(geometry_error)?;
    Ok((g, path.display().to_string()))
}
