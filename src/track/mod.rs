//! Sources, not frames: a tracker over the per-frame detections (beyond the paper).
//!
//! The method gives at most one direction per frame. The [`Tracker`] follows them over
//! time, online, in frame order:
//!
//! - **association:** a detection joins the track whose predicted direction is nearest,
//!   within a gate of [`TrackParams::gate_deg`] widened by
//!   [`TrackParams::max_speed_deg_s`] times the time since the track's last detection, at
//!   most [`TrackParams::max_gate_deg`]. A track's direction is predicted from its last
//!   one and its velocity (its turn measured over at least 0.5 s; none under 10 deg/s,
//!   at most twice `max_speed_deg_s`, in the plane of a planar array), for at most 1 s:
//!   a talker turning at 60 deg/s who pauses for 0.7 s is 42 deg on, past the widest
//!   gate, when heard again;
//! - **riders ride along:** a rider ([`Detection::rider`](crate::method::Detection::rider):
//!   from a frame that gave nothing down to the candidates' share, found down to
//!   [`Talkers::riders`](crate::method::Talkers::riders)) only adds a row to the nearest
//!   track in a stretch of activity within the candidates' gate that none of the
//!   frame's other detections joined; the track is left as it was (its direction, and the time it was last
//!   heard, are the other detections'), and the rider starts, joins and confirms no
//!   candidate. With the evidence test, a detection under the threshold that nothing
//!   took rides the same way a track that talks, within its gate and its scatter (its
//!   stretch's cone on a volumetric array, a sample and a half of delay on another).
//!   (Letting weak detections do what candidates do gave a false track next
//!   to a fan and a false event a minute in a meeting; searching every frame down to
//!   0.3 instead of only those that gave nothing took frames from the detections they
//!   gave before: a third talker lost on the tetrahedron.)
//! - **birth on evidence** ([`ConfirmBy::Evidence`], the default): a detection that
//!   joins no track starts a candidate, and the candidate becomes a track once the
//!   evidence of what joins it passes a threshold set by
//!   [`TrackParams::false_per_hour`] (`evidence`: a sequential probability ratio test
//!   per candidate, with a map of where clutter comes from, `clutter.rs`); it is
//!   dropped once the evidence is against it, or when its detections have waited
//!   [`TrackParams::delay_s`]. A track's gate is then narrow right after a pause unless
//!   its speed has been measured, and a stretch of activity ends after a silence as
//!   long as itself (at least 0.3 s, at most [`TrackParams::end_s`]): each clap is its
//!   own event; it also ends when another source starts one after it has been silent
//!   for 0.2 s (a turn ends when another takes the floor), and a track silent that long
//!   takes no detection scoring under half its frame's strongest (another source's
//!   stray). The image and silent-track rules below hold as well;
//! - **birth on confirmation** ([`ConfirmBy::Rules`], 0.2.0's): a detection that joins
//!   no track starts a candidate; the
//!   candidate becomes a track once [`TrackParams::confirm_hits`] detections above the
//!   threshold have joined it within [`TrackParams::confirm_s`] (or
//!   [`TrackParams::confirm_candidates`] with one above it, or
//!   [`TrackParams::confirm_weak`] under it, or [`TrackParams::confirm_tight`] under it
//!   within [`TrackParams::tight_deg`] of their mean), counted over the window of that length
//!   that ends at its latest detection. Its detections wait up to
//!   [`TrackParams::delay_s`] for that, and then all become the track's rows (but an
//!   isolated first one followed by a silence longer than [`TrackParams::confirm_s`],
//!   no part of the run that confirmed it); a
//!   detection still unconfirmed after it is dropped (isolated outliers never reach the output, unless
//!   [`TrackParams::keep_unconfirmed`] gives them out without an id), and a candidate
//!   with none left is forgotten. A candidate at the azimuth of a talking track but far
//!   from its elevation is that talker's floor or ceiling image and is dropped instead
//!   (`image.rs`). A confirmed candidate near a track that has fallen silent
//!   (within the gate) takes that track's id again: a talker who pauses and speaks again
//!   from the same place keeps one id;
//! - **activity:** a track whose last detection is more than [`TrackParams::end_s`] old
//!   has ended its stretch of activity: its [`Event`] is complete. (1 s by default: real
//!   speech in a reverberant room gives detections in bursts, a word or two at a time,
//!   with pauses of up to about half a second between them within a sentence.) A silent track is
//!   forgotten after [`TrackParams::forget_s`] (at most `MAX_TRACKS` are remembered).
//!
//! - **smoothing:** each row's direction is its track's around that frame, the mean of the
//!   track's rows within [`TrackParams::smooth_s`] before and after it, each turned along
//!   the turn the track's rows show over the last second ([`smoother`]).
//!
//! Every detection that comes out carries its track's id (`source`, from 1, never reused
//! within one recording), but for the unconfirmed ones [`TrackParams::keep_unconfirmed`]
//! keeps. Rows come out in frame order, at most [`TrackParams::latency`] after their
//! frame ([`TrackParams::delay_s`], then [`TrackParams::smooth_s`]): that is the
//! tracker's delay. Memory holds the open candidates and the rows still waiting, bounded
//! by that delay (and the last second of rows, for the turn).
//! Measured in docs/tracking.md.

