//! Each talker's correlation pattern, learned while it dominates and removed before a
//! second look for the others (beyond the paper).
//!
//! When two talk at once, a frame's averaged correlations belong mostly to the louder:
//! its direct path and its reflections (a wall's image, the floor's) outscore the other
//! talker in most frames, and clearing the first source's delays ([`super::steered`])
//! leaves its reflections. So each talker's whole pattern (every pair's correlation at
//! the lags searched, reflections included) is learned from the frames it dominates,
//! and in every frame that gives a source, that source's pattern is fitted to a longer
//! average of the correlations and subtracted before the steered response looks there
//! for another source:
//!
//! - **Learning:** a frame whose first source scores at least [`LEARN_MARGIN`] of the
//!   threshold and [`DOMINANT`] times any other source of the frame teaches the
//!   pattern of the talker within [`SLOT_DEG`] of it (a running mean at first, then an
//!   exponential average over [`PATTERN_S`]); up to [`SLOTS`] talkers are remembered,
//!   the one learned from longest ago replaced first.
//! - **The longer average:** every pair's correlation averaged exponentially over
//!   [`Talkers::patterns_s`](crate::method::Talkers::patterns_s) (0.17 s; 0.25 s found 0-4
//!   points more on the tracking benchmark's prism, its meetings' rows 0.1 deg worse;
//!   0.34 s left a meeting's rows 1.2 deg off, docs/tracking.md).
//! - **Removal:** the first source's pattern times the least-squares gain that fits it
//!   to the longer average over every live pair, once learned from [`MIN_LEARNED`]
//!   frames, and only while the talker keeps still ([`STILL_DEG`]).
//! - **The second look:** the steered response over what is left, the directions found
//!   cleared, down to the candidates' share of the longer average's own threshold (the
//!   frame's with its chance part scaled by the average's spread, `sqrt((1 - a) / (1 +
//!   a))` for an exponential average of factor `a`). What it gives is a further source of
//!   the frame when it is heard in the frame's span too ([`NOW_SHARE`], [`NOW_FLOOR`],
//!   [`NOW_SAMPLES`])
//!   and is no vertical reflection of a source of the frame or of a talker heard lately
//!   ([`IMAGE_ELEVATION_DEG`]).
//!
//! The array must leave room for reflections in its correlations: below [`MIN_LAGS`]
//! samples of delay (a 4.6 cm circle or a 6.5 cm tetrahedron at 16 kHz) the second look
//! found no talker more on the tracking benchmark and, before the span and image checks,
//! made tracks of reflections (with them it changes nothing there); the same arrays at
//! 48 kHz (9-13 samples) found 0-4 points more windows, the prism (17-103 samples at
//! 8-48 kHz) 2-8 points at 48 kHz and 2-12 at 16 kHz over three draws
//! (docs/tracking.md).
//!
//! The same longer average gives a frame that gave nothing its best direction, a faint
//! talker's frames added up ([`accumulated`]).
//!
//! It runs in frame order after the frames' own stages, so its output does not depend on
//! the thread count, and its memory is fixed (a few patterns of every pair's lags).

use super::frame_sources::apart;
use super::steered::{whole_within, Query, Steered, CLEAR_SAMPLES};
use super::threshold::ThresholdPlan;
use crate::method::detect::{detection, solver};
use crate::method::layout::Layout;
use crate::method::outcome::{Detections, Outcome};
use crate::method::paper::direction::DirectionSolver;
use crate::method::paper::pairs::{pair_count, pair_index};
use crate::method::state::{Correlated, FrameState};
use crate::method::uncertainty::uncertainty_deg;
use multiversion::multiversion;
use nalgebra::Vector3;
use std::collections::HashMap;

/// A frame teaches its first source's pattern when that source scores at least this many
/// times any other of the frame.
pub(crate) const DOMINANT: f64 = 2.0;

/// A source within this many degrees of a remembered talker is that talker.
pub(crate) const SLOT_DEG: f64 = 10.0;

/// Time constant (seconds) of a talker's pattern once learned from enough frames.
pub(crate) const PATTERN_S: f64 = 2.0;

/// The most talkers remembered.
pub(crate) const SLOTS: usize = 6;

/// The share of a frame's first source a remembered talker's direction moves by.
pub(crate) const FOLLOW: f64 = 0.3;

