//! A track's rows smoothed over time (beyond the paper): each row's direction becomes
//! the mean direction of its track's rows within [`TrackParams::smooth_s`] of it, before
//! and after, each first moved along the track's turn to the row's time (a fixed-lag
//! smoother: rows come out that much later).
//!
//! A frame's direction errs by its own noise: on a 6.5 cm tetrahedron at 16 kHz two
//! talkers' rows scatter by 2-4 deg, most of it from frame to frame, and the mean of a
//! track's neighbouring rows is nearer the talker (docs/tracking.md). Speech comes in
//! bursts, so the window is often one-sided, where a moving talker's mean lags: the
//! turn, the least-squares slope of the track's rows over the last second, is taken out
//! first (when they span half a second and it is at least the tracker's 10 deg/s, or
//! when it stands four standard errors out of their scatter: a slower turn, or a
//! talker's first words before half a second of rows). Each
//! row's direction is that of the frames averaged up to it
//! ([`Detection::span_s`](crate::method::Detection::span_s)), centred half their span
//! before it: turned by that much too, a talker walking at 30 deg/s is no longer placed
//! 0.8 deg behind, and the cone widens by the correction. A
//! planar array's elevation, which the room's floor and ceiling bias in every frame
//! alike, is not improved. Rows with no track (`--keep-unconfirmed`) keep their own
//! direction.
//!
//! [`TrackParams::smooth_s`]: super::TrackParams::smooth_s

use super::motion::{STILL_SPEED, VELOCITY_SPAN_S};
use super::slope::Slope;
use super::Tracked;
use crate::geometry::angles_deg;
use nalgebra::Vector3;
use std::collections::VecDeque;

/// How far back (seconds) a track's rows give the rate at which its direction turns.
const TURN_S: f64 = 1.0;

/// A turn under the tracker's [`STILL_SPEED`] turns rows when it is at least
/// [`SLOW_TURNS_SE`] standard errors of the rows' slope, and at least [`MIN_TURN`]
/// (radians per second, 2 deg/s): on the prism a walker at 10 deg/s was otherwise
/// smoothed as still, his rows 0.4 deg behind and outside their 0.8 deg cones.
const SLOW_TURNS_SE: f64 = 4.0;

/// See [`SLOW_TURNS_SE`].
const MIN_TURN: f64 = 2.0 * std::f64::consts::PI / 180.0;

/// `u` turned by `turn` (an angular velocity) for `dt` seconds (Rodrigues' formula).
fn turned(u: &Vector3<f64>, turn: &Vector3<f64>, dt: f64) -> Vector3<f64> {
    let rate = turn.norm();
    if rate == 0.0 {
        return *u;
    }
    let (axis, angle) = (turn / rate, rate * dt);
    let (sin, cos) = angle.sin_cos();
    u * cos + axis.cross(u) * sin + axis * axis.dot(u) * (1.0 - cos)
}

/// Holds the tracker's rows until every row of their track within the window after them
/// has come (see the module's documentation).
pub(super) struct Smoother {
    /// Half the window (seconds); 0: rows pass through as they are.
    half_s: f64,
    /// Rows in frame order, as the tracker gave them: those already given out (the
    /// first `done`, kept while a waiting row may still need them), then those waiting.
    rows: VecDeque<Tracked>,
    /// How many of `rows` have been given out.
    done: usize,
}

impl Smoother {
    pub fn new(half_s: f64) -> Self {
        Smoother {
            half_s,
            rows: VecDeque::new(),
            done: 0,
        }
    }

    /// A row from the tracker (in frame order).
    pub fn push(&mut self, row: Tracked, out: &mut Vec<Tracked>) {
        if self.half_s <= 0.0 {
            out.push(row);
            return;
        }
        self.rows.push_back(row);
    }

    /// Every row still to come is at `from_s` or later: the rows with their whole window
    /// before it are smoothed and go to `out`.
    pub fn settle(&mut self, from_s: f64, out: &mut Vec<Tracked>) {
        while self.done < self.rows.len()
            && self.rows[self.done].detection.time_s + self.half_s < from_s
        {
            self.emit_next(out);
        }
    }

