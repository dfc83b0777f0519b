//! A result of `ssl analyze` as `ssl plot` reads it: detections and events of every
//! file, in any of the three formats, with the array and the threshold when the result
//! is a JSON document.

use crate::method::Threshold;
use crate::record::{
    read_result, DetectionRecord, EventRecord, ReadError, ResultInfo, ResultRecord,
};
use crate::Config;
use serde::Deserialize;

/// One file's rows.
#[derive(Debug, Clone, Default)]
#[doc(hidden)]
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
#[doc(hidden)]
pub struct PlotData {
    /// The files, in the order they first appear.
    pub files: Vec<PlotFile>,
    /// The array (name and microphones), from a JSON document's metadata.
    pub array: Option<String>,
    /// The detection threshold, from a JSON document's metadata.
    pub threshold: Option<String>,
    /// The array's geometry, from a JSON document's metadata: what the scores measure.
    pub geometry: Option<crate::Geometry>,
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

    /// Adds a record to its file.
    fn add(&mut self, record: ResultRecord) {
        match record {
            ResultRecord::Detection(r) => {
                let name = r.file.clone();
                self.file(&name).detections.push(r);
            }
            ResultRecord::Event(e) => {
                let name = e.file.clone();
                self.file(&name).events.push(e);
            }
        }
    }

    /// Adds what a result read by [`read_result`] holds: its records, and from a JSON
    /// document the array and the threshold.
    fn take(&mut self, info: &ResultInfo) {
        self.geometry = self.geometry.take().or_else(|| info.array());
        if let Some(g) = &info.geometry {
            if let Some(mics) = g["microphones"].as_u64() {
                self.array = Some(match g["name"].as_str() {
                    Some(n) => format!("{n} ({mics} mics)"),
                    None => format!("{mics} mics"),
                });
            }
        }
        if let Some(p) = &info.parameters {
            self.threshold = threshold_of(p).map(|t| match t {
                Threshold::Fixed { per_pair } => format!("fixed, {per_pair} per pair"),
                Threshold::Calibrated { sigmas } => {
                    format!("calibrated per frame, {sigmas} sigmas")
                }
            });
        }
    }
}

/// The threshold a document's `parameters` record: the configuration's (0.3.0 on), or
/// the flat fields of the documents 0.2.0 and before wrote.
fn threshold_of(parameters: &serde_json::Value) -> Option<Threshold> {
    if let Ok(config) = Config::deserialize(parameters) {
        return Some(config.threshold);
    }
    let old = |key: &str| parameters.get(key).and_then(serde_json::Value::as_f64);
    match (old("min_score_per_pair"), old("threshold_sigmas")) {
        (Some(per_pair), _) => Some(Threshold::Fixed { per_pair }),
        (None, Some(sigmas)) => Some(Threshold::Calibrated { sigmas }),
        _ => None,
    }
}

/// Reads a CSV (detections or `--events`), NDJSON or JSON result, streamed by the one
/// reader of results ([`read_result`]), which refuses what `ssl analyze` does not write
/// (a number that is not finite included: nothing can be drawn of it).
#[doc(hidden)]
pub fn read_plot_data(input: impl std::io::Read) -> Result<PlotData, ReadError> {
    gather(|each| read_result(input, each))
}

/// Reads a result file, or standard input for `-` (see [`read_plot_data`]).
#[cfg(feature = "cli")]
pub(crate) fn read_plot_file(path: &std::path::Path) -> Result<PlotData, ReadError> {
    gather(|each| crate::record::read_result_file(path, each))
}

/// The records and the document's figures that `read` hands over, as drawn.
fn gather(
    read: impl FnOnce(
        &mut dyn FnMut(ResultRecord) -> Result<(), String>,
    ) -> Result<ResultInfo, ReadError>,
) -> Result<PlotData, ReadError> {
    let mut data = PlotData::default();
    let info = read(&mut |r| {
        data.add(r);
        Ok(())
    })?;
    data.take(&info);
    Ok(data)
}