mod candidate;
pub(crate) mod clutter;
mod event;
pub(crate) mod evidence;
pub(crate) mod faint;
pub(crate) mod image;
mod motion;
mod output;
mod slope;
pub mod smoother;
mod tracker;

pub use event::Event;
pub(crate) use event::{ends_after, turn_ended};
pub use faint::FaintPlace;
pub use output::{TrackStats, Tracked};
pub use tracker::Tracker;

/// How a candidate becomes a source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ConfirmBy {
    /// By the evidence of its detections (`evidence`): one overwhelming detection
    /// confirms at once, many weak consistent ones over time, at most
    /// [`TrackParams::false_per_hour`] false sources an hour.
    Evidence,
    /// By the rules of 0.2.0 ([`TrackParams::confirm_hits`] and the fields after it),
    /// kept so that results made with them can be reproduced (`--confirm-by rules`).
    Rules,
}

impl crate::named::Named for ConfirmBy {
    const ALL: &'static [(ConfirmBy, &'static str, &'static str)] = &[
        (
            ConfirmBy::Evidence,
            "evidence",
            "By the evidence of its detections: a clap at once, a distant talker over time, at most --false-per-hour false sources an hour of background",
        ),
        (
            ConfirmBy::Rules,
            "rules",
            "By the rules ssl confirmed sources with before it weighed evidence (release 0.2.0: 2 detections over the threshold within --confirm-s, or runs of candidates), to reproduce results made with them",
        ),
    ];
}

impl ConfirmBy {
    /// What results written before the choice existed were made with.
    fn before_the_choice() -> Self {
        ConfirmBy::Rules
    }
}

/// Tracking: detections grouped into sources, confirmed, smoothed, and written as rows,
/// events or sources.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Tracking {
    /// No tracking: every frame's detection is written, without a `source` (tracking groups detections into sources, drops those no track confirms, smooths each row's direction over its track's (--smooth-s), and delays rows by up to --delay-s and --smooth-s)
    #[cfg_attr(feature = "flags", arg(long = "no-track", id = "no_track", action = clap::ArgAction::SetFalse))]
    pub on: bool,
    /// How a candidate becomes a source
    #[cfg_attr(feature = "flags", arg(long, value_name = "HOW", default_value = "evidence", value_parser = crate::flags::choice::<ConfirmBy>(), conflicts_with = "no_track", hide_short_help = true))]
    pub confirm_by: ConfirmBy,
    /// With --confirm-by evidence: at most this many false sources an hour of background (fewer: more evidence needed before a source is reported)
    #[cfg_attr(feature = "flags", arg(long, value_name = "F", default_value_t = 1.0, value_parser = false_per_hour, conflicts_with = "no_track", hide_short_help = true))]
    pub false_per_hour: f64,
    /// With --confirm-by rules: a track is confirmed by 2 detections within this many seconds (of its latest)
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = 0.5, value_parser = tracker_seconds, conflicts_with = "no_track", hide_short_help = true))]
    pub confirm_s: f64,
    /// Rows wait up to this many seconds for their track to be confirmed (the tracker's delay; never less than --confirm-s): a detection not confirmed by then is dropped, so a talker confirmed late loses its first detections
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = tracker_seconds, conflicts_with = "no_track", hide_short_help = true))]
    pub delay_s: f64,
    /// Each tracked row's direction is its track's mean over this many seconds before and after it, corrected for the track's turn (rows come out that much later); 0: each frame's own direction
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = 0.2, value_parser = smoothing_seconds, conflicts_with = "no_track", hide_short_help = true))]
    pub smooth_s: f64,
    /// Also write the detections no track confirmed (isolated ones, a track's outliers), with an empty `source` (null in JSON), in frame order among the others
    #[cfg_attr(feature = "flags", arg(long, conflicts_with = "no_track"))]
    pub keep_unconfirmed: bool,
    /// A source silent for this many seconds is forgotten: one heard again where it was within this time gets its id back, later a new one. On a static array keep it long; on an array that moves or turns (a robot), about as long as it stays still, since a source's direction then changes without the source moving
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = 120.0, value_parser = forget_seconds, conflicts_with = "no_track", hide_short_help = true))]
    pub forget_s: f64,
}

