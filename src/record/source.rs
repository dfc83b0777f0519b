//! One record of `ssl analyze --sources`: a tracked source over a whole file
//! (docs/interface.md, "Sources"), summed from its events.

use super::{first_non_finite, fixed, EventRecord, OutputError};
use crate::geometry::angles_deg;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A source as written, fields in order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SourceRecord {
    /// The input, as given.
    pub file: String,
    /// The track's id.
    pub source: u64,
    /// The start of its first event (seconds).
    pub first_s: f64,
    /// The end of its last event.
    pub last_s: f64,
    /// The time its events cover (seconds).
    pub active_s: f64,
    /// Its events.
    pub events: u64,
    /// Azimuth of its mean direction over all its detections (degrees).
    pub azimuth_deg: f64,
    /// Elevation of the same (degrees).
    pub elevation_deg: f64,
    /// The mean direction: x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// Angular spread of all its detections (degrees; as an event's `spread_deg`).
    pub spread_deg: f64,
    /// Its detections.
    pub detections: u64,
}

/// The sources of one file, summed from its events as they come.
#[derive(Debug, Clone, Default)]
pub struct Sources {
    by_id: BTreeMap<u64, Sum>,
}

#[derive(Debug, Clone)]
struct Sum {
    first_s: f64,
    last_s: f64,
    active_s: f64,
    events: u64,
    /// The sum of the detections' unit vectors (an event's mean direction times its
    /// mean resultant length times its detections).
    vector: Vector3<f64>,
    detections: u64,
}

impl Sources {
    /// Adds an event.
    pub fn add(&mut self, e: &EventRecord) {
        let n = e.detections as f64;
        let resultant = e.spread_deg.to_radians().cos();
        let v = Vector3::new(e.x, e.y, e.z).normalize() * (resultant * n);
        let s = self.by_id.entry(e.source).or_insert(Sum {
            first_s: e.start_s,
            last_s: e.end_s,
            active_s: 0.0,
            events: 0,
            vector: Vector3::zeros(),
            detections: 0,
        });
        s.first_s = s.first_s.min(e.start_s);
        s.last_s = s.last_s.max(e.end_s);
        s.active_s += e.end_s - e.start_s;
        s.events += 1;
        s.vector += v;
        s.detections += e.detections;
    }

    /// The records of file `file`, by id; fails on a non-finite value.
    pub fn records(&self, file: &str) -> Result<Vec<SourceRecord>, OutputError> {
        self.by_id
            .iter()
            .map(|(&source, s)| {
                let length = s.vector.norm();
                let u = if length > 0.0 {
                    s.vector / length
                } else {
                    Vector3::x()
                };
                let (azimuth, elevation) = angles_deg(&u);
                let resultant = length / s.detections.max(1) as f64;
                let record = SourceRecord {
                    file: file.to_string(),
                    source,
                    first_s: fixed(s.first_s, 6),
                    last_s: fixed(s.last_s, 6),
                    active_s: fixed(s.active_s, 6),
                    events: s.events,
                    azimuth_deg: fixed(azimuth, 3),
                    elevation_deg: fixed(elevation, 3),
                    x: fixed(u.x, 6),
                    y: fixed(u.y, 6),
                    z: fixed(u.z, 6),
                    spread_deg: fixed(resultant.clamp(-1.0, 1.0).acos().to_degrees(), 3),
                    detections: s.detections,
                };
                match first_non_finite(&[
                    ("first_s", record.first_s),
                    ("last_s", record.last_s),
                    ("azimuth_deg", record.azimuth_deg),
                    ("spread_deg", record.spread_deg),
                ]) {
                    Some(field) => Err(OutputError::NonFiniteEvent {
                        field,
                        file: file.to_string(),
                        track: source,
                    }),
                    None => Ok(record),
                }
            })
            .collect()
    }
}
