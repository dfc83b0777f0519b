//! A track's direction over time: smoothed toward its detections, its velocity
//! measured, its direction predicted on through pauses (see the [`track`](super)
//! module).

use super::event::{turn_ended, Accumulator, TURN_GAP_S};
use super::evidence::Bursts;
use super::slope::Slope;
use crate::method::Detection;
use nalgebra::Vector3;

/// How much of a new detection a track's direction takes.
const SMOOTHING: f64 = 0.3;

/// The time over which a track's direction takes [`SMOOTHING`] of a detection.
const SMOOTHING_FRAME_S: f64 = 0.0107;

/// A track's turn is measured over at least this long (seconds): over a shorter time, a
/// degree of noise in its direction reads as several degrees per second.
pub(super) const VELOCITY_SPAN_S: f64 = 0.5;

/// A track heard this long (seconds) without turning faster than [`STILL_SPEED`] is
/// taken as still before its turn is measured over [`VELOCITY_SPAN_S`]: a word is
/// shorter than that, and a talker who said one is where he said it.
pub(super) const STILL_SPAN_S: f64 = 0.25;

/// A track whose smoothed direction's ends turned slower than this over a half-second
/// span (radians per second, 10 deg/s) turns by the least-squares slope of the span's
/// detections when that stands ([`TURN_STANDARD_ERRORS`]), else by its slow turn: the
/// noise of a small array's directions measures about this much.
pub(super) const STILL_SPEED: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// A turn measured over [`VELOCITY_SPAN_S`] counts only when the least-squares slope of
/// the span's detections is at least this many standard errors (their scatter across
/// the track, counted once per span of frames a detection averages): a still talker on
/// a 5.7 cm tetrahedron at 16 kHz scatters by 5-10 deg, which read as a turn of 10-20
/// deg/s, and his track, predicted away, let his next words start another.
const TURN_STANDARD_ERRORS: f64 = 3.0;

/// A turn slower than [`STILL_SPEED`] is measured over spans of this long (seconds).
const SLOW_SPAN_S: f64 = 1.0;

/// Over a [`SLOW_SPAN_S`], a track that has moved [`SLOW_TURN_SCATTERS`] times the
/// scatter of its detections (the root mean square of their angles from where it was
/// predicted), and at least this far (radians, 3 deg), turns, however slowly: a walker
/// at 10 deg/s, measured over half a second only, read as still about half the time,
/// and his track, predicted where he paused, split from him after a pause; a still
/// talker's smoothed direction wanders less than that.
const SLOW_TURN: f64 = 3.0 * std::f64::consts::PI / 180.0;

/// See [`SLOW_TURN`].
const SLOW_TURN_SCATTERS: f64 = 3.0;

/// A track's scatter is averaged over about this many detections.
const SCATTER_DETECTIONS: f64 = 20.0;

/// A new track's scatter (radians, 5 deg) until its detections measure it.
const SCATTER_START: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// A track is predicted at most this far past its last detection (seconds).
const PREDICT_S: f64 = 1.0;

/// A resumption heard more than this many times is the track's own
/// ([`Track::resumed_at_onset`]).
const RESUMED_HEARD: usize = 3;

/// A track's state before it was heard again after a turn's gap of silence.
struct Resumed {
    /// When it was heard again (seconds).
    at_s: f64,
    /// Its first detections since (their times, and whether each led its frame:
    /// [`Track::led`]), and how many it has had.
    heard: [(f64, bool); RESUMED_HEARD],
    count: usize,
    event: Option<Accumulator>,
    last_s: f64,
    direction: Vector3<f64>,
    given_s: f64,
}

