//! Output: detections as CSV, NDJSON or one JSON document, per the interface contract.
//!
//! Every format carries the contract's fields first, in order: `time_s`, `azimuth_deg`,
//! `elevation_deg`, `x`, `y`, `z`, `score`; then `file`, `frame` and `mics`. All three
//! formats are written as frames are analysed (the JSON document too: its `detections`
//! array is streamed), so memory does not grow with the number of detections.

use crate::geometry::{Geometry, Shape};
use crate::pipeline::{Detection, Params};
use crate::session::FileSummary;
use anyhow::{bail, Result};
use serde_json::{json, Value};
use std::io::Write;

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// A header line, then one row per detection.
    Csv,
    /// One JSON document: run metadata and a `detections` array.
    Json,
    /// One JSON object per detection per line.
    Ndjson,
}

/// The contract's columns, then ours.
pub const COLUMNS: [&str; 10] = [
    "time_s",
    "azimuth_deg",
    "elevation_deg",
    "x",
    "y",
    "z",
    "score",
    "file",
    "frame",
    "mics",
];

/// Fixed precision: time to the microsecond, angles to a thousandth of a degree.
fn round(v: f64, decimals: i32) -> f64 {
    let f = 10f64.powi(decimals);
    // `+ 0.0` turns -0.0 into 0.0.
    (v * f).round() / f + 0.0
}

fn fields(d: &Detection) -> [f64; 7] {
    [
        round(d.time_s, 6),
        round(d.azimuth_deg, 3),
        round(d.elevation_deg, 3),
        round(d.direction.x, 6),
        round(d.direction.y, 6),
        round(d.direction.z, 6),
        round(d.score, 4),
    ]
}

/// Writes detections in one format to a byte stream.
pub struct DetectionWriter<W: Write> {
    format: Format,
    out: Out<W>,
    first: bool,
    /// Flush after every record (a live consumer at the other end of a pipe).
    pub line_flush: bool,
}

impl<W: Write> DetectionWriter<W> {
    pub fn new(format: Format, out: W) -> Self {
        DetectionWriter {
            format,
            out: match format {
                Format::Csv => Out::Csv(Box::new(csv::WriterBuilder::new().from_writer(out))),
                _ => Out::Json(out),
            },
            first: true,
            line_flush: false,
        }
    }

    /// Starts the output: the CSV header, or the JSON document's metadata.
    pub fn begin(&mut self, meta: &Value) -> Result<()> {
        match (&mut self.out, self.format) {
            (Out::Csv(csv), _) => csv.write_record(COLUMNS)?,
            (Out::Json(out), Format::Json) => {
                let Value::Object(map) = meta else {
                    bail!("metadata must be an object")
                };
                out.write_all(b"{")?;
                for (key, value) in map {
                    writeln!(out, "{}:{},", Value::from(key.as_str()), value)?;
                }
                out.write_all(b"\"detections\":[")?;
            }
            (Out::Json(_), _) => {}
        }
        Ok(())
    }

    /// Writes one detection.
    pub fn detection(&mut self, file: &str, d: &Detection) -> Result<()> {
        let v = fields(d);
        if let Some(bad) = v.iter().position(|x| !x.is_finite()) {
            bail!(
                "internal error: non-finite {} in a detection of {file} (frame {})",
                COLUMNS[bad],
                d.frame
            );
        }
        match &mut self.out {
            Out::Csv(csv) => {
                for x in v {
                    csv.write_field(x.to_string())?;
                }
                csv.write_field(file)?;
                csv.write_field(d.frame.to_string())?;
                csv.write_field(d.mics.to_string())?;
                csv.write_record(None::<&[u8]>)?;
                if self.line_flush {
                    csv.flush()?;
                }
            }
            Out::Json(out) => {
                let obj = json!({
                    "time_s": v[0], "azimuth_deg": v[1], "elevation_deg": v[2],
                    "x": v[3], "y": v[4], "z": v[5], "score": v[6],
                    "file": file, "frame": d.frame, "mics": d.mics,
                });
                if self.format == Format::Json {
                    out.write_all(if self.first { b"\n" } else { b",\n" })?;
                    serde_json::to_writer(&mut *out, &obj)?;
                } else {
                    serde_json::to_writer(&mut *out, &obj)?;
                    out.write_all(b"\n")?;
                }
                if self.line_flush {
                    out.flush()?;
                }
            }
        }
        self.first = false;
        Ok(())
    }