impl Default for Tracking {
    fn default() -> Self {
        Tracking {
            on: true,
            confirm_by: ConfirmBy::Evidence,
            false_per_hour: 1.0,
            confirm_s: 0.5,
            delay_s: 1.0,
            smooth_s: 0.2,
            keep_unconfirmed: false,
            forget_s: 120.0,
        }
    }
}

impl Tracking {
    /// The tracker's parameters: these, and the tuning of [`TrackParams::default`]
    /// (`None` with tracking off).
    pub fn params(&self) -> Option<TrackParams> {
        let defaults = TrackParams::default();
        self.on.then(|| TrackParams {
            confirm_by: self.confirm_by,
            false_per_hour: self.false_per_hour,
            confirm_s: self.confirm_s,
            // A run of candidates spans at most the window it is counted over.
            weak_span_s: defaults.weak_span_s.min(self.confirm_s),
            delay_s: self.delay_s,
            keep_unconfirmed: self.keep_unconfirmed,
            smooth_s: self.smooth_s,
            forget_s: self.forget_s,
            ..defaults
        })
    }
}

/// A tracker's window or delay: positive, at most [`MAX_DELAY_S`] (rows wait that long
/// in memory).
#[cfg(feature = "flags")]
fn tracker_seconds(s: &str) -> Result<f64, String> {
    crate::flags::positive_at_most(s, MAX_DELAY_S, " s (rows wait that long in memory)")
}

/// How long a silent source is remembered (`--forget-s`): positive, at most a day (the
/// tracks remembered are bounded in number whatever it is).
#[cfg(feature = "flags")]
fn forget_seconds(s: &str) -> Result<f64, String> {
    crate::flags::positive_at_most(s, 86_400.0, " s (a day)")
}

/// The false sources an hour (`--false-per-hour`): over 0, at most the candidates an
/// hour it is a share of.
#[cfg(feature = "flags")]
fn false_per_hour(s: &str) -> Result<f64, String> {
    crate::flags::positive_at_most(
        s,
        evidence::CANDIDATES_PER_HOUR,
        ", the candidates an hour it is a share of",
    )
}

/// The smoothing window (`--smooth-s`): 0 to [`MAX_SMOOTH_S`].
#[cfg(feature = "flags")]
fn smoothing_seconds(s: &str) -> Result<f64, String> {
    let v = crate::flags::non_negative_f64(s)?;
    if v > MAX_SMOOTH_S {
        return Err(format!("{v} is over {MAX_SMOOTH_S} s"));
    }
    Ok(v)
}