pub(super) struct Track {
    pub id: u64,
    pub direction: Vector3<f64>,
    pub last_s: f64,
    pub event: Option<Accumulator>,
    /// Its last stretch of activity, ended but held for the tracker's delay: a
    /// candidate confirmed later whose detections began before it ended joins it again
    /// ([`Track::reopen`]) instead of starting a stretch that overlaps it.
    ended: Option<Accumulator>,
    /// The latest frame (its time, seconds) that gave it a row ([`Track::give`]).
    given_s: f64,
    /// The cone (degrees) of its last stretch of activity once ended: where it was
    /// heard, within what it could tell.
    pub ended_cone_deg: f64,
    /// What it was before it was heard again after a turn's gap of silence, until the
    /// tracker keeps or undoes that ([`Track::resumed_s`]).
    resumed: Option<Resumed>,
    /// How its direction moves (per second, tangent to the sphere at `direction`).
    velocity: Vector3<f64>,
    /// Its direction and the time the velocity was last measured from.
    anchor: (Vector3<f64>, f64),
    /// Whether its velocity has been measured yet (over [`VELOCITY_SPAN_S`]).
    measured: bool,
    /// Its direction and the time its slow turn was last measured from, and that turn
    /// (zero unless it turned [`SLOW_TURN`] over [`SLOW_SPAN_S`]).
    slow_anchor: (Vector3<f64>, f64),
    slow_velocity: Vector3<f64>,
    /// The mean square angle (radians^2) of its detections from where it was predicted,
    /// over about [`SCATTER_DETECTIONS`] detections.
    scatter: f64,
    /// Its evidence as a source heard in bursts, kept on after it was confirmed: a
    /// candidate at its place after a silence starts from it.
    pub bursts: Bursts,
    /// Its detections since the velocity was last measured, for the least-squares
    /// slope that tells whether the measured turn stands out of their scatter.
    fit: Slope,
}

impl Track {
    pub fn new(
        id: u64,
        direction: Vector3<f64>,
        last_s: f64,
        event: Option<Accumulator>,
        bursts: Bursts,
    ) -> Self {
        Track {
            id,
            direction,
            last_s,
            given_s: event.as_ref().map_or(f64::NEG_INFINITY, |e| e.end_s()),
            event,
            ended: None,
            ended_cone_deg: 0.0,
            resumed: None,
            velocity: Vector3::zeros(),
            anchor: (direction, last_s),
            measured: false,
            slow_anchor: (direction, last_s),
            slow_velocity: Vector3::zeros(),
            scatter: SCATTER_START.powi(2),
            bursts,
            fit: Slope::default(),
        }
    }

    /// Counts detection `d` in its stretch of activity (opening one), unless `d`'s frame
    /// is the latest that gave it a row: at most one row per source per frame
    /// (docs/interface.md). Whether it did. Detections come in frame order but a
    /// candidate's, given when it is confirmed, which the tracker checks against the
    /// rows it still holds.
    ///
    /// A detection after a turn's gap of silence in its stretch of activity resumes
    /// it: what it was before is kept until the tracker keeps the resumption
    /// ([`Track::keep_resumed`]) or undoes it ([`Track::undo_resumed`]).
    pub fn give(&mut self, d: &Detection) -> bool {
        if d.time_s == self.given_s {
            return false;
        }
        if self.resumed.is_none() && self.event.is_some() && turn_ended(self.last_s, d.time_s) {
            self.resumed = Some(Resumed {
                at_s: d.time_s,
                heard: [(0.0, false); RESUMED_HEARD],
                count: 0,
                event: self.event.clone(),
                last_s: self.last_s,
                direction: self.direction,
                given_s: self.given_s,
            });
        }
        self.given_s = self.given_s.max(d.time_s);
        if let Some(r) = self.resumed.as_mut() {
            if r.count < RESUMED_HEARD {
                r.heard[r.count] = (d.time_s, false);
            }
            r.count += 1;
        }
        match self.event.as_mut() {
            Some(e) => e.add(d),
            None => self.event = Some(Accumulator::new(d)),
        }
        true
    }

