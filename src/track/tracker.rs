//! The tracker: association, confirmation, activity (see the module's documentation).

use super::candidate::{candidate_gate_deg, heard_alone, Candidate};
use super::clutter::Clutter;
use super::event::{turn_ended, Accumulator, Event};
use super::evidence::{self, Bursts, Evidence, Test, ACTIVE_S};
use super::faint::{self, FaintPlace, FaintPlaces};
use super::image::{
    in_vertical_plane, is_vertical_image, may_be_image_of, IMAGE_TALKING_S, LOOKED_S,
};
use super::motion::Track;
use super::output::{TrackStats, Tracked};
use super::smoother::Smoother;
use super::{ConfirmBy, TrackParams, MAX_TRACKS};
use crate::geometry::angle_between_deg;
use crate::geometry::{Geometry, Shape};
use crate::method::Detection;
use nalgebra::Vector3;
use std::collections::{HashMap, HashSet, VecDeque};

/// For a planar array, how much a difference in the angle out of its plane counts
/// against one in the plane when detections are associated: its elevation errs by 5-10
/// deg on real speech where its azimuth errs by 1 (docs/field.md).
pub(crate) const ELEVATION_WEIGHT: f64 = 0.25;

/// With [`ConfirmBy::Evidence`], a track's gate right after its last detection, in
/// candidates' gates: narrow, so that a source 10 deg from the last one after a pause
/// starts its own track, yet wide enough for the scatter of the track's own rows.
const GATE_IN_CANDIDATE_GATES: f64 = 1.5;

/// With [`ConfirmBy::Evidence`], how fast the gate of a track measured still widens
/// (degrees per second): a talker shifting in his seat. A track turning widens it by
/// half its speed more; one whose speed is not measured yet by
/// [`TrackParams::max_speed_deg_s`].
const STILL_DRIFT_DEG_S: f64 = 3.0;

/// With [`ConfirmBy::Evidence`], the most a still track's gate widens over a silence
/// (degrees): a talker who speaks again where he was heard is within his gate (his
/// rows' scatter and a shift in his seat), but a talker 12 deg from a silent one is
/// not that one (five talkers in turn, 12-20 deg apart: the silent neighbour's widened
/// gate took each new turn, and a person had several ids and an id several people).
const STILL_WANDER_DEG: f64 = 3.0;

/// With [`ConfirmBy::Evidence`] on a volumetric array, a candidate's gate for a
/// detection under the threshold widens as one over its margin, at most this many
/// times: a detection's delay error grows as its margin falls, and a weak talker beside
/// another on a 6.5 cm tetrahedron scattered over 22 deg, split among three candidates
/// of 8 deg none of which gathered the evidence (two talkers 30 deg apart: 38% of
/// windows, 70% widened). Not on planar arrays, whose candidates are compared mostly in
/// azimuth: the 6-mic circle's two talkers 60 deg apart lost a talker to a third track
/// (72% -> 52%).
const WEAK_WIDENING: f64 = 1.5;

/// A candidate heard in the same frames as a track in this share of its frames or more
/// is another source than that track, however close (see [`Tracker::confirm`]):
/// one source gives two detections in a frame only when they are more than
/// `frame_sources::SEPARATION_DEG` apart, which its scatter rarely reaches.
const TOGETHER_SHARE: f64 = 0.1;

/// A track silent for a turn's gap ([`turn_ended`]) takes a detection only if it scores
/// at least this share of its frame's strongest: a weaker one beside it, in a frame
/// another source dominates, is that source's stray (five talkers in turn: a further
/// source of the next talker's frame, at the silent one's elevation and 2-4 deg from
/// him, scoring 0.4 of the talker, ran the silent one's event on into the next turn).
/// It goes to a candidate, which needs the evidence. (At 1, two talkers at once on
/// the 5.7 cm tetrahedron lost 2 of 150 windows.)
const STRAY_SHARE: f64 = 0.5;

/// A track heard again after a turn's gap of silence ([`turn_ended`]) within this long
/// (seconds) of the first detection of another source that then takes the floor, and
/// since then heard on its own once at most ([`Track::resumed_at_onset`]), was hearing
/// that source's onset at its own place: its resumption is undone. Five talkers 12-20
/// deg apart in turn on the prism at 16 kHz (`benches/words.py --only turns5`): a lone
/// detection at the silent talker's place 8-32 ms before or 16 ms after the next
/// talker's first ran his event into the next turn in 3 of 334 turns. (Two talkers at
/// once on a 6-mic circle: one heard twice in the 50 ms before the other's first
/// detection lost 6 rows when that was undone too.)
const ONSET_S: f64 = 0.05;

/// The defaults a tracker assumes before it is told the recording's looks
/// ([`Tracker::looking`]): 6 hops of 512 samples at 48 kHz, candidates down to 0.4,
/// the accumulated look down to 0.25.
const DEFAULT_LOOK_S: f64 = 0.064;
const DEFAULT_FLOOR: f64 = 0.4;
const DEFAULT_LOOK_FLOOR: f64 = 0.25;

#[derive(Clone, Copy)]
enum Slot {
    Track(u64),
    /// A candidate's key and the row's number (0 until [`Tracker::join`] numbers the
    /// row: pairings and joins name the candidate only).
    Candidate(u64, u64),
    /// A track's id and the row's number: a row of a track heard again after a turn's
    /// gap of silence, until the resumption is kept or undone ([`ONSET_S`]).
    Held(u64, u64),
    /// A detection that joins nothing and starts nothing (kept only to be given out
    /// unconfirmed).
    Dropped,
}

/// Follows detections over time (see the [`track`](super) module).
pub struct Tracker {
    params: TrackParams,
    /// A candidate's gate (degrees): [`TrackParams::candidate_gate_deg`], or wider for
    /// an array whose directions scatter more ([`Tracker::for_array`]).
    candidate_gate: f64,
    /// A planar array's normal: its detections are compared mostly in the plane.
    plane: Option<Vector3<f64>>,
    tracks: Vec<Track>,
    candidates: Vec<Candidate>,
    /// The accumulated looks' detections of the last [`LOOKED_S`] (time, direction).
    looked: VecDeque<(f64, Vector3<f64>)>,
    /// Rows not yet given out, in frame order, with what they joined.
    waiting: VecDeque<(Detection, Slot)>,
    /// The frame last given out (its time's bits) and the sources of its rows
    /// ([`Tracker::frames_of`]).
    given: (u64, Vec<u64>),
    /// The fate of waiting candidates' rows, by row number: their track's id, or `None`
    /// (dropped).
    resolved: HashMap<u64, Option<u64>>,
    next_id: u64,
    next_key: u64,
    next_row: u64,
    /// The rows held for tracks whose resumption is not yet kept or undone: (track id,
    /// row number).
    held: Vec<(u64, u64)>,
    /// Rows given out, their directions smoothed over their track's.
    smoother: Smoother,
    ready: Vec<Tracked>,
    events: Vec<Event>,
    stats: TrackStats,
    /// Where candidates dropped unconfirmed were heard.
    faint: FaintPlaces,
    /// Per frame, reused: candidate pairings, detections placed, tracks and candidates
    /// taken (`true` for a track, then its id or key).
    pairs: Vec<(f64, usize, Slot)>,
    used: Vec<Option<Slot>>,
    taken: Vec<(bool, u64)>,
    /// With [`ConfirmBy::Evidence`]: the test's parameters, where clutter comes from,
    /// and how far a direction moves per sample of delay error (degrees; 0 unknown).
    evidence: Evidence,
    clutter: Clutter,
    spread_deg: f64,
    /// Whether the array is volumetric (see [`WEAK_WIDENING`] and [`Tracker::confirm`]).
    volumetric: bool,
    /// The tracks' own detections of the last [`ACTIVE_S`]: (track id, time), for
    /// [`Tracker::muted`].
    joins: VecDeque<(u64, f64)>,
    /// Until then (seconds) candidates under the threshold tell nothing (see
    /// [`Tracker::looking`]).
    warmup_s: f64,
}

