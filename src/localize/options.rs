//! What a user asks for ([`Options`]: the command line's flags, one field each, in
//! units) and what the method and the tracker then run with ([`Settings`]). The presets
//! (the defaults, the paper's method, untracked, a fixed threshold) and every rule that
//! ties one option to another live here, once: `ssl analyze` only copies its flags into
//! an [`Options`].

use crate::method::{
    Dereverb, Interpolation, Params, ParamsError, Window, DEFAULT_AVERAGE_FRAMES,
    DEFAULT_BACKGROUND_S, DEFAULT_CANDIDATES, DEFAULT_MAX_SOURCES, DEFAULT_MIN_SCORE_PER_PAIR,
    DEFAULT_PATTERNS_S, DEFAULT_PEAKS, DEFAULT_RESIDUAL_GATE_US, DEFAULT_REVERB_LEVEL,
    DEFAULT_RIDERS, DEFAULT_THRESHOLD_SIGMAS, DEFAULT_TOLERANCE, DEFAULT_TOLERANCE_US,
};
use crate::track::{ConfirmBy, TrackParams, TrackParamsError};

/// What a user asks of a [`Localizer`](super::Localizer): one field per option of
/// `ssl analyze`, in its units. Start from a preset ([`Options::default`],
/// [`Options::paper`], [`Options::untracked`], [`Options::fixed_threshold`]) and change
/// fields; [`Options::settings`] resolves them. A field the preset does not use (the
/// tolerance in microseconds under the paper's method) is ignored, as the command line
/// refuses the combination.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Options {
    /// The paper's method as published (`--paper`): a tolerance of 2 samples, no residual
    /// gate, no averaging over frames, no background subtraction, no candidates, a fixed
    /// threshold, parabolic peaks.
    pub paper: bool,
    /// Group detections into tracked sources (`--no-track` turns it off): rows carry a
    /// source, unconfirmed detections are dropped, events can be written.
    pub track: bool,
    /// Frame size N in samples (`None`: from `frame_ms`, else about 21 ms at each rate).
    pub frame_size: Option<usize>,
    /// Frame length in milliseconds (N the nearest power of two at each rate).
    pub frame_ms: Option<f64>,
    /// `alpha` of eq. (4).
    pub alpha: f32,
    /// `gamma` of eq. (5).
    pub gamma: f32,
    /// The spectral weighting (`false`: plain PHAT).
    pub weighting: bool,
    /// Peaks M kept per pair.
    pub peaks: usize,
    /// Consistency tolerance in samples; when given it replaces `tolerance_us`.
    pub tolerance: Option<f32>,
    /// Consistency tolerance in microseconds.
    pub tolerance_us: f64,
    /// Residual gate in microseconds (0: none).
    pub residual_gate_us: f64,
    /// Frames each pair's correlation is averaged over (1: none).
    pub average_frames: usize,
    /// Time constant of the steady background subtracted (seconds; 0: none).
    pub background_s: f64,
    /// Overrides the geometry's speed of sound (m/s).
    pub speed_of_sound: Option<f64>,
    /// A fixed threshold per microphone pair instead of the calibrated one.
    pub min_score: Option<f64>,
    /// The calibrated threshold's allowance for chance (standard deviations).
    pub threshold_sigmas: f64,
    /// Share of late reverberation in the noise estimate (`None`: 0.5, or 0 with the
    /// paper's method or a fixed threshold).
    pub reverb_level: Option<f32>,
    /// The analysis window.
    pub window: Window,
    /// Sub-sample refinement of the peaks (`None`: cosine, or parabolic with the paper's
    /// method).
    pub interpolation: Option<Interpolation>,
    /// When the reverberation's diffuse part is removed from the cross-spectra.
    pub dereverb: Dereverb,
    /// Dereverberate the input first (WPE; about 15 times the rest of the analysis).
    pub wpe: bool,
    /// Where to start (seconds from the start of the recording).
    pub start_s: f64,
    /// Where to end (`None`: the end of the recording).
    pub end_s: Option<f64>,
    /// The frequencies analysed, `(low, high)` in Hz (`None`: all).
    pub band_hz: Option<(f64, f64)>,
    /// Rows and events carry wall-clock times from each recording's Broadcast WAV time
    /// reference (`--clock`; see [`Localizer::with_clock`](super::Localizer::with_clock)).
    pub clock: bool,
    /// Riders from single frequency bins on small arrays (with a tracker).
    pub bin_votes: bool,
    /// The most sources one frame gives (1 to 4; 1 with the paper's method, a fixed
    /// threshold or no tracker).
    pub max_sources: usize,
    /// Candidates down to this share of the threshold (`None`: 0.4 with the calibrated
    /// threshold and a tracker, else 1: none).
    pub candidates: Option<f64>,
    /// Riders down to this share of the threshold (`None`: 0.3 with the calibrated
    /// threshold and a tracker, else 1: none).
    pub riders: Option<f64>,
    /// Time constant of the average each talker's pattern is removed from (seconds; 0:
    /// none).
    pub patterns_s: f64,
    /// Write the detections no track confirmed too, without a source.
    pub keep_unconfirmed: bool,
    /// How a candidate becomes a source.
    pub confirm_by: ConfirmBy,
    /// With [`ConfirmBy::Evidence`]: at most this many false sources an hour.
    pub false_per_hour: f64,
    /// A track's confirmation window (seconds, [`ConfirmBy::Rules`]).
    pub confirm_s: f64,
    /// The tracker's delay (seconds).
    pub delay_s: f64,
    /// Each tracked row's direction smoothed over this many seconds each side.
    pub smooth_s: f64,
}

