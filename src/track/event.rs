//! A stretch of activity of one tracked source (docs/interface.md, "Events").

use crate::method::Detection;
use nalgebra::Vector3;

/// With [`ConfirmBy::Evidence`](super::ConfirmBy::Evidence), a stretch of activity ends
/// after a silence as long as itself, at least this long (seconds) and at most
/// [`TrackParams::end_s`](super::TrackParams::end_s): each clap is its own event, a
/// sentence's pauses are not ends.
const END_MIN_S: f64 = 0.3;

/// How long a silence ends a stretch of activity that has lasted `length_s` (seconds):
/// as long as the stretch, within [`END_MIN_S`, `end_s`], when `by_length` (confirmation
/// by the evidence, the default), else `end_s`. The tracker ends its events by it, and
/// `ssl evaluate` reads events off rows by it.
pub(crate) fn ends_after(length_s: f64, end_s: f64, by_length: bool) -> f64 {
    if by_length {
        length_s.clamp(END_MIN_S.min(end_s), end_s)
    } else {
        end_s
    }
}

/// With [`ConfirmBy::Evidence`](super::ConfirmBy::Evidence), a track silent for longer
/// than this (seconds) when another source starts a stretch of activity ends its own
/// there: a turn ends when another takes the floor. Its stretch would otherwise run on
/// for a silence as long as itself and take the new talker's first strays (five
/// talkers 12-20 deg apart in turn: an event ran 0.1-0.7 s into the next talker's turn
/// in 19 of 498 turns, 9 at 0.2 s; at 0.1 s two talkers at once on a 6-mic circle had
/// their events split, 10 -> 14).
pub(crate) const TURN_GAP_S: f64 = 0.2;

/// Whether a stretch of activity whose last detection was at `last_s` ends when another
/// source starts one at `start_s` ([`TURN_GAP_S`]). The tracker ends its events by it,
/// and `ssl evaluate` reads events off rows by it.
pub(crate) fn turn_ended(last_s: f64, start_s: f64) -> bool {
    start_s - last_s > TURN_GAP_S
}

/// One stretch of activity of one track: from its first detection to its last, with no
/// silence longer than [`TrackParams::end_s`](super::TrackParams::end_s) in between.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    /// The track's id.
    pub source: u64,
    /// Time of the first detection (frame centre, seconds).
    pub start_s: f64,
    /// Time of the last detection.
    pub end_s: f64,
    /// Mean direction of the detections (unit vector).
    pub direction: Vector3<f64>,
    /// Angular spread of the detections (degrees): `acos` of the mean resultant length,
    /// the angle whose cosine is the mean cosine between each detection and the mean
    /// direction (0 when they all agree; close to their RMS angle from it when small).
    pub spread_deg: f64,
    /// Detections in the stretch.
    pub detections: u64,
    /// Mean score of the detections.
    pub score: f64,
    /// The direction of its first detection (unit vector): where a moving source started.
    pub start_direction: Vector3<f64>,
    /// The direction of its last detection: where a moving source ended.
    pub end_direction: Vector3<f64>,
    /// The half-angle (degrees) of the cone around [`Event::direction`] that holds the
    /// true direction with 95% probability: the mean of its detections'
    /// [`Detection::uncertainty_deg`]. Their errors are mostly shared (the room biases
    /// every frame alike), so the mean of many is not much nearer than one
    /// (docs/method.md, "Uncertainty").
    pub uncertainty_deg: f64,
}

/// An event being accumulated: sums only, so memory does not grow with its length.
#[derive(Debug, Clone)]
pub(crate) struct Accumulator {
    start_s: f64,
    end_s: f64,
    /// The first and the last detection's directions.
    first: Vector3<f64>,
    last: Vector3<f64>,
    sum: Vector3<f64>,
    score: f64,
    uncertainty: f64,
    count: u64,
}

impl Accumulator {
    pub fn new(d: &Detection) -> Self {
        Accumulator {
            start_s: d.time_s,
            end_s: d.time_s,
            first: d.direction,
            last: d.direction,
            sum: d.direction,
            score: d.score,
            uncertainty: d.uncertainty_deg,
            count: 1,
        }
    }

    /// When its first detection was (seconds).
    pub fn start_s(&self) -> f64 {
        self.start_s
    }

    /// Its last detection's time.
    pub fn end_s(&self) -> f64 {
        self.end_s
    }

    /// The mean of its detections' [`Detection::uncertainty_deg`] so far.
    pub fn uncertainty_deg(&self) -> f64 {
        self.uncertainty / self.count as f64
    }

    /// The mean direction of its detections so far.
    pub fn direction(&self) -> Vector3<f64> {
        self.sum.try_normalize(1e-12).unwrap_or(self.last)
    }

    /// Adds `d` (detections may come out of order: a candidate's, once confirmed).
    pub fn add(&mut self, d: &Detection) {
        self.merge(Accumulator::new(d));
    }

    /// Takes in `other`, a stretch of the same source: one stretch from the earlier
    /// start to the later end.
    pub fn merge(&mut self, other: Accumulator) {
        if other.start_s < self.start_s {
            self.first = other.first;
        }
        if other.end_s >= self.end_s {
            self.last = other.last;
        }
        self.start_s = self.start_s.min(other.start_s);
        self.end_s = self.end_s.max(other.end_s);
        self.sum += other.sum;
        self.score += other.score;
        self.uncertainty += other.uncertainty;
        self.count += other.count;
    }

    pub fn finish(&self, source: u64) -> Event {
        let n = self.count as f64;
        let resultant = self.sum.norm() / n;
        let direction = self.direction();
        Event {
            source,
            start_s: self.start_s,
            end_s: self.end_s,
            direction,
            spread_deg: resultant.clamp(-1.0, 1.0).acos().to_degrees(),
            detections: self.count,
            score: self.score / n,
            start_direction: self.first,
            end_direction: self.last,
            uncertainty_deg: self.uncertainty_deg(),
        }
    }
}
