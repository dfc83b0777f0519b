//! Scoring detections against a truth, a simulation's or a hand-written one (`ssl evaluate`).
//!
//! Frames are those of the analysis: frame `f` is centred at `(f + 1) * hop` seconds and
//! spans one hop either side, the hop being read off the detections (`time_s / (frame +
//! 1)`). For each source:
//! - errors: by the [`Metric`] chosen (the 3-D angle, or what the array observes), between
//!   each detection in a frame lying wholly inside one of the source's active intervals
//!   and the source's direction (when several sources are active, a detection counts for
//!   the nearest of them);
//! - frame detection rate: the share of those frames with a detection within
//!   `HIT_DEG` of the source;
//! - event detection rate: the share of active intervals (events) with at least one
//!   detection within `HIT_DEG` in a frame that overlaps the interval;
//! - event coverage: each interval counted in proportion to how much of it was heard,
//!   the share of its time covered by its source's rows within `HIT_DEG` grouped into
//!   stretches as `--events` groups them (the `coverage` module);
//! - false detections: detections in frames that overlap no active interval (each
//!   extended by a reverberation tail), per minute of such time;
//! - when the rows carry a `source` (tracking on), or the result holds the run's events:
//!   tracks and events (the `tracks` module).

mod coverage;
mod metric;
mod pool;
mod report;
mod spans;
mod tracks;

pub use metric::Metric;
pub use pool::{pool, Pooled};
pub use tracks::{SourceTracks, TrackReport};

use crate::geometry::angles_deg;
use crate::method::default_frame_size;
use crate::record::truth::turned;
use crate::record::{DetectionRecord, EventRecord, Truth};
use nalgebra::Vector3;
use spans::Spans;

/// A detection within this many degrees of a source counts as detecting it.
pub(crate) const HIT_DEG: f64 = 10.0;

/// Results that cannot be scored against one truth.
#[derive(Debug, thiserror::Error)]
pub enum EvaluateError {
    /// The result holds detections of several recordings.
    #[error("results for {0} files; evaluate one recording at a time")]
    SeveralFiles(usize),
    /// The truth holds a value that cannot be meant (NaN, a zero vector, a reversed
    /// interval, an absurd duration).
    #[error("the truth: {0}")]
    Truth(String),
    /// A detection holds a value that cannot be meant.
    #[error("{0}")]
    Result(String),
}

/// The longest recording scored (seconds): a week.
pub(crate) const MAX_DURATION_S: f64 = 7.0 * 86400.0;
/// The shortest analysis hop accepted (seconds): 16 samples at 768 kHz.
const MIN_HOP_S: f64 = 16.0 / 768_000.0 / 2.0;

/// A unit vector from finite components, or `None` (NaN, infinite or zero).
fn unit(x: f64, y: f64, z: f64) -> Option<Vector3<f64>> {
    let v = Vector3::new(x, y, z);
    let n = v.norm();
    (n.is_finite() && n > 1e-9).then(|| v / n)
}

/// Refuses truth values that cannot be meant.
fn check_truth(truth: &Truth) -> Result<(), EvaluateError> {
    let bad = |m: String| Err(EvaluateError::Truth(m));
    // 0: a hand-written truth, which does not know it.
    if truth.sample_rate != 0 && !(1000..=768_000).contains(&truth.sample_rate) {
        return bad(format!(
            "sample_rate {} Hz is outside 1000-768000",
            truth.sample_rate
        ));
    }
    let d = truth.duration_s;
    if !(d.is_finite() && d > 0.0 && d <= MAX_DURATION_S) {
        return bad(format!(
            "duration_s {} is not between 0 and {MAX_DURATION_S} s",
            crate::text::BriefNumber(d)
        ));
    }
    for s in &truth.sources {
        if unit(s.x, s.y, s.z).is_none() {
            return bad(format!(
                "source {}: its direction is not a finite non-zero vector",
                s.index
            ));
        }
        for &[a, b] in &s.active {
            if !(a.is_finite() && b.is_finite() && 0.0 <= a && a < b && b <= d + 1.0) {
                return bad(format!(
                    "source {}: the active interval [{a}, {b}] is not within [0, {d}] s or is reversed",
                    s.index
                ));
            }
        }
    }
    Ok(())
}