/// What the second look finds within the vertical plane of a source found in the frame
/// ([`IMAGE_PLANE_DEG`](super::frame_sources::IMAGE_PLANE_DEG)) and this many degrees
/// or more from its elevation is that source's floor or ceiling image, left over from its
/// pattern (measured on the tracking benchmark's prism at 16 kHz: images 15-17 deg
/// above and below a talker made tracks of their own; the frame's own further sources
/// take 20).
pub const IMAGE_ELEVATION_DEG: f64 = 10.0;

/// A remembered talker is heard lately when it was a frame's first source at most this
/// long ago (seconds).
pub(crate) const TALKING_S: f64 = 0.5;

/// What the second look finds scores at least this share of its score in the longer
/// average in the correlations averaged over the frame's span (pairs that cannot tell
/// it from a source found left out): a source that stopped leaves the span long before
/// the longer average.
pub(crate) const NOW_SHARE: f64 = 0.5;

/// ...and at least this share of the frame's candidates' floor there. Without these two,
/// `tests/integration/accuracy.rs` failed: after each noise burst or train of clicks ended, rows of
/// it came in the next one's first 0.05-0.1 s (its span scored 0.12-0.21 of the floor;
/// the second talkers of the tracking benchmark 0.21-0.72, the lowest tenth cut).
pub(crate) const NOW_FLOOR: f64 = 0.25;

/// The direction found is heard in the frame's span when each pair's correlation there
/// peaks within this many samples of its delay (not the consistency tolerance: with 50
/// us, 2.4 samples at 48 kHz, a noise burst that had ended 0.45 s before still passed
/// in `tests/integration/accuracy.rs`, its pairs' best values over five lags adding up to the floor;
/// with one sample the tracking benchmark's prism at 48 kHz finds 0-4 points fewer of
/// two talkers' windows than with the tolerance, docs/tracking.md).
pub(crate) const NOW_SAMPLES: f64 = 1.0;

/// A talker whose direction now is further than this (degrees) from its direction
/// averaged as the longer average is, is moving: its pattern, smeared along its way, is
/// not removed (else what is left of it was taken for a second talker: the tracking
/// benchmark's prism made two tracks of a talker turning at 15 and 60 deg/s).
pub(crate) const STILL_DEG: f64 = 2.0;

/// A pattern is removed once learned from this many frames (3 found 0-10 points more
/// windows than 8 on the tracking benchmark's prism).
pub(crate) const MIN_LEARNED: u32 = 3;

/// A frame teaches its first source's pattern only when that source scores at least
/// this share of the threshold (0.5 found as many windows as 1 on the tracking
/// benchmark's prism, 0-14 points more on the small arrays at 48 kHz).
pub(crate) const LEARN_MARGIN: f64 = 0.5;

/// Patterns are learned only when the array's longest delay is at least this many
/// samples.
pub(crate) const MIN_LAGS: usize = 8;

/// The longer average's scale under which it is multiplied out.
const RESCALE: f32 = 1e-6;

struct Slot {
    direction: Vector3<f64>,
    /// Its direction averaged as the longer average is: where a moving talker is in it.
    trail: Vector3<f64>,
    pattern: Vec<f32>,
    learned: u32,
    last: u64,
    /// The last frame it was the first source of.
    seen: u64,
}

/// What the longer average gives ([`Patterns::residual_source`]).
struct Heard {
    direction: Vector3<f64>,
    score: f64,
    uncertainty_deg: f64,
    /// The longer average's threshold over the frame's live pairs.
    threshold: f64,
}

/// The learned patterns, the longer average and the buffers of the second look.
pub(crate) struct Patterns {
    keep: f32,
    /// The longer average is `scale` times `long`.
    scale: f32,
    /// The standard deviation of an exponential average of independent values, as a
    /// share of theirs.
    spread: f64,
    /// The smallest share of a new frame in a pattern (its exponential average's).
    min_share: f32,
    long: Vec<f32>,
    residual: Vec<f32>,
    slots: Vec<Slot>,
    steered: Steered,
    solvers: HashMap<u64, Option<DirectionSolver>>,
    directions: Vec<Vector3<f64>>,
    /// The run's detection threshold.
    threshold: ThresholdPlan,
}