    /// When it was heard again after a turn's gap of silence, while the tracker has
    /// not yet kept or undone that.
    pub fn resumed_s(&self) -> Option<f64> {
        self.resumed.as_ref().map(|r| r.at_s)
    }

    /// Its detection just given led its frame (nothing there scored more).
    pub fn led(&mut self) {
        if let Some(r) = self.resumed.as_mut().filter(|r| r.count <= RESUMED_HEARD) {
            r.heard[r.count - 1].1 = true;
        }
    }

    /// Whether it was heard again only in another source's onset, that source's first
    /// detection at `start_s`: within `onset_s` of it, and with at most one detection
    /// since that was its own (before `start_s`, or leading its frame).
    pub fn resumed_at_onset(&self, start_s: f64, onset_s: f64) -> bool {
        self.resumed.as_ref().is_some_and(|r| {
            let own = r.heard[..r.count.min(RESUMED_HEARD)]
                .iter()
                .filter(|&&(t, led)| t < start_s || led)
                .count();
            (r.at_s - start_s).abs() <= onset_s && r.count <= RESUMED_HEARD && own <= 1
        })
    }

    /// Its resumption is its own: what it was before is forgotten.
    pub fn keep_resumed(&mut self) {
        self.resumed = None;
    }

    /// Its resumption was not its own: it is again what it was before it (its stretch of
    /// activity, when and where it was last heard). Its motion's measures keep what the
    /// resumption added (a detection or two).
    pub fn undo_resumed(&mut self) {
        if let Some(r) = self.resumed.take() {
            self.event = r.event;
            self.last_s = r.last_s;
            self.direction = r.direction;
            self.given_s = r.given_s;
        }
    }

    /// Ends its stretch of activity, held ([`Track::ended`]); gives back the one held
    /// before, to be written.
    pub fn end_stretch(&mut self) -> Option<Accumulator> {
        let e = self.event.take()?;
        self.ended_cone_deg = e.uncertainty_deg();
        self.ended.replace(e)
    }

    /// Its held stretch, once no candidate still waiting can have begun within a turn's
    /// gap of its end ([`TURN_GAP_S`] and `delay_s` after its end, at `now`), or at the
    /// end (`now` infinite).
    pub fn release_ended(&mut self, now: f64, delay_s: f64) -> Option<Accumulator> {
        self.ended
            .take_if(|e| now - e.end_s() >= delay_s + TURN_GAP_S - 1e-9)
    }

    /// Whether it holds an ended stretch not yet written.
    pub fn holds_ended(&self) -> bool {
        self.ended.is_some()
    }

    /// Its held stretch opened again, when a candidate joining it began at `start_s`,
    /// before that stretch ended or within a turn's gap after ([`TURN_GAP_S`]): the two
    /// are one stretch (and one with the stretch open since, which the candidate's
    /// detections bridge to it), as a source's turns are a turn's gap apart. Whether it
    /// was. (Before the gap counted, a stretch's first few detections, ended while the
    /// next ones waited in a candidate, were an event of their own 0.02 s before the
    /// rest: a false event 15 deg off on a 4.6 cm square, and a turn counted twice.)
    pub fn reopen(&mut self, start_s: f64) -> bool {
        let Some(ended) = self.ended.take_if(|e| !turn_ended(e.end_s(), start_s)) else {
            return false;
        };
        match self.event.as_mut() {
            Some(open) => open.merge(ended),
            None => self.event = Some(ended),
        }
        true
    }

    /// How fast it turns (degrees per second), once measured; `None` before.
    pub fn speed_deg_s(&self) -> Option<f64> {
        self.measured.then(|| self.velocity.norm().to_degrees())
    }

    /// Where it is expected at time `t_s`: its direction moved on by its velocity (for
    /// at most [`PREDICT_S`]).
    pub fn predicted(&self, t_s: f64) -> Vector3<f64> {
        let ahead = (t_s - self.last_s).clamp(0.0, PREDICT_S);
        let v = self.direction + self.velocity * ahead;
        let n = v.norm();
        if n > 1e-9 {
            v / n
        } else {
            self.direction
        }
    }