impl Default for Options {
    /// What `ssl analyze` runs with no option.
    fn default() -> Self {
        let track = TrackParams::default();
        Options {
            paper: false,
            track: true,
            frame_size: None,
            frame_ms: None,
            alpha: crate::method::weighting::ALPHA,
            gamma: crate::method::weighting::GAMMA,
            weighting: true,
            peaks: DEFAULT_PEAKS,
            tolerance: None,
            tolerance_us: DEFAULT_TOLERANCE_US,
            residual_gate_us: DEFAULT_RESIDUAL_GATE_US,
            average_frames: DEFAULT_AVERAGE_FRAMES,
            background_s: DEFAULT_BACKGROUND_S,
            speed_of_sound: None,
            min_score: None,
            threshold_sigmas: DEFAULT_THRESHOLD_SIGMAS,
            reverb_level: None,
            window: Window::Hann,
            interpolation: None,
            dereverb: Dereverb::Auto,
            wpe: false,
            start_s: 0.0,
            end_s: None,
            band_hz: None,
            clock: false,
            bin_votes: true,
            max_sources: DEFAULT_MAX_SOURCES,
            candidates: None,
            riders: None,
            patterns_s: DEFAULT_PATTERNS_S,
            keep_unconfirmed: false,
            confirm_by: track.confirm_by,
            false_per_hour: track.false_per_hour,
            confirm_s: track.confirm_s,
            delay_s: track.delay_s,
            smooth_s: track.smooth_s,
        }
    }
}

impl Options {
    /// The paper's method as published (`ssl analyze --paper`), with the tracker.
    pub fn paper() -> Self {
        Options {
            paper: true,
            ..Options::default()
        }
    }

    /// Every frame's detection, no tracker (`ssl analyze --no-track`).
    pub fn untracked() -> Self {
        Options {
            track: false,
            ..Options::default()
        }
    }

    /// A fixed threshold of `per_pair` per microphone pair instead of the calibrated one
    /// (`ssl analyze --min-score`).
    pub fn fixed_threshold(per_pair: f64) -> Self {
        Options {
            min_score: Some(per_pair),
            ..Options::default()
        }
    }

    /// Under the calibrated threshold with a tracker: what only a tracker confirms is on
    /// (the steered response, further sources, candidates). Under a fixed threshold sums
    /// of chance peaks pass the steered response, and candidates were mostly reflections
    /// (docs/method.md).
    fn for_tracker(&self) -> bool {
        !self.paper && self.track && self.min_score.is_none()
    }

    /// A share of the threshold for the tracker (candidates, riders): the one `given`,
    /// else `default` under the calibrated threshold; 1 (none) without a tracker, with
    /// the paper's method, and by default with a fixed threshold.
    fn tracker_share(&self, given: Option<f64>, default: f64) -> f64 {
        if self.paper || !self.track {
            1.0
        } else {
            given.unwrap_or(if self.min_score.is_some() {
                1.0
            } else {
                default
            })
        }
    }

    /// The method's parameters and the tracker's these options ask for, checked.
    pub fn settings(&self) -> Result<Settings, SettingsError> {
        let paper = self.paper;
        let calibrated = !paper && self.min_score.is_none();
        let method = Params {
            frame_size: self.frame_size,
            frame_ms: self.frame_ms,
            alpha: self.alpha,
            gamma: self.gamma,
            weighting: self.weighting,
            peaks: self.peaks,
            tolerance: self.tolerance.unwrap_or(DEFAULT_TOLERANCE),
            tolerance_us: (!paper && self.tolerance.is_none()).then_some(self.tolerance_us),
            residual_gate_us: (!paper && self.residual_gate_us > 0.0)
                .then_some(self.residual_gate_us),
            speed_of_sound: self.speed_of_sound,
            min_score_per_pair: self.min_score.unwrap_or(DEFAULT_MIN_SCORE_PER_PAIR),
            threshold_sigmas: calibrated.then_some(self.threshold_sigmas),
            reverb_level: self.reverb_level.unwrap_or(if calibrated {
                DEFAULT_REVERB_LEVEL
            } else {
                0.0
            }),
            window: self.window,
            interpolation: self.interpolation.unwrap_or(if paper {
                Interpolation::Parabolic
            } else {
                Interpolation::Cosine
            }),
            background_s: (!paper && self.background_s > 0.0).then_some(self.background_s),
            dereverb: if paper { Dereverb::Off } else { self.dereverb },
            average_frames: if paper { 1 } else { self.average_frames },
            steered: self.for_tracker(),
            frame_sources: self.for_tracker(),
            patterns_s: (self.for_tracker() && self.patterns_s > 0.0).then_some(self.patterns_s),
            max_sources: if self.for_tracker() {
                self.max_sources
            } else {
                1
            },
            candidates: self.tracker_share(self.candidates, DEFAULT_CANDIDATES),
            riders: self.tracker_share(self.riders, DEFAULT_RIDERS),
            wpe: self.wpe,
            start_s: self.start_s,
            end_s: self.end_s,
            band_hz: self.band_hz,
            bin_votes: calibrated && self.bin_votes,
            ..Params::default()
        };
        let defaults = TrackParams::default();
        let track = self.track.then(|| TrackParams {
            confirm_by: self.confirm_by,
            false_per_hour: self.false_per_hour,
            confirm_s: self.confirm_s,
            // A run of candidates spans at most the window it is counted over.
            weak_span_s: defaults.weak_span_s.min(self.confirm_s),
            delay_s: self.delay_s,
            keep_unconfirmed: self.keep_unconfirmed,
            smooth_s: self.smooth_s,
            ..defaults
        });
        Settings::new(method, track)
    }
}