impl Patterns {
    /// Nothing learned, or `None` when the parameters leave it out.
    pub fn new(setup: &Layout, threshold: &ThresholdPlan) -> Option<Self> {
        let tau = setup.params.talkers.patterns_tau_s()?;
        let longest = setup.max_lag.iter().copied().max().unwrap_or(0);
        if !setup.params.steered.is_on() || longest < MIN_LAGS {
            return None;
        }
        let hop_s = setup.hop as f64 / setup.rate;
        let keep = (-hop_s / tau).exp();
        let positions: Vec<_> = setup.geometry.mics.iter().map(|m| m.position).collect();
        Some(Patterns {
            keep: keep as f32,
            scale: 1.0,
            spread: ((1.0 - keep) / (1.0 + keep)).sqrt(),
            min_share: (hop_s / PATTERN_S).min(1.0) as f32,
            long: vec![0.0; setup.windows_len],
            residual: vec![0.0; setup.windows_len],
            slots: Vec::with_capacity(SLOTS),
            steered: Steered::new(&positions, setup.rate, setup.speed, &setup.max_lag),
            solvers: HashMap::new(),
            directions: Vec::with_capacity(super::MAX_SOURCES),
            threshold: threshold.clone(),
        })
    }

    /// In frame order: folds each frame into the longer average, learns from the frames
    /// one source dominates, and adds to each frame that gives a source what the second
    /// look finds. `states` holds the block's frames after the `carried` before them
    /// (each frame's span, [`Room::average_frames`](crate::method::Room::average_frames) in
    /// all); `first` is the index of the block's first frame.
    pub fn apply(
        &mut self,
        setup: &Layout,
        states: &[FrameState],
        carried: usize,
        outcomes: &mut [Outcome],
        first: u64,
    ) {
        for (i, outcome) in outcomes.iter_mut().enumerate() {
            let index = first + i as u64;
            let span = &states[i..=i + carried];
            let state = &span[carried];
            self.fold(setup, state);
            if let Some(d) = self.accumulated_look(setup, span, outcome, index) {
                *outcome = Outcome::Detected(Detections::one(d), false);
                continue;
            }
            let Outcome::Detected(found, _) = outcome else {
                continue;
            };
            // Riders (a frame that gave nothing down to the candidates' share) teach
            // nothing and get no second look: the frames that gave something are
            // analysed as without them.
            if found.as_slice().first().is_some_and(|d| d.rider) {
                continue;
            }
            let slot = self.learn(setup, state, found, index);
            if found.len() < setup.params.talkers.max_sources {
                if let Some(slot) = slot {
                    self.look(setup, span, found, slot, index);
                }
            }
        }
    }

    /// The score of direction `u` in the correlations averaged over `span` (as the
    /// frame's own stages average them): per live pair, the highest value within
    /// [`NOW_SAMPLES`] (or the tolerance, when smaller) of `u`'s delay, summed over the
    /// pairs.
    fn score_now(&self, setup: &Layout, span: &[FrameState], u: &Vector3<f64>) -> f64 {
        let reach = 2.0 * setup.tolerance as f64 + CLEAR_SAMPLES as f64;
        let state = span.last().expect("a frame");
        let (live, mics) = (&state.live, setup.mics());
        let tolerance = (setup.tolerance as f64).min(NOW_SAMPLES);
        let mut total = 0.0;
        for (i, &a) in live.iter().enumerate() {
            for &b in &live[i + 1..] {
                let pair = pair_index(a, b, mics);
                let half = setup.max_lag[pair] + 1;
                let start = setup.window_starts[pair];
                let centre = u.dot(self.steered.pair_samples(pair)) + half as f64;
                // A pair that cannot tell `u` from a source found (their delays within the
                // tolerance of what was cleared around it) says nothing.
                if self.directions.iter().any(|f| {
                    (f.dot(self.steered.pair_samples(pair)) + half as f64 - centre).abs() <= reach
                }) {
                    continue;
                }
                let (lo, hi) = whole_within(centre - tolerance, centre + tolerance);
                let (lo, hi) = (lo.max(0) as usize, (hi.max(0) as usize).min(2 * half));
                let both = (1u64 << a) | (1u64 << b);
                let frames = || {
                    span.iter()
                        .filter(move |f| f.correlated == Correlated::Yes && f.mask & both == both)
                };
                let count = frames().count();
                if count == 0 || lo > hi {
                    continue;
                }
                let best = (lo..=hi)
                    .map(|k| frames().map(|f| f.windows[start + k]).sum::<f32>())
                    .fold(0.0f32, f32::max);
                total += (best / count as f32) as f64;
            }
        }
        total
    }

