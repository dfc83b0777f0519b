//! The configuration ([`Config`]): what a user asks for, in units, one section per stage
//! and each section declared in its stage's file with its defaults, its flags and its
//! serde form. The presets (the defaults, the paper's method, untracked, a fixed
//! threshold) are its constructors; [`Config::resolved`] makes every choice that depends
//! on another explicit, and [`Config::settings`] turns it into what the method and the
//! tracker run with ([`Settings`]). `ssl analyze` parses its flags straight into a
//! [`Config`], and the JSON metadata records it resolved.

use crate::method::beyond::{DEFAULT_CANDIDATES, DEFAULT_RIDERS};
use crate::method::search::PAPER_TOLERANCE;
use crate::method::threshold::PAPER_MIN_SCORE_PER_PAIR;
use crate::method::weighting::DEFAULT_REVERB_LEVEL;
use crate::method::{
    Dereverb, Framing, Interpolation, Params, ParamsError, Peaks, Room, Steering, Talkers,
    Threshold, Tolerance, Weighting,
};
use crate::track::{TrackParams, TrackParamsError, Tracking};

/// What a user asks of a [`Localizer`](crate::Localizer), section by section, in units:
/// every option of `ssl analyze` that changes what is found. Start from a preset
/// ([`Config::default`], [`Config::paper`], [`Config::untracked`],
/// [`Config::fixed_threshold`], [`Config::every_frame`]) and change fields; a choice left to its preset (`None`)
/// is made by [`Config::resolved`].
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[cfg_attr(feature = "flags", command(next_help_heading = "Method"))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Config {
    /// The paper's method as published: a tolerance of 2 samples, a fixed threshold of 0.5 per pair, parabolic peaks, no residual gate, no averaging over frames, no background subtraction, no dereverberation, one source per frame
    #[cfg_attr(feature = "flags", arg(long, conflicts_with_all = ["tolerance", "tolerance_us", "residual_gate_us", "average_frames", "min_score", "threshold_sigmas", "reverb_level", "background_s", "dereverb", "wpe"]))]
    pub paper: bool,
    /// A direction for every frame with sound and no detection decision (what SRP-PHAT tools give): the consistent set when there is one, else the steered response's peak over the same weighted correlations; no tracker. The threshold only sets the cones: a row far under it may be a reflection or the noise, and its uncertainty_deg widens toward 180 (choose rows by it or by score yourself)
    #[cfg_attr(feature = "flags", arg(long, conflicts_with_all = ["paper", "max_sources", "confirm_by", "false_per_hour", "confirm_s", "delay_s", "smooth_s", "keep_unconfirmed", "forget_s"]))]
    pub every_frame: bool,
    /// Speed of sound in m/s [default: the geometry's, else 343]
    #[cfg_attr(feature = "flags", arg(short = 'c', long, value_name = "M/S", value_parser = crate::geometry::speed_of_sound_flag, hide_short_help = true))]
    pub speed_of_sound: Option<f64>,
    /// Frames: their size, window, and the part of each recording analysed.
    #[cfg_attr(feature = "flags", command(flatten, next_help_heading = "Frames"))]
    pub framing: Framing,
    /// The spectral weighting of eq. (4)-(5) and the band analysed.
    #[cfg_attr(
        feature = "flags",
        command(flatten, next_help_heading = "Spectral weighting")
    )]
    pub weighting: Weighting,
    /// The peaks kept per pair (eq. 7).
    #[cfg_attr(
        feature = "flags",
        command(flatten, next_help_heading = "Peaks and consistency")
    )]
    pub peaks: Peaks,
    /// The consistency tolerance of eq. (8).
    #[cfg_attr(feature = "flags", command(flatten))]
    pub tolerance: Tolerance,
    /// When a frame's best set is a detection.
    #[cfg_attr(
        feature = "flags",
        command(flatten, next_help_heading = "Detection threshold")
    )]
    pub threshold: Threshold,
    /// The room's reverberation and background, taken out.
    #[cfg_attr(
        feature = "flags",
        command(flatten, next_help_heading = "Reverberation and background")
    )]
    pub room: Room,
    /// Several talkers at once.
    #[cfg_attr(
        feature = "flags",
        command(flatten, next_help_heading = "Several talkers")
    )]
    pub talkers: Talkers,
    /// Detections grouped into sources.
    #[cfg_attr(feature = "flags", command(flatten, next_help_heading = "Tracking"))]
    pub tracking: Tracking,
    /// Add wall-clock times from each recording's Broadcast WAV time reference (bext: date and samples since midnight): `clock` on rows, `start_clock` and `end_clock` on events, ISO 8601 to the microsecond on the recorder's clock; a file without one is an error
    #[cfg_attr(feature = "flags", arg(long, help_heading = "Output"))]
    pub clock: bool,
}

