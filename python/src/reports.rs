//! `ssl check` and `ssl evaluate` for Python: their reports as dicts.

use crate::audio::{borrowed_view, with_array_source, ArraySource, Borrowed, View};
use crate::convert::{geometry_of, os_error, to_python, value_error};
use crate::localizer::Run;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssl::check::{CheckOptions, Expected};
use ssl::evaluate::Metric;
use ssl::stream::{InputError, SampleSource};
use ssl::{Geometry, Truth};
use std::path::PathBuf;

/// `ssl check` on a path or an array.
#[pyfunction]
#[pyo3(signature = (audio, geometry, sample_rate=None, name="<array>", expect=Vec::new()))]
pub fn check<'py>(
    py: Python<'py>,
    audio: &Bound<'py, PyAny>,
    geometry: &Bound<'py, PyAny>,
    sample_rate: Option<u32>,
    name: &str,
    expect: Vec<(f64, f64, Option<f64>)>,
) -> PyResult<Bound<'py, PyAny>> {
    let (geometry, _) = geometry_of(geometry)?;
    let options = CheckOptions {
        expect: expect
            .into_iter()
            .map(|(azimuth_deg, elevation_deg, at_s)| Expected {
                azimuth_deg,
                elevation_deg,
                at_s,
            })
            .collect(),
    };
    let check_error = |e: ssl::check::CheckError| match &e {
        ssl::check::CheckError::Input {
            error: InputError::Open(io) | InputError::Io(io) | InputError::Read(io),
            ..
        } => os_error(io, e.to_string()),
        _ => value_error(e),
    };
    let report = if let Ok(path) = audio.extract::<PathBuf>() {
        let path = path.display().to_string();
        py.detach(|| ssl::check::check(&path, &geometry, &options))
            .map_err(check_error)?
    } else {
        let rate =
            sample_rate.ok_or_else(|| value_error("an array's sample_rate must be given"))?;
        let borrowed = Borrowed::new(audio)?;
        let view = borrowed_view(&borrowed);
        py.detach(|| {
            with_array_source!(view, name, rate, |source| checked(
                source, &geometry, &options
            ))
        })
        .map_err(check_error)?
    };
    to_python(py, &report)
}

fn checked<S: SampleSource>(
    mut source: S,
    geometry: &Geometry,
    options: &CheckOptions,
) -> Result<ssl::check::CheckReport, ssl::check::CheckError> {
    ssl::check::check_source(&mut source, geometry, options)
}

/// `ssl evaluate`: a run (or a result file) against a truth (a file, or a dict of the
/// JSON form).
#[pyfunction]
#[pyo3(signature = (result, truth, geometry=None, metric=None, tail=None))]
pub fn evaluate<'py>(
    py: Python<'py>,
    result: &Bound<'py, PyAny>,
    truth: &Bound<'py, PyAny>,
    geometry: Option<&Bound<'py, PyAny>>,
    metric: Option<&str>,
    tail: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let truth = if truth.is_instance_of::<PyDict>() {
        let value: serde_json::Value =
            pythonize::depythonize(truth).map_err(|e| value_error(format!("truth: {e}")))?;
        Truth::from_json(&value.to_string()).map_err(|e| value_error(format!("truth: {e}")))?
    } else {
        let path: PathBuf = truth.extract()?;
        Truth::from_file(&path).map_err(value_error)?
    };
    let (rows, events, array, shown) = if let Ok(run) = result.cast::<Run>() {
        let run = run.get();
        let events = run.tracked.then(|| run.events.clone());
        (
            run.rows.clone(),
            events,
            Some(run.geometry.clone()),
            run.file.file.clone(),
        )
    } else {
        let path: PathBuf = result.extract()?;
        let (rows, events, info) =
            ssl::record::read_records_with_info(&path).map_err(value_error)?;
        let events = (!events.is_empty()).then_some(events);
        (rows, events, info.array(), path.display().to_string())
    };
    let array = match geometry {
        Some(g) => Some(geometry_of(g)?.0),
        None => array,
    };
    let metric =
        Metric::asked(metric, array.as_ref()).map_err(|e| value_error(format!("metric: {e}")))?;
    let (tail, rule) = match tail {
        Some(t) => (t, "tail".to_string()),
        None => ssl::evaluate::default_tail(&truth, &rows),
    };
    let mut report = ssl::evaluate::evaluate_by(&truth, &rows, events.as_deref(), tail, &metric)
        .map_err(|e| value_error(format!("{shown}: {e}")))?;
    report.tail_rule = rule;
    to_python(py, &report)
}
