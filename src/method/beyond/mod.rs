//! The stages beyond the paper, each in its own file with the measurements that chose it
//! (docs/method.md): the threshold calibrated against the background, the steady
//! background subtracted from the correlations, the reverberation's diffuse part removed
//! from the cross-spectra, the steered response (partial agreement, further sources),
//! further sources from a frame's own correlations, each talker's learned pattern
//! removed before a second look, the directions of single frequency bins, and a count
//! of pairs whose delays run past the geometry's. They use
//! the paper's stages and the frame's layout and state; the engine
//! ([`super::engine`]) builds their plans and calls them.

pub(crate) mod background;
pub(crate) mod dereverb;
pub(crate) mod edges;
pub(crate) mod frame_sources;
pub(crate) mod patterns;
pub(crate) mod steered;
pub(crate) mod threshold;
pub(crate) mod votes;

use crate::geometry::Shape;
use crate::Named;

/// The most sources one frame can give (`--max-sources`).
pub(crate) const MAX_SOURCES: usize = 4;
/// The most sources one frame gives by default with a tracker.
pub(crate) const DEFAULT_MAX_SOURCES: usize = 2;
/// Default time constant of the coherent background estimate (seconds).
pub(crate) const DEFAULT_BACKGROUND_S: f64 = 2.0;
/// Default time constant (seconds) of the longer average each talker's pattern is
/// removed from.
pub(crate) const DEFAULT_PATTERNS_S: f64 = 0.17;
/// The share of the detection threshold down to which candidates are reported for a
/// tracker: 0.4 finds two and three talkers at once in more windows than 0.5 with no
/// false event or track in any benchmark (docs/method.md).
pub(crate) const DEFAULT_CANDIDATES: f64 = 0.4;
/// The share of the detection threshold down to which the frames that give nothing down
/// to the candidates' share are searched again for riders: a talking track's rows in the
/// frames where its talker is weakest (docs/method.md).
pub(crate) const DEFAULT_RIDERS: f64 = 0.3;
/// Default number of frames each correlation is averaged over: the frame and the five
/// before it, 75 ms at the default frame size (docs/field.md).
pub(crate) const DEFAULT_AVERAGE_FRAMES: usize = 6;
/// The most frames a correlation can be averaged over.
pub(crate) const MAX_AVERAGE_FRAMES: usize = 64;
/// Default residual gate in microseconds (docs/field.md).
pub(crate) const DEFAULT_RESIDUAL_GATE_US: f64 = 100.0;

/// What the room adds to the correlations and how it is taken out (beyond the paper;
/// `--paper` turns each off).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Room {
    /// Drop detections whose delays no single source fits (plane wave, or spherical wave from 0.25-3 m) with an RMS residual under this many microseconds; 0 turns the gate off
    #[cfg_attr(feature = "flags", arg(long, value_name = "US", default_value_t = DEFAULT_RESIDUAL_GATE_US, value_parser = crate::flags::non_negative_f64, hide_short_help = true))]
    pub residual_gate_us: f64,
    /// Average each pair's correlation over this many frames: the frame's own and the ones before it (1: none, as in the paper)
    #[cfg_attr(feature = "flags", arg(long, value_name = "FRAMES", default_value_t = DEFAULT_AVERAGE_FRAMES, value_parser = crate::flags::count(1..=MAX_AVERAGE_FRAMES), hide_short_help = true))]
    pub average_frames: usize,
    /// Subtract from each pair's correlation its steady background (a fan next to the array), learned over about this many seconds; 0: none, as in the paper
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = DEFAULT_BACKGROUND_S, value_parser = crate::flags::non_negative_f64, hide_short_help = true))]
    pub background_s: f64,
    /// Remove the reverberation's diffuse part from each pair's cross-spectrum (its coherence over the frames averaged) before correlating: a room shortens the delays by a few percent, which raises a planar array's elevations by 5-13 deg
    #[cfg_attr(feature = "flags", arg(long, default_value = "auto", value_parser = crate::flags::choice::<Dereverb>(), hide_short_help = true))]
    pub dereverb: Dereverb,
    /// Dereverberate the input before analysis (multichannel linear prediction, WPE, below 4 kHz): more of a reverberant room's speech is found (two talkers 2 m from the prism at RT60 0.45 s: 74% of the 0.1 s windows instead of 68%), at about 15 times the time; at most 32 microphones
    #[cfg_attr(feature = "flags", arg(long))]
    pub wpe: bool,
}

impl Default for Room {
    fn default() -> Self {
        Room {
            residual_gate_us: DEFAULT_RESIDUAL_GATE_US,
            average_frames: DEFAULT_AVERAGE_FRAMES,
            background_s: DEFAULT_BACKGROUND_S,
            dereverb: Dereverb::Auto,
            wpe: false,
        }
    }
}

impl Room {
    /// The residual gate in microseconds, if on.
    pub(crate) fn gate_us(&self) -> Option<f64> {
        (self.residual_gate_us > 0.0).then_some(self.residual_gate_us)
    }

    /// The background's time constant in seconds, if it is subtracted.
    pub(crate) fn background_tau_s(&self) -> Option<f64> {
        (self.background_s > 0.0).then_some(self.background_s)
    }
}