impl Config {
    /// The paper's method as published (`ssl analyze --paper`), with the tracker.
    pub fn paper() -> Self {
        Config {
            paper: true,
            ..Config::default()
        }
    }

    /// A direction for every frame with sound, no tracker; the threshold only sets the
    /// cones (`ssl analyze --every-frame`).
    pub fn every_frame() -> Self {
        Config {
            every_frame: true,
            ..Config::default()
        }
    }

    /// Every frame's detection, no tracker (`ssl analyze --no-track`).
    pub fn untracked() -> Self {
        let mut c = Config::default();
        c.tracking.on = false;
        c
    }

    /// A fixed threshold of `per_pair` per microphone pair instead of the calibrated one
    /// (`ssl analyze --min-score`).
    pub fn fixed_threshold(per_pair: f64) -> Self {
        Config {
            threshold: Threshold::Fixed { per_pair },
            ..Config::default()
        }
    }

    /// Under the calibrated threshold with a tracker: what only a tracker confirms is on
    /// (the steered response, further sources, candidates). Under a fixed threshold sums
    /// of chance peaks pass the steered response, and candidates were mostly reflections
    /// (docs/method.md).
    fn for_tracker(&self) -> bool {
        !self.paper && !self.every_frame && self.tracking.on && self.threshold.is_calibrated()
    }

    /// A share of the threshold for the tracker (candidates, riders): the one `given`,
    /// else `default` under the calibrated threshold; 1 (none) without a tracker, with
    /// the paper's method, and by default with a fixed threshold.
    fn tracker_share(&self, given: Option<f64>, default: f64) -> f64 {
        if self.paper || self.every_frame || !self.tracking.on {
            1.0
        } else {
            given.unwrap_or(if self.threshold.is_calibrated() {
                default
            } else {
                1.0
            })
        }
    }

    /// The same configuration with every choice made: what a preset leaves to another
    /// option (`None`) is filled in, and what the paper's method, a fixed threshold or
    /// no tracker turns off is off. Running it gives the same results; resolving it
    /// again changes nothing.
    pub fn resolved(&self) -> Config {
        let mut r = self.clone();
        if self.paper {
            if let Tolerance::Us(_) = r.tolerance {
                r.tolerance = Tolerance::Samples(PAPER_TOLERANCE);
            }
            if r.threshold.is_calibrated() {
                r.threshold = Threshold::Fixed {
                    per_pair: PAPER_MIN_SCORE_PER_PAIR,
                };
            }
            r.room.residual_gate_us = 0.0;
            r.room.average_frames = 1;
            r.room.background_s = 0.0;
            r.room.dereverb = Dereverb::Off;
        }
        if self.every_frame {
            r.tracking.on = false;
        }
        let calibrated = r.threshold.is_calibrated();
        r.weighting.reverb_level = Some(self.weighting.reverb_level.unwrap_or(if calibrated {
            DEFAULT_REVERB_LEVEL
        } else {
            0.0
        }));
        r.peaks.interpolation = Some(self.peaks.interpolation.unwrap_or(if self.paper {
            Interpolation::Parabolic
        } else {
            Interpolation::Cosine
        }));
        let t = &self.talkers;
        let tracker = self.for_tracker();
        r.talkers = Talkers {
            max_sources: if tracker { t.max_sources } else { 1 },
            candidates: Some(self.tracker_share(t.candidates, DEFAULT_CANDIDATES)),
            riders: Some(self.tracker_share(t.riders, DEFAULT_RIDERS)),
            patterns_s: if tracker { t.patterns_s } else { 0.0 },
            bin_votes: tracker && t.bin_votes,
        };
        r
    }

