//! The tracker: association, confirmation, activity (see the module's documentation).

use super::event::{Accumulator, Event};
use super::{TrackParams, MAX_TRACKS};
use crate::method::direction::angle_between_deg;
use crate::method::Detection;
use nalgebra::Vector3;
use std::collections::{HashMap, VecDeque};

/// A detection as the tracker gives it out: with its track's id.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracked {
    /// The detection.
    pub detection: Detection,
    /// Its track's id (from 1, never reused within one recording).
    pub source: u64,
}

/// How much of a new detection a track's direction takes.
const SMOOTHING: f64 = 0.3;

struct Track {
    id: u64,
    direction: Vector3<f64>,
    last_s: f64,
    event: Option<Accumulator>,
}

struct Candidate {
    key: u64,
    direction: Vector3<f64>,
    first_s: f64,
    last_s: f64,
    hits: Vec<Detection>,
}

#[derive(Clone, Copy)]
enum Slot {
    Track(u64),
    Candidate(u64),
}

/// Follows detections over time (see the [`track`](super) module).
pub struct Tracker {
    params: TrackParams,
    tracks: Vec<Track>,
    candidates: Vec<Candidate>,
    /// Rows not yet given out, in frame order, with what they joined.
    waiting: VecDeque<(Detection, Slot)>,
    /// Resolved candidates still named by waiting rows: their track's id (or `None`:
    /// dropped) and how many rows still name them.
    resolved: HashMap<u64, (Option<u64>, usize)>,
    next_id: u64,
    next_key: u64,
    ready: Vec<Tracked>,
    events: Vec<Event>,
    /// Per frame, reused: candidate pairings, detections placed, tracks and candidates
    /// taken (`true` for a track, then its id or key).
    pairs: Vec<(f64, usize, Slot)>,
    used: Vec<bool>,
    taken: Vec<(bool, u64)>,
}

impl Tracker {
    /// A tracker for one recording (parameters checked by [`TrackParams::check`]).
    pub fn new(params: TrackParams) -> Self {
        Tracker {
            params,
            tracks: Vec::new(),
            candidates: Vec::new(),
            waiting: VecDeque::new(),
            resolved: HashMap::new(),
            next_id: 1,
            next_key: 0,
            ready: Vec::new(),
            events: Vec::new(),
            pairs: Vec::new(),
            used: Vec::new(),
            taken: Vec::new(),
        }
    }

    /// The gate around a direction last confirmed `since` seconds ago.
    fn gate(&self, since: f64) -> f64 {
        (self.params.gate_deg + self.params.max_speed_deg_s * since.max(0.0))
            .min(self.params.max_gate_deg)
    }

    /// Takes the detections of the frame at `time_s` (frames in order; none is fine: time
    /// still passes). Rows and events that are complete become available through
    /// [`Tracker::take_rows`] and [`Tracker::take_events`].
    pub fn push(&mut self, time_s: f64, detections: &[Detection]) {
        self.advance(time_s);
        // Nearest first: every (detection, track or candidate) within its gate.
        self.pairs.clear();
        for (i, d) in detections.iter().enumerate() {
            for t in self.tracks.iter().filter(|t| t.event.is_some()) {
                let angle = angle_between_deg(&d.direction, &t.direction);
                if angle <= self.gate(time_s - t.last_s) {
                    self.pairs.push((angle, i, Slot::Track(t.id)));
                }
            }
            for c in &self.candidates {
                let angle = angle_between_deg(&d.direction, &c.direction);
                if angle <= self.gate(time_s - c.last_s) {
                    self.pairs.push((angle, i, Slot::Candidate(c.key)));
                }
            }
        }
        let mut pairs = std::mem::take(&mut self.pairs);
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut used = std::mem::take(&mut self.used);
        used.clear();
        used.resize(detections.len(), false);
        let mut taken = std::mem::take(&mut self.taken);
        taken.clear();
        for &(_, i, slot) in &pairs {
            let key = match slot {
                Slot::Track(id) => (true, id),
                Slot::Candidate(k) => (false, k),
            };
            if used[i] || taken.contains(&key) {
                continue;
            }
            used[i] = true;
            taken.push(key);
            self.join(&detections[i], slot);
        }
        self.pairs = pairs;
        self.taken = taken;
        for (d, _) in detections.iter().zip(&used).filter(|(_, &u)| !u) {
            let key = self.next_key;
            self.next_key += 1;
            self.candidates.push(Candidate {
                key,
                direction: d.direction,
                first_s: d.time_s,
                last_s: d.time_s,
                hits: Vec::new(),
            });
            self.join(d, Slot::Candidate(key));
        }
        self.used = used;
        self.release();
    }