/// The tracker's parameters (see the module's documentation).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub struct TrackParams {
    /// How a candidate becomes a source.
    #[serde(default = "ConfirmBy::before_the_choice")]
    pub confirm_by: ConfirmBy,
    /// With [`ConfirmBy::Evidence`]: at most this many false sources an hour of
    /// background (sets the threshold `ln(N / F)` of `evidence`).
    #[serde(default = "default_false_per_hour")]
    pub false_per_hour: f64,
    /// With [`ConfirmBy::Rules`] (as the fields down to [`TrackParams::confirm_s`]):
    /// detections at or above the detection threshold a candidate needs to become a
    /// track.
    pub confirm_hits: usize,
    /// Or this many detections of any margin, one of them at or above the threshold
    /// (candidates included, see [`Talkers::candidates`](crate::method::Talkers::candidates)).
    pub confirm_candidates: usize,
    /// Or this many detections of any margin, none of them above the threshold: a run
    /// of candidates at one direction this dense is a source (a talker that other
    /// talkers keep under the threshold in every frame), not chance or a side lobe.
    #[serde(default = "default_confirm_weak")]
    pub confirm_weak: usize,
    /// Or this many detections of any margin, all within [`TrackParams::tight_deg`] of
    /// their mean direction: a run this steady is a talker that the others keep under
    /// the threshold, heard from one place (measured: a talker 90 deg from another on
    /// the prism at 48 kHz gave 9 candidates within 0.5 deg, and never 12).
    #[serde(default = "default_confirm_tight")]
    pub confirm_tight: usize,
    /// The spread (degrees) of [`TrackParams::confirm_tight`]'s detections.
    #[serde(default = "default_tight_deg")]
    pub tight_deg: f64,
    /// The runs of [`TrackParams::confirm_weak`] and [`TrackParams::confirm_tight`]
    /// confirm only when their detections span at least this many seconds. Consecutive
    /// frames share most of their averaged correlations (6 frames, 64-85 ms at the
    /// default frame sizes) and a talker's learned pattern is removed from a longer
    /// average (0.17 s), so a run shorter than that is one observation, not several: a
    /// wall's reflection of a talker left in that average gave 9 candidates in 72 ms,
    /// all within 0.5 deg, and a false event in a meeting on the prism at 16 kHz
    /// (docs/tracking.md). 0 for no such condition.
    #[serde(default = "default_weak_span_s")]
    pub weak_span_s: f64,
    /// The rules with a detection above the threshold ([`TrackParams::confirm_hits`],
    /// [`TrackParams::confirm_candidates`]) confirm a candidate only when one of its
    /// detections within the tracker's delay was heard alone: the frame's only
    /// detection, with no talking track heard within this many seconds before it. A
    /// talker's reflection is heard only while the talker is, and in a small room it can
    /// outscore the talker in a few frames: on the prism in a 5 x 4 x 2.7 m office, two
    /// such detections 14 deg from a talker made a false event in each of its turns; a
    /// second talker has moments of its own, and a talker that others keep under the
    /// threshold throughout is confirmed by the runs of candidates, which need no such
    /// moment (docs/tracking.md). 0 for no such condition.
    #[serde(default = "default_alone_s")]
    pub alone_s: f64,
    /// Within this many seconds (a window ending at the candidate's latest detection).
    pub confirm_s: f64,
    /// A candidate's detections wait this many seconds (at least
    /// [`TrackParams::confirm_s`]) for it to be confirmed, and all of them then become
    /// its track's rows: the tracker's delay. A talker that another keeps under the
    /// threshold is often heard in a few candidates, then not for a few tenths of a
    /// second, then confirmed; waiting longer than the confirmation window keeps those
    /// first candidates (docs/tracking.md). A shorter delay is taken as the
    /// confirmation window ([`TrackParams::delay`]).
    #[serde(default = "default_delay_s")]
    pub delay_s: f64,
    /// Association gate (degrees) right after a track's last detection, with
    /// [`ConfirmBy::Rules`] (with the evidence: 1.5 candidates' gates).
    pub gate_deg: f64,
    /// The gate (degrees) of a candidate under the detection threshold (see
    /// [`Talkers::candidates`](crate::method::Talkers::candidates)): it never widens.
    pub candidate_gate_deg: f64,
    /// A candidate's gate is at least this many samples of delay error on every pair,
    /// as the angle it moves a direction on the array at the recording's rate
    /// ([`Tracker::for_array`]; 0: never wider than [`TrackParams::candidate_gate_deg`]).
    /// 0.6 (three times the 0.2 sample a direction errs by on real speech) leaves 5
    /// deg on the prism and the 6- and 8-mic circles at 16 kHz and above, and opens
    /// 8 deg on a 6.5 cm tetrahedron at 16 kHz, whose rows err by 2-5 deg
    /// (docs/tracking.md); never more than `MAX_CANDIDATE_GATE_DEG`.
    #[serde(default = "default_candidate_gate_samples")]
    pub candidate_gate_samples: f64,
    /// The gate widens by this many degrees per second since a track's last detection.
    pub max_speed_deg_s: f64,
    /// The widest gate (degrees): 30, so that a talker turning at 60 deg/s through a
    /// 0.4 s pause keeps its track (at 25 it did not on the prism at 48 kHz; nothing
    /// else in docs/tracking.md changed).
    pub max_gate_deg: f64,
    /// A track silent for longer than this (seconds) ends its stretch of activity (with
    /// [`ConfirmBy::Evidence`], one silent for longer than the stretch so far, at least
    /// 0.3 s and at most this).
    pub end_s: f64,
    /// A silent track is forgotten after this many seconds (its id is never reused).
    pub forget_s: f64,
    /// Give out the detections no track confirmed too, without a track id, instead of
    /// dropping them (`--keep-unconfirmed`).
    #[serde(default)]
    pub keep_unconfirmed: bool,
    /// Each tracked row's direction is the mean of its track's rows within this many
    /// seconds of it, before and after ([`smoother`]); rows come out that much later.
    /// 0: every row keeps its frame's own direction.
    #[serde(default = "default_smooth_s")]
    pub smooth_s: f64,
}

