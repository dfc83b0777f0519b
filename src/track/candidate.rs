//! A candidate track: detections that no track took, waiting to be confirmed (see the
//! [`track`](super) module), and the gate within which further detections join it.

use super::evidence::{Bursts, Test};
use super::faint::FaintPlace;
use super::motion::{smooth, Track};
use super::{TrackParams, MAX_CANDIDATE_GATE_DEG};
use crate::geometry::Geometry;
use crate::method::Detection;
use nalgebra::Vector3;
use std::collections::VecDeque;

/// A candidate track.
pub(super) struct Candidate {
    /// Its key (never reused within a recording).
    pub key: u64,
    /// Its direction, smoothed over its detections.
    pub direction: Vector3<f64>,
    /// Its latest detection's time.
    pub last_s: f64,
    /// Its detections within the tracker's delay ([`TrackParams::delay_s`]) of the
    /// latest frame, oldest first, each with the number of its waiting row.
    pub hits: VecDeque<(u64, Detection)>,
    /// The rows of those hits heard while a track talked, oldest first.
    pub beside_talk: VecDeque<u64>,
    /// Whether an accumulated look ([`Detection::accumulated`]) has heard it.
    pub accumulated: bool,
    /// The time of its latest detection heard alone (see [`TrackParams::alone_s`]).
    pub alone_s: f64,
    /// Its evidence (with [`ConfirmBy::Evidence`](super::ConfirmBy::Evidence)).
    pub test: Test,
    /// Its evidence as a source heard in bursts, taken on from the silent track at its
    /// place (`place`) if there was one.
    pub bursts: Bursts,
    /// The silent track whose place it started at and whose bursts it took on.
    pub place: Option<u64>,
    /// Its detections so far, the first one's time, and the most evidence it has
    /// gathered (nats): what it adds to its place if it is dropped (see `faint`).
    pub heard: u64,
    pub first_s: f64,
    pub best_nats: f64,
    /// The tracks that took a detection in a frame that gave it one, with how many such
    /// frames (see `Tracker::confirm`).
    pub together: Vec<(u64, u64)>,
}

impl Candidate {
    /// The mean of its detections' [`Detection::uncertainty_deg`] (0 with none).
    pub fn uncertainty_deg(&self) -> f64 {
        let n = self.hits.len().max(1) as f64;
        self.hits
            .iter()
            .map(|(_, d)| d.uncertainty_deg)
            .sum::<f64>()
            / n
    }

    /// The mean direction of its detections (its smoothed direction with none): where
    /// it was heard over its whole run, not where its latest detections drifted.
    pub fn mean_direction(&self) -> Vector3<f64> {
        let sum: Vector3<f64> = self.hits.iter().map(|(_, d)| d.direction).sum();
        sum.try_normalize(1e-12).unwrap_or(self.direction)
    }

    /// What it tells of its place if it is dropped unconfirmed (`needed_nats`: what a
    /// source needs, with the evidence test).
    pub fn as_place(&self, needed_nats: Option<f64>) -> FaintPlace {
        FaintPlace {
            direction: self.direction,
            detections: self.heard,
            first_s: self.first_s,
            last_s: self.last_s,
            best_nats: needed_nats.map(|_| self.best_nats),
            needed_nats,
        }
    }

    /// The hits within the confirmation window (`window_s`) that ends at the latest.
    fn recent(&self, window_s: f64) -> impl Iterator<Item = &Detection> + Clone {
        let last = self
            .hits
            .back()
            .map_or(f64::NEG_INFINITY, |(_, d)| d.time_s);
        self.hits
            .iter()
            .map(|(_, d)| d)
            .filter(move |d| last - d.time_s <= window_s)
    }

    /// Takes detection `d`, waiting as row `row`, heard while a track talked (`busy`)
    /// or not.
    pub fn hear(&mut self, row: u64, d: &Detection, busy: bool) {
        self.direction = smooth(&self.direction, &d.direction, d.time_s - self.last_s);
        self.last_s = d.time_s;
        self.heard += 1;
        self.hits.push_back((row, *d));
        self.accumulated |= d.accumulated;
        if busy {
            self.beside_talk.push_back(row);
        }
        let oldest = self.hits.front().map_or(row, |&(r, _)| r);
        while self.beside_talk.front().is_some_and(|&r| r < oldest) {
            self.beside_talk.pop_front();
        }
    }