    /// The method's parameters and the tracker's this configuration asks for, checked.
    pub fn settings(&self) -> Result<Settings, SettingsError> {
        let r = self.resolved();
        let method = Params {
            framing: r.framing,
            weighting: r.weighting,
            peaks: r.peaks,
            tolerance: r.tolerance,
            threshold: r.threshold,
            room: r.room,
            talkers: r.talkers,
            speed_of_sound: r.speed_of_sound,
            // Every frame's best direction: the steered response where no set is
            // consistent.
            steered: if self.every_frame {
                Steering::EveryFrame
            } else if self.for_tracker() {
                Steering::Partial
            } else {
                Steering::Off
            },
            frame_sources: self.for_tracker(),
            ..Params::default()
        };
        Settings::new(method, r.tracking.params())
    }
}

/// What a [`Localizer`](crate::Localizer) runs with: the method's parameters and the
/// tracker's (none: every frame's detection), checked together.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Settings {
    /// The method's parameters.
    pub method: Params,
    /// The tracker's parameters, or `None` for every frame's detection.
    pub track: Option<TrackParams>,
}

impl Settings {
    /// `method` and `track`, checked: every check that needs no recording is made here
    /// (the frame against the array's delays waits for the sample rate).
    pub fn new(method: Params, track: Option<TrackParams>) -> Result<Self, SettingsError> {
        method.check()?;
        if let Some(t) = &track {
            t.check()?;
        }
        Ok(Settings { method, track })
    }
}