/// What a frame tells each of its detections: whether it was heard alone
/// ([`TrackParams::alone_s`]) and its strongest detection's score.
#[derive(Clone, Copy)]
struct Frame {
    alone: bool,
    strongest: f64,
}

/// Whether track `t` is talking at `now`: in a stretch of activity and heard within
/// [`ACTIVE_S`].
fn talks(t: &Track, now: f64) -> bool {
    t.event.is_some() && now - t.last_s <= ACTIVE_S
}

/// The angle between `a` and `b` for association (degrees): see [`Tracker::distance`].
fn distance(plane: Option<Vector3<f64>>, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let Some(n) = plane else {
        return angle_between_deg(a, b);
    };
    let (pa, pb) = (a - n * n.dot(a), b - n * n.dot(b));
    let (ea, eb) = (n.dot(a).clamp(-1.0, 1.0), n.dot(b).clamp(-1.0, 1.0));
    let in_plane = if pa.norm() > 1e-9 && pb.norm() > 1e-9 {
        angle_between_deg(&pa, &pb)
    } else {
        0.0
    };
    let out = (ea.asin() - eb.asin()).to_degrees() * ELEVATION_WEIGHT;
    in_plane.hypot(out)
}

impl Tracker {
    /// A tracker for one recording (parameters checked by [`TrackParams::check`]).
    pub fn new(params: TrackParams) -> Self {
        let params_false_per_hour = params.false_per_hour;
        Tracker {
            candidate_gate: params.candidate_gate_deg,
            smoother: Smoother::new(params.smooth_s),
            params,
            plane: None,
            tracks: Vec::new(),
            candidates: Vec::new(),
            waiting: VecDeque::new(),
            given: (f64::NAN.to_bits(), Vec::new()),
            resolved: HashMap::new(),
            next_id: 1,
            next_key: 0,
            next_row: 0,
            held: Vec::new(),
            ready: Vec::new(),
            events: Vec::new(),
            stats: TrackStats::default(),
            faint: FaintPlaces::default(),
            pairs: Vec::new(),
            used: Vec::new(),
            taken: Vec::new(),
            joins: VecDeque::new(),
            evidence: Evidence::new(
                DEFAULT_LOOK_S,
                DEFAULT_FLOOR,
                DEFAULT_LOOK_FLOOR,
                params_false_per_hour,
            ),
            clutter: Clutter::default(),
            looked: VecDeque::new(),
            spread_deg: 0.0,
            volumetric: false,
            warmup_s: 0.0,
        }
    }

    /// Tells the tracker the recording's looks: each averaged correlation spans
    /// `look_s` seconds, candidates are reported down to `floor` times the threshold
    /// and the accumulated look's down to `look_floor` times its own (see `evidence`),
    /// and the method has begun removing the steady background
    /// after `warmup_s` seconds (0: from the start, or never): until then a candidate
    /// under the threshold may be that background (a fan beside the array), and tells
    /// nothing.
    pub fn with_evidence_window(
        mut self,
        look_s: f64,
        floor: f64,
        look_floor: f64,
        warmup_s: f64,
    ) -> Self {
        self.evidence = Evidence::new(look_s, floor, look_floor, self.params.false_per_hour);
        self.warmup_s = warmup_s;
        self
    }

    /// A tracker for an array of `shape`: a planar array's detections are compared
    /// mostly by their direction in its plane, since their angle out of it is known
    /// only roughly (see `ELEVATION_WEIGHT`).
    pub fn for_shape(params: TrackParams, shape: &Shape) -> Self {
        let mut tracker = Tracker::new(params);
        if let Shape::Planar { normal } = shape {
            tracker.plane = Some(*normal);
        }
        tracker
    }

    /// A tracker for `geometry` at `rate` Hz and `speed` m/s: as [`Tracker::for_shape`],
    /// with a candidate's gate at least [`TrackParams::candidate_gate_samples`] times
    /// how far a direction moves per sample of delay error
    /// ([`Geometry::direction_spread_deg`]): a small array's directions scatter more.
    pub fn for_array(params: TrackParams, geometry: &Geometry, rate: f64, speed: f64) -> Self {
        let mut tracker = Tracker::for_shape(params, &geometry.shape);
        tracker.candidate_gate = candidate_gate_deg(&tracker.params, geometry, rate, speed);
        tracker.spread_deg = geometry.direction_spread_deg(rate, speed);
        tracker.volumetric = matches!(geometry.shape, Shape::Volumetric);
        tracker
    }

    /// How far apart two directions are for association (degrees): the angle between
    /// them, or for a planar array the angle between their projections on its plane
    /// combined with `ELEVATION_WEIGHT` times the difference of their angles out of it.
    fn distance(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
        distance(self.plane, a, b)
    }

    /// The fastest a track's direction is predicted to move (radians per second): twice
    /// [`TrackParams::max_speed_deg_s`].
    fn max_speed(&self) -> f64 {
        2.0 * self.params.max_speed_deg_s.to_radians()
    }

    /// The gate around a direction last confirmed `since` seconds ago, turning at
    /// `speed` degrees per second (`None`: not measured yet).
    fn gate(&self, speed: Option<f64>, since: f64) -> f64 {
        let p = &self.params;
        let (base, growth) = match p.confirm_by {
            ConfirmBy::Rules => (p.gate_deg, p.max_speed_deg_s),
            ConfirmBy::Evidence => (
                GATE_IN_CANDIDATE_GATES * self.candidate_gate,
                speed.map_or(p.max_speed_deg_s, |v| STILL_DRIFT_DEG_S + v / 2.0),
            ),
        };
        let widest = match (p.confirm_by, speed) {
            (ConfirmBy::Evidence, Some(0.0)) => base + STILL_WANDER_DEG,
            _ => p.max_gate_deg,
        };
        (base + growth * since.max(0.0))
            .min(widest)
            .min(p.max_gate_deg)
    }