    /// Takes out its first runs of hits each followed by a silence longer than `gap_s`
    /// (seconds), no part of the run that confirms the candidate: by the rules, a lone
    /// first hit; with the evidence (`beside_talk_only`), a run of any length heard
    /// while a track talked, another source's strays (a stray on its own followed by a
    /// silence has been rejected, and a faint talker's words before a pause are his).
    /// Gives their rows.
    pub fn strays(&mut self, gap_s: f64, beside_talk_only: bool) -> Vec<u64> {
        let mut rows = Vec::new();
        while let Some(k) = (1..self.hits.len())
            .find(|&k| self.hits[k].1.time_s - self.hits[k - 1].1.time_s > gap_s)
        {
            let stray = if beside_talk_only {
                let talked = |(row, _): &(u64, Detection)| self.beside_talk.contains(row);
                self.hits.range(..k).all(talked)
            } else {
                k == 1
            };
            if !stray {
                break;
            }
            rows.extend(self.hits.drain(..k).map(|(row, _)| row));
        }
        rows
    }

    /// Whether the hits within the confirmation window confirm the candidate.
    pub fn confirmed(&self, p: &TrackParams) -> bool {
        let recent = self.recent(p.confirm_s);
        let hits = recent.clone().count();
        let strong = recent.clone().filter(|d| d.margin >= 1.0).count();
        // A reflection of a talker is heard only while the talker is: the rules with a
        // detection above the threshold need one heard alone within the delay.
        let heard_alone = p.alone_s == 0.0 || self.last_s - self.alone_s <= p.delay();
        if heard_alone && (strong >= p.confirm_hits || (strong > 0 && hits >= p.confirm_candidates))
        {
            return true;
        }
        // The runs under the threshold: long enough to be several observations.
        let first = recent
            .clone()
            .map(|d| d.time_s)
            .fold(f64::INFINITY, f64::min);
        if self.last_s - first < p.weak_span_s {
            return false;
        }
        hits >= p.confirm_weak || (hits >= p.confirm_tight && spread_deg(recent) <= p.tight_deg)
    }
}

/// Whether the frame at `time_s` with `detections` is heard alone (see
/// [`TrackParams::alone_s`]): its only detection, riders aside, with no talking track
/// heard within `alone_s` before it.
pub fn heard_alone(detections: &[Detection], tracks: &[Track], time_s: f64, alone_s: f64) -> bool {
    detections.iter().filter(|d| !d.rider).count() == 1
        && !tracks
            .iter()
            .any(|t| t.event.is_some() && time_s - t.last_s <= alone_s)
}

/// The largest angle (degrees) between a detection's direction and their mean.
fn spread_deg<'a>(detections: impl Iterator<Item = &'a Detection> + Clone) -> f64 {
    let sum = detections
        .clone()
        .fold(Vector3::zeros(), |a: Vector3<f64>, d| a + d.direction);
    let Some(mean) = sum.try_normalize(1e-12) else {
        return 180.0;
    };
    detections
        .map(|d| d.direction.angle(&mean).to_degrees())
        .fold(0.0, f64::max)
}

/// A candidate's gate (degrees) on `geometry` at `rate` Hz and `speed` m/s: the larger of
/// [`TrackParams::candidate_gate_deg`] and [`TrackParams::candidate_gate_samples`] times
/// [`Geometry::direction_spread_deg`], the latter at most [`MAX_CANDIDATE_GATE_DEG`].
pub(crate) fn candidate_gate_deg(
    p: &TrackParams,
    geometry: &Geometry,
    rate: f64,
    speed: f64,
) -> f64 {
    let spread = geometry.direction_spread_deg(rate, speed);
    let scaled = (p.candidate_gate_samples * spread).min(MAX_CANDIDATE_GATE_DEG);
    p.candidate_gate_deg.max(scaled)
}
