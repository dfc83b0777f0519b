//! `ssloc._native`: the `ssl` library's localizer, check and evaluation for Python. The
//! package around it (python/ssloc/) gives the names users call; this module only
//! converts: options (through the flags' definitions, keywords.rs), samples (audio.rs),
//! geometries and errors (convert.rs), records to columns (columns.rs); the localizer's
//! runs (localizer.rs) and the reports (reports.rs).

mod audio;
mod columns;
mod convert;
mod keywords;
mod localizer;
mod reports;

use localizer::{Localizer, Run};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use reports::{check, evaluate};

/// Every option: keyword, flag, help, section, switch, value name, choices, default.
#[pyfunction]
fn options(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for o in keywords::infos() {
        let d = PyDict::new(py);
        d.set_item("keyword", o.keyword)?;
        d.set_item("flag", o.flag)?;
        d.set_item("help", o.help)?;
        d.set_item("section", o.section)?;
        d.set_item("switch", o.switch)?;
        d.set_item("value_name", o.value_name)?;
        d.set_item("choices", o.choices)?;
        d.set_item("default", o.default)?;
        d.set_item("repeatable", o.repeatable)?;
        list.append(d)?;
    }
    Ok(list)
}

/// The presets' names and the options that make them.
#[pyfunction]
fn presets() -> Vec<(&'static str, Vec<String>)> {
    keywords::PRESETS
        .iter()
        .map(|(n, flags)| {
            (
                *n,
                flags
                    .iter()
                    .map(|f| f.trim_start_matches("--").replace('-', "_"))
                    .collect(),
            )
        })
        .collect()
}

/// The version of the `ssl` library inside.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Localizer>()?;
    m.add_class::<Run>()?;
    m.add_function(wrap_pyfunction!(options, m)?)?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add("DTYPES", audio::DTYPES)?;
    Ok(())
}