    /// How far `u` is from track `t` at `now`: from where it is predicted, or from where
    /// it was last heard when that is nearer (a still talker's directions on a small
    /// planar array wander by 5 deg over a second, which reads as a turn of 10-15 deg/s
    /// that predicts him away from his next words).
    fn off_track(&self, u: &Vector3<f64>, t: &Track, now: f64) -> f64 {
        self.distance(u, &t.predicted(now))
            .min(self.distance(u, &t.direction))
    }

    /// A track's gate at `now`.
    fn track_gate(&self, t: &Track, now: f64) -> f64 {
        self.gate(t.speed_deg_s(), now - t.last_s)
    }

    /// How much wider a candidate's gate is for detection `d` (see [`WEAK_WIDENING`]).
    fn weak_widening(&self, d: &Detection) -> f64 {
        if self.params.confirm_by != ConfirmBy::Evidence || !self.volumetric || d.margin >= 1.0 {
            return 1.0;
        }
        (1.0 / d.margin.max(1e-3)).min(WEAK_WIDENING)
    }

    /// How far a talking track's strays reach (degrees; see [`evidence::REACH_SAMPLES`]):
    /// at least a track's gate right after a detection.
    fn reach(&self) -> f64 {
        (evidence::REACH_SAMPLES * self.spread_deg)
            .min(evidence::MAX_REACH_DEG)
            .max(self.gate(Some(0.0), 0.0))
    }

    /// Whether any track is talking (see [`talks`]).
    fn talking(&self, now: f64) -> bool {
        self.tracks.iter().any(|t| talks(t, now))
    }

    /// Whether candidate `c`, heard at `direction` (with `pending` detections of this
    /// frame not yet in it), tells nothing at `now`: a talking track (see [`talks`]) is
    /// within reach of `direction` or in its vertical plane (its floor and ceiling
    /// images, [`in_vertical_plane`]), and `c` did not outhear it. To outhear a track,
    /// `c` was heard over the last [`ACTIVE_S`] at least [`evidence::OWN_HITS`] times
    /// and [`evidence::OWN_RATIO`] times as often as the track's own detections (not
    /// what rode it): a talker's strays are rarer than his own detections, and a run
    /// that outnumbers them is a source of its own, whose evidence counts.
    fn muted(&self, c: &Candidate, direction: &Vector3<f64>, now: f64, pending: usize) -> bool {
        let since = now - ACTIVE_S;
        let mine = || c.hits.iter().filter(|(_, d)| d.time_s > since).count() + pending;
        let reach = self.reach();
        self.tracks.iter().filter(|t| talks(t, now)).any(|t| {
            let at = t.predicted(now);
            let beside =
                self.distance(direction, &at) <= reach || in_vertical_plane(direction, &at);
            beside && {
                let mine = mine();
                let theirs = self
                    .joins
                    .iter()
                    .filter(|&&(id, at_s)| id == t.id && at_s > since);
                mine < evidence::OWN_HITS
                    || (mine as f64) < evidence::OWN_RATIO * theirs.count() as f64
            }
        })
    }

    /// Takes the detections of the frame at `time_s` (frames in order; none is fine: time
    /// still passes). Rows and events that are complete become available through
    /// [`Tracker::take_rows`] and [`Tracker::take_events`].
    pub fn push(&mut self, time_s: f64, detections: &[Detection]) {
        self.advance(time_s);
        let frame = Frame {
            alone: heard_alone(detections, &self.tracks, time_s, self.params.alone_s),
            strongest: detections
                .iter()
                .filter(|d| !d.rider)
                .map(|d| d.score)
                .fold(0.0, f64::max),
        };
        // Where each detection's row goes, and the tracks and candidates already joined.
        let mut used = std::mem::take(&mut self.used);
        used.clear();
        used.resize(detections.len(), None);
        let mut taken = std::mem::take(&mut self.taken);
        taken.clear();
        self.associate(time_s, detections, frame, &mut used, &mut taken);
        self.ride(time_s, detections, &mut used, &mut taken);
        self.start(time_s, detections, frame, &mut used);
        self.looked.extend(
            detections
                .iter()
                .filter(|d| d.accumulated)
                .map(|d| (d.time_s, d.direction)),
        );
        while self
            .looked
            .front()
            .is_some_and(|&(at_s, _)| time_s - at_s > LOOKED_S)
        {
            self.looked.pop_front();
        }
        self.heard_together(detections, &used, &taken);
        self.taken = taken;
        // Rows wait in the frame's order of its detections.
        for (d, slot) in detections.iter().zip(&used) {
            if let Some(slot) = *slot {
                self.waiting.push_back((*d, slot));
            }
        }
        self.used = used;
        self.release();
        // Rows still to come: the waiting ones, then later frames'.
        let from_s = self
            .waiting
            .front()
            .map_or(time_s + 1e-9, |(d, _)| d.time_s);
        self.smoother.settle(from_s, &mut self.ready);
    }

