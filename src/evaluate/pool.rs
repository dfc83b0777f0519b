//! The scores of many recordings as one ([`pool`]): what `ssl evaluate` reports for a
//! folder of results, each recording scored against its own truth.

use super::{mean, median, Report};

/// Reports of several recordings pooled: every detection, active frame, event and second
/// of background counts once, whichever recording it came from (a long recording weighs
/// more than a short one, as its frames do).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Pooled {
    /// Recordings scored.
    pub recordings: usize,
    /// Detections counted for a source.
    pub detections: usize,
    /// Their mean error (degrees).
    pub mean_error_deg: Option<f64>,
    /// Their median error (degrees).
    pub median_error_deg: Option<f64>,
    /// Share of every source's active frames detected.
    pub frame_detection_rate: Option<f64>,
    /// Share of every source's events detected.
    pub event_detection_rate: Option<f64>,
    /// Every source's events, each counted by the share of it heard.
    pub event_coverage: Option<f64>,
    /// Detections outside every active interval (with its tail).
    pub false_detections: usize,
    /// Seconds of such background.
    pub background_s: f64,
    /// False detections per minute of background.
    pub false_per_minute: Option<f64>,
}

/// Pools `reports` (one per recording).
pub fn pool<'a>(reports: impl IntoIterator<Item = &'a Report>) -> Pooled {
    let reports: Vec<&Report> = reports.into_iter().collect();
    let mut errors: Vec<f64> = reports
        .iter()
        .flat_map(|r| r.errors_deg.iter().copied())
        .collect();
    let sum = |f: &dyn Fn(&Report) -> usize| reports.iter().map(|r| f(r)).sum::<usize>();
    let sources = |f: &dyn Fn(&super::SourceReport) -> usize| {
        reports
            .iter()
            .flat_map(|r| &r.sources)
            .map(f)
            .sum::<usize>()
    };
    let ratio = |a: usize, b: usize| (b > 0).then(|| a as f64 / b as f64);
    let false_detections = sum(&|r| r.false_detections);
    let background_s: f64 = reports.iter().map(|r| r.background_s).sum();
    Pooled {
        recordings: reports.len(),
        detections: errors.len(),
        mean_error_deg: mean(&errors),
        median_error_deg: median(&mut errors),
        frame_detection_rate: ratio(
            sources(&|s| s.frames_detected),
            sources(&|s| s.active_frames),
        ),
        event_detection_rate: ratio(sources(&|s| s.events_detected), sources(&|s| s.events)),
        event_coverage: {
            let events = sources(&|s| s.events);
            (events > 0).then(|| {
                reports
                    .iter()
                    .flat_map(|r| &r.sources)
                    .map(|s| s.events_heard)
                    .sum::<f64>()
                    / events as f64
            })
        },
        false_detections,
        background_s,
        false_per_minute: (background_s > 0.0)
            .then(|| false_detections as f64 / (background_s / 60.0)),
    }
}