/// What a [`Localizer`](super::Localizer) runs with: the method's parameters and the
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
    use crate::method::ParamsError;

    fn settings(o: &Options) -> Settings {
        o.settings().expect("valid options")
    }

    #[test]
    fn the_defaults_track_with_everything_a_tracker_confirms() {
        let s = settings(&Options::default());
        let m = &s.method;
        assert!(s.track.is_some());
        assert!(m.steered && m.frame_sources && m.bin_votes_on());
        assert_eq!((m.max_sources, m.candidates, m.riders), (2, 0.4, 0.3));
        assert_eq!(m.patterns_s, Some(DEFAULT_PATTERNS_S));
        assert_eq!(m.threshold_sigmas, Some(DEFAULT_THRESHOLD_SIGMAS));
        assert_eq!(m.tolerance_us, Some(DEFAULT_TOLERANCE_US));
    }

    #[test]
    fn untracked_is_the_method_alone_which_params_default_is() {
        let s = settings(&Options::untracked());
        assert!(s.track.is_none());
        assert_eq!(s.method, Params::default());
        let m = &s.method;
        assert!(!m.steered && !m.frame_sources && !m.bin_votes_on());
        assert_eq!((m.max_sources, m.candidates, m.riders), (1, 1.0, 1.0));
    }

    #[test]
    fn the_paper_preset_is_the_published_method() {
        let m = settings(&Options::paper()).method;
        assert_eq!((m.tolerance, m.tolerance_us), (2.0, None));
        assert_eq!(m.residual_gate_us, None);
        assert_eq!((m.average_frames, m.background_s), (1, None));
        assert_eq!((m.threshold_sigmas, m.min_score_per_pair), (None, 0.5));
        assert_eq!((m.reverb_level, m.dereverb), (0.0, Dereverb::Off));
        assert_eq!(m.interpolation, Interpolation::Parabolic);
        assert!(!m.steered && m.max_sources == 1 && m.candidates == 1.0);
        // A given interpolation is kept.
        let mut o = Options::paper();
        o.interpolation = Some(Interpolation::Cosine);
        assert_eq!(settings(&o).method.interpolation, Interpolation::Cosine);
    }

    #[test]
    fn a_fixed_threshold_turns_off_what_only_the_calibrated_one_allows() {
        let m = settings(&Options::fixed_threshold(0.3)).method;
        assert_eq!((m.min_score_per_pair, m.threshold_sigmas), (0.3, None));
        assert_eq!(m.reverb_level, 0.0);
        assert!(!m.steered && !m.bin_votes && m.max_sources == 1);
        assert_eq!((m.candidates, m.riders), (1.0, 1.0));
        // Candidates asked for are kept for the tracker.
        let mut o = Options::fixed_threshold(0.3);
        o.candidates = Some(0.5);
        assert_eq!(settings(&o).method.candidates, 0.5);
    }

    #[test]
    fn bad_options_are_refused_once_with_what_is_wrong() {
        let o = Options {
            peaks: 0,
            ..Options::default()
        };
        assert_eq!(
            o.settings(),
            Err(SettingsError::Method(ParamsError::Peaks(0)))
        );
        let o = Options {
            tolerance_us: f64::NAN,
            ..Options::default()
        };
        assert!(matches!(
            o.settings(),
            Err(SettingsError::Method(ParamsError::ToleranceUs(_)))
        ));
        let mut o = Options {
            smooth_s: 5.0,
            ..Options::default()
        };
        assert!(matches!(o.settings(), Err(SettingsError::Track(_))));
        // Without a tracker its options are not checked: they are not used.
        o.track = false;
        assert!(o.settings().is_ok());
    }
}
