//! Records and output formats (docs/interface.md, "Detections").
//!
//! One serde type per record: [`DetectionRecord`] (a row of `ssl analyze`),
//! [`RunMetadata`] and [`FileEntry`] (the JSON document's metadata and per-file entries),
//! and [`Truth`] (what `ssl simulate` knows and `ssl evaluate` scores against). The
//! field order of each type is the column order of every format. Writers for CSV, NDJSON
//! and JSON sit behind one [`Exporter`] trait; [`read_detections`] reads any of them
//! back.

mod csv;
mod detection;
pub(crate) mod event;
mod json;
pub(crate) mod metadata;
mod read;
mod source;
pub(crate) mod truth;
mod truth_forms;
mod truth_labels;

pub(crate) use self::csv::CsvExporter;
pub(crate) use self::json::{JsonExporter, NdjsonExporter};
pub use detection::DetectionRecord;
pub use event::EventRecord;
pub use metadata::{FileEntry, GeometryInfo, MicInfo, RunMetadata, Tool};
#[cfg(feature = "cli")]
pub(crate) use read::{array_of, MAX_TRUTH_BYTES};
pub use read::{
    parse_detections, read_detections, read_records_with_info, read_result, read_result_file,
    ReadError, ResultInfo, ResultRecord,
};
pub use source::{SourceRecord, Sources};
pub use truth::{Truth, TruthArray, TruthFan, TruthNoise, TruthRoom, TruthSource};

pub(crate) use crate::text::fixed;
use crate::Named;
use std::io::{self, Write};

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// A header line, then one row per detection.
    Csv,
    /// One JSON document: run metadata and a `detections` array.
    Json,
    /// One JSON object per detection per line.
    Ndjson,
}

impl Named for Format {
    const ALL: &'static [(Format, &'static str, &'static str)] = &[
        (
            Format::Csv,
            "csv",
            "A header line, then one row per detection",
        ),
        (
            Format::Json,
            "json",
            "One JSON document: run metadata and a `detections` array",
        ),
        (
            Format::Ndjson,
            "ndjson",
            "One JSON object per detection per line",
        ),
    ];
}

impl Format {
    /// A writer of this format to `out` of `records` (CSV and NDJSON: those only; JSON:
    /// the detections, and the events and sources asked for in their own arrays).
    pub fn exporter<W: Write + 'static>(self, out: W, records: Records) -> Box<dyn Exporter<W>> {
        match self {
            Format::Csv => Box::new(CsvExporter::new(out, records)),
            Format::Json => Box::new(JsonExporter::new(out, records)),
            Format::Ndjson => Box::new(NdjsonExporter::new(out, records)),
        }
    }
}

/// What an output holds: CSV and NDJSON hold one kind of record; a JSON document holds
/// the detections always, the events with `Events`, events and sources with `Sources`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Records {
    /// The rows (`ssl analyze`).
    Detections,
    /// The events (`--events`).
    Events,
    /// The sources (`--sources`).
    Sources,
}

/// Writes detections in one format, as they are analysed: memory does not grow with
/// the number of detections (the JSON document's array is streamed too).
pub trait Exporter<W: Write> {
    /// Starts the output: the CSV header, or the JSON document's metadata.
    fn begin(&mut self, meta: &RunMetadata) -> Result<(), OutputError>;
    /// Writes one detection (nothing when a CSV or NDJSON writer writes events).
    fn detection(&mut self, record: &DetectionRecord) -> Result<(), OutputError>;
    /// Writes one event (nothing unless the writer was made for events; JSON keeps them
    /// for the end of the document).
    fn event(&mut self, record: &EventRecord) -> Result<(), OutputError>;
    /// Writes one source (nothing unless the writer was made for sources; JSON keeps
    /// them for the end of the document).
    fn source(&mut self, record: &SourceRecord) -> Result<(), OutputError>;
    /// Flush after every record from now on (a live consumer at the other end of a pipe).
    fn flush_each_record(&mut self);
    /// Ends the output (the JSON document closes with the per-file entries) and returns
    /// the writer, flushed.
    fn finish(self: Box<Self>, files: &[FileEntry]) -> Result<W, OutputError>;
}

/// Why output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The destination failed.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The CSV writer failed.
    #[error("{0}")]
    Csv(#[from] ::csv::Error),
    /// The JSON writer failed.
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// A record holds NaN or an infinity (a bug: it is never written).
    #[error("internal error: non-finite {field} in a detection of {file} (frame {frame})")]
    NonFinite {
        /// The field.
        field: &'static str,
        /// The input's name.
        file: String,
        /// The frame.
        frame: u64,
    },
    /// An event holds NaN or an infinity (a bug: it is never written).
    #[error("internal error: non-finite {field} in an event of {file} (source {track})")]
    NonFiniteEvent {
        /// The field.
        field: &'static str,
        /// The input's name.
        file: String,
        /// The track.
        track: u64,
    },
}

impl OutputError {
    /// Why, in a few words: the operating system's reason for a failed write (`No space
    /// left on device`), without the error number.
    pub fn reason(&self) -> String {
        let text = match self {
            OutputError::Io(e) => return crate::stream::io_reason(e),
            OutputError::Csv(e) => match e.kind() {
                ::csv::ErrorKind::Io(e) => return crate::stream::io_reason(e),
                _ => e.to_string(),
            },
            other => other.to_string(),
        };
        match text.find(" (os error") {
            Some(i) => text[..i].to_string(),
            None => text,
        }
    }

    /// Whether the reader at the other end went away (`ssl ... | head`).
    pub fn is_broken_pipe(&self) -> bool {
        let kind = match self {
            OutputError::Io(e) => Some(e.kind()),
            OutputError::Csv(e) => match e.kind() {
                ::csv::ErrorKind::Io(e) => Some(e.kind()),
                _ => None,
            },
            OutputError::Json(e) => e.io_error_kind(),
            OutputError::NonFinite { .. } | OutputError::NonFiniteEvent { .. } => None,
        };
        kind == Some(io::ErrorKind::BrokenPipe)
    }
}

/// The first of `values` (a record's numbers, by field) that is NaN or infinite.
pub(crate) fn first_non_finite(values: &[(&'static str, f64)]) -> Option<&'static str> {
    values.iter().find(|(_, v)| !v.is_finite()).map(|&(f, _)| f)
}