    /// Joins the frame's detections (not its riders) to the tracks and candidates
    /// within their gates, nearest pairs first, one detection to each.
    fn associate(
        &mut self,
        time_s: f64,
        detections: &[Detection],
        frame: Frame,
        used: &mut [Option<Slot>],
        taken: &mut Vec<(bool, u64)>,
    ) {
        // Nearest first: every (detection, track or candidate) within its gate.
        let mut pairs = std::mem::take(&mut self.pairs);
        pairs.clear();
        for (i, d) in detections.iter().enumerate().filter(|(_, d)| !d.rider) {
            // A candidate (under the threshold) joins only what is close and recent.
            let gate = |speed: Option<f64>, since: f64| {
                if d.margin >= 1.0 {
                    self.gate(speed, since)
                } else {
                    self.candidate_gate
                }
            };
            // A track silent for a turn's gap takes no detection that another source
            // dominates in its frame (that source's stray).
            let stray = d.score < STRAY_SHARE * frame.strongest;
            for t in self
                .tracks
                .iter()
                .filter(|t| t.event.is_some() && !(stray && turn_ended(t.last_s, time_s)))
            {
                let angle = self.off_track(&d.direction, t, time_s);
                if angle <= gate(t.speed_deg_s(), time_s - t.last_s) {
                    pairs.push((angle, i, Slot::Track(t.id)));
                }
            }
            let widen = self.weak_widening(d);
            // A source heard before at the detection's place explains it better than a
            // candidate farther away, but the candidate that took that source's evidence.
            let known = self.silent_at(&d.direction);
            for c in &self.candidates {
                let angle = self.distance(&d.direction, &c.direction);
                let explained = known.is_some_and(|(t, k)| k <= angle && c.place != Some(t.id));
                if angle <= gate(None, time_s - c.last_s) * widen && !explained {
                    pairs.push((angle, i, Slot::Candidate(c.key, 0)));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, i, slot) in &pairs {
            let key = match slot {
                Slot::Track(id) => (true, id),
                Slot::Candidate(k, _) => (false, k),
                // Never paired: placed only after association.
                Slot::Dropped | Slot::Held(..) => continue,
            };
            if used[i].is_some() || taken.contains(&key) {
                continue;
            }
            used[i] = Some(self.join(&detections[i], slot, frame));
            taken.push(key);
        }
        self.pairs = pairs;
    }

    /// Riders: rows of the tracks in a stretch of activity near them that the frame's
    /// other detections left, nearest first; the tracks themselves are left as they were.
    /// With the evidence, a detection under the threshold that nothing took rides a
    /// track that talks (heard within a turn's gap) when it lies within
    /// the track's gate and its scatter (its stretch's cone on a volumetric array, its
    /// reach on another): that track's outlier, which would start nothing. On a small
    /// array a talker's detections scatter past a candidate's gate (two at once on a
    /// 5.7 cm tetrahedron and a 6-mic circle, `benches/together.py`: 1-3 more windows
    /// in a hundred); on the prism its cone holds nothing past that gate.
    fn ride(
        &mut self,
        time_s: f64,
        detections: &[Detection],
        used: &mut [Option<Slot>],
        taken: &mut Vec<(bool, u64)>,
    ) {
        let mut pairs = std::mem::take(&mut self.pairs);
        pairs.clear();
        let by_evidence = self.params.confirm_by == ConfirmBy::Evidence;
        for (i, d) in detections
            .iter()
            .enumerate()
            .filter(|&(i, d)| d.rider || by_evidence && d.margin < 1.0 && used[i].is_none())
        {
            for t in self.tracks.iter().filter(|t| t.event.is_some()) {
                let angle = self.off_track(&d.direction, t, time_s);
                let gate = if d.rider {
                    self.candidate_gate
                } else if turn_ended(t.last_s, time_s) {
                    continue;
                } else {
                    self.track_gate(t, time_s).min(self.scatter_deg(t))
                };
                if angle <= gate && !taken.contains(&(true, t.id)) {
                    pairs.push((angle, i, Slot::Track(t.id)));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for &(_, i, slot) in &pairs {
            let Slot::Track(id) = slot else { continue };
            if used[i].is_some() || taken.contains(&(true, id)) {
                continue;
            }
            // The track itself is left as it was: where it is, when it was last heard.
            let k = self.track_index(id);
            if !self.tracks[k].give(&detections[i]) {
                continue;
            }
            used[i] = Some(self.hold_if_resumed(k));
            taken.push((true, id));
        }
        self.pairs = pairs;
    }

    /// Notes, for each candidate that took one of the frame's detections (`used`), the
    /// tracks that took another of them beyond its reach (`taken`): two detections of
    /// one frame closer than that are the array's scatter of one source, not two heard
    /// together.
    fn heard_together(
        &mut self,
        detections: &[Detection],
        used: &[Option<Slot>],
        taken: &[(bool, u64)],
    ) {
        let reach = self.reach();
        for (i, slot) in used.iter().enumerate() {
            let Some(Slot::Candidate(key, _)) = *slot else {
                continue;
            };
            for &(_, id) in taken.iter().filter(|(track, _)| *track) {
                // The track's detections of this frame all beyond reach of the candidate's.
                let far = used.iter().zip(detections).all(|(s, d)| {
                    !matches!(s, Some(Slot::Track(t) | Slot::Held(t, _)) if *t == id)
                        || self.distance(&d.direction, &detections[i].direction) > reach
                });
                if !far {
                    continue;
                }
                let Some(c) = self.candidates.iter_mut().find(|c| c.key == key) else {
                    continue;
                };
                match c.together.iter_mut().find(|(t, _)| *t == id) {
                    Some((_, n)) => *n += 1,
                    None => c.together.push((id, 1)),
                }
            }
        }
    }

    /// The detections nothing took start candidates, unless they are riders or a live
    /// track's outliers.
    fn start(
        &mut self,
        time_s: f64,
        detections: &[Detection],
        frame: Frame,
        used: &mut [Option<Slot>],
    ) {
        for (d, placed) in detections.iter().zip(used.iter_mut()) {
            if placed.is_some() {
                continue;
            }
            // A rider that rides along nothing starts nothing; nor does a candidate near
            // a live track but not near enough to join it: that track's outlier (which
            // rides it when the track talks and it lies within the track's scatter). A
            // turning track silent for a turn's gap has no outliers: a walker's next
            // words come back under the threshold ahead of where it was heard, and
            // dropped, let a new track take him (a candidate there that is confirmed
            // takes the track up again, see [`Tracker::confirm`]).
            if d.rider
                || d.margin < 1.0
                    && self.tracks.iter().any(|t| {
                        let paused_turning = turn_ended(t.last_s, time_s)
                            && t.speed_deg_s().is_some_and(|v| v > 0.0);
                        t.event.is_some()
                            && !paused_turning
                            && self.off_track(&d.direction, t, time_s) <= self.track_gate(t, time_s)
                    })
            {
                if self.params.keep_unconfirmed {
                    *placed = Some(Slot::Dropped);
                } else {
                    self.stats.unconfirmed += 1;
                }
                if d.rider {
                    // Heard in its frame's own correlations: it tells where something
                    // faint may be (a talker too faint for the averaged ones).
                    let gate = self.faint_gate();
                    self.faint.add(FaintPlace::heard_once(d), gate);
                }
                continue;
            }
            let key = self.next_key;
            self.next_key += 1;
            let look = self.evidence.look(d.time_s);
            let (bursts, place) = self.place_of(&d.direction, look);
            self.candidates.push(Candidate {
                key,
                direction: d.direction,
                last_s: d.time_s,
                hits: VecDeque::new(),
                beside_talk: VecDeque::new(),
                accumulated: false,
                alone_s: f64::NEG_INFINITY,
                test: Test::new(look),
                bursts,
                place,
                heard: 0,
                first_s: d.time_s,
                best_nats: f64::NEG_INFINITY,
                together: Vec::new(),
            });
            *placed = Some(self.join(d, Slot::Candidate(key, 0), frame));
        }
    }

    /// Adds `d` to a track or a candidate (confirming the candidate when it has enough);
    /// returns the slot its row waits in (a candidate's with the row's number).
    /// `frame`: what its frame tells it.
    fn join(&mut self, d: &Detection, slot: Slot, frame: Frame) -> Slot {
        let (max_speed, plane) = (self.max_speed(), self.plane);
        match slot {
            Slot::Track(id) => {
                let heard =
                    (self.params.confirm_by == ConfirmBy::Evidence).then(|| self.track_hit_nats(d));
                let look = self.evidence.look(d.time_s);
                let e = self.evidence;
                let k = self.track_index(id);
                let t = &mut self.tracks[k];
                // Its frame gave it a row already (through a candidate confirmed in it).
                if !t.give(d) {
                    return Slot::Dropped;
                }
                if let Some(nats) = heard {
                    t.bursts.hit(look, Some(nats), &e);
                }
                t.update(d, max_speed, plane);
                if d.score >= frame.strongest {
                    t.led();
                }
                // Its own detections of the last `ACTIVE_S`, for `muted`.
                self.joins.push_back((id, d.time_s));
                let since = d.time_s - ACTIVE_S;
                while self.joins.front().is_some_and(|&(_, at_s)| at_s < since) {
                    self.joins.pop_front();
                }
                self.hold_if_resumed(k)
            }
            Slot::Dropped | Slot::Held(..) => slot,
            Slot::Candidate(key, _) => {
                let i = self
                    .candidates
                    .iter()
                    .position(|c| c.key == key)
                    .expect("an open candidate");
                let muted = self.muted(&self.candidates[i], &d.direction, d.time_s, 1);
                let weighed = (self.params.confirm_by == ConfirmBy::Evidence)
                    .then(|| self.hit_nats(d, frame, muted, &self.candidates[i]));
                let row = self.next_row;
                self.next_row += 1;
                // A source in bursts stays at its place: a detection farther from it
                // than a candidate's gate (a gate widened for a source that might be
                // moving) is as likely clutter as the area it was taken from is
                // larger, the square of the distance (see `Bursts`).
                let far = self.distance(&d.direction, &self.candidates[i].direction)
                    / self.candidate_gate.max(1e-9);
                let in_place = weighed.flatten().map(|n| n - 2.0 * far.max(1.0).ln());
                let busy = self.talking(d.time_s);
                let c = &mut self.candidates[i];
                c.hear(row, d, busy);
                if frame.alone {
                    c.alone_s = d.time_s;
                }
                let confirmed = match self.params.confirm_by {
                    ConfirmBy::Rules => c.confirmed(&self.params),
                    ConfirmBy::Evidence => {
                        let e = &self.evidence;
                        let look = e.look(d.time_s);
                        c.test.hit(look, weighed.flatten(), e);
                        c.bursts.hit(look, in_place, e);
                        c.best_nats = c.best_nats.max(c.test.total()).max(c.bursts.total());
                        let heard_alone = c.alone_s > f64::NEG_INFINITY;
                        c.test.total() >= e.confirm_nats || c.bursts.confirms(e, busy, heard_alone)
                    }
                };
                if confirmed {
                    let c = self.candidates.remove(i);
                    self.confirm(c);
                }
                Slot::Candidate(key, row)
            }
        }
    }

    /// What detection `d` of a candidate is worth (`evidence`), or `None` when a
    /// talking track heard beside it makes it tell nothing (`muted`, [`Tracker::muted`]).
    /// Its margin is the largest
    /// its frame gave it ([`Detection::peak_margin`]: a knock passes the threshold in
    /// its frame's own correlations, not in their average); one over the threshold
    /// weaker than its frame's strongest counts at that margin times its share of the
    /// strongest score: a loud sound's stray is not a second source's evidence.
    /// An accumulated look's is weighed by the accumulated looks' own law
    /// ([`Evidence::look_nats`]) when nothing else sounds: no track talking (`busy`), no
    /// silent track's place but candidate `c`'s heard again within [`ACTIVE_S`] (at a
    /// talker's onset the longer average named the silent talker before him, a false
    /// event in `benches/words.py --seed 900`), and it is not maybe the vertical image
    /// of another accumulated look heard within [`LOOKED_S`] ([`may_be_image_of`]: a
    /// faint talker's floor image, as loud as he is, became a source in scene 8111 of
    /// `benches/words.py --seed 8100`).
    fn hit_nats(&self, d: &Detection, frame: Frame, muted: bool, c: &Candidate) -> Option<f64> {
        let margin = d.peak_margin.max(d.margin);
        let busy = self.talking(d.time_s);
        if muted || margin < 1.0 && d.time_s < self.warmup_s {
            return None;
        }
        let m = if margin > 1.0 && frame.strongest > 0.0 {
            margin * (d.score / frame.strongest).min(1.0)
        } else {
            margin
        };
        let floor = if busy {
            evidence::BUSY_RATE_PER_S
        } else if margin >= 1.0 {
            evidence::QUIET_RATE_PER_S
        } else {
            evidence::CANDIDATE_RATE_PER_S
        };
        let own_law = d.accumulated
            && !busy
            && !self.candidates.iter().any(|o| {
                o.place.is_some() && o.place != c.place && d.time_s - o.last_s <= ACTIVE_S
            })
            && !self
                .looked
                .iter()
                .any(|(at_s, u)| d.time_s - at_s <= LOOKED_S && may_be_image_of(&d.direction, u));
        if own_law {
            // Not the clutter map's rate: the map learns where frames' clutter returns (a
            // fan's leaks), and the accumulated look skips the steady frames they come
            // from; its own clutter is measured in `LOOK_RATE_PER_S`.
            return Some(self.evidence.look_nats(m, evidence::LOOK_RATE_PER_S));
        }
        let rate = self.clutter.rate(&d.direction, d.time_s, floor);
        Some(self.evidence.hit_nats(m, rate))
    }

    /// A candidate becomes a track: the nearest track's when one is within its gate
    /// (a live track takes its detections; a silent one is taken up again), else a new
    /// one.
    fn confirm(&mut self, mut c: Candidate) {
        let now = c.last_s;
        // Detections before a silence longer than the confirmation window are not the
        // run that confirmed it: a stray there would start the event early. With the
        // evidence, only those heard while a track talked (`benches/words.py`
        // turns5-901: a stray at a silent talker's place during another's turn, kept
        // alive by its bursts, began the event of his own turn 0.9 s early).
        let by_evidence = self.params.confirm_by == ConfirmBy::Evidence;
        for row in c.strays(self.params.confirm_s, by_evidence) {
            self.resolved.insert(row, None);
        }
        // A talking track's floor or ceiling image starts nothing (see `image`): a track
        // heard within `IMAGE_TALKING_S`, whether its stretch of activity has ended or
        // not (with the evidence a short one ends after 0.3 s of silence).
        if self.tracks.iter().any(|t| {
            now - t.last_s <= IMAGE_TALKING_S
                && is_vertical_image(&c.direction, c.uncertainty_deg(), &t.predicted(now))
        }) {
            for (row, _) in &c.hits {
                self.resolved.insert(*row, None);
            }
            self.stats.reflections += c.hits.len() as u64;
            return;
        }
        // A track in a stretch of activity is the candidate's source, even beyond its
        // gate, when the two (the track where it is predicted or last heard, or its
        // detections' mean, against the candidate where it is or its detections' mean)
        // are closer than the array can tell apart, and the candidate was not heard in
        // the same frames as the track (two talkers at once, which the frames tell
        // apart):
        // - within reach (a sample and a half of delay, [`Tracker::reach`]), on any
        //   array: a low voice on the 6-mic circle at 16 kHz, heard 8-10 deg from his
        //   track in azimuth as his words went on, confirmed a second track beside it;
        // - within their cones combined, on a volumetric array: a talker on a 5.7 cm
        //   tetrahedron at 16 kHz scatters by 5-10 deg, and his words' detections 12-19
        //   deg from his track confirmed a second one beside it. Not on a planar array,
        //   whose cone is mostly its elevation's uncertainty, which association weighs
        //   little (two talkers 30 deg apart on the 6-mic circle at once were taken as
        //   one), nor on a linear one, whose cone holds the circle around its axis.
        //   The candidate's mean counts: a low voice's candidate heard for a second
        //   beside his track on the tetrahedron had drifted 29 deg from it by its last
        //   detections (toward the ceiling's image), its mean 6 deg.
        // A silent track on a volumetric array is the candidate's source within their
        // cones combined (its last stretch's and the candidate's), beyond its gate: a
        // source heard again where it was, within what the array tells apart (the same
        // place, the same source). The same low voice, heard again 15-16 deg from his
        // track (its gate 15 deg, cones 13-15), became a second source. A track within
        // its gate or talking beside the candidate comes first (a talker's second
        // track talking, his first silent: a stray 20 deg off, cone 27 deg, went to
        // the silent one and made an event of its own).
        let cone = c.uncertainty_deg();
        let reach = self.reach();
        let near = self
            .tracks
            .iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let angle = self.off_track(&c.direction, t, now);
                let in_gate = angle <= self.track_gate(t, now);
                let same = self
                    .beside_stretch(&c, t, now)
                    .is_some_and(|(angle, near, cone_t)| {
                        angle <= reach || self.volumetric && near <= cone_t.hypot(cone)
                    });
                let heard_again =
                    self.volumetric && t.event.is_none() && angle <= t.ended_cone_deg.hypot(cone);
                let rank = u8::from(!(in_gate || same));
                (in_gate || same || heard_again).then_some((i, angle, in_gate, rank))
            })
            .min_by(|a, b| a.3.cmp(&b.3).then(a.1.total_cmp(&b.1)))
            .map(|(i, angle, in_gate, _)| (i, angle, in_gate));
        // A candidate of a track heard again after a silence: the track is talking again.
        if let Some((i, _, _)) = near {
            self.settle_resumed(i, true);
        }
        // A candidate that began before its track's last stretch ended is of that
        // stretch (its detections were beyond the track's gate then, and the stretch
        // ended while it waited to be confirmed): one stretch, not two that overlap,
        // and one with a stretch the track opened since (the candidate bridges them).
        let reopened = near.is_some_and(|(i, _, _)| self.tracks[i].reopen(c.hits[0].1.time_s));
        let opens = !reopened && near.is_none_or(|(i, _, _)| self.tracks[i].event.is_none());
        // At most one row per source per frame (docs/interface.md): a candidate's
        // detection in a frame that already gave the track one (its scatter, heard in
        // the track's own frames) is dropped.
        let taken = near.map_or_else(HashSet::new, |(i, _, _)| self.frames_of(self.tracks[i].id));
        let id = match near {
            Some((i, _, in_gate)) => {
                let t = &mut self.tracks[i];
                for &(row, ref d) in &c.hits {
                    let given = !taken.contains(&d.time_s.to_bits()) && t.give(d);
                    self.resolved.insert(row, given.then_some(t.id));
                }
                // A track taken up where the candidate is heard; one whose scatter the
                // candidate was stays where it is.
                if in_gate && t.last_s <= c.last_s {
                    t.direction = c.direction;
                }
                t.last_s = t.last_s.max(c.last_s);
                t.bursts = c.bursts;
                let id = t.id;
                // Its own, whatever silence its detections came after.
                self.settle_resumed(i, true);
                id
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
                        let mut t = self.tracks.remove(oldest);
                        if let Some(e) = t.release_ended(f64::INFINITY, 0.0) {
                            self.events.push(e.finish(t.id));
                        }
                    }
                }
                let mut event = Accumulator::new(&c.hits[0].1);
                for (_, d) in c.hits.iter().skip(1) {
                    event.add(d);
                }
                self.tracks
                    .push(Track::new(id, c.direction, c.last_s, Some(event), c.bursts));
                for &(row, _) in &c.hits {
                    self.resolved.insert(row, Some(id));
                }
                id
            }
        };
        if opens && self.params.confirm_by == ConfirmBy::Evidence {
            self.take_the_floor(id, c.hits[0].1.time_s);
        }
    }

    /// Where candidate `c` stands to track `t` at `now`, if the track is in a stretch of
    /// activity and the candidate was heard in the same frames as it in under a tenth of
    /// its own (two talkers at once are heard together, a talker and his scatter are
    /// not): its distance from the track, the nearer of that and its detections' mean
    /// from the stretch's direction, and the stretch's cone (degrees).
    fn beside_stretch(&self, c: &Candidate, t: &Track, now: f64) -> Option<(f64, f64, f64)> {
        let e = t.event.as_ref()?;
        let together = c.together.iter().find(|(id, _)| *id == t.id);
        let together = together.map_or(0, |&(_, n)| n) as f64;
        if together >= TOGETHER_SHARE * c.heard as f64 {
            return None;
        }
        let angle = self.off_track(&c.direction, t, now);
        let mean = self
            .distance(&c.direction, &e.direction())
            .min(self.distance(&c.mean_direction(), &e.direction()));
        Some((angle, angle.min(mean), e.uncertainty_deg()))
    }

    /// Gives track `i` the rows of candidate `c`, its scatter, that fall within its
    /// stretch (from its start to its last detection): the track stays where it is,
    /// with its own evidence (the candidate's was muted beside it), and its stretch
    /// keeps the ends its own detections gave it (an event's path runs from its first
    /// detection to its last: a scatter row 11 deg off at a talker's onset made the
    /// event of a talker in the paper's room start there).
    fn give_scatter(&mut self, c: Candidate, i: usize) {
        let taken = self.frames_of(self.tracks[i].id);
        let t = &mut self.tracks[i];
        let (from, to) = (
            t.event.as_ref().map_or(f64::INFINITY, |e| e.start_s()),
            t.last_s,
        );
        for &(row, ref d) in &c.hits {
            let within = (from..=to).contains(&d.time_s) && !taken.contains(&d.time_s.to_bits());
            let given = within && t.give(d);
            self.resolved.insert(row, given.then_some(t.id));
        }
    }

    /// The frames (their times' bits) that gave source `id` a row a candidate's
    /// detections may share: the rows still waiting and the frame last given out
    /// (rows wait in order behind a candidate's first, so only its frame can have
    /// given out a row of `id` before it). The frame being taken in is
    /// [`Track::give`]'s to check.
    fn frames_of(&self, id: u64) -> HashSet<u64> {
        let (frame, sources) = &self.given;
        self.waiting
            .iter()
            .filter(|(_, slot)| match *slot {
                Slot::Track(t) => t == id,
                Slot::Candidate(_, row) => self.resolved.get(&row) == Some(&Some(id)),
                Slot::Held(t, row) => t == id && self.resolved.get(&row) != Some(&None),
                Slot::Dropped => false,
            })
            .map(|(d, _)| d.time_s.to_bits())
            .chain(sources.contains(&id).then_some(*frame))
            .collect()
    }

    /// Source `id` starts a stretch of activity at `start_s`: the stretches of the
    /// tracks that fell silent before it began end there (a turn ends when another
    /// source takes the floor).
    ///
    /// A track heard again (after a turn's gap of silence) within [`ONSET_S`] of that
    /// start was hearing the new source's onset: its resumption is undone first.
    fn take_the_floor(&mut self, id: u64, start_s: f64) {
        for i in 0..self.tracks.len() {
            let t = &self.tracks[i];
            if t.id == id {
                continue;
            }
            if t.resumed_s().is_some() {
                let onset = t.resumed_at_onset(start_s, ONSET_S);
                self.settle_resumed(i, !onset);
            }
            let t = &mut self.tracks[i];
            if t.event.is_some() && turn_ended(t.last_s, start_s) {
                if let Some(e) = t.end_stretch() {
                    self.events.push(e.finish(t.id));
                }
            }
        }
    }

    /// Keeps (`keep`) or undoes track `i`'s resumption ([`Track::resumed_s`]) and gives
    /// its held rows their fate.
    fn settle_resumed(&mut self, i: usize, keep: bool) {
        let t = &mut self.tracks[i];
        if t.resumed_s().is_none() {
            return;
        }
        if keep {
            t.keep_resumed();
        } else {
            t.undo_resumed();
        }
        let id = t.id;
        for &(track, row) in &self.held {
            if track == id {
                self.resolved.insert(row, keep.then_some(id));
            }
        }
        self.held.retain(|&(track, _)| track != id);
    }

    /// Where live track `id` is in the tracker's list.
    fn track_index(&self, id: u64) -> usize {
        self.tracks
            .iter()
            .position(|t| t.id == id)
            .expect("a live track")
    }

    /// The slot of a row just given to track `i`: its own, or held (numbered) while the
    /// track's resumption is neither kept nor undone. Only the evidence's turns undo
    /// one: by the rules it is kept at once.
    fn hold_if_resumed(&mut self, i: usize) -> Slot {
        let id = self.tracks[i].id;
        if self.params.confirm_by == ConfirmBy::Rules {
            self.settle_resumed(i, true);
        }
        if self.tracks[i].resumed_s().is_none() {
            return Slot::Track(id);
        }
        let row = self.next_row;
        self.next_row += 1;
        self.held.push((id, row));
        Slot::Held(id, row)
    }

    /// Time passes to `now`: a candidate's detections older than the tracker's delay
    /// are dropped (and the candidate with its last), stretches of activity that
    /// have been silent long enough end, silent tracks are forgotten.
    fn advance(&mut self, now: f64) {
        let p = &self.params;
        let (delay_s, end_s, forget_s) = (p.delay(), p.end_s, p.forget_s);
        let by_evidence = p.confirm_by == ConfirmBy::Evidence;
        if by_evidence {
            self.give_expiring_scatter(now, delay_s);
        }
        for c in &mut self.candidates {
            while c
                .hits
                .front()
                .is_some_and(|(_, d)| now - d.time_s >= delay_s - 1e-9)
            {
                let (row, _) = c.hits.pop_front().expect("checked");
                self.resolved.insert(row, None);
            }
        }
        for i in (0..self.candidates.len()).rev() {
            if !self.candidates[i].hits.is_empty() {
                continue;
            }
            let c = self.candidates.remove(i);
            self.unconfirmed_at(&c);
        }
        if by_evidence {
            self.weigh(now);
        }
        let by_length = self.params.confirm_by == ConfirmBy::Evidence;
        let ends = |t: &Track| match &t.event {
            Some(e) => super::event::ends_after(t.last_s - e.start_s(), end_s, by_length),
            None => end_s,
        };
        // A resumption is kept once no candidate that began within its onset window is
        // still open to take the floor, or when its stretch ends.
        for i in 0..self.tracks.len() {
            let t = &self.tracks[i];
            let Some(at_s) = t.resumed_s() else {
                continue;
            };
            let pending = self.candidates.iter().any(|c| {
                c.hits
                    .front()
                    .is_some_and(|(_, d)| (d.time_s - at_s).abs() <= ONSET_S)
            });
            if !pending && now - at_s > ONSET_S || now - t.last_s > ends(t) {
                self.settle_resumed(i, true);
            }
        }
        for t in &mut self.tracks {
            let end_s = ends(t);
            if t.event.is_some() && now - t.last_s > end_s {
                if let Some(e) = t.end_stretch() {
                    self.events.push(e.finish(t.id));
                }
            }
            if let Some(e) = t.release_ended(now, delay_s) {
                self.events.push(e.finish(t.id));
            }
        }
        self.tracks
            .retain(|t| t.event.is_some() || t.holds_ended() || now - t.last_s <= forget_s);
    }

    /// A candidate about to lose a detection to the delay, that is one stretch's
    /// scatter (within the stretch's own cone on a volumetric array, within reach on
    /// another, whose cones are mostly their elevation's; not heard with it), gives that
    /// stretch its rows: its evidence was muted beside the stretch, so it could never
    /// be confirmed into it. Within two stretches' it is neither's (two talkers 30 deg
    /// apart at once on a 6.5 cm tetrahedron: the second's rows erred by 4.7 deg
    /// instead of 2.4 when it went to the nearer).
    fn give_expiring_scatter(&mut self, now: f64, delay_s: f64) {
        for i in (0..self.candidates.len()).rev() {
            let c = &self.candidates[i];
            let expires = c
                .hits
                .front()
                .is_some_and(|(_, d)| now - d.time_s >= delay_s - 1e-9);
            if !expires {
                continue;
            }
            let mut stretches = (0..self.tracks.len()).filter(|&k| {
                let t = &self.tracks[k];
                self.beside_stretch(c, t, c.last_s)
                    .is_some_and(|(angle, near, _)| {
                        (if self.volumetric { near } else { angle }) <= self.scatter_deg(t)
                    })
            });
            // (Not to a track whose resumption is still to be settled: its rows since
            // are what decides it.)
            let (Some(k), None) = (stretches.next(), stretches.next()) else {
                continue;
            };
            if self.tracks[k].resumed_s().is_none() {
                let c = self.candidates.remove(i);
                self.give_scatter(c, k);
            }
        }
    }

    /// How far track `t`'s scatter reaches (degrees): its stretch's cone on a volumetric
    /// array, a sample and a half of delay ([`Tracker::reach`]) on another, whose cones
    /// are mostly their elevation's.
    fn scatter_deg(&self, t: &Track) -> f64 {
        match &t.event {
            Some(e) if self.volumetric => e.uncertainty_deg(),
            _ => self.reach(),
        }
    }

    /// What a track's own detection `d` adds to its evidence as bursts: as a
    /// candidate's ([`Tracker::hit_nats`]) with no track beside it.
    fn track_hit_nats(&self, d: &Detection) -> f64 {
        let margin = d.peak_margin.max(d.margin);
        let floor = if margin >= 1.0 {
            evidence::QUIET_RATE_PER_S
        } else {
            evidence::CANDIDATE_RATE_PER_S
        };
        let rate = self.clutter.rate(&d.direction, d.time_s, floor);
        self.evidence.hit_nats(margin, rate)
    }

    /// The nearest silent track within a still track's gate of where it was last heard
    /// (a source heard at `direction` before), with its distance (degrees).
    fn silent_at(&self, direction: &Vector3<f64>) -> Option<(&Track, f64)> {
        let place = self.gate(Some(0.0), 0.0);
        self.tracks
            .iter()
            .filter(|t| t.event.is_none())
            .map(|t| (t, self.distance(direction, &t.direction)))
            .filter(|&(_, angle)| angle <= place)
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// The evidence as bursts a candidate starting at `direction` in look `look` takes
    /// on, with the track it takes it from: that of the silent track at its place
    /// ([`Tracker::silent_at`]), else none.
    fn place_of(&self, direction: &Vector3<f64>, look: i64) -> (Bursts, Option<u64>) {
        match self.silent_at(direction) {
            Some((t, _)) => {
                let mut b = t.bursts;
                b.close_to(look, &self.evidence, false);
                (b, Some(t.id))
            }
            None => (Bursts::new(look), None),
        }
    }

    /// With [`ConfirmBy::Evidence`], time passes to `now` for every candidate's test:
    /// looks gone by without a detection count against it (but those in which a track
    /// was heard beside it), and a candidate whose evidence falls to
    /// [`evidence::REJECT_NATS`] is clutter: its rows are dropped, and the clutter map
    /// learns its place. One an accumulated look has heard falls only once its
    /// evidence as a source heard in bursts ([`Bursts`]) falls there too: a faint
    /// talker's first word gave 8.9 of the 9.2 nats, the pause after it rejected him as
    /// a source heard throughout ([`Test`]) while as one heard in bursts he still stood
    /// at 8.7, and his next word started from nothing (scene 7106 of `benches/words.py
    /// --seed 7100 --only hard`; kept alive, scene 8108's talker is found in 8 words of
    /// 8 instead of 5). Not one the frames alone heard: a fan 0.9 m from the prism
    /// leaks from one place every second or so, a source in bursts to that evidence,
    /// and kept alive its leaks made 7-8 false events a minute in the tracking
    /// benchmark, where the clutter map learns the place from each rejected candidate
    /// (the accumulated look skips the fan's steady frames:
    /// [`evidence::LOOK_RATE_PER_S`]).
    fn weigh(&mut self, now: f64) {
        self.clutter.observe(now);
        let look = self.evidence.look(now);
        let e = self.evidence;
        for t in &mut self.tracks {
            t.bursts.close_to(look, &e, false);
        }
        let mut i = 0;
        while i < self.candidates.len() {
            let c = &self.candidates[i];
            let near = self.muted(c, &c.direction, now, 0) || now < self.warmup_s;
            let c = &mut self.candidates[i];
            c.test.close_to(look, &e, near);
            c.bursts.close_to(look, &e, near);
            if near {
                c.test.mute();
                c.bursts.mute();
            }
            if c.test.rejected() && (!c.accumulated || c.bursts.rejected()) {
                let c = self.candidates.remove(i);
                self.clutter.learn(&c.direction, c.test.hit_looks, now);
                self.unconfirmed_at(&c);
                for (row, _) in c.hits {
                    self.resolved.insert(row, None);
                }
                continue;
            }
            i += 1;
        }
    }

    /// Gives out the waiting rows whose fate is known, in order (those no track
    /// confirmed only with [`TrackParams::keep_unconfirmed`]).
    fn release(&mut self) {
        while let Some((_, slot)) = self.waiting.front() {
            let source = match *slot {
                Slot::Track(id) => Some(id),
                Slot::Dropped => None,
                Slot::Candidate(_, row) | Slot::Held(_, row) => {
                    let Some(id) = self.resolved.remove(&row) else {
                        break;
                    };
                    id
                }
            };
            let (detection, _) = self.waiting.pop_front().expect("a front");
            let frame = detection.time_s.to_bits();
            if self.given.0 != frame {
                self.given.0 = frame;
                self.given.1.clear();
            }
            if let Some(id) = source {
                debug_assert!(!self.given.1.contains(&id), "two rows of {id} in a frame");
                self.given.1.push(id);
            }
            match source {
                Some(_) => self.stats.rows += 1,
                None => self.stats.unconfirmed += 1,
            }
            if source.is_some() || self.params.keep_unconfirmed {
                self.smoother
                    .push(Tracked { detection, source }, &mut self.ready);
            }
        }
    }

    /// The end of the recording: open candidates are dropped, every stretch of activity
    /// ends, and every row still waiting is given out or dropped.
    pub fn finish(&mut self) {
        for i in 0..self.tracks.len() {
            self.settle_resumed(i, true);
        }
        debug_assert!(self.held.is_empty(), "rows held for no track");
        for c in std::mem::take(&mut self.candidates) {
            self.unconfirmed_at(&c);
            for (row, _) in c.hits {
                self.resolved.insert(row, None);
            }
        }
        let mut ending: Vec<Event> = Vec::new();
        for t in &mut self.tracks {
            let open = t.event.take();
            let held = t.release_ended(f64::INFINITY, 0.0);
            ending.extend(held.into_iter().chain(open).map(|e| e.finish(t.id)));
        }
        ending.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
        self.events.extend(ending);
        self.release();
        self.smoother.finish(&mut self.ready);
    }

    /// What the tracker has made of the detections so far (complete after
    /// [`Tracker::finish`]).
    pub fn stats(&self) -> TrackStats {
        TrackStats {
            tracks: self.next_id - 1,
            faint: self.faint.most(),
            ..self.stats
        }
    }

    /// Candidate `c` is dropped unconfirmed: its detections count for its place.
    fn unconfirmed_at(&mut self, c: &Candidate) {
        let needed =
            (self.params.confirm_by == ConfirmBy::Evidence).then_some(self.evidence.confirm_nats);
        let gate = self.faint_gate();
        self.faint.add(c.as_place(needed), gate);
    }

    /// How far apart (degrees) detections are still of one faint place.
    fn faint_gate(&self) -> f64 {
        faint::PLACE_GATES * self.gate(Some(0.0), 0.0)
    }

    /// The rows given out since the last call, in frame order.
    pub fn take_rows(&mut self) -> std::vec::Drain<'_, Tracked> {
        self.ready.drain(..)
    }

    /// The events completed since the last call: each is given out once no candidate
    /// still waiting can continue it (the tracker's delay after its end).
    pub fn take_events(&mut self) -> std::vec::Drain<'_, Event> {
        self.events.drain(..)
    }
}

#[cfg(test)]
#[path = "tracker_tests.rs"]
mod tests;