    /// The end of the recording: every waiting row goes out.
    pub fn finish(&mut self, out: &mut Vec<Tracked>) {
        while self.done < self.rows.len() {
            self.emit_next(out);
        }
        self.rows.clear();
        self.done = 0;
    }

    /// How `source`'s direction turns around `t` (an angular velocity: its axis, and its
    /// length in radians per second), from the least-squares slope of its rows from
    /// [`TURN_S`] before `t` to the half window after it. When they spread over less
    /// than rows spread evenly over [`VELOCITY_SPAN_S`] (the tracker's span for a turn),
    /// or it is under the tracker's [`STILL_SPEED`], only a turn that stands
    /// [`SLOW_TURNS_SE`] standard errors out of the rows' scatter counts.
    fn turn(&self, source: u64, t: f64) -> Vector3<f64> {
        let mut fit = Slope::default();
        for r in self.rows.iter().filter(|r| {
            r.source == Some(source)
                && r.detection.time_s >= t - TURN_S
                && r.detection.time_s <= t + self.half_s
        }) {
            fit.add(
                r.detection.time_s,
                &r.detection.direction,
                r.detection.span_s,
            );
        }
        let Some((mean, slope)) = fit.line() else {
            return Vector3::zeros();
        };
        // As a rotation: the rows' arc is curved, and a slope taken at their middle
        // points off the tangent at `t` by half the angle turned.
        let middle = mean.normalize();
        let turn = middle.cross(&slope);
        let rate = turn.norm();
        if !rate.is_finite() {
            return Vector3::zeros();
        }
        // Rows over less than the tracker's span (a talker's first words, or his first
        // after a pause), or a turn slower than it counts, turn them only when their
        // slope stands out of their scatter.
        let short = fit.time_variance() < VELOCITY_SPAN_S * VELOCITY_SPAN_S / 12.0;
        if (rate < STILL_SPEED || short)
            && (rate < MIN_TURN
                || fit
                    .standard_error(&middle, None)
                    .is_none_or(|se| rate < SLOW_TURNS_SE * se))
        {
            return Vector3::zeros();
        }
        turn
    }