/// A detection as scored: its time, direction and frame.
#[derive(Debug, Clone, Copy)]
struct Det {
    time_s: f64,
    direction: Vector3<f64>,
    frame: Option<u64>,
    source: Option<u64>,
}

/// The scores of one true source.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SourceReport {
    /// The source's index in the scene.
    pub index: usize,
    /// Its signal.
    pub signal: String,
    /// Its azimuth (degrees).
    pub azimuth_deg: f64,
    /// Its elevation (degrees), unless the truth gives its azimuth only.
    pub elevation_deg: Option<f64>,
    /// Its distance (metres), when known.
    pub distance_m: Option<f64>,
    /// Detections counted for it (in frames wholly inside its intervals, nearest to it).
    pub detections: usize,
    /// Their mean angular error (degrees).
    pub mean_error_deg: Option<f64>,
    /// Their median angular error (degrees).
    pub median_error_deg: Option<f64>,
    /// Frames wholly inside its active intervals.
    pub active_frames: usize,
    /// Those frames with a detection within `HIT_DEG`.
    pub frames_detected: usize,
    /// Its active intervals.
    pub events: usize,
    /// Intervals with a detection within `HIT_DEG`.
    pub events_detected: usize,
    /// Its intervals as heard: each counts by the share of its time its rows within
    /// `HIT_DEG` cover (grouped into stretches as `--events` groups them).
    pub events_heard: f64,
}

/// The scores of a result against a truth: per source and overall.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// Per source.
    pub sources: Vec<SourceReport>,
    /// Detections counted for any source.
    pub detections: usize,
    /// Their mean angular error (degrees).
    pub mean_error_deg: Option<f64>,
    /// Their median angular error (degrees).
    pub median_error_deg: Option<f64>,
    /// Their mean error in azimuth alone (degrees, each against its source; the angle
    /// about the z axis, whatever the elevation): what a planar array measures well.
    pub mean_azimuth_error_deg: Option<f64>,
    /// Their mean error in elevation alone (degrees).
    pub mean_elevation_error_deg: Option<f64>,
    /// Their mean signed error in elevation (degrees; positive: above the source), which
    /// shows a bias such as a horizontal planar array's toward its normal (the floor's and
    /// ceiling's reflections shorten its delays).
    pub elevation_bias_deg: Option<f64>,
    /// Share of active frames detected, over all sources.
    pub frame_detection_rate: Option<f64>,
    /// Share of events detected, over all sources.
    pub event_detection_rate: Option<f64>,
    /// Events found in proportion to how much of each was heard: the mean share of an
    /// interval's time its source's rows cover, over all sources' intervals.
    pub event_coverage: Option<f64>,
    /// Detections in frames that overlap no active interval (with its tail).
    pub false_detections: usize,
    /// Seconds of such frames.
    pub background_s: f64,
    /// False detections per minute of background.
    pub false_per_minute: Option<f64>,
    /// The analysis hop (seconds).
    pub hop_s: f64,
    /// The tail added to each interval (seconds).
    pub tail_s: f64,
    /// Where the tail comes from (`--tail`, or what [`default_tail`] is made of); empty
    /// when the caller did not say.
    pub tail_rule: String,
    /// Tracks and events, when the rows carry a `source`.
    pub tracking: Option<TrackReport>,
    /// What the errors measure ([`Metric::name`]).
    pub metric: String,
    /// Every counted detection's error (degrees, ascending), for pooling reports
    /// ([`pool`]); not written out.
    #[serde(skip)]
    pub errors_deg: Vec<f64>,
}

