//! JSON: one document with the run's metadata, a streamed `detections` array and the
//! per-file entries; NDJSON: one detection object per line.

use super::{
    DetectionRecord, EventRecord, Exporter, FileEntry, OutputError, Records, RunMetadata,
    SourceRecord,
};
use serde_json::Value;
use std::io::Write;

/// Writes one JSON document.
pub(crate) struct JsonExporter<W: Write> {
    out: W,
    first: bool,
    flush_each: bool,
    /// With events or sources: the events, written after the detections (a few hundred
    /// bytes each, one per stretch of activity).
    events: Option<Vec<EventRecord>>,
    /// With sources: the sources, written after the events (one per track).
    sources: Option<Vec<SourceRecord>>,
}

impl<W: Write> JsonExporter<W> {
    /// A JSON document writer to `out`: its `detections` array, and an `events` array
    /// with `Records::Events`, `events` and `sources` with `Records::Sources`.
    pub fn new(out: W, records: Records) -> Self {
        JsonExporter {
            out,
            first: true,
            flush_each: false,
            events: (records != Records::Detections).then(Vec::new),
            sources: (records == Records::Sources).then(Vec::new),
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

    fn event(&mut self, record: &EventRecord) -> Result<(), OutputError> {
        if let Some(events) = self.events.as_mut() {
            events.push(record.clone());
        }
        Ok(())
    }

    fn source(&mut self, record: &SourceRecord) -> Result<(), OutputError> {
        if let Some(sources) = self.sources.as_mut() {
            sources.push(record.clone());
        }
        Ok(())
    }

    fn flush_each_record(&mut self) {
        self.flush_each = true;
    }

    fn finish(mut self: Box<Self>, files: &[FileEntry]) -> Result<W, OutputError> {
        self.out.write_all(b"\n],\n")?;
        if let Some(events) = &self.events {
            self.out.write_all(b"\"events\":[")?;
            for (i, e) in events.iter().enumerate() {
                self.out.write_all(if i == 0 { b"\n" } else { b",\n" })?;
                serde_json::to_writer(&mut self.out, e)?;
            }
            self.out.write_all(b"\n],\n")?;
        }
        if let Some(sources) = &self.sources {
            self.out.write_all(b"\"sources\":[")?;
            for (i, s) in sources.iter().enumerate() {
                self.out.write_all(if i == 0 { b"\n" } else { b",\n" })?;
                serde_json::to_writer(&mut self.out, s)?;
            }
            self.out.write_all(b"\n],\n")?;
        }
        writeln!(self.out, "\"files\":{}}}", serde_json::to_string(files)?)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes one JSON object per detection per line.
pub(crate) struct NdjsonExporter<W: Write> {
    out: W,
    flush_each: bool,
    records: Records,
}

impl<W: Write> NdjsonExporter<W> {
    /// An NDJSON writer to `out` of `records`.
    pub fn new(out: W, records: Records) -> Self {
        NdjsonExporter {
            out,
            flush_each: false,
            records,
        }
    }

    fn line<T: serde::Serialize>(&mut self, record: &T) -> Result<(), OutputError> {
        serde_json::to_writer(&mut self.out, record)?;
        self.out.write_all(b"\n")?;
        if self.flush_each {
            self.out.flush()?;
        }
        Ok(())
    }
}

impl<W: Write> Exporter<W> for NdjsonExporter<W> {
    fn begin(&mut self, _meta: &RunMetadata) -> Result<(), OutputError> {
        Ok(())
    }

    fn detection(&mut self, record: &DetectionRecord) -> Result<(), OutputError> {
        if self.records != Records::Detections {
            return Ok(());
        }
        self.line(record)
    }

    fn event(&mut self, record: &EventRecord) -> Result<(), OutputError> {
        if self.records != Records::Events {
            return Ok(());
        }
        self.line(record)
    }

    fn source(&mut self, record: &SourceRecord) -> Result<(), OutputError> {
        if self.records != Records::Sources {
            return Ok(());
        }
        self.line(record)
    }

    fn flush_each_record(&mut self) {
        self.flush_each = true;
    }

    fn finish(mut self: Box<Self>, _files: &[FileEntry]) -> Result<W, OutputError> {
        self.out.flush()?;
        Ok(self.out)
    }
}