    /// Smooths the first waiting row and gives it out; forgets the rows no waiting row
    /// needs any more.
    fn emit_next(&mut self, out: &mut Vec<Tracked>) {
        let mut row = self.rows[self.done].clone();
        if let Some(source) = row.source {
            let t = row.detection.time_s;
            let turn = self.turn(source, t);
            let sum: Vector3<f64> = self
                .rows
                .iter()
                .filter(|r| {
                    r.source == Some(source) && (r.detection.time_s - t).abs() <= self.half_s
                })
                // Each row's direction is that of its frames' span, centred before it.
                .map(|r| {
                    let heard = r.detection.time_s - r.detection.span_s / 2.0;
                    turned(&r.detection.direction, &turn, t - heard)
                })
                .sum();
            let n = sum.norm();
            if n > 1e-9 && n.is_finite() {
                let u = sum / n;
                let (az, el) = angles_deg(&u);
                row.detection.direction = u;
                row.detection.azimuth_deg = az;
                row.detection.elevation_deg = el;
                // The lag taken out is an estimate: the cone widens by as much.
                let lag_deg = turn.norm().to_degrees() * row.detection.span_s / 2.0;
                row.detection.uncertainty_deg =
                    (row.detection.uncertainty_deg + lag_deg).min(180.0);
            }
        }
        out.push(row);
        self.done += 1;
        // The rows still to come are at the next waiting row's time or later (at the
        // row just given out's, when none waits).
        let next = self.rows[self.done.min(self.rows.len() - 1)]
            .detection
            .time_s;
        while self.done > 0 && next - self.rows[0].detection.time_s > self.half_s.max(TURN_S) {
            self.rows.pop_front();
            self.done -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{angle_between_deg, unit_from_angles};
    use crate::method::Detection;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn row(time_s: f64, u: Vector3<f64>, source: Option<u64>) -> Tracked {
        let (azimuth_deg, elevation_deg) = angles_deg(&u);
        Tracked {
            detection: Detection {
                frame: (time_s / 0.008).round() as u64,
                time_s,
                azimuth_deg,
                elevation_deg,
                direction: u,
                score: 1.0,
                mics: 8,
                margin: 1.0,
                peak_margin: 1.0,
                uncertainty_deg: 2.0,
                rider: false,
                span_s: 0.0,
                accumulated: false,
            },
            source,
        }
    }

    fn smooth_all(half_s: f64, rows: &[Tracked]) -> Vec<Tracked> {
        let mut s = Smoother::new(half_s);
        let mut out = Vec::new();
        for r in rows {
            s.settle(r.detection.time_s, &mut out);
            s.push(r.clone(), &mut out);
        }
        s.finish(&mut out);
        out
    }

    /// The oracle: every row's direction the normalised sum of its source's rows
    /// within `half_s`, computed over the whole list at once.
    fn brute_force(half_s: f64, rows: &[Tracked]) -> Vec<Vector3<f64>> {
        rows.iter()
            .map(|r| match r.source {
                None => r.detection.direction,
                Some(s) => rows
                    .iter()
                    .filter(|o| {
                        o.source == Some(s)
                            && (o.detection.time_s - r.detection.time_s).abs() <= half_s
                    })
                    .map(|o| o.detection.direction)
                    .sum::<Vector3<f64>>()
                    .normalize(),
            })
            .collect()
    }

    /// Two talkers 40 deg apart with rows scattered by a few degrees, some frames with
    /// both, a gap, and a row without a track.
    fn two_talkers(rng: &mut ChaCha8Rng) -> Vec<Tracked> {
        let mut rows = Vec::new();
        for k in 0..400 {
            let t = 0.5 + k as f64 * 0.008;
            if (1.2..1.6).contains(&t) {
                continue;
            }
            for (source, az) in [(1, 20.0), (2, -20.0)] {
                if rng.random_bool(0.6) {
                    let u = unit_from_angles(
                        az + rng.random_range(-4.0..4.0),
                        10.0 + rng.random_range(-4.0..4.0),
                    );
                    rows.push(row(t, u, Some(source)));
                }
            }
            if k == 150 {
                rows.push(row(t, unit_from_angles(120.0, 0.0), None));
            }
        }
        rows
    }

    #[test]
    fn every_row_is_the_mean_of_its_tracks_rows_around_it() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let rows = two_talkers(&mut rng);
        let out = smooth_all(0.1, &rows);
        assert_eq!(out.len(), rows.len());
        for ((o, r), want) in out.iter().zip(&rows).zip(brute_force(0.1, &rows)) {
            assert_eq!(o.source, r.source);
            assert_eq!(o.detection.time_s, r.detection.time_s);
            assert_eq!(o.detection.score, r.detection.score);
            assert!(angle_between_deg(&o.detection.direction, &want) < 1e-9);
            let (az, el) = angles_deg(&want);
            assert!((o.detection.azimuth_deg - az).abs() < 1e-9);
            assert!((o.detection.elevation_deg - el).abs() < 1e-9);
        }
        let untracked = out.iter().find(|o| o.source.is_none()).expect("kept");
        assert!((untracked.detection.azimuth_deg - 120.0).abs() < 1e-9);
    }

    #[test]
    fn smoothing_brings_scattered_rows_nearer_their_talker() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let rows = two_talkers(&mut rng);
        let truth = |s: Option<u64>| match s {
            Some(1) => unit_from_angles(20.0, 10.0),
            _ => unit_from_angles(-20.0, 10.0),
        };
        let mean = |rows: &[Tracked]| {
            let tracked = rows.iter().filter(|r| r.source.is_some());
            let n = tracked.clone().count() as f64;
            tracked
                .map(|r| angle_between_deg(&r.detection.direction, &truth(r.source)))
                .sum::<f64>()
                / n
        };
        let (before, after) = (mean(&rows), mean(&smooth_all(0.1, &rows)));
        assert!(before > 2.0, "{before}");
        assert!(after < 0.5 * before, "{before} -> {after}");
    }