    /// Ends the output (closes the JSON document with the per-file summaries) and
    /// returns the inner writer, flushed.
    pub fn finish(self, files: &[Value]) -> Result<W> {
        let mut out = match self.out {
            Out::Csv(csv) => csv.into_inner().map_err(|e| e.into_error())?,
            Out::Json(out) => out,
        };
        if self.format == Format::Json {
            write!(out, "\n],\n\"files\":{}}}\n", Value::from(files.to_vec()))?;
        }
        out.flush()?;
        Ok(out)
    }
}

enum Out<W: Write> {
    Csv(Box<csv::Writer<W>>),
    Json(W),
}

/// The run's metadata for the JSON document.
pub fn run_metadata(geometry: &Geometry, geometry_path: &str, params: &Params) -> Value {
    json!({
        "tool": { "name": "ssl", "version": env!("CARGO_PKG_VERSION") },
        "geometry": geometry_json(geometry, geometry_path),
        "parameters": {
            "frame_size": params.frame_size.map_or(json!("auto"), |n| json!(n)),
            "hop": "frame_size / 2",
            "window": params.window,
            "alpha": params.alpha,
            "gamma": params.gamma,
            "weighting": params.weighting,
            "peaks": params.peaks,
            "tolerance_samples": params.tolerance,
            "interpolation": params.interpolation,
            "speed_of_sound": params.speed_of_sound.unwrap_or(geometry.speed_of_sound),
            "min_score": params.min_score.map_or(
                json!(format!("{} per microphone pair", crate::pipeline::DEFAULT_MIN_SCORE_PER_PAIR)),
                |s| json!(s)
            ),
        },
    })
}

/// What the tool understood of the geometry, including the ambiguity it resolves.
pub fn geometry_json(g: &Geometry, path: &str) -> Value {
    let mics: Vec<Value> = g
        .mics
        .iter()
        .map(|m| json!({ "position": [m.position.x, m.position.y, m.position.z], "channel": m.channel }))
        .collect();
    json!({
        "file": path,
        "name": g.name,
        "microphones": g.mics.len(),
        "speed_of_sound": g.speed_of_sound,
        "centre": [round(g.centre.x, 9), round(g.centre.y, 9), round(g.centre.z, 9)],
        "shape": g.shape.label(),
        "side": match g.shape { Shape::Volumetric => Value::Null, _ => json!([g.side.x, g.side.y, g.side.z]) },
        "note": ambiguity_note(g),
        "mics": mics,
    })
}

/// One sentence on what the array cannot tell, or `None` for a 3-D array.
pub fn ambiguity_note(g: &Geometry) -> Option<String> {
    let s = g.side;
    match g.shape {
        Shape::Volumetric => None,
        Shape::Planar { normal } => Some(format!(
            "planar array: a direction and its mirror image through the array's plane are indistinguishable; directions are reported on the side of the plane that side = [{}, {}, {}] points to (normal [{:.3}, {:.3}, {:.3}])",
            s.x, s.y, s.z, normal.x + 0.0, normal.y + 0.0, normal.z + 0.0
        )),
        Shape::Linear { axis } => Some(format!(
            "linear array: only the angle to the axis [{:.3}, {:.3}, {:.3}] is known; directions are reported in the plane of the axis and side = [{}, {}, {}], on that side",
            axis.x + 0.0, axis.y + 0.0, axis.z + 0.0, s.x, s.y, s.z
        )),
    }
}

/// A file's entry in the JSON document's `files` array.
pub fn file_json(name: &str, summary: Option<&FileSummary>, error: Option<&str>) -> Value {
    let mut v = json!({ "file": name, "error": error });
    if let Some(s) = summary {
        let obj = v.as_object_mut().expect("object");
        obj.insert("sample_rate".into(), json!(s.format.sample_rate));
        obj.insert("channels".into(), json!(s.format.channels));
        obj.insert("format".into(), json!(s.format.describe()));
        obj.insert("frame_size".into(), json!(s.frame_size));
        obj.insert("frames".into(), json!(s.stats.frames));
        obj.insert("detections".into(), json!(s.stats.detections));
        obj.insert("warnings".into(), json!(s.warnings));
    }
    v
}
