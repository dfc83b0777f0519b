//! One row of `ssl analyze --events`: a stretch of activity of one tracked source.

use super::{first_non_finite, fixed, OutputError};
use crate::geometry::angles_deg;
use crate::track::Event;
use serde::{Deserialize, Serialize};

/// An event as written (docs/interface.md, "Events"), fields in order, rounded as
/// detections are.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EventRecord {
    /// The input, as given (`<stdin>` for `-`).
    pub file: String,
    /// The track's id.
    pub source: u64,
    /// Centre of the first detection's frame (seconds from the start of the file).
    pub start_s: f64,
    /// Centre of the last detection's frame.
    pub end_s: f64,
    /// Azimuth of the mean direction (degrees).
    pub azimuth_deg: f64,
    /// Elevation of the mean direction (degrees).
    pub elevation_deg: f64,
    /// Mean direction: x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// Angular spread of the detections (degrees; see [`Event::spread_deg`]).
    pub spread_deg: f64,
    /// Detections in the event.
    pub detections: u64,
    /// Mean score of the detections.
    pub score: f64,
    /// Azimuth of the first detection (degrees): where a moving source started.
    #[serde(default)]
    pub start_azimuth_deg: f64,
    /// Elevation of the first detection (degrees).
    #[serde(default)]
    pub start_elevation_deg: f64,
    /// Azimuth of the last detection (degrees): where a moving source ended.
    #[serde(default)]
    pub end_azimuth_deg: f64,
    /// Elevation of the last detection (degrees).
    #[serde(default)]
    pub end_elevation_deg: f64,
    /// The half-angle (degrees) of the cone around the mean direction that holds the
    /// true direction with 95% probability (see [`Event::uncertainty_deg`]); `None` in a
    /// result written before 0.3.0.
    #[serde(default)]
    pub uncertainty_deg: Option<f64>,
    /// The wall-clock times of `start_s` and `end_s` on the recorder's clock, ISO 8601
    /// to the microsecond, with `--clock` only (the fields are absent without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_clock: Option<String>,
    /// See `start_clock`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_clock: Option<String>,
}

/// An event whose first and last detections' directions lie this many degrees apart
/// or more is a moving source's, scored (`ssl evaluate`) and drawn (`ssl plot`) along
/// its path: a still source's two single frames differ by their errors (a few
/// degrees), a walker's by his turn.
pub(crate) const PATH_DEG: f64 = 10.0;

/// Whether an event from `first` to `last` (directions of any length) is a path
/// ([`PATH_DEG`]).
pub(crate) fn is_path(first: &nalgebra::Vector3<f64>, last: &nalgebra::Vector3<f64>) -> bool {
    crate::geometry::angle_between_deg(first, last) >= PATH_DEG
}

impl EventRecord {
    /// The directions of its first and last detections (unit vectors), unless the
    /// result was written before those fields (read then as 0, all four).
    pub(crate) fn ends(&self) -> Option<(nalgebra::Vector3<f64>, nalgebra::Vector3<f64>)> {
        let angles = [
            self.start_azimuth_deg,
            self.start_elevation_deg,
            self.end_azimuth_deg,
            self.end_elevation_deg,
        ];
        (angles != [0.0; 4]).then(|| {
            (
                crate::geometry::unit_from_angles(angles[0], angles[1]),
                crate::geometry::unit_from_angles(angles[2], angles[3]),
            )
        })
    }

    /// The record of `event` in the recording named `file`. Fails on a non-finite value.
    pub fn new(file: &str, e: &Event) -> Result<Self, OutputError> {
        let (azimuth, elevation) = angles_deg(&e.direction);
        let (start_azimuth, start_elevation) = angles_deg(&e.start_direction);
        let (end_azimuth, end_elevation) = angles_deg(&e.end_direction);
        let record = EventRecord {
            file: file.to_string(),
            source: e.source,
            start_s: fixed(e.start_s, 6),
            end_s: fixed(e.end_s, 6),
            azimuth_deg: fixed(azimuth, 3),
            elevation_deg: fixed(elevation, 3),
            x: fixed(e.direction.x, 6),
            y: fixed(e.direction.y, 6),
            z: fixed(e.direction.z, 6),
            spread_deg: fixed(e.spread_deg, 3),
            detections: e.detections,
            score: fixed(e.score, 4),
            start_azimuth_deg: fixed(start_azimuth, 3),
            start_elevation_deg: fixed(start_elevation, 3),
            end_azimuth_deg: fixed(end_azimuth, 3),
            end_elevation_deg: fixed(end_elevation, 3),
            uncertainty_deg: Some(fixed(e.uncertainty_deg, 2)),
            start_clock: None,
            end_clock: None,
        };
        match record.non_finite() {
            Some(field) => Err(OutputError::NonFiniteEvent {
                field,
                file: file.to_string(),
                track: e.source,
            }),
            None => Ok(record),
        }
    }

    /// The first of its numbers that is NaN or infinite, by field name: such a record is
    /// never written, nor read back.
    pub fn non_finite(&self) -> Option<&'static str> {
        first_non_finite(&[
            ("start_s", self.start_s),
            ("end_s", self.end_s),
            ("azimuth_deg", self.azimuth_deg),
            ("elevation_deg", self.elevation_deg),
            ("x", self.x),
            ("y", self.y),
            ("z", self.z),
            ("spread_deg", self.spread_deg),
            ("score", self.score),
            ("start_azimuth_deg", self.start_azimuth_deg),
            ("start_elevation_deg", self.start_elevation_deg),
            ("end_azimuth_deg", self.end_azimuth_deg),
            ("end_elevation_deg", self.end_elevation_deg),
            ("uncertainty_deg", self.uncertainty_deg.unwrap_or(0.0)),
        ])
    }
}