    /// Takes detection `d`: its direction moves from the prediction toward `d`'s, and
    /// the velocity is measured again once [`VELOCITY_SPAN_S`] has passed since the
    /// last time: under [`STILL_SPEED`] the detections' slope where it stands, at most
    /// `max_speed` radians per second, and for a planar array (normal `plane`) about
    /// the normal only.
    pub fn update(&mut self, d: &Detection, max_speed: f64, plane: Option<Vector3<f64>>) {
        let predicted = self.predicted(d.time_s);
        let off = predicted.angle(&d.direction);
        self.scatter += (off * off - self.scatter) / SCATTER_DETECTIONS;
        // A candidate under the threshold moves a track by one frame's share, however
        // long the gap before it.
        let since = if d.margin >= 1.0 {
            d.time_s - self.last_s
        } else {
            0.0
        };
        self.direction = smooth(&predicted, &d.direction, since);
        self.last_s = d.time_s;
        self.fit.add(d.time_s, &d.direction, d.span_s);
        let (from, from_s) = self.anchor;
        let span = d.time_s - from_s;
        if !self.measured && (STILL_SPAN_S..VELOCITY_SPAN_S).contains(&span) {
            let turned = self.direction.angle(&from);
            if turned < STILL_SPEED * span {
                self.measured = true;
            }
        }
        let (slow_from, slow_from_s) = self.slow_anchor;
        let slow_span = d.time_s - slow_from_s;
        if slow_span >= SLOW_SPAN_S {
            let u = self.direction;
            let slow_turn = (SLOW_TURN_SCATTERS * self.scatter.sqrt()).max(SLOW_TURN);
            self.slow_velocity = if u.angle(&slow_from) >= slow_turn {
                tangent(&u, (u - slow_from) / slow_span, plane)
            } else {
                Vector3::zeros()
            };
            self.slow_anchor = (u, d.time_s);
            // A slow turn found replaces a velocity under [`STILL_SPEED`]; none found
            // leaves it (a slope that stood) to the next half second's measure.
            if self.velocity.norm() < STILL_SPEED && self.slow_velocity.norm() > 0.0 {
                self.velocity = self.slow_velocity;
            }
        }
        if span >= VELOCITY_SPAN_S {
            let u = self.direction;
            let v = tangent(&u, (u - from) / span, plane);
            let speed = v.norm();
            let slope = self.fit.line().map(|(_, slope)| tangent(&u, slope, plane));
            let stands = match (slope, self.fit.standard_error(&u, plane)) {
                (Some(slope), Some(se)) => slope.norm() >= TURN_STANDARD_ERRORS * se,
                _ => false,
            };
            self.fit = Slope::default();
            // A turn the slope stands for is the track's, slow or not: a walker at 10
            // deg/s read under [`STILL_SPEED`] from his smoothed direction's ends
            // about half the time, and his track, predicted where he paused, split
            // from him when he spoke again (see [`SLOW_TURN`]).
            let turn = match slope {
                Some(slope) if stands && speed < STILL_SPEED => Some(slope),
                _ if stands => Some(v),
                _ => None,
            };
            self.velocity = match turn {
                // Slower than a half-second span measures: the slow turn, if any.
                None => self.slow_velocity,
                Some(t) if t.norm() > max_speed => t * (max_speed / t.norm()),
                Some(t) => t,
            };
            self.anchor = (u, d.time_s);
            self.measured = true;
        }
    }
}

/// Velocity `v` at direction `u` made tangent to the sphere there, and for a planar
/// array (normal `plane`) about the normal only: its elevations are rough, so its
/// tracks turn in its plane.
fn tangent(u: &Vector3<f64>, v: Vector3<f64>, plane: Option<Vector3<f64>>) -> Vector3<f64> {
    let v = v - u * u.dot(&v);
    match plane {
        Some(n) => {
            let along = n.cross(u);
            let norm = along.norm();
            if norm > 1e-9 {
                along * (along.dot(&v) / (norm * norm))
            } else {
                Vector3::zeros()
            }
        }
        None => v,
    }
}

