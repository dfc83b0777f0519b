//! JSON: one document with the run's metadata, a streamed `detections` array and the
//! per-file entries; NDJSON: one detection object per line.

use super::{DetectionRecord, EventRecord, Exporter, FileEntry, OutputError, RunMetadata};
use serde_json::Value;
use std::io::Write;

/// Writes one JSON document.
pub struct JsonExporter<W: Write> {
    out: W,
    first: bool,
    flush_each: bool,
    /// With `events`: the events, written after the detections (a few hundred bytes
    /// each, one per stretch of activity).
    events: Option<Vec<EventRecord>>,
}

impl<W: Write> JsonExporter<W> {
    /// A JSON document writer to `out`; with `events`, the document has an `events`
    /// array too.
    pub fn new(out: W, events: bool) -> Self {
        JsonExporter {
            out,
            first: true,
            flush_each: false,
            events: events.then(Vec::new),
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
        writeln!(self.out, "\"files\":{}}}", serde_json::to_string(files)?)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Writes one JSON object per detection per line.
pub struct NdjsonExporter<W: Write> {
    out: W,
    flush_each: bool,
    events: bool,
}

impl<W: Write> NdjsonExporter<W> {
    /// An NDJSON writer to `out`, of detections or (`events`) of events.
    pub fn new(out: W, events: bool) -> Self {
        NdjsonExporter {
            out,
            flush_each: false,
            events,
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
        if self.events {
            return Ok(());
        }
        self.line(record)
    }

    fn event(&mut self, record: &EventRecord) -> Result<(), OutputError> {
        if !self.events {
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