/// Settings that cannot be run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SettingsError {
    /// A parameter of the method.
    #[error(transparent)]
    Method(#[from] ParamsError),
    /// A parameter of the tracker.
    #[error(transparent)]
    Track(#[from] TrackParamsError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::beyond::DEFAULT_PATTERNS_S;
    use crate::method::search::DEFAULT_TOLERANCE_US;
    use crate::method::threshold::DEFAULT_THRESHOLD_SIGMAS;

    fn settings(c: &Config) -> Settings {
        c.settings().expect("valid configuration")
    }

    #[test]
    fn the_defaults_track_with_everything_a_tracker_confirms() {
        let s = settings(&Config::default());
        let m = &s.method;
        assert!(s.track.is_some());
        assert!(m.steered == Steering::Partial && m.frame_sources && m.bin_votes_on());
        assert_eq!(
            (
                m.talkers.max_sources,
                m.talkers.candidate_share(),
                m.talkers.rider_share()
            ),
            (2, 0.4, 0.3)
        );
        assert_eq!(m.talkers.patterns_tau_s(), Some(DEFAULT_PATTERNS_S));
        assert_eq!(
            m.threshold,
            Threshold::Calibrated {
                sigmas: DEFAULT_THRESHOLD_SIGMAS
            }
        );
        assert_eq!(m.tolerance, Tolerance::Us(DEFAULT_TOLERANCE_US));
    }

    #[test]
    fn untracked_is_the_method_alone_which_params_default_is() {
        let s = settings(&Config::untracked());
        assert!(s.track.is_none());
        assert_eq!(s.method, Params::default());
        let m = &s.method;
        assert!(m.steered == Steering::Off && !m.frame_sources && !m.bin_votes_on());
        assert_eq!(
            (
                m.talkers.max_sources,
                m.talkers.candidate_share(),
                m.talkers.rider_share()
            ),
            (1, 1.0, 1.0)
        );
    }

    #[test]
    fn the_paper_preset_is_the_published_method() {
        let m = settings(&Config::paper()).method;
        assert_eq!(m.tolerance, Tolerance::Samples(2.0));
        assert_eq!(m.room.gate_us(), None);
        assert_eq!(
            (m.room.average_frames, m.room.background_tau_s()),
            (1, None)
        );
        assert_eq!(m.threshold, Threshold::Fixed { per_pair: 0.5 });
        assert_eq!(
            (m.weighting.reverb_share(), m.room.dereverb),
            (0.0, Dereverb::Off)
        );
        assert_eq!(m.peaks.refinement(), Interpolation::Parabolic);
        assert!(m.steered == Steering::Off && m.talkers.max_sources == 1);
        assert_eq!(m.talkers.candidate_share(), 1.0);
        // A given interpolation is kept.
        let mut c = Config::paper();
        c.peaks.interpolation = Some(Interpolation::Cosine);
        assert_eq!(
            settings(&c).method.peaks.refinement(),
            Interpolation::Cosine
        );
    }

    #[test]
    fn every_frame_is_the_steered_response_without_a_tracker_its_threshold_for_the_cones() {
        let s = settings(&Config::every_frame());
        assert!(s.track.is_none());
        let m = &s.method;
        // The defaults' threshold and weighting, which set the cones and hold back nothing.
        let d = settings(&Config::default()).method;
        assert_eq!(
            (m.threshold, m.weighting.reverb_level),
            (d.threshold, d.weighting.reverb_level)
        );
        assert!(
            m.steered == Steering::EveryFrame && !m.frame_sources && m.talkers.max_sources == 1
        );
    }

    #[test]
    fn a_fixed_threshold_turns_off_what_only_the_calibrated_one_allows() {
        let m = settings(&Config::fixed_threshold(0.3)).method;
        assert_eq!(m.threshold, Threshold::Fixed { per_pair: 0.3 });
        assert_eq!(m.weighting.reverb_share(), 0.0);
        assert!(m.steered == Steering::Off && !m.talkers.bin_votes && m.talkers.max_sources == 1);
        assert_eq!(
            (m.talkers.candidate_share(), m.talkers.rider_share()),
            (1.0, 1.0)
        );
        // Candidates asked for are kept for the tracker.
        let mut c = Config::fixed_threshold(0.3);
        c.talkers.candidates = Some(0.5);
        assert_eq!(settings(&c).method.talkers.candidate_share(), 0.5);
    }

    /// Every preset, and each with the choices a preset leaves open given: resolving
    /// makes each choice explicit, runs the same, and a second time changes nothing.
    #[test]
    fn resolving_runs_the_same_and_is_done_once() {
        let mut given = Config::default();
        given.peaks.interpolation = Some(Interpolation::None);
        given.weighting.reverb_level = Some(0.2);
        given.talkers.candidates = Some(0.6);
        given.tolerance = Tolerance::Samples(1.5);
        for c in [
            Config::default(),
            Config::paper(),
            Config::every_frame(),
            Config::untracked(),
            Config::fixed_threshold(0.3),
            given,
        ] {
            let r = c.resolved();
            assert_eq!(r.resolved(), r, "{c:?}");
            assert_eq!(settings(&r), settings(&c), "{c:?}");
            assert!(r.weighting.reverb_level.is_some() && r.peaks.interpolation.is_some());
            assert!(r.talkers.candidates.is_some() && r.talkers.riders.is_some());
            // The JSON form reads back as the same configuration.
            let json = serde_json::to_string(&r).unwrap();
            assert_eq!(serde_json::from_str::<Config>(&json).unwrap(), r, "{json}");
        }
    }

    #[test]
    fn bad_configurations_are_refused_once_with_what_is_wrong() {
        let mut c = Config::default();
        c.peaks.count = 0;
        assert_eq!(
            c.settings(),
            Err(SettingsError::Method(ParamsError::Peaks(0)))
        );
        let c = Config {
            tolerance: Tolerance::Us(f64::NAN),
            ..Config::default()
        };
        assert!(matches!(
            c.settings(),
            Err(SettingsError::Method(ParamsError::ToleranceUs(_)))
        ));
        let mut c = Config::default();
        c.tracking.smooth_s = 5.0;
        assert!(matches!(c.settings(), Err(SettingsError::Track(_))));
        // Without a tracker its options are not checked: they are not used.
        c.tracking.on = false;
        assert!(c.settings().is_ok());
    }
}
