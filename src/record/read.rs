//! Reading records back: detections in any of the three formats, and truth files.

use super::{DetectionRecord, Truth};
use crate::stream::{io_reason, read_text};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Why a result or truth file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("{}: cannot read: {}", path.display(), io_reason(error))]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The text is not what the tool writes.
    #[error("{}{message}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Format {
        /// The file, when reading one.
        path: Option<PathBuf>,
        /// What is wrong, and where.
        message: String,
    },
}

fn format_error(message: String) -> ReadError {
    ReadError::Format {
        path: None,
        message,
    }
}

fn in_file(path: &Path, e: ReadError) -> ReadError {
    match e {
        ReadError::Format { message, .. } => ReadError::Format {
            path: Some(path.to_path_buf()),
            message,
        },
        other => other,
    }
}

/// The largest result file read (about ten million detections).
pub const MAX_RESULT_BYTES: u64 = 1 << 30;
/// The largest truth file read.
pub const MAX_TRUTH_BYTES: u64 = 64 << 20;

fn read_file(path: &Path, limit: u64) -> Result<String, ReadError> {
    read_text(path, limit).map_err(|error| ReadError::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// Reads the detections of a CSV, NDJSON or JSON result of `ssl analyze`.
pub fn read_detections(path: &Path) -> Result<Vec<DetectionRecord>, ReadError> {
    parse_detections(&read_file(path, MAX_RESULT_BYTES)?).map_err(|e| in_file(path, e))
}

/// Parses detections from the text of a CSV, NDJSON or JSON result.
pub fn parse_detections(text: &str) -> Result<Vec<DetectionRecord>, ReadError> {
    let trimmed = text.trim_start();
    if !trimmed.starts_with('{') {
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        return reader
            .deserialize()
            .enumerate()
            .map(|(i, r)| r.map_err(|e| format_error(format!("row {}: {e}", i + 1))))
            .collect();
    }
    if let Ok(doc) = serde_json::from_str::<Value>(trimmed) {
        if let Some(detections) = doc.get("detections") {
            return serde_json::from_value(detections.clone())
                .map_err(|e| format_error(format!("`detections`: {e}")));
        }
    }
    trimmed
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str(l).map_err(|e| format_error(format!("line {}: {e}", i + 1)))
        })
        .collect()
}

impl Truth {
    /// Reads a truth file written by `ssl simulate`.
    pub fn from_file(path: &Path) -> Result<Self, ReadError> {
        Self::from_json(&read_file(path, MAX_TRUTH_BYTES)?).map_err(|e| in_file(path, e))
    }

    /// Parses a truth file's text.
    pub fn from_json(text: &str) -> Result<Self, ReadError> {
        serde_json::from_str(text).map_err(|e| format_error(format!("not a truth file: {e}")))
    }
}