    /// Adds `d` to a track or a candidate (confirming the candidate when it has enough).
    fn join(&mut self, d: &Detection, slot: Slot) {
        self.waiting.push_back((*d, slot));
        match slot {
            Slot::Track(id) => {
                let t = self
                    .tracks
                    .iter_mut()
                    .find(|t| t.id == id)
                    .expect("a live track");
                t.direction = smooth(&t.direction, &d.direction);
                t.last_s = d.time_s;
                match t.event.as_mut() {
                    Some(e) => e.add(d),
                    None => t.event = Some(Accumulator::new(d)),
                }
            }
            Slot::Candidate(key) => {
                let i = self
                    .candidates
                    .iter()
                    .position(|c| c.key == key)
                    .expect("an open candidate");
                let c = &mut self.candidates[i];
                c.direction = smooth(&c.direction, &d.direction);
                c.last_s = d.time_s;
                c.hits.push(*d);
                if c.hits.len() >= self.params.confirm_hits {
                    let c = self.candidates.remove(i);
                    self.confirm(c);
                }
            }
        }
    }

    /// A candidate becomes a track: a silent track's id when one is near, else a new one.
    fn confirm(&mut self, c: Candidate) {
        let now = c.last_s;
        let silent = self
            .tracks
            .iter()
            .enumerate()
            .filter(|(_, t)| t.event.is_none())
            .map(|(i, t)| (i, angle_between_deg(&c.direction, &t.direction), t))
            .filter(|(_, angle, t)| *angle <= self.gate(now - t.last_s))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _, _)| i);
        let mut event = Accumulator::new(&c.hits[0]);
        for d in &c.hits[1..] {
            event.add(d);
        }
        let id = match silent {
            Some(i) => {
                let t = &mut self.tracks[i];
                t.direction = c.direction;
                t.last_s = c.last_s;
                t.event = Some(event);
                t.id
            }
            None => {
                let id = self.next_id;
                self.next_id += 1;
                if self.tracks.len() >= MAX_TRACKS {
                    // Forget the silent track heard least recently.
                    if let Some(oldest) = self
                        .tracks
                        .iter()
                        .enumerate()
                        .filter(|(_, t)| t.event.is_none())
                        .min_by(|a, b| a.1.last_s.total_cmp(&b.1.last_s))
                        .map(|(i, _)| i)
                    {
                        self.tracks.remove(oldest);
                    }
                }
                self.tracks.push(Track {
                    id,
                    direction: c.direction,
                    last_s: c.last_s,
                    event: Some(event),
                });
                id
            }
        };
        self.resolved.insert(c.key, (Some(id), c.hits.len()));
    }

    /// Time passes to `now`: candidates too old are dropped, stretches of activity that
    /// have been silent long enough end, silent tracks are forgotten.
    fn advance(&mut self, now: f64) {
        let p = &self.params;
        let (confirm_s, end_s, forget_s) = (p.confirm_s, p.end_s, p.forget_s);
        let mut i = 0;
        while i < self.candidates.len() {
            if now - self.candidates[i].first_s > confirm_s {
                let c = self.candidates.remove(i);
                self.resolved.insert(c.key, (None, c.hits.len()));
            } else {
                i += 1;
            }
        }
        for t in &mut self.tracks {
            if t.event.is_some() && now - t.last_s > end_s {
                let e = t.event.take().expect("checked");
                self.events.push(e.finish(t.id));
            }
        }
        self.tracks
            .retain(|t| t.event.is_some() || now - t.last_s <= forget_s);
    }

    /// Gives out the waiting rows whose fate is known, in order.
    fn release(&mut self) {
        while let Some((_, slot)) = self.waiting.front() {
            let source = match *slot {
                Slot::Track(id) => Some(id),
                Slot::Candidate(key) => {
                    let Some(entry) = self.resolved.get_mut(&key) else {
                        break;
                    };
                    entry.1 -= 1;
                    let id = entry.0;
                    if entry.1 == 0 {
                        self.resolved.remove(&key);
                    }
                    id
                }
            };
            let (detection, _) = self.waiting.pop_front().expect("a front");
            if let Some(source) = source {
                self.ready.push(Tracked { detection, source });
            }
        }
    }

    /// The end of the recording: open candidates are dropped, every stretch of activity
    /// ends, and every row still waiting is given out or dropped.
    pub fn finish(&mut self) {
        for c in std::mem::take(&mut self.candidates) {
            self.resolved.insert(c.key, (None, c.hits.len()));
        }
        let mut ending: Vec<Event> = self
            .tracks
            .iter_mut()
            .filter_map(|t| t.event.take().map(|e| e.finish(t.id)))
            .collect();
        ending.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        self.events.extend(ending);
        self.release();
    }

    /// The rows given out since the last call, in frame order.
    pub fn take_rows(&mut self) -> std::vec::Drain<'_, Tracked> {
        self.ready.drain(..)
    }

    /// The events completed since the last call, in the order they ended.
    pub fn take_events(&mut self) -> std::vec::Drain<'_, Event> {
        self.events.drain(..)
    }
}

