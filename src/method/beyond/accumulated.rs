//! The accumulated look: a faint source's frames added up before deciding (beyond the
//! paper; issue 51, "faint sources accumulate").
//!
//! A talker across the room gives frames that each stay under the threshold, even under
//! the candidates' share of it: his words come out as two or three looks each, and the
//! tracker's evidence test ([`crate::track`]) stalls short of a source. Yet his frames
//! agree in direction over a word. The patterns' longer average (every pair's correlation
//! averaged exponentially over [`Talkers::patterns_s`](crate::method::Talkers::patterns_s),
//! 0.17 s) holds them added up, and its chance fluctuation is `sqrt((1 - a) / (1 + a))`
//! of a frame's (0.15 at 16 kHz), so its own threshold (the frame's, its chance part
//! scaled by that spread) is far lower. So once per look (the
//! [`Room::average_frames`](crate::method::Room::average_frames) hops the tracker counts
//! as one observation), a frame that gave nothing, or only riders, is given the longer
//! average's best direction (the steered response) when:
//!
//! - it scores at least [`CANDIDATES_SHARE`] of the candidates' share of the longer
//!   average's threshold, with its delays fitting one source (the residual gate), as the
//!   second look's must;
//! - it is heard in the frame's own span too ([`NOW_SHARE`](super::NOW_SHARE),
//!   [`NOW_FLOOR`](super::NOW_FLOOR)): a source that stopped stays in the longer
//!   average a while;
//! - it is not a talker heard lately seen a little beside itself: within
//!   [`BESIDE_DEG`] of such a talker it counts only within [`OWN_DEG`] (further, the
//!   longer average's peak is the talker's direct path merged with a wall's image, read
//!   7-8 deg off in the tracking benchmark's office, where it made a second track of a
//!   loud talker between his words), nor that talker's floor or ceiling image
//!   ([`IMAGE_ELEVATION_DEG`]).
//!
//! Its margin is over the longer average's threshold, and it is marked
//! [`Detection::accumulated`]: the tracker weighs it by the accumulated looks' own law
//! (`Evidence::look_nats` in `src/track/evidence.rs`, measured on training scenes: far
//! less often clutter than a frame's candidate), and a place it names needs the evidence
//! of looks like any other.

use super::{
    apart, detection, Correlated, FrameState, Layout, Outcome, Patterns, IMAGE_ELEVATION_DEG,
    SLOT_DEG, TALKING_S,
};
use crate::method::beyond::Talkers;
use crate::method::Detection;

/// A talker heard lately makes what the longer average gives within this many degrees
/// of it suspect (twice a talker's slot).
pub(crate) const BESIDE_DEG: f64 = 2.0 * SLOT_DEG;

/// ...unless it is within this many degrees of the talker: its own place (a candidate's
/// gate is 5-8 deg; the office's stray peaks were 7-8 deg off; 3 deg found one word
/// fewer of 180 on `benches/words.py --seed 500`, the office alike).
pub(crate) const OWN_DEG: f64 = 5.0;

/// The accumulated look reports down to this share of the candidates' share of its
/// threshold (0.25 at the default 0.4): added up over a word, a faint talker stands at
/// 0.33-0.47 of the longer average's threshold, most looks within 1-3 deg of him (one
/// talker at 2.5 m at 0 dB in RT60 0.6 s, on the prism at 16 kHz), and the tracker's
/// evidence test, not this floor, decides what is a source. Words found in rooms of
/// RT60 0.2-0.8 s at 0-20 dB (`benches/words.py --only hard`, the four draws it was
/// chosen on, 384 words): 308 at the candidates' share, 315 at 0.75 of it, 330 at 0.625,
/// 332 at 0.5 (docs/experiments.md, 2026-12-07, seventh session). Tested by
/// `tests/integration/rooms.rs`: a talker 8 dB under the noise, heard only this way.
pub(crate) const CANDIDATES_SHARE: f64 = 0.625;

impl Talkers {
    /// The share of its own threshold the accumulated look reports down to (1: none,
    /// with no candidates), reported with
    /// [`Detection::accumulated`](crate::method::Detection::accumulated).
    pub(crate) fn accumulated_share(&self) -> f64 {
        match self.candidate_share() {
            c if c < 1.0 => c * CANDIDATES_SHARE,
            _ => 1.0,
        }
    }
}

impl Patterns {
    /// The accumulated look of the frame `span` ends (see the module), when the frame
    /// gave nothing (or riders only) and begins a look.
    pub(super) fn accumulated_look(
        &mut self,
        setup: &Layout,
        span: &[FrameState],
        outcome: &Outcome,
        index: u64,
    ) -> Option<Detection> {
        let nothing = match outcome {
            Outcome::Detected(found, _) => found.as_slice().iter().all(|d| d.rider),
            Outcome::BelowThreshold(..) => true,
            _ => false,
        };
        let state = span.last().expect("a frame");
        if !nothing
            || index % setup.params.room.average_frames as u64 != 0
            || state.steady
            || state.correlated != Correlated::Yes
        {
            return None;
        }
        let scale = self.scale;
        for r in Self::ranges(setup, state) {
            for (out, v) in self.residual[r.clone()].iter_mut().zip(&self.long[r]) {
                *out = scale * v;
            }
        }
        self.directions.clear();
        // With no candidates (a share of 1), none under the threshold here either.
        let share = setup.params.talkers.accumulated_share();
        let found = self.residual_source(setup, span, share)?;
        let u = found.direction;
        let heard = (TALKING_S * setup.rate / setup.hop as f64) as u64;
        let (own, beside) = (OWN_DEG.to_radians().cos(), BESIDE_DEG.to_radians().cos());
        let suspect = self.slots.iter().any(|s| {
            let cos = s.direction.dot(&u);
            index - s.seen <= heard
                && cos <= own
                && (cos >= beside || !apart(&u, &s.direction, IMAGE_ELEVATION_DEG))
        });
        if suspect {
            return None;
        }
        let mut d = detection(setup, state, index, u, found.score, found.uncertainty_deg);
        d.margin = found.score / found.threshold;
        d.peak_margin = d.margin;
        d.accumulated = true;
        Some(d)
    }
}