/// Scores `dets` against `truth`. `tail_s` extends each active interval when counting
/// false detections (reverberation keeps a source audible after it stops).
pub fn evaluate(
    truth: &Truth,
    records: &[DetectionRecord],
    tail_s: f64,
) -> Result<Report, EvaluateError> {
    evaluate_by(truth, records, None, tail_s, &Metric::ThreeD)
}

/// As [`evaluate`], with errors measured by `metric`, and events scored from `events`
/// (those the run wrote, `--events` or a JSON result's) when given, else read off the
/// rows as `--events` makes them.
pub fn evaluate_by(
    truth: &Truth,
    records: &[DetectionRecord],
    events: Option<&[EventRecord]>,
    tail_s: f64,
    metric: &Metric,
) -> Result<Report, EvaluateError> {
    let files: std::collections::BTreeSet<&str> = records
        .iter()
        .map(|r| r.file.as_str())
        .chain(events.unwrap_or_default().iter().map(|e| e.file.as_str()))
        .filter(|f| !f.is_empty())
        .collect();
    if files.len() > 1 {
        return Err(EvaluateError::SeveralFiles(files.len()));
    }
    check_truth(truth)?;
    // A truth of azimuths only is scored in azimuth (about z: the rows' azimuth_deg),
    // whatever the array.
    let azimuths = Metric::azimuth();
    let metric = if truth.sources.iter().any(|s| s.azimuth_only) {
        &azimuths
    } else {
        metric
    };
    let dets = records
        .iter()
        .enumerate()
        .map(|(i, r)| match unit(r.x, r.y, r.z) {
            Some(direction) if r.time_s.is_finite() && r.time_s >= 0.0 => Ok(Det {
                time_s: r.time_s,
                direction,
                frame: r.frame,
                source: r.source,
            }),
            _ => Err(EvaluateError::Result(format!(
                "detection {}: its time or direction is not finite (or the vector is zero)",
                i + 1
            ))),
        })
        .collect::<Result<Vec<Det>, _>>()?;
    let written = events
        .map(|events| {
            events
                .iter()
                .enumerate()
                .map(|(i, e)| match unit(e.x, e.y, e.z) {
                    Some(direction)
                        if e.start_s.is_finite() && e.end_s.is_finite() && e.start_s >= 0.0 =>
                    {
                        Ok(tracks::Stretch::written(e, direction))
                    }
                    _ => Err(EvaluateError::Result(format!(
                        "event {}: its times or direction are not finite (or the vector is zero)",
                        i + 1
                    ))),
                })
                .collect::<Result<Vec<_>, _>>()
        })
        .transpose()?;
    if let Some(d) = dets.iter().find(|d| {
        d.frame
            .is_some_and(|f| d.time_s / (f as f64 + 1.0) < MIN_HOP_S)
    }) {
        return Err(EvaluateError::Result(format!(
            "the detection at {} s in frame {} implies an analysis hop under {MIN_HOP_S:.1e} s",
            d.time_s,
            d.frame.unwrap_or(0)
        )));
    }
    let sources: Vec<Source> = truth
        .sources
        .iter()
        .map(|s| {
            Source::new(
                unit(s.x, s.y, s.z).expect("checked"),
                s.turn(),
                s.waypoints.clone(),
                s.active.iter().map(|&[a, b]| (a, b)).collect(),
            )
        })
        .collect();
    // A hand-written truth may not say how long the recording is: at least as long as
    // its last detection.
    let last = dets
        .iter()
        .map(|d| d.time_s)
        .chain(written.iter().flatten().map(|e| e.end))
        .fold(0.0, f64::max);
    let truth = if truth.sample_rate == 0 && last > truth.duration_s {
        std::borrow::Cow::Owned(Truth {
            duration_s: last,
            ..truth.clone()
        })
    } else {
        std::borrow::Cow::Borrowed(truth)
    };
    Ok(score(&truth, &sources, &dets, written, tail_s, metric))
}