fn smooth(old: &Vector3<f64>, new: &Vector3<f64>) -> Vector3<f64> {
    let v = old * (1.0 - SMOOTHING) + new * SMOOTHING;
    let n = v.norm();
    if n > 1e-9 {
        v / n
    } else {
        *new
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::direction::unit_from_angles;

    const HOP: f64 = 0.01;

    fn detection(frame: u64, azimuth: f64) -> Detection {
        let direction = unit_from_angles(azimuth, 0.0);
        Detection {
            frame,
            time_s: frame as f64 * HOP,
            azimuth_deg: azimuth,
            elevation_deg: 0.0,
            direction,
            score: 10.0,
            mics: 8,
        }
    }

    /// Runs `frames` (per frame, the azimuths detected) through a tracker with the
    /// default parameters: the rows (frame, source) and the events.
    fn track(frames: &[Vec<f64>]) -> (Vec<(u64, u64, f64)>, Vec<Event>) {
        let mut tracker = Tracker::new(TrackParams::default());
        let (mut rows, mut events) = (Vec::new(), Vec::new());
        for (i, azimuths) in frames.iter().enumerate() {
            let ds: Vec<Detection> = azimuths.iter().map(|&a| detection(i as u64, a)).collect();
            tracker.push(i as f64 * HOP, &ds);
            for r in tracker.take_rows() {
                // Rows come out at most the confirmation window after their frame.
                assert!(i as f64 * HOP - r.detection.time_s <= 0.5 + 1e-9);
                rows.push((r.detection.frame, r.source, r.detection.azimuth_deg));
            }
            events.extend(tracker.take_events());
        }
        tracker.finish();
        rows.extend(
            tracker
                .take_rows()
                .map(|r| (r.detection.frame, r.source, r.detection.azimuth_deg)),
        );
        events.extend(tracker.take_events());
        (rows, events)
    }

    #[test]
    fn two_talkers_taking_turns_keep_their_ids_and_outliers_are_dropped() {
        // A at 30 deg for 1 s, B at -60 deg for 1 s, A again after 2 s of silence; a
        // detection every other frame, and single outliers in the silences.
        let mut frames = vec![Vec::new(); 560];
        for (start, azimuth) in [(10, 30.0), (110, -60.0), (410, 31.0)] {
            for f in (start..start + 100).step_by(2) {
                frames[f] = vec![azimuth];
            }
        }
        for (f, azimuth) in [(250, 150.0), (300, -150.0), (350, 100.0)] {
            frames[f] = vec![azimuth];
        }
        let (rows, events) = track(&frames);
        // Every row of the talkers, none of the outliers, in frame order.
        assert_eq!(rows.len(), 150);
        assert!(rows.windows(2).all(|w| w[0].0 < w[1].0));
        assert!(rows.iter().all(|r| r.2 < 90.0));
        let ids: Vec<u64> = rows.iter().map(|r| r.1).collect();
        assert!(rows.iter().all(|r| (r.2 > 0.0) == (r.1 == 1)), "{ids:?}");
        assert!(rows.iter().any(|r| r.1 == 2));
        // Three stretches: A, B, A again with A's id.
        assert_eq!(events.len(), 3, "{events:?}");
        let e: Vec<(u64, u64)> = events.iter().map(|e| (e.source, e.detections)).collect();
        assert_eq!(e, vec![(1, 50), (2, 50), (1, 50)]);
        assert!((events[0].start_s - 0.10).abs() < 1e-9);
        assert!((events[0].end_s - 1.08).abs() < 1e-9);
        assert!(events.iter().all(|e| e.spread_deg < 1.0));
    }

    #[test]
    fn a_source_moving_at_60_degrees_a_second_is_one_track() {
        // 3 s at 60 deg/s, detected in 2 frames of 3.
        let frames: Vec<Vec<f64>> = (0..300)
            .map(|f| {
                if f % 3 == 2 {
                    Vec::new()
                } else {
                    vec![-90.0 + 60.0 * f as f64 * HOP]
                }
            })
            .collect();
        let (rows, events) = track(&frames);
        assert_eq!(rows.len(), 200);
        assert!(rows.iter().all(|r| r.1 == 1));
        assert_eq!(events.len(), 1);
        // The spread of a 180 deg sweep is large, and says so.
        assert!(events[0].spread_deg > 45.0, "{}", events[0].spread_deg);
    }

    #[test]
    fn two_sources_in_the_same_frames_get_one_row_each() {
        let frames: Vec<Vec<f64>> = (0..100).map(|_| vec![10.0, 70.0]).collect();
        let (rows, events) = track(&frames);
        assert_eq!(rows.len(), 200);
        for f in 0..100 {
            let here: Vec<_> = rows.iter().filter(|r| r.0 == f).collect();
            assert_eq!(here.len(), 2);
            assert_ne!(here[0].1, here[1].1);
        }
        assert_eq!(events.len(), 2);
    }

    #[test]
    fn scattered_detections_never_make_a_track() {
        // One detection every 0.2 s, each 47 deg round from the one before: no two
        // within a confirmation window are within the gate of each other.
        let frames: Vec<Vec<f64>> = (0..2000)
            .map(|f| {
                if f % 20 == 0 {
                    vec![(f as f64 / 20.0 * 47.0) % 360.0 - 180.0]
                } else {
                    Vec::new()
                }
            })
            .collect();
        let (rows, events) = track(&frames);
        assert!(rows.is_empty() && events.is_empty());
    }
}