/// A track's direction moved toward a detection `since` seconds after its last: by
/// [`SMOOTHING`] a frame (10.7 ms at the default frame size), more after a gap (a talker
/// who moved while silent is taken where the detection is).
pub(super) fn smooth(old: &Vector3<f64>, new: &Vector3<f64>, since: f64) -> Vector3<f64> {
    let share = 1.0 - (1.0 - SMOOTHING).powf(since.max(0.0) / SMOOTHING_FRAME_S);
    let share = share.clamp(SMOOTHING, 1.0);
    let v = old * (1.0 - share) + new * share;
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
    use crate::geometry::{angle_between_deg, unit_from_angles};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn at(time_s: f64, azimuth: f64, elevation: f64) -> Detection {
        Detection {
            frame: (time_s / 0.008).round() as u64,
            time_s,
            azimuth_deg: azimuth,
            elevation_deg: elevation,
            direction: unit_from_angles(azimuth, elevation),
            score: 10.0,
            mics: 4,
            margin: 2.0,
            peak_margin: 2.0,
            uncertainty_deg: 10.0,
            rider: false,
            span_s: 0.04,
            accumulated: false,
        }
    }

    /// The fastest turn a track measures over 4 s of detections every 8 ms at
    /// `azimuth(t)`, scattered by `sigma` deg each way (deg/s).
    fn fastest(seed: u64, sigma: f64, azimuth: impl Fn(f64) -> f64) -> f64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, sigma).expect("a normal");
        let first = at(0.0, azimuth(0.0), 10.0);
        let mut track = Track::new(1, first.direction, 0.0, None, Bursts::new(0));
        let mut fastest: f64 = 0.0;
        for k in 1..500 {
            let t = k as f64 * 0.008;
            let d = at(
                t,
                azimuth(t) + noise.sample(&mut rng),
                10.0 + noise.sample(&mut rng),
            );
            track.update(&d, 2.0 * 60f64.to_radians(), None);
            fastest = fastest.max(track.speed_deg_s().unwrap_or(0.0));
        }
        fastest
    }

    /// A still talker on a small array, his detections scattered by 5 deg each way
    /// (and each the average of six frames): his track's direction wanders, but the
    /// slope of his detections does not stand out of their scatter, so no turn is
    /// measured (before, 10-20 deg/s, and his track was predicted away from him). A
    /// walker at 20 deg/s scattered by 2 deg is measured turning. (Scattered by 5 deg,
    /// his half-second turn is within three standard errors of none and is not
    /// measured: on the arrays of `benches/moving.py` no walker was lost to that.)
    #[test]
    fn a_scattered_still_talker_is_not_taken_as_turning() {
        for seed in 0..6 {
            assert_eq!(fastest(seed, 5.0, |_| 20.0), 0.0, "seed {seed}");
            let walker = fastest(seed, 2.0, |t| 20.0 + 20.0 * t);
            assert!((15.0..25.0).contains(&walker), "seed {seed}: {walker}");
        }
    }

    /// A walker at 6 deg/s, under [`STILL_SPEED`], on a planar array: his detections
    /// scattered by 0.5 deg in azimuth and 5 deg in elevation (a small array's rough
    /// elevation). The slope of each half second's azimuths stands out of their scatter,
    /// so his track turns with him, and a second's slow-turn test that finds nothing
    /// does not stop it (before, the ends of its smoothed direction read under 10
    /// deg/s and it was taken as still unless a second's turn passed three scatters,
    /// elevation included, which it never did here: 0 of 17 looks; on
    /// `benches/moving.py` walkers at 10 deg/s split at their pauses).
    #[test]
    fn a_walker_slower_than_a_half_seconds_measure_is_taken_as_turning() {
        for seed in 0..6 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (across, up) = (
                Normal::new(0.0, 0.5).expect("a normal"),
                Normal::new(0.0, 5.0).expect("a normal"),
            );
            let azimuth = |t: f64| 20.0 + 6.0 * t;
            let first = at(0.0, azimuth(0.0), 10.0);
            let mut track = Track::new(1, first.direction, 0.0, None, Bursts::new(0));
            let mut turning = 0;
            for k in 1..500 {
                let t = k as f64 * 0.008;
                let d = at(
                    t,
                    azimuth(t) + across.sample(&mut rng),
                    10.0 + up.sample(&mut rng),
                );
                track.update(&d, 2.0 * 60f64.to_radians(), Some(Vector3::z()));
                // Once a half second's turn has been measured: 0.6 s on.
                if k % 25 == 0 && t > 0.6 {
                    let speed = track.speed_deg_s().unwrap_or(0.0);
                    turning += usize::from((3.0..9.0).contains(&speed));
                }
            }
            // 17 looks at 0.8-4.0 s (16 of them on every seed).
            assert!(
                turning >= 14,
                "seed {seed}: turning in {turning} of 17 looks"
            );
        }
    }

    /// A track whose stretch of two detections (times, azimuths at elevation 0) ended:
    /// held, nothing to write yet.
    fn ended_track(from: (f64, f64), to: (f64, f64)) -> Track {
        let mut t = Track::new(1, unit_from_angles(from.1, 0.0), 0.0, None, Bursts::new(0));
        let mut stretch = Accumulator::new(&at(from.0, from.1, 0.0));
        stretch.add(&at(to.0, to.1, 0.0));
        t.event = Some(stretch);
        assert!(t.end_stretch().is_none());
        assert!(t.holds_ended() && t.event.is_none());
        t
    }

    #[test]
    fn an_ended_stretch_is_held_and_reopened_by_what_began_within_a_turns_gap_of_its_end() {
        let mut t = ended_track((1.0, 30.0), (1.2, 30.0));
        // A candidate that began more than a turn's gap after its end opens nothing of
        // it...
        assert!(!t.reopen(1.2 + TURN_GAP_S + 0.01));
        // ...one that began before its end, or within a turn's gap after, continues it.
        assert!(t.reopen(1.1));
        let e = t.event.as_ref().expect("reopened");
        assert_eq!((e.start_s(), e.end_s()), (1.0, 1.2));
        assert!(t.end_stretch().is_none());
        assert!(t.reopen(1.2 + TURN_GAP_S - 0.01));
        // Held for the delay and a turn's gap after its end, then given out.
        assert!(t.end_stretch().is_none());
        assert!(t.release_ended(2.2 + TURN_GAP_S - 0.01, 1.0).is_none());
        assert!(t.release_ended(2.2 + TURN_GAP_S, 1.0).is_some());
        assert!(!t.holds_ended());
    }

    #[test]
    fn a_candidate_that_bridges_a_held_stretch_and_an_open_one_makes_them_one() {
        let mut t = ended_track((0.72, 30.0), (0.77, 31.0));
        // A second stretch opened after the first ended...
        t.event = Some(Accumulator::new(&at(0.90, 32.0, 0.0)));
        // ...then a candidate waiting since before the first's end joins: one stretch.
        assert!(t.reopen(0.74));
        assert!(!t.holds_ended());
        let e = t.event.as_ref().expect("open").finish(1);
        assert_eq!((e.start_s, e.end_s, e.detections), (0.72, 0.90, 3));
        assert!(angle_between_deg(&e.start_direction, &unit_from_angles(30.0, 0.0)) < 1e-9);
        assert!(angle_between_deg(&e.end_direction, &unit_from_angles(32.0, 0.0)) < 1e-9);
    }
}