/// A true source as scored: its direction (a moving one's when it starts turning), its
/// turn or waypoints, and its active intervals.
struct Source {
    direction: Vector3<f64>,
    turn: Option<(f64, f64)>,
    waypoints: Vec<[f64; 3]>,
    intervals: Vec<(f64, f64)>,
    /// The intervals indexed.
    spans: Spans,
}

impl Source {
    fn new(
        direction: Vector3<f64>,
        turn: Option<(f64, f64)>,
        waypoints: Vec<[f64; 3]>,
        intervals: Vec<(f64, f64)>,
    ) -> Self {
        Source {
            direction,
            turn,
            waypoints,
            spans: Spans::new(intervals.iter().copied()),
            intervals,
        }
    }

    /// Its direction at time `t` (seconds).
    fn at(&self, t: f64) -> Vector3<f64> {
        if self.waypoints.is_empty() {
            turned(&self.direction, self.turn, t)
        } else {
            crate::record::truth::along(&self.waypoints, t)
        }
    }
}

/// How far past each interval its rows still count as its own unless told (`--tail`):
/// one analysis frame (a frame that ends after the sound still holds it, and a tracked
/// row may be smoothed into the next), plus half the room's RT60 when the truth knows
/// the room; with what it is made of, for the report.
pub fn default_tail(truth: &Truth, records: &[DetectionRecord]) -> (f64, String) {
    let frame = 2.0 * hop_of(truth, records.iter().map(|r| (r.time_s, r.frame)));
    match truth.rt60_s() {
        Some(rt60) => (
            frame + rt60 / 2.0,
            format!("one frame, {frame:.3} s, and half the room's RT60"),
        ),
        None => (
            frame,
            format!("one frame, {frame:.3} s; --tail adds the room's reverberation"),
        ),
    }
}

/// The analysis hop (seconds) of rows given as (time, frame): from the first with a
/// frame index, else the default frame at the truth's rate (48 kHz when a hand-written
/// truth does not give it).
fn hop_of(truth: &Truth, rows: impl Iterator<Item = (f64, Option<u64>)>) -> f64 {
    let mut rows = rows;
    rows.find_map(|(t, f)| f.map(|f| t / (f as f64 + 1.0)))
        .unwrap_or_else(|| {
            // Rows without frame indices: the default frame at the truth's rate (48 kHz
            // when a hand-written truth does not give it).
            let rate = if truth.sample_rate == 0 {
                48_000
            } else {
                truth.sample_rate
            };
            default_frame_size(rate) as f64 / 2.0 / rate as f64
        })
}

