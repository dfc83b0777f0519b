//! `ssl check` and `ssl evaluate` for Python: their reports as dicts.

use crate::audio::{with_array_source, ArraySource, Borrowed, View};
use crate::convert::{geometry_of, os_error, to_python, value_error};
use crate::localizer::Run;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssl::check::{CheckOptions, Expected};
use ssl::evaluate::Metric;
use ssl::record::{DetectionRecord, EventRecord};
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
        let view = borrowed.view();
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
    // A run's records are read where they are; a file's are read here.
    let given = result.cast::<Run>().ok();
    let read;
    let (rows, events, array, shown): (&[DetectionRecord], Option<&[EventRecord]>, _, _) =
        match &given {
            Some(run) => {
                let run = run.get();
                let events = run.tracked.then_some(run.events.as_slice());
                let shown = run.file.file.clone();
                (&run.rows, events, Some(run.geometry.clone()), shown)
            }
            None => {
                let path: PathBuf = result.extract()?;
                read = ssl::record::read_records_with_info(&path).map_err(value_error)?;
                let (rows, events, info) = &read;
                let events = (!events.is_empty()).then_some(events.as_slice());
                (rows, events, info.array(), path.display().to_string())
            }
        };
    let array = match geometry {
        Some(g) => Some(geometry_of(g)?.0),
        None => array,
    };
    let metric =
        Metric::asked(metric, array.as_ref()).map_err(|e| value_error(format!("metric: {e}")))?;
    let (tail, rule) = match tail {
        Some(t) => (t, "tail".to_string()),
        None => ssl::evaluate::default_tail(&truth, rows),
    };
    let mut report = ssl::evaluate::evaluate_by(&truth, rows, events, tail, &metric)
        .map_err(|e| value_error(format!("{shown}: {e}")))?;
    report.tail_rule = rule;
    to_python(py, &report)
}
