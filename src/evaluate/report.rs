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
}
