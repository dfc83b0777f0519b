//! `ssloc._native`: the `ssl` library's localizer, check and evaluation for Python. The
//! package around it (python/ssloc/) gives the names users call; this module only
//! converts: geometries, options (through the flags' definitions, options.rs), samples
//! (audio.rs), records to columns (columns.rs), reports to dicts.

mod audio;
mod columns;
mod keywords;

use audio::{ArraySource, BlockSource, Borrowed};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use ssl::check::{CheckOptions, Expected};
use ssl::evaluate::Metric;
use ssl::localize::{ErrorKind, Output, Recording, RunError};
use ssl::record::{DetectionRecord, EventRecord, FileEntry, RunMetadata, SourceRecord};
use ssl::stream::{InputError, SampleSource};
use ssl::{AnalysisError, Geometry, GeometryError, Truth};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How often a running analysis looks for Ctrl-C.
const SIGNAL_EVERY: Duration = Duration::from_millis(100);

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// An I/O failure as `OSError` (`FileNotFoundError` for a missing file), the message
/// as the command line says it.
fn os_error(io: &std::io::Error, message: String) -> PyErr {
    match io.kind() {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// A recording's error: a file that cannot be opened or read is an `OSError`; what
/// its samples or the options are wrong in is a `ValueError`.
fn analysis_error(e: &AnalysisError) -> PyErr {
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
fn to_python<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let json = serde_json::to_value(value).map_err(value_error)?;
    Ok(pythonize::pythonize(py, &json)?)
}

/// A geometry from a TOML path, a dict of the file's form, or a list of positions (m),
/// with the name results give it.
fn geometry_of(given: &Bound<'_, PyAny>) -> PyResult<(Geometry, String)> {
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

/// `$body` with `$source` an [`ArraySource`] of the view, whatever its dtype.
macro_rules! with_array_source {
    ($view:expr, $name:expr, $rate:expr, |$source:ident| $body:expr) => {
        match $view {
            View::I16(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::I32(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::F32(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
            View::F64(v) => {
                let $source = ArraySource::new($name, v, $rate);
                $body
            }
        }
    };
}

/// The views of a borrowed array, which may cross into a thread without the GIL.
enum View<'a> {
    I16(numpy::ndarray::ArrayView2<'a, i16>),
    I32(numpy::ndarray::ArrayView2<'a, i32>),
    F32(numpy::ndarray::ArrayView2<'a, f32>),
    F64(numpy::ndarray::ArrayView2<'a, f64>),
}

fn borrowed_view<'a>(b: &'a Borrowed<'_>) -> View<'a> {
    match b {
        Borrowed::I16(a) => View::I16(a.as_array()),
        Borrowed::I32(a) => View::I32(a.as_array()),
        Borrowed::F32(a) => View::F32(a.as_array()),
        Borrowed::F64(a) => View::F64(a.as_array()),
    }
}

/// An array and the options it is analysed with.
#[pyclass(module = "ssloc._native", frozen)]
struct Localizer {
    inner: ssl::Localizer,
    geometry_file: String,
}

/// Everything one recording gave.
#[pyclass(module = "ssloc._native", frozen)]
struct Run {
    rows: Vec<DetectionRecord>,
    events: Vec<EventRecord>,
    sources: Vec<SourceRecord>,
    file: FileEntry,
    metadata: RunMetadata,
    geometry: Geometry,
    tracked: bool,
}

/// What a run brings back across the GIL.
struct Gathered {
    rows: Vec<DetectionRecord>,
    events: Vec<EventRecord>,
    sources: Vec<SourceRecord>,
    entry: Option<FileEntry>,
    error: Option<PyErr>,
}

impl Localizer {
    /// Opens a recording with `open` and runs it with the GIL released, looking for
    /// Ctrl-C every [`SIGNAL_EVERY`]; `on_record` is called with each record as it
    /// comes (`"row"`, `"event"` or `"source"`, and the record as a dict).
    fn run<'a, S: SampleSource>(
        &'a self,
        on_record: Option<&Py<PyAny>>,
        open: impl FnOnce(&'a ssl::Localizer) -> Result<Recording<'a, S>, AnalysisError>,
    ) -> Gathered {
        let mut g = Gathered {
            rows: Vec::new(),
            events: Vec::new(),
            sources: Vec::new(),
            entry: None,
            error: None,
        };
        let recording = match open(&self.inner) {
            Ok(r) => r,
            Err(e) => {
                g.error = Some(analysis_error(&e));
                return g;
            }
        };
        let mut signal: Option<PyErr> = None;
        let mut refused: Option<PyErr> = None;
        let mut last = Instant::now();
        let (report, result) = recording.run_observed(
            |_| {
                if last.elapsed() < SIGNAL_EVERY {
                    return Ok(());
                }
                last = Instant::now();
                match Python::attach(|py| py.check_signals()) {
                    Ok(()) => Ok(()),
                    Err(e) => {
                        signal = Some(e);
                        Err(std::io::Error::from(std::io::ErrorKind::Interrupted).into())
                    }
                }
            },
            |out| {
                if let Some(callback) = on_record {
                    let called = Python::attach(|py| {
                        let (kind, record) = match &out {
                            Output::Row(r) => ("row", to_python(py, r)?),
                            Output::Event(e) => ("event", to_python(py, e)?),
                            Output::Source(s) => ("source", to_python(py, s)?),
                            _ => return Ok(()),
                        };
                        callback.call1(py, (kind, record)).map(|_| ())
                    });
                    if let Err(e) = called {
                        refused = Some(e);
                        return Err(std::io::Error::from(std::io::ErrorKind::Interrupted).into());
                    }
                }
                match out {
                    Output::Row(r) => g.rows.push(r),
                    Output::Event(e) => g.events.push(e),
                    Output::Source(s) => g.sources.push(s),
                    _ => {}
                }
                Ok(())
            },
        );
        let summary = &report.summary;
        let unconfirmed = report
            .tracking
            .zip(self.inner.tracking())
            .and_then(|(stats, p)| stats.nothing_confirmed(p))
            .map(|note| format!("{}: {note}", summary.name));
        g.entry = Some(
            FileEntry::new(&summary.name, Some(summary), None)
                .with_rows(report.rows)
                .with_tracking(report.tracking)
                .with_warning(unconfirmed),
        );
        g.error = match (signal.or(refused), result) {
            (Some(e), _) => Some(e),
            (None, Err(RunError::Input(e))) => Some(analysis_error(&e)),
            (None, Err(e)) => Some(value_error(e)),
            (None, Ok(())) => None,
        };
        g
    }

    /// The run's records as a [`Run`], or its error.
    fn finish(&self, g: Gathered, raised: Option<PyErr>) -> PyResult<Run> {
        if let Some(e) = raised.or(g.error) {
            return Err(e);
        }
        Ok(Run {
            rows: g.rows,
            events: g.events,
            sources: g.sources,
            file: g.entry.expect("a run that did not fail has its entry"),
            metadata: self.inner.metadata(&self.geometry_file),
            geometry: self.inner.geometry().clone(),
            tracked: self.inner.tracking().is_some(),
        })
    }
}

#[pymethods]
impl Localizer {
    #[new]
    #[pyo3(signature = (geometry, preset=None, options=None))]
    fn new(
        geometry: &Bound<'_, PyAny>,
        preset: Option<&str>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let config = keywords::config(preset, options)?;
        let (geometry, geometry_file) = geometry_of(geometry)?;
        let inner = ssl::Localizer::new(geometry, &config).map_err(value_error)?;
        Ok(Localizer {
            inner,
            geometry_file,
        })
    }

    /// The configuration, resolved, as the JSON metadata's `parameters`.
    fn config<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.config())
    }

    /// The metadata a JSON result of this localizer carries.
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.metadata(&self.geometry_file))
    }

    /// Remarks about the geometry.
    fn geometry_warnings(&self) -> Vec<String> {
        let g = self.inner.geometry();
        g.warnings
            .iter()
            .map(|w| format!("{}: {w}", self.geometry_file))
            .collect()
    }

    /// A WAV, RF64 or FLAC file.
    #[pyo3(signature = (path, on_record=None))]
    fn analyze_path(
        &self,
        py: Python<'_>,
        path: PathBuf,
        on_record: Option<Py<PyAny>>,
    ) -> PyResult<Run> {
        let name = path.display().to_string();
        let g = py.detach(|| self.run(on_record.as_ref(), |l| l.open(&name)));
        self.finish(g, None)
    }

    /// A numpy array, samples x channels.
    #[pyo3(signature = (array, sample_rate, name, on_record=None))]
    fn analyze_array(
        &self,
        py: Python<'_>,
        array: &Bound<'_, PyAny>,
        sample_rate: u32,
        name: &str,
        on_record: Option<Py<PyAny>>,
    ) -> PyResult<Run> {
        let borrowed = Borrowed::new(array)?;
        let view = borrowed_view(&borrowed);
        let g = py.detach(|| {
            with_array_source!(view, name, sample_rate, |source| self
                .run(on_record.as_ref(), |l| l.from_source(source)))
        });
        self.finish(g, None)
    }

    /// Blocks of samples from an iterator.
    #[pyo3(signature = (iterator, sample_rate, name, on_record=None))]
    fn analyze_blocks(
        &self,
        py: Python<'_>,
        iterator: Bound<'_, PyAny>,
        sample_rate: u32,
        name: &str,
        on_record: Option<Py<PyAny>>,
    ) -> PyResult<Run> {
        let source = BlockSource::new(name, iterator, sample_rate)?;
        let raised = source.raised.clone();
        let g = py.detach(|| self.run(on_record.as_ref(), |l| l.from_source(source)));
        let raised = raised.lock().expect("not poisoned").take();
        self.finish(g, raised)
    }
}

#[pymethods]
impl Run {
    /// The rows, as columns.
    fn rows<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let template = DetectionRecord {
            clock: self.metadata.clock().then(String::new),
            ..Default::default()
        };
        columns::columns(py, &template, &self.rows)
    }

    /// The events, as columns.
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let clock = self.metadata.clock().then(String::new);
        let template = EventRecord {
            start_clock: clock.clone(),
            end_clock: clock,
            ..Default::default()
        };
        columns::columns(py, &template, &self.events)
    }

    /// The sources, as columns.
    fn sources<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        columns::columns(py, &SourceRecord::default(), &self.sources)
    }

    /// The run's metadata.
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.metadata)
    }

    /// The recording's entry (the JSON result's `files` entry).
    fn file<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file)
    }

    /// Whether the run was tracked (rows carry sources; events and sources exist).
    #[getter]
    fn tracked(&self) -> bool {
        self.tracked
    }
}

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

/// `ssl check` on a path or an array.
#[pyfunction]
#[pyo3(signature = (audio, geometry, sample_rate=None, name="<array>", expect=Vec::new()))]
fn check<'py>(
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
fn evaluate<'py>(
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
