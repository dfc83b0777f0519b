//! JSON: one document with the run's metadata, a streamed `detections` array and the
//! per-file entries; NDJSON: one detection object per line.

use super::{DetectionRecord, Exporter, FileEntry, OutputError, RunMetadata};
use serde_json::Value;
use std::io::Write;

/// Writes one JSON document.
pub struct JsonExporter<W: Write> {
    out: W,
    first: bool,
    flush_each: bool,
}

impl<W: Write> JsonExporter<W> {
    /// A JSON document writer to `out`.
    pub fn new(out: W) -> Self {
        JsonExporter {
            out,
            first: true,
            flush_each: false,
        }
    }
}

impl<W: Write> Exporter<W> for JsonExporter<W> {
    fn begin(&mut self, meta: &RunMetadata) -> Result<(), OutputError> {
        let Value::Object(map) = serde_json::to_value(meta)? else {
            unreachable!("the metadata is a struct");
        };
        self.out.write_all(b"{")?;
        for (key, value) in map {
            writeln!(self.out, "{}:{},", Value::from(key), value)?;
        }
        self.out.write_all(b"\"detections\":[")?;
        Ok(())
    }

    fn detection(&mut self, record: &DetectionRecord) -> Result<(), OutputError> {
        self.out
            .write_all(if self.first { b"\n" } else { b",\n" })?;
        serde_json::to_writer(&mut self.out, record)?;
        self.first = false;
        if self.flush_each {
            self.out.flush()?;
        }
        Ok(())
    }

    fn flush_each_record(&mut self) {
        self.flush_each = true;
    }

    fn finish(mut self: Box<Self>, files: &[FileEntry]) -> Result<W, OutputError> {
        write!(
            self.out,
            "\n],\n\"files\":{}}}\n",
            serde_json::to_string(files)?
        )?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes one JSON object per detection per line.
pub struct NdjsonExporter<W: Write> {
    out: W,
    flush_each: bool,
}

impl<W: Write> NdjsonExporter<W> {
    /// An NDJSON writer to `out`.
    pub fn new(out: W) -> Self {
        NdjsonExporter {
            out,
            flush_each: false,
        }
    }
}

impl<W: Write> Exporter<W> for NdjsonExporter<W> {
    fn begin(&mut self, _meta: &RunMetadata) -> Result<(), OutputError> {
        Ok(())
    }

    fn detection(&mut self, record: &DetectionRecord) -> Result<(), OutputError> {
        serde_json::to_writer(&mut self.out, record)?;
        self.out.write_all(b"\n")?;
        if self.flush_each {
            self.out.flush()?;
        }
        Ok(())
    }

    fn flush_each_record(&mut self) {
        self.flush_each = true;
    }

    fn finish(mut self: Box<Self>, _files: &[FileEntry]) -> Result<W, OutputError> {
        self.out.flush()?;
        Ok(self.out)
    }
}
