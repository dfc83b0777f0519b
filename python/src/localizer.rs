//! The localizer and one recording's run: the library's `Localizer` opened on a file, an
//! array or blocks, run with the GIL released, its records kept for Python.

use crate::audio::{with_array_source, ArraySource, BlockSource, Borrowed, View};
use crate::columns;
use crate::convert::{analysis_error, geometry_of, to_python, value_error};
use crate::keywords;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use ssl::localize::{Output, Recording, RunError};
use ssl::record::{DetectionRecord, EventRecord, FileEntry, RunMetadata, SourceRecord};
use ssl::stream::SampleSource;
use ssl::{AnalysisError, Geometry};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How often a running analysis looks for Ctrl-C.
const SIGNAL_EVERY: Duration = Duration::from_millis(100);

/// An array and the options it is analysed with.
#[pyclass(module = "ssloc._native", frozen)]
pub struct Localizer {
    inner: ssl::Localizer,
    geometry_file: String,
}

/// Everything one recording gave.
#[pyclass(module = "ssloc._native", frozen)]
pub struct Run {
    pub(crate) rows: Vec<DetectionRecord>,
    pub(crate) events: Vec<EventRecord>,
    pub(crate) sources: Vec<SourceRecord>,
    pub(crate) file: FileEntry,
    pub(crate) metadata: RunMetadata,
    pub(crate) geometry: Geometry,
    pub(crate) tracked: bool,
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
        let view = borrowed.view();
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
