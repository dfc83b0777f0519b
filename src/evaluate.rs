//! Scoring detections against a simulation's truth (`ssl evaluate`).
//!
//! Frames are those of the analysis: frame `f` is centred at `(f + 1) * hop` seconds and
//! spans one hop either side, the hop being read off the detections (`time_s / (frame +
//! 1)`). For each source:
//! - errors: the angle between each detection in a frame lying wholly inside one of the
//!   source's active intervals and the source's direction (when several sources are
//!   active, a detection counts for the nearest of them);
//! - frame detection rate: the share of those frames with a detection within
//!   [`HIT_DEG`] of the source;
//! - event detection rate: the share of active intervals (events) with at least one
//!   detection within [`HIT_DEG`] in a frame that overlaps the interval;
//! - false detections: detections in frames that overlap no active interval (each
//!   extended by a reverberation tail), per minute of such time.

use crate::direction::{angle_between_deg, unit_from_angles};
use anyhow::{bail, Context, Result};
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::path::Path;

/// A detection within this many degrees of a source counts as detecting it.
pub const HIT_DEG: f64 = 10.0;

#[derive(Debug, Clone)]
pub struct TruthSource {
    pub index: usize,
    pub signal: String,
    pub direction: Vector3<f64>,
    pub distance_m: Option<f64>,
    pub intervals: Vec<(f64, f64)>,
}

#[derive(Debug, Clone)]
pub struct Truth {
    pub duration_s: f64,
    pub sample_rate: u32,
    /// The room's measured reverberation time, when the truth has one.
    pub rt60_s: Option<f64>,
    pub sources: Vec<TruthSource>,
}

#[derive(Debug, Clone, Copy)]
pub struct Det {
    pub time_s: f64,
    pub direction: Vector3<f64>,
    pub frame: Option<u64>,
}

impl Truth {
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read truth file", path.display()))?;
        let v: Value =
            serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
        Self::from_json(&v).with_context(|| format!("{}", path.display()))
    }

    pub fn from_json(v: &Value) -> Result<Self> {
        let num = |v: &Value, k: &str| {
            v[k].as_f64()
                .with_context(|| format!("truth: missing number `{k}`"))
        };
        let sources = v["sources"]
            .as_array()
            .context("truth: missing `sources` array")?
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let direction = match (s["x"].as_f64(), s["y"].as_f64(), s["z"].as_f64()) {
                    (Some(x), Some(y), Some(z)) => Vector3::new(x, y, z).normalize(),
                    _ => unit_from_angles(num(s, "azimuth_deg")?, num(s, "elevation_deg")?),
                };
                let intervals = s["active"]
                    .as_array()
                    .context("truth: a source has no `active` intervals")?
                    .iter()
                    .map(|iv| {
                        Ok((
                            iv[0].as_f64().context("interval")?,
                            iv[1].as_f64().context("interval")?,
                        ))
                    })
                    .collect::<Result<Vec<_>>>()?;
                Ok(TruthSource {
                    index: s["index"].as_u64().map_or(i, |v| v as usize),
                    signal: s["signal"].as_str().unwrap_or("").to_string(),
                    direction,
                    distance_m: s["distance_m"].as_f64(),
                    intervals,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Truth {
            duration_s: num(v, "duration_s")?,
            sample_rate: v["sample_rate"].as_u64().unwrap_or(48000) as u32,
            rt60_s: v["room"]["rt60_measured"].as_f64(),
            sources,
        })
    }
}

/// Reads detections from a CSV, NDJSON or JSON result of `ssl analyze`.
pub fn read_detections(path: &Path) -> Result<Vec<Det>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read results", path.display()))?;
    parse_detections(&text).with_context(|| format!("{}", path.display()))
}