impl Default for TrackParams {
    /// [`Tracking::default`]'s choices and the tracker's tuning.
    fn default() -> Self {
        let user = Tracking::default();
        TrackParams {
            confirm_by: user.confirm_by,
            false_per_hour: user.false_per_hour,
            confirm_hits: 2,
            confirm_candidates: 4,
            confirm_weak: 12,
            confirm_tight: 8,
            tight_deg: 1.5,
            weak_span_s: 0.15,
            alone_s: 0.1,
            confirm_s: user.confirm_s,
            delay_s: user.delay_s,
            gate_deg: 12.0,
            candidate_gate_deg: 5.0,
            candidate_gate_samples: 0.6,
            max_speed_deg_s: 60.0,
            max_gate_deg: 30.0,
            end_s: 1.0,
            forget_s: 120.0,
            keep_unconfirmed: user.keep_unconfirmed,
            smooth_s: user.smooth_s,
        }
    }
}

fn default_false_per_hour() -> f64 {
    TrackParams::default().false_per_hour
}

fn default_smooth_s() -> f64 {
    TrackParams::default().smooth_s
}

fn default_confirm_weak() -> usize {
    TrackParams::default().confirm_weak
}

fn default_confirm_tight() -> usize {
    TrackParams::default().confirm_tight
}

fn default_candidate_gate_samples() -> f64 {
    TrackParams::default().candidate_gate_samples
}

fn default_delay_s() -> f64 {
    TrackParams::default().delay_s
}

fn default_tight_deg() -> f64 {
    TrackParams::default().tight_deg
}

fn default_weak_span_s() -> f64 {
    TrackParams::default().weak_span_s
}

fn default_alone_s() -> f64 {
    TrackParams::default().alone_s
}

/// The widest a candidate's gate opens with the array's scatter
/// ([`TrackParams::candidate_gate_samples`]): the 6.5 cm tetrahedron at 8 kHz would open
/// 16 deg, and its single talkers' rows (`cargo bench --bench field -- track`) erred by
/// 3.7 deg with 19 confidently wrong (2.9 deg and 4 at 5 deg; 3.2 and 5 at 8).
pub(crate) const MAX_CANDIDATE_GATE_DEG: f64 = 8.0;

/// The longest confirmation window and delay (seconds): rows wait in memory that long,
/// so memory stays bounded whatever the recording's length.
pub(crate) const MAX_DELAY_S: f64 = 10.0;

/// The widest smoothing window ([`TrackParams::smooth_s`], seconds each side).
pub(crate) const MAX_SMOOTH_S: f64 = 1.0;

/// At most this many tracks are remembered at once (the oldest silent one goes first).
pub(crate) const MAX_TRACKS: usize = 64;

/// Why tracker parameters were refused.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum TrackParamsError {
    /// A parameter is out of its range.
    #[error("{0}")]
    Invalid(String),
}

impl TrackParams {
    /// The tracker's delay: [`TrackParams::delay_s`], or the confirmation window when
    /// that is longer.
    pub fn delay(&self) -> f64 {
        self.delay_s.max(self.confirm_s)
    }

    /// How long after its frame a row comes out at most: the tracker's delay, then the
    /// smoothing window after it ([`TrackParams::smooth_s`]).
    pub fn latency(&self) -> f64 {
        self.delay() + self.smooth_s
    }