fn score(
    truth: &Truth,
    sources: &[Source],
    dets: &[Det],
    written: Option<Vec<tracks::Stretch>>,
    tail_s: f64,
    metric: &Metric,
) -> Report {
    let hop = hop_of(truth, dets.iter().map(|d| (d.time_s, d.frame)));
    let frames = if truth.duration_s >= 2.0 * hop {
        ((truth.duration_s - 2.0 * hop) / hop + 1e-9).floor() as u64 + 1
    } else {
        0
    };
    let centre = |f: u64| (f as f64 + 1.0) * hop;
    // A frame centred at t wholly inside one of the source's intervals.
    let inside = |t: f64, s: &Source| s.spans.any_reaching(t - hop + 1e-9, t + hop - 1e-9);
    // The detections in time order, to find those around an interval by bisection.
    let mut by_time: Vec<&Det> = dets.iter().collect();
    by_time.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let times: Vec<f64> = by_time.iter().map(|d| d.time_s).collect();
    let frame_of = |d: &Det| {
        d.frame
            .unwrap_or_else(|| ((d.time_s / hop).round() as u64).saturating_sub(1))
    };

    let mut reports = Vec::new();
    let mut all_errors = Vec::new();
    // Per counted detection: its azimuth error and its signed elevation error.
    let mut split: Vec<(f64, f64)> = Vec::new();
    let (mut active_total, mut detected_total, mut events_total, mut events_hit) = (0, 0, 0, 0);
    let mut heard_total = 0.0;
    for (si, (s, t)) in sources.iter().zip(&truth.sources).enumerate() {
        // Detections counted for this source: in a frame wholly inside one of its
        // intervals, and nearer to it than to any other source heard within the frame
        // (its interval with its tail overlapping the frame: a row in a frame that
        // straddles another source's start or end may be that source's).
        let heard = |t: f64, o: &Source| o.spans.any_strictly(t + hop, t - hop - tail_s);
        let mine: Vec<(&Det, f64)> = dets
            .iter()
            .filter(|d| inside(d.time_s, s))
            .filter(|d| {
                let own = metric.error_deg(&d.direction, &s.at(d.time_s));
                sources.iter().enumerate().all(|(oi, o)| {
                    oi == si
                        || !heard(d.time_s, o)
                        || metric.error_deg(&d.direction, &o.at(d.time_s)) > own
                })
            })
            .map(|d| (d, metric.error_deg(&d.direction, &s.at(d.time_s))))
            .collect();
        let mut errors: Vec<f64> = mine.iter().map(|(_, e)| *e).collect();
        all_errors.extend_from_slice(&errors);
        split.extend(mine.iter().map(|(d, _)| {
            let ((daz, del), (saz, sel)) = (angles_deg(&d.direction), angles_deg(&s.at(d.time_s)));
            let turn = (daz - saz).rem_euclid(360.0);
            (turn.min(360.0 - turn), del - sel)
        }));
        // The frames wholly inside one of its intervals: a run of frames per interval,
        // counted without visiting them (a week-long truth has tens of millions).
        let active = FrameRuns::new(s.intervals.iter().map(|&iv| {
            (
                first_true(frames, |f| centre(f) - hop >= iv.0 - 1e-9),
                first_true(frames, |f| centre(f) + hop > iv.1 + 1e-9),
            )
        }));
        let hit_frames: std::collections::BTreeSet<u64> = mine
            .iter()
            .filter(|(_, e)| *e < HIT_DEG)
            .map(|(d, _)| frame_of(d))
            .collect();
        let frames_detected = hit_frames.iter().filter(|&&f| active.contains(f)).count();
        // Per interval, the times of the rows within HIT_DEG in the frames that overlap
        // it (centres strictly within (a - hop, b + hop)).
        let near: Vec<Vec<f64>> = s
            .intervals
            .iter()
            .map(|&(a, b)| {
                let from = times.partition_point(|&t| t + hop <= a);
                let to = times.partition_point(|&t| t - hop < b);
                by_time[from..to.max(from)]
                    .iter()
                    .filter(|d| metric.error_deg(&d.direction, &s.at(d.time_s)) < HIT_DEG)
                    .map(|d| d.time_s)
                    .collect()
            })
            .collect();
        let events_detected = near.iter().filter(|t| !t.is_empty()).count();
        let events_heard: f64 = s
            .intervals
            .iter()
            .zip(&near)
            .map(|(&(a, b), t)| coverage::share(a, b, &coverage::stretches(t.iter().copied()), hop))
            .sum();
        active_total += active.len() as usize;
        detected_total += frames_detected;
        events_total += s.intervals.len();
        events_hit += events_detected;
        heard_total += events_heard;
        let (az, el) = angles_deg(&s.direction);
        reports.push(SourceReport {
            index: t.index,
            signal: t.signal.clone(),
            azimuth_deg: az,
            elevation_deg: (!t.azimuth_only).then_some(el),
            distance_m: t.distance_m,
            detections: errors.len(),
            mean_error_deg: mean(&errors),
            median_error_deg: median(&mut errors),
            active_frames: active.len() as usize,
            frames_detected,
            events: s.intervals.len(),
            events_detected,
            events_heard,
        });
    }
    // A frame centred at t that overlaps an interval with its tail.
    let all = Spans::new(sources.iter().flat_map(|s| s.intervals.iter().copied()));
    let busy = |t: f64| all.any_strictly(t + hop, t - hop - tail_s);
    // Frames that overlap an interval (with its tail) are busy; the rest is background.
    let busy_runs = FrameRuns::new(sources.iter().flat_map(|s| &s.intervals).map(|&(a, b)| {
        (
            first_true(frames, |f| centre(f) + hop > a),
            first_true(frames, |f| centre(f) - hop >= b + tail_s),
        )
    }));
    let background_frames = frames - busy_runs.len();
    let false_detections = dets.iter().filter(|d| !busy(d.time_s)).count();
    let background_s = background_frames as f64 * hop;
    let (mean_error_deg, median_error_deg) = (mean(&all_errors), median(&mut all_errors));
    // A result of events alone (`--events` as CSV or NDJSON) has no rows to score
    // frames or intervals by: those scores are absent, not zero.
    let rows = !(dets.is_empty() && written.is_some());
    Report {
        sources: reports,
        detections: all_errors.len(),
        mean_error_deg,
        median_error_deg,
        mean_azimuth_error_deg: mean(&split.iter().map(|s| s.0).collect::<Vec<_>>()),
        mean_elevation_error_deg: mean(&split.iter().map(|s| s.1.abs()).collect::<Vec<_>>()),
        elevation_bias_deg: mean(&split.iter().map(|s| s.1).collect::<Vec<_>>()),
        frame_detection_rate: (rows && active_total > 0)
            .then(|| detected_total as f64 / active_total as f64),
        event_detection_rate: (rows && events_total > 0)
            .then(|| events_hit as f64 / events_total as f64),
        event_coverage: (rows && events_total > 0).then(|| heard_total / events_total as f64),
        false_detections,
        background_s,
        false_per_minute: (background_s > 0.0)
            .then(|| false_detections as f64 / (background_s / 60.0)),
        hop_s: hop,
        tail_s,
        tail_rule: String::new(),
        metric: metric.name().to_string(),
        errors_deg: all_errors,
        tracking: (written.is_some() || dets.iter().any(|d| d.source.is_some())).then(|| {
            let tracked: Vec<Det> = dets
                .iter()
                .filter(|d| d.source.is_some())
                .copied()
                .collect();
            let ids: Vec<u64> = tracked.iter().filter_map(|d| d.source).collect();
            let scoring = tracks::Scoring {
                duration_s: truth.duration_s,
                hop_s: hop,
                tail_s,
                metric,
            };
            tracks::score_tracks(sources, &tracked, &ids, written, &scoring)
        }),
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

#[cfg(test)]
mod tests;

/// The first frame in `0..n` for which `cond` holds, or `n`; `cond` must be false and
/// then true as the frame grows (a binary search, so that no frame is visited).
fn first_true(n: u64, cond: impl Fn(u64) -> bool) -> u64 {
    let (mut lo, mut hi) = (0, n);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if cond(mid) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}

/// A set of frames as sorted, disjoint runs `[start, end)`.
struct FrameRuns(Vec<(u64, u64)>);

impl FrameRuns {
    fn new(runs: impl Iterator<Item = (u64, u64)>) -> Self {
        let mut runs: Vec<(u64, u64)> = runs.filter(|(a, b)| a < b).collect();
        runs.sort_unstable();
        let mut merged: Vec<(u64, u64)> = Vec::with_capacity(runs.len());
        for (a, b) in runs {
            match merged.last_mut() {
                Some(last) if a <= last.1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        FrameRuns(merged)
    }

    fn len(&self) -> u64 {
        self.0.iter().map(|(a, b)| b - a).sum()
    }

    fn contains(&self, f: u64) -> bool {
        let i = self.0.partition_point(|&(_, b)| b <= f);
        self.0.get(i).is_some_and(|&(a, _)| a <= f)
    }
}