    #[test]
    fn a_talker_moving_steadily_is_left_where_it_was_at_each_row() {
        // 60 deg/s, a row every 8 ms: the window's mean is the middle of its arc.
        let rows: Vec<Tracked> = (0..300)
            .map(|k| {
                let t = k as f64 * 0.008;
                row(t, unit_from_angles(-60.0 + 60.0 * t, 5.0), Some(1))
            })
            .collect();
        let out = smooth_all(0.1, &rows);
        for (o, r) in out.iter().zip(&rows).skip(13).take(270) {
            let err = angle_between_deg(&o.detection.direction, &r.detection.direction);
            assert!(err < 0.05, "{} s: {err} deg", r.detection.time_s);
        }
    }

    #[test]
    fn a_direction_heard_over_frames_before_its_row_is_moved_to_the_rows_time() {
        // 60 deg/s; each row's direction is that of the 6 frames up to it (53 ms of
        // centres), so it lags 27 ms (1.6 deg): smoothed, each row is where the talker
        // is at its time.
        let span_s = 5.0 * 0.0107;
        let at = |t: f64| unit_from_angles(-60.0 + 60.0 * t, 5.0);
        let rows: Vec<Tracked> = (0..300)
            .map(|k| {
                let t = k as f64 * 0.008;
                let mut r = row(t, at(t - span_s / 2.0), Some(1));
                r.detection.span_s = span_s;
                r
            })
            .collect();
        let out = smooth_all(0.1, &rows);
        // Once the rows span enough time to give the turn.
        for (o, r) in out.iter().zip(&rows).skip(70).take(215) {
            let t = r.detection.time_s;
            let err = angle_between_deg(&o.detection.direction, &at(t));
            assert!(err < 0.1, "{t} s: {err} deg");
            // Unsmoothed, the row lagged.
            assert!(angle_between_deg(&r.detection.direction, &at(t)) > 1.5);
        }
    }

    #[test]
    fn a_talker_moving_in_bursts_is_not_dragged_back_at_their_edges() {
        // 60 deg/s, talking 0.6 s in every 0.9 s: at a burst's edges the window is
        // one-sided, and the plain mean lags by up to a quarter of its span.
        let truth = |t: f64| unit_from_angles(-60.0 + 60.0 * t, 5.0);
        let rows: Vec<Tracked> = (0..400)
            .map(|k| k as f64 * 0.008)
            .filter(|t| t % 0.9 < 0.6)
            .map(|t| row(t, truth(t), Some(1)))
            .collect();
        let plain = brute_force(0.1, &rows);
        let out = smooth_all(0.1, &rows);
        let (mut worst_plain, mut worst) = (0.0f64, 0.0f64);
        // From the second burst on (the first has no second of turn behind it).
        for ((o, r), p) in out.iter().zip(&rows).zip(&plain) {
            if r.detection.time_s < 0.9 {
                continue;
            }
            let want = truth(r.detection.time_s);
            worst_plain = worst_plain.max(angle_between_deg(p, &want));
            worst = worst.max(angle_between_deg(&o.detection.direction, &want));
        }
        assert!(worst_plain > 2.0, "{worst_plain}");
        assert!(worst < 0.3, "{worst}");
    }