pub fn parse_detections(text: &str) -> Result<Vec<Det>> {
    let trimmed = text.trim_start();
    let objects: Vec<Value> = if trimmed.starts_with('{') {
        match serde_json::from_str::<Value>(trimmed) {
            Ok(doc) if doc.get("detections").is_some() => doc["detections"]
                .as_array()
                .context("`detections` is not an array")?
                .clone(),
            _ => trimmed
                .lines()
                .filter(|l| !l.trim().is_empty())
                .enumerate()
                .map(|(i, l)| {
                    serde_json::from_str(l)
                        .with_context(|| format!("line {}: not a JSON object", i + 1))
                })
                .collect::<Result<_>>()?,
        }
    } else {
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let headers = reader.headers()?.clone();
        reader
            .records()
            .map(|r| {
                let r = r?;
                let mut obj = serde_json::Map::new();
                for (h, f) in headers.iter().zip(r.iter()) {
                    let v = f
                        .parse::<f64>()
                        .map(Value::from)
                        .unwrap_or_else(|_| Value::from(f));
                    obj.insert(h.to_string(), v);
                }
                Ok(Value::Object(obj))
            })
            .collect::<Result<_>>()?
    };
    let mut files = std::collections::BTreeSet::new();
    let dets = objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            if let Some(f) = o.get("file").and_then(Value::as_str) {
                files.insert(f.to_string());
            }
            let time_s = o["time_s"]
                .as_f64()
                .with_context(|| format!("detection {}: no `time_s`", i + 1))?;
            let direction = match (o["x"].as_f64(), o["y"].as_f64(), o["z"].as_f64()) {
                (Some(x), Some(y), Some(z)) => Vector3::new(x, y, z).normalize(),
                _ => unit_from_angles(
                    o["azimuth_deg"]
                        .as_f64()
                        .with_context(|| format!("detection {}: no direction", i + 1))?,
                    o["elevation_deg"].as_f64().unwrap_or(0.0),
                ),
            };
            Ok(Det {
                time_s,
                direction,
                frame: o.get("frame").and_then(Value::as_f64).map(|f| f as u64),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    if files.len() > 1 {
        bail!(
            "results for {} files; evaluate one recording at a time",
            files.len()
        );
    }
    Ok(dets)
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct SourceReport {
    pub index: usize,
    pub signal: String,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub distance_m: Option<f64>,
    pub detections: usize,
    pub mean_error_deg: Option<f64>,
    pub median_error_deg: Option<f64>,
    pub active_frames: usize,
    pub frames_detected: usize,
    pub events: usize,
    pub events_detected: usize,
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    pub sources: Vec<SourceReport>,
    pub detections: usize,
    pub mean_error_deg: Option<f64>,
    pub median_error_deg: Option<f64>,
    pub frame_detection_rate: Option<f64>,
    pub event_detection_rate: Option<f64>,
    pub false_detections: usize,
    pub background_s: f64,
    pub false_per_minute: Option<f64>,
    pub hop_s: f64,
    pub tail_s: f64,
}

/// Scores `dets` against `truth`. `tail_s` extends each active interval when counting
/// false detections (reverberation keeps a source audible after it stops).
pub fn evaluate(truth: &Truth, dets: &[Det], tail_s: f64) -> Report {
    let hop = dets
        .iter()
        .find_map(|d| d.frame.map(|f| d.time_s / (f as f64 + 1.0)))
        .unwrap_or_else(|| {
            crate::pipeline::default_frame_size(truth.sample_rate) as f64
                / 2.0
                / truth.sample_rate as f64
        });
    let frames = if truth.duration_s >= 2.0 * hop {
        ((truth.duration_s - 2.0 * hop) / hop + 1e-9).floor() as u64 + 1
    } else {
        0
    };
    let centre = |f: u64| (f as f64 + 1.0) * hop;
    let inside = |t: f64, (a, b): (f64, f64)| t - hop >= a - 1e-9 && t + hop <= b + 1e-9;
    let overlaps = |t: f64, (a, b): (f64, f64), tail: f64| t + hop > a && t - hop < b + tail;
    let frame_of = |d: &Det| {
        d.frame
            .unwrap_or_else(|| ((d.time_s / hop).round() as u64).saturating_sub(1))
    };

    let mut reports = Vec::new();
    let mut all_errors = Vec::new();
    let (mut active_total, mut detected_total, mut events_total, mut events_hit) = (0, 0, 0, 0);
    for (si, s) in truth.sources.iter().enumerate() {
        // Detections counted for this source: in a frame wholly inside one of its
        // intervals, and nearer to it than to any other source active then.
        let mine: Vec<(&Det, f64)> = dets
            .iter()
            .filter(|d| s.intervals.iter().any(|&iv| inside(d.time_s, iv)))
            .filter(|d| {
                let own = angle_between_deg(&d.direction, &s.direction);
                truth.sources.iter().enumerate().all(|(oi, o)| {
                    oi == si
                        || !o.intervals.iter().any(|&iv| inside(d.time_s, iv))
                        || angle_between_deg(&d.direction, &o.direction) > own
                })
            })
            .map(|d| (d, angle_between_deg(&d.direction, &s.direction)))
            .collect();
        let mut errors: Vec<f64> = mine.iter().map(|(_, e)| *e).collect();
        all_errors.extend_from_slice(&errors);
        let active: Vec<u64> = (0..frames)
            .filter(|&f| s.intervals.iter().any(|&iv| inside(centre(f), iv)))
            .collect();
        let hit_frames: std::collections::BTreeSet<u64> = mine
            .iter()
            .filter(|(_, e)| *e < HIT_DEG)
            .map(|(d, _)| frame_of(d))
            .collect();
        let frames_detected = active.iter().filter(|f| hit_frames.contains(f)).count();
        let events_detected = s
            .intervals
            .iter()
            .filter(|&&iv| {
                dets.iter().any(|d| {
                    overlaps(d.time_s, iv, 0.0)
                        && angle_between_deg(&d.direction, &s.direction) < HIT_DEG
                })
            })
            .count();
        active_total += active.len();
        detected_total += frames_detected;
        events_total += s.intervals.len();
        events_hit += events_detected;
        let (az, el) = crate::direction::angles_deg(&s.direction);
        reports.push(SourceReport {
            index: s.index,
            signal: s.signal.clone(),
            azimuth_deg: az,
            elevation_deg: el,
            distance_m: s.distance_m,
            detections: errors.len(),
            mean_error_deg: mean(&errors),
            median_error_deg: median(&mut errors),
            active_frames: active.len(),
            frames_detected,
            events: s.intervals.len(),
            events_detected,
        });
    }
    let busy = |t: f64| {
        truth
            .sources
            .iter()
            .any(|s| s.intervals.iter().any(|&iv| overlaps(t, iv, tail_s)))
    };
    let background_frames = (0..frames).filter(|&f| !busy(centre(f))).count();
    let false_detections = dets.iter().filter(|d| !busy(d.time_s)).count();
    let background_s = background_frames as f64 * hop;
    Report {
        sources: reports,
        detections: all_errors.len(),
        mean_error_deg: mean(&all_errors),
        median_error_deg: median(&mut all_errors),
        frame_detection_rate: (active_total > 0)
            .then(|| detected_total as f64 / active_total as f64),
        event_detection_rate: (events_total > 0).then(|| events_hit as f64 / events_total as f64),
        false_detections,
        background_s,
        false_per_minute: (background_s > 0.0)
            .then(|| false_detections as f64 / (background_s / 60.0)),
        hop_s: hop,
        tail_s,
    }
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

impl Report {
    /// The human-readable table.
    pub fn table(&self) -> String {
        let opt = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |x| format!("{x:.d$}"));
        let pct = |a: usize, b: usize| {
            if b == 0 {
                "-".to_string()
            } else {
                format!("{:.1}%", 100.0 * a as f64 / b as f64)
            }
        };
        let mut s = String::new();
        s += "source  signal   azimuth  elevation  distance  detections  mean_err  median_err  frames_detected  events_detected\n";
        for r in &self.sources {
            s += &format!(
                "{:<6}  {:<7}  {:>7.1}  {:>9.1}  {:>8}  {:>10}  {:>8}  {:>10}  {:>15}  {:>15}\n",
                r.index,
                r.signal,
                r.azimuth_deg,
                r.elevation_deg,
                opt(r.distance_m, 2),
                r.detections,
                opt(r.mean_error_deg, 2),
                opt(r.median_error_deg, 2),
                format!(
                    "{} ({}/{})",
                    pct(r.frames_detected, r.active_frames),
                    r.frames_detected,
                    r.active_frames
                ),
                format!(
                    "{} ({}/{})",
                    pct(r.events_detected, r.events),
                    r.events_detected,
                    r.events
                ),
            );
        }
        s += &format!(
            "overall: {} detections, mean error {} deg, median {} deg, frames detected {}, events detected {}\n",
            self.detections,
            opt(self.mean_error_deg, 2),
            opt(self.median_error_deg, 2),
            opt(self.frame_detection_rate.map(|r| 100.0 * r), 1) + "%",
            opt(self.event_detection_rate.map(|r| 100.0 * r), 1) + "%",
        );
        s += &format!(
            "false detections: {} in {:.1} s outside active intervals (+{:.2} s tails): {} per minute\n",
            self.false_detections,
            self.background_s,
            self.tail_s,
            opt(self.false_per_minute, 1)
        );
        s
    }

    pub fn json(&self) -> Value {
        json!(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> Truth {
        Truth {
            duration_s: 10.0,
            sample_rate: 48000,
            rt60_s: None,
            sources: vec![
                TruthSource {
                    index: 0,
                    signal: "a".into(),
                    direction: Vector3::x(),
                    distance_m: Some(2.0),
                    intervals: vec![(1.0, 2.0), (5.0, 6.0)],
                },
                TruthSource {
                    index: 1,
                    signal: "b".into(),
                    direction: Vector3::y(),
                    distance_m: None,
                    intervals: vec![(3.0, 4.0)],
                },
            ],
        }
    }

    /// A detection in frame `f` (hop 0.01 s) at `deg` degrees from +x toward +z.
    fn det(f: u64, deg: f64) -> Det {
        let r = deg.to_radians();
        Det {
            time_s: (f + 1) as f64 * 0.01,
            direction: Vector3::new(r.cos(), 0.0, r.sin()),
            frame: Some(f),
        }
    }

    #[test]
    fn scores_hand_made_detections() {
        // Source 0, interval 1..2 s: frames wholly inside have centres 1.01..1.99, i.e.
        // f = 100..=198 (99 frames); likewise 5..6 s: f = 500..=598. Total 198 frames.
        let mut dets = vec![det(100, 1.0), det(101, 3.0), det(150, 20.0), det(500, 2.0)];
        // A detection between the intervals (7.5 s, far from any tail): false.
        dets.push(det(749, 0.0));
        // Source 1 (+y), interval 3..4 s, detected exactly in one frame.
        dets.push(Det {
            time_s: 3.5,
            direction: Vector3::y(),
            frame: Some(349),
        });
        let r = evaluate(&truth(), &dets, 0.1);
        assert!((r.hop_s - 0.01).abs() < 1e-12);
        let s0 = &r.sources[0];
        assert_eq!(s0.detections, 4);
        assert!(
            (s0.mean_error_deg.unwrap() - 6.5).abs() < 1e-9,
            "{:?}",
            s0.mean_error_deg
        );
        assert!((s0.median_error_deg.unwrap() - 2.5).abs() < 1e-9);
        assert_eq!(s0.active_frames, 198);
        assert_eq!(s0.frames_detected, 3, "the 20 deg detection is not a hit");
        assert_eq!((s0.events, s0.events_detected), (2, 2));
        let s1 = &r.sources[1];
        assert_eq!(
            (s1.detections, s1.frames_detected, s1.events_detected),
            (1, 1, 1)
        );
        assert_eq!(r.false_detections, 1);
        // Background: frames overlapping no interval + 0.1 s tail.
        assert!(
            r.background_s > 6.0 && r.background_s < 7.0,
            "{}",
            r.background_s
        );
        assert!((r.false_per_minute.unwrap() - 60.0 / r.background_s).abs() < 1e-9);
        assert_eq!(r.event_detection_rate, Some(1.0));
    }

    #[test]
    fn reads_every_output_format() {
        let csv = "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics\n0.5,0,0,1,0,0,3,a.wav,49,8\n";
        let nd = "{\"time_s\":0.5,\"azimuth_deg\":0,\"elevation_deg\":0,\"x\":1,\"y\":0,\"z\":0,\"score\":3,\"file\":\"a.wav\",\"frame\":49}\n";
        let doc = "{\"tool\":{},\"detections\":[\n{\"time_s\":0.5,\"azimuth_deg\":0,\"elevation_deg\":0,\"x\":1,\"y\":0,\"z\":0,\"score\":3,\"file\":\"a.wav\",\"frame\":49}\n],\"files\":[]}";
        for text in [csv, nd, doc] {
            let d = parse_detections(text).unwrap();
            assert_eq!(d.len(), 1);
            assert_eq!(d[0].frame, Some(49));
            assert!((d[0].direction - Vector3::x()).norm() < 1e-12);
        }
        let two = "time_s,x,y,z,file\n0.5,1,0,0,a.wav\n0.6,1,0,0,b.wav\n";
        assert!(parse_detections(two)
            .unwrap_err()
            .to_string()
            .contains("2 files"));
    }
}