    /// Checks every parameter.
    pub fn check(&self) -> Result<(), TrackParamsError> {
        let positive = [
            ("the confirmation window", self.confirm_s),
            ("the tracker's delay", self.delay_s),
            ("the gate", self.gate_deg),
            ("the candidates' gate", self.candidate_gate_deg),
            ("the widest gate", self.max_gate_deg),
            ("the spread of a steady run of candidates", self.tight_deg),
            ("the end of activity", self.end_s),
            ("the memory of silent tracks", self.forget_s),
        ];
        for (what, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                fail!(
                    TrackParamsError::Invalid,
                    "{what} must be a positive number, got {}",
                    crate::text::BriefNumber(v)
                );
            }
        }
        for (what, v) in [
            ("the confirmation window", self.confirm_s),
            ("the tracker's delay", self.delay_s),
        ] {
            if v > MAX_DELAY_S {
                fail!(
                    TrackParamsError::Invalid,
                    "{what} must be at most {MAX_DELAY_S} s (rows wait that long in memory), got {}",
                    crate::text::BriefNumber(v)
                );
            }
        }
        if !(self.false_per_hour.is_finite()
            && self.false_per_hour > 0.0
            && self.false_per_hour <= evidence::CANDIDATES_PER_HOUR)
        {
            fail!(
                TrackParamsError::Invalid,
                "the false sources an hour must be over 0 and at most {}, got {}",
                evidence::CANDIDATES_PER_HOUR,
                crate::text::BriefNumber(self.false_per_hour)
            );
        }
        if !(self.candidate_gate_samples.is_finite()
            && (0.0..=100.0).contains(&self.candidate_gate_samples))
        {
            fail!(
                TrackParamsError::Invalid,
                "the candidates' gate in samples must be 0 to 100, got {}",
                crate::text::BriefNumber(self.candidate_gate_samples)
            );
        }
        if !(self.weak_span_s.is_finite() && (0.0..=self.confirm_s).contains(&self.weak_span_s)) {
            fail!(
                TrackParamsError::Invalid,
                "the span of a run of candidates must be 0 to the confirmation window ({} s), got {}",
                crate::text::BriefNumber(self.confirm_s),
                crate::text::BriefNumber(self.weak_span_s)
            );
        }
        if !(self.alone_s.is_finite() && (0.0..=MAX_DELAY_S).contains(&self.alone_s)) {
            fail!(
                TrackParamsError::Invalid,
                "the time a detection must be heard alone must be 0 to {MAX_DELAY_S} s, got {}",
                crate::text::BriefNumber(self.alone_s)
            );
        }
        if !(self.smooth_s.is_finite() && (0.0..=MAX_SMOOTH_S).contains(&self.smooth_s)) {
            fail!(
                TrackParamsError::Invalid,
                "the smoothing window must be 0 to {MAX_SMOOTH_S} s, got {}",
                crate::text::BriefNumber(self.smooth_s)
            );
        }
        if !(self.max_speed_deg_s.is_finite() && self.max_speed_deg_s >= 0.0) {
            fail!(
                TrackParamsError::Invalid,
                "the largest speed must be a non-negative number, got {}",
                crate::text::BriefNumber(self.max_speed_deg_s)
            );
        }
        if self.confirm_hits == 0 || self.confirm_hits > 1000 {
            fail!(
                TrackParamsError::Invalid,
                "the detections that confirm a track must be 1 to 1000, got {}",
                self.confirm_hits
            );
        }
        if self.confirm_weak == 0 || self.confirm_weak > 1000 {
            fail!(
                TrackParamsError::Invalid,
                "the candidates that confirm a track alone must be 1 to 1000, got {}",
                self.confirm_weak
            );
        }
        if self.confirm_tight == 0 || self.confirm_tight > 1000 {
            fail!(
                TrackParamsError::Invalid,
                "the steady candidates that confirm a track alone must be 1 to 1000, got {}",
                self.confirm_tight
            );
        }
        if self.confirm_candidates == 0 || self.confirm_candidates > 1000 {
            fail!(
                TrackParamsError::Invalid,
                "the candidates that confirm a track must be 1 to 1000, got {}",
                self.confirm_candidates
            );
        }
        Ok(())
    }
}