/// Several talkers at once: what the method reports beyond each frame's best source, for
/// a tracker to confirm (beyond the paper; only with the calibrated threshold and a
/// tracker).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Talkers {
    /// The most sources reported in one frame (1 to 4), for the tracker to confirm; a further source must pass the threshold on its own (1 with --min-score or --no-track)
    #[cfg_attr(feature = "flags", arg(long, value_name = "K", default_value_t = DEFAULT_MAX_SOURCES, value_parser = crate::flags::count(1..=MAX_SOURCES), conflicts_with_all = ["paper", "min_score", "no_track"], hide_short_help = true))]
    pub max_sources: usize,
    /// Also report candidates down to this share of the detection threshold, for the tracker to confirm (a track starts from 2 detections above the threshold, 4 of which 1 is above it, or 12 candidates within --confirm-s) or drop [default: 0.4 with the calibrated threshold, 1 (none) with --min-score]
    #[cfg_attr(feature = "flags", arg(long, value_name = "SHARE", value_parser = crate::flags::share, conflicts_with_all = ["no_track", "paper"], hide_short_help = true))]
    pub candidates: Option<f64>,
    /// Search a frame that gives nothing down to --candidates again down to this share of the threshold: what it gives only adds a row to a talking track within a candidate's gate, without moving it, and starts nothing; at or above --candidates, none [default: 0.3 with the calibrated threshold, 1 (none) with --min-score]
    #[cfg_attr(feature = "flags", arg(long, value_name = "SHARE", value_parser = crate::flags::share, conflicts_with_all = ["no_track", "paper"], hide_short_help = true))]
    pub riders: Option<f64>,
    /// Learn each talker's correlation pattern (its reflections too) while it dominates, and look for other talkers once it is removed from each pair's correlation averaged over about this many seconds; in frames that give nothing, that average's best direction adds up a faint talker's frames (arrays whose longest delay is 8 samples or more); 0: neither
    #[cfg_attr(feature = "flags", arg(long, value_name = "SECONDS", default_value_t = DEFAULT_PATTERNS_S, value_parser = crate::flags::non_negative_f64, conflicts_with_all = ["no_track", "paper", "min_score"], hide_short_help = true))]
    pub patterns_s: f64,
    /// No riders from single frequency bins: on arrays a few centimetres across, each bin's own direction finds a talker that a louder one hides in the correlations, and adds its rows to that talker's track (two talkers on a 6-mic circle at 16 kHz: 60-70% of the 0.1 s windows instead of 56-66%)
    #[cfg_attr(feature = "flags", arg(long = "no-bin-votes", id = "no_bin_votes", action = clap::ArgAction::SetFalse, conflicts_with_all = ["no_track", "paper"], hide_short_help = true))]
    pub bin_votes: bool,
}

impl Talkers {
    /// One source per frame and nothing below the threshold: the method alone, without
    /// a tracker to confirm the rest.
    pub(crate) fn alone() -> Self {
        Talkers {
            max_sources: 1,
            candidates: Some(1.0),
            riders: Some(1.0),
            patterns_s: 0.0,
            bin_votes: false,
        }
    }

    /// Candidates' share of the threshold as the stages read it (1: none), reported with
    /// [`Detection::margin`](super::Detection::margin) under 1.
    pub(crate) fn candidate_share(&self) -> f64 {
        self.candidates.unwrap_or(1.0)
    }

    /// Riders' share of the threshold as the stages read it (1: none), reported as
    /// [`Detection::rider`](super::Detection::rider).
    pub(crate) fn rider_share(&self) -> f64 {
        self.riders.unwrap_or(1.0)
    }

    /// The talkers' patterns' time constant in seconds, if they are learned.
    pub(crate) fn patterns_tau_s(&self) -> Option<f64> {
        (self.patterns_s > 0.0).then_some(self.patterns_s)
    }
}

impl Default for Talkers {
    fn default() -> Self {
        Talkers {
            max_sources: DEFAULT_MAX_SOURCES,
            candidates: None,
            riders: None,
            patterns_s: DEFAULT_PATTERNS_S,
            bin_votes: true,
        }
    }
}

/// When the diffuse part is removed ([`Room::dereverb`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dereverb {
    /// For planar and linear arrays (the default): they read directions from how long
    /// their delays are, which the diffuse part shortens. A 3-D array's directions hardly
    /// move, and summing cross-spectra over frames favours the louder of two talkers at
    /// once (measured in docs/field.md and docs/tracking.md).
    Auto,
    /// For every array.
    On,
    /// Never (`--paper`'s).
    Off,
}

impl Named for Dereverb {
    const ALL: &'static [(Dereverb, &'static str, &'static str)] = &[
        (
            Dereverb::Auto,
            "auto",
            "For planar and linear arrays, whose directions the reverberation biases most (the default)",
        ),
        (Dereverb::On, "on", "For every array"),
        (Dereverb::Off, "off", "Never (--paper's)"),
    ];
}

impl Dereverb {
    /// Whether it applies to an array of this shape.
    pub fn applies(self, shape: &Shape) -> bool {
        match self {
            Dereverb::Auto => !matches!(shape, Shape::Volumetric),
            Dereverb::On => true,
            Dereverb::Off => false,
        }
    }
}
