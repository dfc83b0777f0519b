//! A result of `ssl analyze` as `ssl plot` reads it: detections and events of every
//! file, in any of the three formats, with the array and the threshold when the result
//! is a JSON document.

use crate::record::{DetectionRecord, EventRecord, ReadError};
use serde_json::Value;

/// One file's rows.
#[derive(Debug, Clone, Default)]
pub struct PlotFile {
    /// The file, as the result names it.
    pub name: String,
    /// Its detections, in order.
    pub detections: Vec<DetectionRecord>,
    /// Its events.
    pub events: Vec<EventRecord>,
}

/// What a result holds for drawing.
#[derive(Debug, Clone, Default)]
pub struct PlotData {
    /// The files, in the order they first appear.
    pub files: Vec<PlotFile>,
    /// The array (name and microphones), from a JSON document's metadata.
    pub array: Option<String>,
    /// The detection threshold, from a JSON document's metadata.
    pub threshold: Option<String>,
}

impl PlotData {
    fn file(&mut self, name: &str) -> &mut PlotFile {
        match self.files.iter().position(|f| f.name == name) {
            Some(i) => &mut self.files[i],
            None => {
                self.files.push(PlotFile {
                    name: name.to_string(),
                    ..Default::default()
                });
                self.files.last_mut().expect("just pushed")
            }
        }
    }

    /// Adds a detection; one with a value that is not finite (`inf` in a CSV) is
    /// refused: nothing can be drawn of it, and it would stretch the axes without end.
    fn add_detection(&mut self, r: DetectionRecord) -> Result<(), String> {
        if let Some(field) = r.non_finite() {
            return Err(format!("a detection's {field} is not a finite number"));
        }
        let name = r.file.clone();
        self.file(&name).detections.push(r);
        Ok(())
    }

    /// Adds an event; one with a value that is not finite is refused.
    fn add_event(&mut self, e: EventRecord) -> Result<(), String> {
        if let Some(field) = e.non_finite() {
            return Err(format!("an event's {field} is not a finite number"));
        }
        let name = e.file.clone();
        self.file(&name).events.push(e);
        Ok(())
    }
}

fn bad(message: String) -> ReadError {
    ReadError::Format {
        path: None,
        message,
    }
}

/// Parses a CSV (detections or `--events`), NDJSON or JSON result.
pub fn parse_result(text: &str) -> Result<PlotData, ReadError> {
    let mut data = PlotData::default();
    let trimmed = text.trim_start();
    if !trimmed.starts_with('{') {
        let events = trimmed.starts_with("file,source,start_s,");
        if !events && !trimmed.starts_with("time_s,") {
            let first = trimmed
                .lines()
                .next()
                .unwrap_or("")
                .chars()
                .take(60)
                .collect::<String>();
            return Err(bad(format!(
                "not a result of ssl analyze: its first line is {first:?}, not a CSV header of detections or events"
            )));
        }
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let headers = reader.headers().map_err(|e| bad(e.to_string()))?.clone();
        for (i, row) in reader.records().enumerate() {
            let row = row.map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
            if events {
                let e = row
                    .deserialize::<EventRecord>(Some(&headers))
                    .map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
                data.add_event(e)
                    .map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
            } else {
                let r = row
                    .deserialize::<DetectionRecord>(Some(&headers))
                    .map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
                data.add_detection(r)
                    .map_err(|e| bad(format!("row {}: {e}", i + 1)))?;
            }
        }
        return Ok(data);
    }
    if let Ok(doc) = serde_json::from_str::<Value>(trimmed) {
        if doc.get("detections").is_some() {
            let rows: Vec<DetectionRecord> = serde_json::from_value(doc["detections"].clone())
                .map_err(|e| bad(format!("`detections`: {e}")))?;
            for (k, r) in rows.into_iter().enumerate() {
                data.add_detection(r)
                    .map_err(|e| bad(format!("`detections`[{k}]: {e}")))?;
            }
            if let Some(events) = doc.get("events") {
                let events: Vec<EventRecord> = serde_json::from_value(events.clone())
                    .map_err(|e| bad(format!("`events`: {e}")))?;
                for (k, e) in events.into_iter().enumerate() {
                    data.add_event(e)
                        .map_err(|e| bad(format!("`events`[{k}]: {e}")))?;
                }
            }
            let g = &doc["geometry"];
            if let Some(mics) = g["microphones"].as_u64() {
                data.array = Some(match g["name"].as_str() {
                    Some(n) => format!("{n} ({mics} mics)"),
                    None => format!("{mics} mics"),
                });
            }
            let p = &doc["parameters"];
            data.threshold = match (
                p["min_score_per_pair"].as_f64(),
                p["threshold_sigmas"].as_f64(),
            ) {
                (Some(m), _) => Some(format!("fixed, {m} per pair")),
                (None, Some(z)) => Some(format!("calibrated per frame, {z} sigmas")),
                _ => None,
            };
            return Ok(data);
        }
    }
    for (i, line) in trimmed
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let v: Value =
            serde_json::from_str(line).map_err(|e| bad(format!("line {}: {e}", i + 1)))?;
        let added = if v.get("start_s").is_some() {
            data.add_event(
                serde_json::from_value(v).map_err(|e| bad(format!("line {}: {e}", i + 1)))?,
            )
        } else {
            data.add_detection(
                serde_json::from_value(v).map_err(|e| bad(format!("line {}: {e}", i + 1)))?,
            )
        };
        added.map_err(|e| bad(format!("line {}: {e}", i + 1)))?;
    }
    Ok(data)
}
