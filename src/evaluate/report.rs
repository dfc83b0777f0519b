//! The evaluation report as a table for people.

use super::Report;

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
        // A result of events alone: no rows to score frames and intervals by.
        let events_only =
            self.event_detection_rate.is_none() && self.sources.iter().any(|s| s.events > 0);
        let pct = |a: usize, b: usize| {
            if events_only {
                "-".to_string()
            } else {
                pct(a, b)
            }
        };
        let mut s = String::new();
        if events_only {
            s += "rows: none in the result (events only): the events are scored below\n";
        }
        if !self.metric.is_empty() {
            s += &format!("errors: {}\n", self.metric);
        }
        s += "source  signal   azimuth  elevation  distance  detections  mean_err  median_err  frames_detected  events_detected  heard\n";
        for r in &self.sources {
            s += &format!(
                "{:<6}  {:<7}  {:>7.1}  {:>9}  {:>8}  {:>10}  {:>8}  {:>10}  {:>15}  {:>15}  {:>6}\n",
                r.index,
                r.signal,
                r.azimuth_deg,
                opt(r.elevation_deg, 1),
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
                if r.events == 0 || events_only {
                    "-".to_string()
                } else {
                    format!("{:.0}%", 100.0 * r.events_heard / r.events as f64)
                },
            );
        }
        if !events_only {
            s += &format!(
                "overall: {} detections, mean error {} deg, median {} deg, frames detected {}, events detected {} (heard {}: each by the share of its time its rows cover)\n",
                self.detections,
                opt(self.mean_error_deg, 2),
                opt(self.median_error_deg, 2),
                opt(self.frame_detection_rate.map(|r| 100.0 * r), 1) + "%",
                opt(self.event_detection_rate.map(|r| 100.0 * r), 1) + "%",
                opt(self.event_coverage.map(|r| 100.0 * r), 1) + "%",
            );
            if let (Some(az), Some(el), Some(bias)) = (
                self.mean_azimuth_error_deg,
                self.mean_elevation_error_deg,
                self.elevation_bias_deg,
            ) {
                // No "-0.00".
                let bias = if bias.abs() < 0.005 { 0.0 } else { bias };
                s += &format!(
                    "error split: azimuth {az:.2} deg, elevation {el:.2} deg (on average {bias:+.2} deg: above the sources when positive)\n"
                );
            }
            let rule = if self.tail_rule.is_empty() {
                String::new()
            } else {
                format!(": {}", self.tail_rule)
            };
            s += &format!(
                "false detections: {} in {:.1} s outside active intervals (+{:.2} s tails{rule}): {} per minute\n",
                self.false_detections,
                self.background_s,
                self.tail_s,
                opt(self.false_per_minute, 1)
            );
        }
        if let Some(t) = &self.tracking {
            if !events_only {
                s += &format!(
                    "tracks: {} ({} per source, lowest purity of a source's dominant track {})\n",
                    t.tracks,
                    opt(t.tracks_per_source, 2),
                    opt(t.min_purity.map(|p| 100.0 * p), 1) + "%",
                );
            }
            s += &format!(
                "events ({}): {} of {} true events recalled, covering {} of their time, {} false ({:.1} per minute) of {}; direction error {} deg, onset {} s, offset {} s\n",
                if t.events_from == "written" {
                    "those the run wrote"
                } else {
                    "read off the rows as --events makes them"
                },
                t.events_recalled,
                t.true_events,
                opt(t.event_coverage.map(|c| 100.0 * c), 1) + "%",
                t.false_events,
                t.false_events_per_minute,
                t.events,
                opt(t.event_error_deg, 2),
                opt(t.onset_error_s, 2),
                opt(t.offset_error_s, 2),
            );
            if t.overlap_pairs > 0 && !events_only {
                s += &format!(
                    "several sources at once: {} of {} (0.1 s window, source) pairs detected\n",
                    t.overlap_detected, t.overlap_pairs
                );
            }
        }
        s
    }
}