    /// The live pairs of `state`: each one's range in the windows.
    fn ranges<'a>(
        setup: &'a Layout,
        state: &'a FrameState,
    ) -> impl Iterator<Item = std::ops::Range<usize>> + 'a {
        let (live, mics) = (&state.live, setup.mics());
        live.iter().enumerate().flat_map(move |(i, &a)| {
            live[i + 1..].iter().map(move |&b| {
                let pair = pair_index(a, b, mics);
                let start = setup.window_starts[pair];
                start..start + 2 * setup.max_lag[pair] + 3
            })
        })
    }

    /// Folds a frame into the longer average, kept as `scale` times `long` so that the
    /// frames' decay costs one multiplication (`long` is rescaled when `scale` gets small).
    fn fold(&mut self, setup: &Layout, state: &FrameState) {
        self.scale *= self.keep;
        if self.scale < RESCALE {
            let scale = self.scale;
            self.long.iter_mut().for_each(|v| *v *= scale);
            self.scale = 1.0;
        }
        if state.correlated != Correlated::Yes {
            return;
        }
        let share = (1.0 - self.keep) / self.scale;
        for r in Self::ranges(setup, state) {
            add_scaled(&mut self.long[r.clone()], &state.windows[r], share);
        }
    }

    /// The slot of the frame's first source (learning from the frame when it dominates),
    /// or `None` when none is remembered near it.
    fn learn(
        &mut self,
        setup: &Layout,
        state: &FrameState,
        found: &Detections,
        index: u64,
    ) -> Option<usize> {
        let first = found.as_slice().first()?;
        let near = SLOT_DEG.to_radians().cos();
        let mut slot = self
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.direction.dot(&first.direction) > near)
            .max_by(|x, y| {
                x.1.direction
                    .dot(&first.direction)
                    .total_cmp(&y.1.direction.dot(&first.direction))
            })
            .map(|(i, _)| i);
        let dominant = first.margin >= LEARN_MARGIN
            && state.correlated == Correlated::Yes
            && found.as_slice()[1..]
                .iter()
                .all(|d| first.score >= DOMINANT * d.score);
        if let Some(s) = slot {
            // The talker's direction now, and where it was over the longer average.
            let s = &mut self.slots[s];
            s.seen = index;
            let towards = |from: &Vector3<f64>, share: f64| {
                (from * (1.0 - share) + first.direction * share)
                    .try_normalize(1e-9)
                    .unwrap_or(first.direction)
            };
            s.direction = towards(&s.direction, FOLLOW);
            s.trail = towards(&s.trail, 1.0 - self.keep as f64);
        }
        if !dominant {
            return slot;
        }
        let s = match slot {
            Some(s) => s,
            None if self.slots.len() < SLOTS => {
                self.slots.push(Slot {
                    direction: first.direction,
                    trail: first.direction,
                    pattern: vec![0.0; setup.windows_len],
                    learned: 0,
                    last: index,
                    seen: index,
                });
                self.slots.len() - 1
            }
            None => {
                let s = (0..self.slots.len())
                    .min_by_key(|&s| self.slots[s].last)
                    .expect("slots");
                let slot = &mut self.slots[s];
                slot.direction = first.direction;
                slot.trail = first.direction;
                slot.seen = index;
                slot.pattern.iter_mut().for_each(|v| *v = 0.0);
                slot.learned = 0;
                s
            }
        };
        slot = Some(s);
        let min_share = self.min_share;
        let target = &mut self.slots[s];
        let share = (1.0 / (target.learned as f32 + 1.0)).max(min_share);
        for r in Self::ranges(setup, state) {
            move_towards(&mut target.pattern[r.clone()], &state.windows[r], share);
        }
        target.learned += 1;
        target.last = index;
        slot
    }

    /// The best direction of `residual` (the longer average, less what was removed) with
    /// `directions` cleared, down to `share` of the longer average's own threshold (the
    /// frame's with its chance part scaled by the exponential average's spread over
    /// independent frames), fitting one source, and heard in the frame's own span too: a
    /// source that has stopped stays in the longer average a while.
    fn residual_source(
        &mut self,
        setup: &Layout,
        span: &[FrameState],
        share: f64,
    ) -> Option<Heard> {
        let state = span.last().expect("a frame");
        let solver = solver(&mut self.solvers, setup, state)?;
        let pairs = pair_count(state.live.len());
        let threshold = self.threshold.per_pair_spread(&state.weights, self.spread) * pairs as f64;
        let floor = threshold * share;
        let steer = self.steered.search(
            &mut self.residual,
            &Query {
                live: &state.live,
                mics: setup.mics(),
                found: &self.directions,
                tolerance: setup.steer_tolerance,
                floor,
            },
            solver,
        )?;
        let residual = self
            .steered
            .accepts(&steer, floor, pairs, setup.gate(), solver)?;
        let (direction, score) = (steer.direction, steer.score);
        let uncertainty_deg = uncertainty_deg(solver, &direction, Some(residual), setup.speed);
        let now = self.score_now(setup, span, &direction);
        if now < NOW_SHARE * score || now < NOW_FLOOR * state.floor * pairs as f64 {
            return None;
        }
        Some(Heard {
            direction,
            score,
            uncertainty_deg,
            threshold,
        })
    }

    /// The second look (see the module): what is left of the longer average once the
    /// pattern of `slot` is removed.
    fn look(
        &mut self,
        setup: &Layout,
        span: &[FrameState],
        found: &mut Detections,
        slot: usize,
        index: u64,
    ) {
        let state = span.last().expect("a frame");
        let pattern = &self.slots[slot];
        // A moving talker's pattern is smeared along its way: what is left of it would
        // be taken for another source.
        if pattern.learned < MIN_LEARNED
            || pattern.direction.angle(&pattern.trail).to_degrees() > STILL_DEG
        {
            return;
        }
        let scale = self.scale;
        let (mut cross, mut energy) = (0.0f64, 0.0f64);
        for r in Self::ranges(setup, state) {
            let (c, e) = products(&self.long[r.clone()], &pattern.pattern[r]);
            cross += c;
            energy += e;
        }
        if energy <= 0.0 {
            return;
        }
        let gain = (scale as f64 * cross / energy).max(0.0) as f32;
        for r in Self::ranges(setup, state) {
            let out = &mut self.residual[r.clone()];
            remove(out, &self.long[r.clone()], &pattern.pattern[r], scale, gain);
        }
        self.directions.clear();
        self.directions
            .extend(found.as_slice().iter().map(|d| d.direction));
        let share = setup.params.talkers.candidate_share();
        let Some(heard) = self.residual_source(setup, span, share) else {
            return;
        };
        let (u, score, uncertainty) = (heard.direction, heard.score, heard.uncertainty_deg);
        // Not a reflection of a source of the frame, nor of a talker heard lately (its
        // direction there is its own).
        let near = SLOT_DEG.to_radians().cos();
        let heard = (TALKING_S * setup.rate / setup.hop as f64) as u64;
        if found
            .as_slice()
            .iter()
            .all(|f| apart(&u, &f.direction, IMAGE_ELEVATION_DEG))
            && self.slots.iter().all(|s| {
                index - s.seen > heard
                    || s.direction.dot(&u) > near
                    || apart(&u, &s.direction, IMAGE_ELEVATION_DEG)
            })
        {
            found.push(detection(setup, state, index, u, score, uncertainty));
        }
    }
}

