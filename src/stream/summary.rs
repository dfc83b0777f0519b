//! What a recording that was analysed reports: its facts, its counters and what the
//! user should know about it ([`Warning`]).

use crate::method::{FrameStats, StageTimes};
use std::fmt;

/// Something the user should know about a recording that was analysed.
#[derive(Debug, Clone, PartialEq)]
pub enum Warning {
    /// Every channel was constant.
    Silence,
    /// A microphone's channel was constant in some frames, which left it out of them.
    DeadMic {
        /// 0-based microphone.
        mic: usize,
        /// Its channel in the recording.
        channel: usize,
        /// Frames where it was constant.
        frames: u64,
        /// Frames analysed.
        of: u64,
    },
    /// Something about the input itself (a WAV whose sizes wrapped at 4 GiB).
    Input(String),
    /// The array's largest delay is only a few samples at the recording's rate: delays,
    /// and so directions, are coarse.
    CoarseDelays {
        /// The largest delay between two microphones (samples).
        samples: f64,
        /// The sample rate (Hz).
        sample_rate: u32,
    },
    /// `--band` holds so few frequency bins that even a perfectly coherent source
    /// stands little above the calibrated threshold's allowance for chance.
    NarrowBand {
        /// The bins in the band.
        bins: usize,
        /// The chance deviations the threshold allows for.
        sigmas: f64,
        /// The frame size.
        frame_size: usize,
        /// The sample rate (Hz).
        sample_rate: u32,
    },
    /// Many pairs' correlations peaked past the longest delay the geometry allows.
    BeyondGeometry {
        /// Pairs (over the frames) that heard a clear sound.
        pairs: u64,
        /// Of those, the ones that peaked past the geometry's delays.
        beyond: u64,
    },
    /// Hardly any frame (under 1%) gave a detection: why, as far as the run can tell.
    FewDetections {
        /// Frames with a detection.
        detections: u64,
        /// Frames analysed.
        frames: u64,
        /// The best score per microphone pair of any consistent set searched.
        best_per_pair: Option<f64>,
        /// The most any frame decided before its search could have scored per pair.
        bound_per_pair: Option<f64>,
        /// The fixed threshold per pair, or `None` for the calibrated one.
        threshold_per_pair: Option<f64>,
        /// The recording's loudness stays within 6 dB from start to end, and the
        /// spectral weighting is on: a source on from the first sample is background to it.
        steady: bool,
    },
    /// The consistency search stopped at its budget in some frames.
    SearchBudget {
        /// Frames where it did.
        frames: u64,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            Warning::Input(note) => f.write_str(note),
            Warning::CoarseDelays { samples, sample_rate } => write!(
                f,
                "the array's largest delay is only {samples:.1} samples at {sample_rate} Hz: delays, and so directions, are coarse (a higher sample rate or a wider array helps)"
            ),
            Warning::NarrowBand { bins, sigmas, frame_size, sample_rate } => write!(
                f,
                "the band holds {bins} frequency bins of a {frame_size}-sample frame at {sample_rate} Hz: a source's correlation stands at most about sqrt(2 x {bins}) = {:.1} chance deviations high, and the threshold asks for {}, so only clear, coherent sources are found (a longer frame, --frame-size {}, has about {} bins)",
                (2.0 * *bins as f64).sqrt(),
                crate::text::BriefNumber(*sigmas),
                frame_size * 4,
                bins * 4
            ),
            Warning::BeyondGeometry { pairs, beyond } => write!(
                f,
                "the delays keep exceeding what the geometry allows: {:.0}% of the microphone pairs that heard a clear sound ({beyond} of {pairs}) peaked past the longest delay their spacing allows; the positions may be too small (they are metres), or the sample rate, the speed of sound or the channel order wrong: `ssl check` tells which",
                100.0 * *beyond as f64 / *pairs as f64
            ),
            Warning::Silence => write!(f, "every channel is constant (digital silence): no detections"),
            Warning::DeadMic { mic, channel, frames, of } => write!(
                f,
                "mic {} (channel {channel}) is constant (dead or disconnected?) in {frames} of {of} frames; it was left out of those frames' pairs",
                mic + 1
            ),
            Warning::FewDetections {
                detections,
                frames,
                best_per_pair,
                bound_per_pair,
                threshold_per_pair,
                steady,
            } => {
                write!(f, "{detections} detections in {frames} frames: ")?;
                match (best_per_pair, bound_per_pair) {
                    (Some(best), _) => write!(
                        f,
                        "the best consistent set of delays scored {best:.2} per microphone pair"
                    )?,
                    (None, Some(bound)) => write!(
                        f,
                        "no frame stood out of the noise estimate: none could score more than {bound:.2} per microphone pair"
                    )?,
                    (None, None) => write!(f, "no frame held a consistent set of delays")?,
                }
                match threshold_per_pair {
                    Some(t) => write!(
                        f,
                        ", against a threshold of {} per pair",
                        crate::text::BriefNumber(*t)
                    )?,
                    None => write!(f, ", against the threshold calibrated from each frame's background")?,
                }
                if *steady {
                    write!(f, "; the recording is steady from start to end (its loudness varies by less than 6 dB), and the spectral weighting takes a source that sounds from the first sample without a pause as background")?;
                }
                Ok(())
            }
            Warning::SearchBudget { frames } => write!(
                f,
                "the consistency search hit its budget in {frames} frames (best set found so far used); a smaller tolerance or fewer peaks per pair avoids this"
            ),
        }
    }
}

/// What a finished (or failed) recording reports.
#[derive(Debug, Clone)]
pub struct Summary {
    /// The input's name.
    pub name: String,
    /// The source's sample format, e.g. `8 ch, 48000 Hz, 16-bit PCM`.
    pub format: String,
    /// Channels in the source.
    pub channels: usize,
    /// Sample rate (Hz).
    pub sample_rate: u32,
    /// The frame size N used.
    pub frame_size: usize,
    /// The counters.
    pub stats: FrameStats,
    /// Time per stage, when stage timing was on.
    pub stage_times: Option<StageTimes>,
    /// Remarks for the user.
    pub warnings: Vec<Warning>,
}