    #[test]
    fn a_slow_walker_is_turned_and_a_still_talkers_scatter_is_not() {
        // 6 deg/s, under the tracker's turn, in bursts, its rows scattered by 0.5 deg:
        // the rows' slope stands out of their scatter, so each row is turned to its
        // time (the plain mean lags at the bursts' edges).
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let truth = |t: f64| unit_from_angles(-60.0 + 6.0 * t, 5.0);
        let rows: Vec<Tracked> = (0..800)
            .map(|k| k as f64 * 0.008)
            .filter(|t| t % 0.9 < 0.6)
            .map(|t| {
                let u = truth(t)
                    + Vector3::new(
                        rng.random_range(-0.005..0.005),
                        rng.random_range(-0.005..0.005),
                        rng.random_range(-0.005..0.005),
                    );
                row(t, u.normalize(), Some(1))
            })
            .collect();
        let plain = brute_force(0.2, &rows);
        let out = smooth_all(0.2, &rows);
        let (mut err_plain, mut err, mut n) = (0.0, 0.0, 0.0);
        for ((o, r), p) in out.iter().zip(&rows).zip(&plain) {
            if r.detection.time_s < 0.9 {
                continue;
            }
            let want = truth(r.detection.time_s);
            err_plain += angle_between_deg(p, &want);
            err += angle_between_deg(&o.detection.direction, &want);
            n += 1.0;
        }
        assert!(err < 0.7 * err_plain, "{} {}", err / n, err_plain / n);
        // A still talker scattered by 4 deg is smoothed by the plain mean: its slope
        // does not stand out.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        assert_eq!(
            smooth_all(0.2, &two_talkers(&mut rng))
                .iter()
                .map(|r| r.detection.direction)
                .collect::<Vec<_>>(),
            brute_force(0.2, &two_talkers(&mut ChaCha8Rng::seed_from_u64(7)))
        );
    }

    #[test]
    fn a_walkers_first_words_are_turned_before_half_a_second_of_rows() {
        // 30 deg/s, 0.4 s of rows scattered by 0.3 deg (a prism's): the window is
        // one-sided at the first rows, and its plain mean leads them by up to 3 deg; the
        // rows' slope stands out of their scatter, so each is turned to its time.
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let truth = |t: f64| unit_from_angles(30.0 * t, 5.0);
        let rows: Vec<Tracked> = (0..38)
            .map(|k| {
                let t = k as f64 * 0.0107;
                let u = truth(t)
                    + Vector3::new(
                        rng.random_range(-0.003..0.003),
                        rng.random_range(-0.003..0.003),
                        rng.random_range(-0.003..0.003),
                    );
                let mut r = row(t, u.normalize(), Some(1));
                r.detection.uncertainty_deg = 1.0;
                r
            })
            .collect();
        let plain = brute_force(0.2, &rows);
        let out = smooth_all(0.2, &rows);
        let (mut worst_plain, mut worst) = (0.0f64, 0.0f64);
        for ((o, r), p) in out.iter().zip(&rows).zip(&plain) {
            let want = truth(r.detection.time_s);
            worst_plain = worst_plain.max(angle_between_deg(p, &want));
            let err = angle_between_deg(&o.detection.direction, &want);
            assert!(
                err <= o.detection.uncertainty_deg,
                "{} s: {err} deg",
                r.detection.time_s
            );
            worst = worst.max(err);
        }
        assert!(worst_plain > 2.0, "{worst_plain}");
        assert!(worst < 0.5, "{worst}");
    }

    #[test]
    fn rows_come_out_once_the_window_after_them_has_passed_and_no_later() {
        let rows: Vec<Tracked> = (0..100)
            .map(|k| row(k as f64 * 0.01, unit_from_angles(0.0, 0.0), Some(1)))
            .collect();
        let mut s = Smoother::new(0.1);
        let mut out = Vec::new();
        for r in &rows {
            let now = r.detection.time_s;
            s.push(r.clone(), &mut out);
            // Rows to come are a frame later: out, the rows 0.1 s before now or more.
            s.settle(now + 1e-9, &mut out);
            let want = rows
                .iter()
                .filter(|o| o.detection.time_s + 0.1 < now + 1e-9)
                .count();
            assert_eq!(out.len(), want, "{now}");
        }
        // Memory: only the rows of the last turn's span and the window are held.
        assert!(s.rows.len() <= 113, "{}", s.rows.len());
        s.finish(&mut out);
        assert_eq!(out.len(), rows.len());
    }

    #[test]
    fn no_window_passes_rows_through_unchanged() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let rows = two_talkers(&mut rng);
        assert_eq!(smooth_all(0.0, &rows), rows);
    }
}
