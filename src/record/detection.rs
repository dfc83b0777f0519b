//! One row of `ssl analyze`: a detected source in one frame.

use super::{first_non_finite, fixed, OutputError};
use crate::method::Detection;
use serde::{Deserialize, Serialize};

/// A detection as written (docs/interface.md, "Detections"): the fields every tool reads
/// first, in order, then ours. Values are rounded to fixed precision: time to the
/// microsecond, angles to a thousandth of a degree, the vector to 1e-6, the score to
/// 1e-4.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DetectionRecord {
    /// Centre of the analysis frame, seconds from the start of the file.
    pub time_s: f64,
    /// `atan2(y, x)` in degrees, in (-180, 180]: 0 is +x (forward), +90 is +y (left).
    pub azimuth_deg: f64,
    /// `asin(z)` in degrees: +90 is +z (up).
    pub elevation_deg: f64,
    /// Unit vector from the array centre toward the source: x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// Summed weighted correlation of the chosen delay set.
    pub score: f64,
    /// The input, as given (`<stdin>` for `-`).
    #[serde(default)]
    pub file: String,
    /// Frame index: frame `i` starts at sample `i * N / 2`.
    #[serde(default)]
    pub frame: Option<u64>,
    /// Microphones that took part.
    #[serde(default)]
    pub mics: Option<usize>,
    /// The track the detection belongs to (docs/interface.md, "Tracked sources"), or
    /// `None` with tracking off.
    #[serde(default)]
    pub source: Option<u64>,
    /// The half-angle (degrees) of the cone around the direction that holds the true
    /// direction with 95% probability (docs/interface.md, "Detections"); `None` in a
    /// result written before 0.3.0.
    #[serde(default)]
    pub uncertainty_deg: Option<f64>,
    /// The frame centre's wall-clock time on the recorder's clock, ISO 8601 to the
    /// microsecond, with `--clock` only (the field is absent without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<String>,
}

impl DetectionRecord {
    /// The record of `detection` in the recording named `file`. Fails on a non-finite
    /// value, which is never written.
    pub fn new(file: &str, d: &Detection) -> Result<Self, OutputError> {
        Self::tracked(file, d, None)
    }

    /// The record of `detection`, from the track `source` (or none).
    pub fn tracked(file: &str, d: &Detection, source: Option<u64>) -> Result<Self, OutputError> {
        let record = DetectionRecord {
            time_s: fixed(d.time_s, 6),
            azimuth_deg: fixed(d.azimuth_deg, 3),
            elevation_deg: fixed(d.elevation_deg, 3),
            x: fixed(d.direction.x, 6),
            y: fixed(d.direction.y, 6),
            z: fixed(d.direction.z, 6),
            score: fixed(d.score, 4),
            file: file.to_string(),
            frame: Some(d.frame),
            mics: Some(d.mics),
            source,
            uncertainty_deg: Some(fixed(d.uncertainty_deg, 2)),
            clock: None,
        };
        match record.non_finite() {
            Some(field) => Err(OutputError::NonFinite {
                field,
                file: file.to_string(),
                frame: d.frame,
            }),
            None => Ok(record),
        }
    }

    /// The first of its numbers that is NaN or infinite, by field name: such a record is
    /// never written, nor read back.
    pub fn non_finite(&self) -> Option<&'static str> {
        first_non_finite(&[
            ("time_s", self.time_s),
            ("azimuth_deg", self.azimuth_deg),
            ("elevation_deg", self.elevation_deg),
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("score", self.score),
            ("uncertainty_deg", self.uncertainty_deg.unwrap_or(0.0)),
        ])
    }
}