/// `out = scale long - gain pattern`: the longer average less a talker's pattern.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn remove(out: &mut [f32], long: &[f32], pattern: &[f32], scale: f32, gain: f32) {
    for ((o, l), p) in out.iter_mut().zip(long).zip(pattern) {
        *o = scale * l - gain * p;
    }
}

/// `to += share from`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn add_scaled(to: &mut [f32], from: &[f32], share: f32) {
    for (t, f) in to.iter_mut().zip(from) {
        *t += share * f;
    }
}

/// `to += share (from - to)`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn move_towards(to: &mut [f32], from: &[f32], share: f32) {
    for (t, f) in to.iter_mut().zip(from) {
        *t += share * (f - *t);
    }
}

/// `sum a_i b_i` and `sum b_i^2`, in eight lanes (which the compiler vectorises).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn products(a: &[f32], b: &[f32]) -> (f64, f64) {
    let (mut cross, mut energy) = ([0.0f32; 8], [0.0f32; 8]);
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            cross[k] += x[k] * y[k];
            energy[k] += y[k] * y[k];
        }
    }
    let mut c: f64 = cross.iter().map(|&v| v as f64).sum();
    let mut e: f64 = energy.iter().map(|&v| v as f64).sum();
    for (x, y) in ra.iter().zip(rb) {
        c += (*x as f64) * (*y as f64);
        e += (*y as f64) * (*y as f64);
    }
    (c, e)
}

#[path = "accumulated.rs"]
mod accumulated;

#[cfg(test)]
#[path = "patterns_tests.rs"]
mod tests;
