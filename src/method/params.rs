//! The method's parameters, their defaults, and their validation against an array and a
//! sample rate.

use super::beyond::steered::Steering;
use super::beyond::threshold::Threshold;
use super::beyond::{Room, Talkers, MAX_AVERAGE_FRAMES, MAX_SOURCES};
use super::paper::frames::{FrameSize, Framing};
use super::paper::peaks::{Interpolation, Peaks, MAX_PEAKS};
use super::paper::search::Tolerance;
use super::paper::weighting::{NoiseSettings, Weighting, DEFAULT_REVERB_LEVEL};
use crate::geometry::{speed_of_sound_ok, SPEED_OF_SOUND_RANGE};

/// The method's parameters as its stages read them: the configuration's sections
/// resolved ([`Config::settings`](crate::Config::settings)), each read by its own
/// stage, with the tuning a configuration does not reach. Each section is declared,
/// with its units, defaults and flags, in its stage's file. `Params::default()` is the
/// method alone, as `ssl analyze --no-track` runs it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub struct Params {
    /// Frames: size, window and the span analysed.
    pub framing: Framing,
    /// The spectral weighting of eq. (4)-(5) and the band (its reverberation share
    /// resolved).
    pub weighting: Weighting,
    /// The peaks kept per pair (eq. 7; the refinement resolved).
    pub peaks: Peaks,
    /// Consistency tolerance of eq. (8); the layout has it in samples at the
    /// recording's rate.
    pub tolerance: Tolerance,
    /// When a frame's best set is a detection.
    pub threshold: Threshold,
    /// The room's reverberation and background, taken out.
    pub room: Room,
    /// Several talkers at once (the shares resolved; one source and none without a
    /// tracker).
    pub talkers: Talkers,
    /// Overrides the geometry's speed of sound (m/s).
    pub speed_of_sound: Option<f64>,
    /// The steered response: a direction for frames whose pairs do not all agree, and
    /// further sources (partial with a tracker under the calibrated threshold).
    pub steered: Steering,
    /// Further sources from each frame's own correlations beside the averaged ones' (on
    /// with a tracker under the calibrated threshold).
    pub frame_sources: bool,
    /// The consistency search's budget per frame, in candidate matches
    /// ([`Searcher::work`](crate::method::search::Searcher::work)); a frame that reaches
    /// it gives the best set found so far, and the run warns.
    pub max_work: u64,
    /// The noise estimator behind `X_n(k)`.
    pub noise: NoiseSettings,
}

impl Params {
    /// Checks every parameter that needs no recording (the frame against the array's
    /// delays is checked when a recording's sample rate is known), section by section.
    pub fn check(&self) -> Result<(), ParamsError> {
        let framing = &self.framing;
        match framing.size {
            FrameSize::Ms(ms) if !(ms.is_finite() && ms > 0.0) => {
                return Err(ParamsError::FrameMs(ms))
            }
            FrameSize::Samples(n) if !(16..=MAX_FRAME_SIZE).contains(&n) || n % 2 != 0 => {
                return Err(ParamsError::FrameSize(n))
            }
            _ => {}
        }
        if !(framing.start_s.is_finite() && framing.start_s >= 0.0)
            || framing
                .end_s
                .is_some_and(|e| !(e.is_finite() && e > framing.start_s))
        {
            return Err(ParamsError::Span {
                start_s: framing.start_s,
                end_s: framing.end_s,
            });
        }
        let weighting = &self.weighting;
        if let Some((low, high)) = weighting
            .band_hz
            .filter(|&(l, h)| !(l.is_finite() && h.is_finite() && l >= 0.0 && h > l))
        {
            return Err(ParamsError::Band { low, high });
        }
        if let Some(r) = weighting.reverb_level.filter(|r| !(0.0..=1.0).contains(r)) {
            return Err(ParamsError::ReverbLevel(r as f32));
        }
        if self.peaks.count == 0 || self.peaks.count > MAX_PEAKS {
            return Err(ParamsError::Peaks(self.peaks.count));
        }
        match self.tolerance {
            Tolerance::Us(us) if !(us.is_finite() && us >= 0.0) => {
                return Err(ParamsError::ToleranceUs(us))
            }
            Tolerance::Samples(s) if !(s.is_finite() && s >= 0.0) => {
                return Err(ParamsError::Tolerance(s as f32))
            }
            _ => {}
        }
        match self.threshold {
            Threshold::Calibrated { sigmas } if !(sigmas.is_finite() && sigmas >= 0.0) => {
                return Err(ParamsError::ThresholdSigmas(sigmas))
            }
            Threshold::Fixed { per_pair } if per_pair.is_nan() => {
                return Err(ParamsError::MinScore(per_pair))
            }
            _ => {}
        }
        let room = &self.room;
        if !(1..=MAX_AVERAGE_FRAMES).contains(&room.average_frames) {
            return Err(ParamsError::AverageFrames(room.average_frames));
        }
        if !(room.residual_gate_us.is_finite() && room.residual_gate_us >= 0.0) {
            return Err(ParamsError::ResidualGate(room.residual_gate_us));
        }
        if !(room.background_s.is_finite() && room.background_s >= 0.0) {
            return Err(ParamsError::BackgroundS(room.background_s));
        }
        let talkers = &self.talkers;
        if !(1..=MAX_SOURCES).contains(&talkers.max_sources) {
            return Err(ParamsError::MaxSources(talkers.max_sources));
        }
        if let Some(c) = talkers.candidates.filter(|c| !(*c > 0.0 && *c <= 1.0)) {
            return Err(ParamsError::Candidates(c));
        }
        if let Some(r) = talkers.riders.filter(|r| !(*r > 0.0 && *r <= 1.0)) {
            return Err(ParamsError::Riders(r));
        }
        if !(talkers.patterns_s.is_finite() && talkers.patterns_s >= 0.0) {
            return Err(ParamsError::PatternsS(talkers.patterns_s));
        }
        if let Some(c) = self.speed_of_sound.filter(|&c| !speed_of_sound_ok(c)) {
            return Err(ParamsError::SpeedOfSound(c));
        }
        Ok(())
    }

    /// Whether riders come from the bins' directions: [`Talkers::bin_votes`], and a
    /// tracker to ride along (candidates under the threshold). On arrays too large for
    /// them there are none either way (see `method/beyond/votes.rs`).
    pub fn bin_votes_on(&self) -> bool {
        self.talkers.bin_votes && self.talkers.candidate_share() < 1.0
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            framing: Framing::default(),
            weighting: Weighting {
                reverb_level: Some(DEFAULT_REVERB_LEVEL),
                ..Weighting::default()
            },
            peaks: Peaks {
                interpolation: Some(Interpolation::Cosine),
                ..Peaks::default()
            },
            tolerance: Tolerance::default(),
            threshold: Threshold::default(),
            room: Room::default(),
            talkers: Talkers::alone(),
            speed_of_sound: None,
            steered: Steering::Off,
            frame_sources: false,
            max_work: DEFAULT_MAX_WORK,
            noise: NoiseSettings::default(),
        }
    }
}

/// Default budget of the consistency search per frame, in candidate matches
/// ([`Params::max_work`]): about 60 ms of one core, and 70,000 nodes on 8 microphones,
/// where no frame of the benchmarks' scenes takes 20,000 (docs/method.md, "Consistency
/// search").
pub(crate) const DEFAULT_MAX_WORK: u64 = 4_000_000;

/// How much of the start of a recording primes the noise estimate before it is analysed
/// (seconds, at most one block of frames; see the `analyzer` module).
pub(crate) const PRIMING_S: f64 = 0.25;

/// The fewest frequency bins a `--band` may hold: a correlation of K bins has peaks
/// about N/K lags wide, and with fewer than 8 the M = 8 peaks of a pair are ripples of
/// one broad hump.
pub const MIN_BAND_BINS: usize = 8;
/// The largest frame size (samples): 1.4 s at 48 kHz, 0.34 s at 192 kHz.
pub(crate) const MAX_FRAME_SIZE: usize = 1 << 16;

/// Time constant of the late-reverberation estimate (seconds): 0.65 per frame of 1024 at
/// 48 kHz, as in Valin et al.'s later work.
pub(crate) const REVERB_TAU_S: f64 = 0.025;

/// The default frame size: the power of two nearest (in ratio) to 1024 samples at
/// 48 kHz, i.e. about 21 ms: 128 at 8 kHz, 256 at 16 kHz, 1024 at 44.1/48 kHz, 2048 at
/// 96 kHz, 4096 at 192 kHz. Keeping the duration fixed keeps the method's time and
/// frequency resolution (and the noise estimator's behaviour) the same at every rate.
pub(crate) fn default_frame_size(sample_rate: u32) -> usize {
    let ideal = 1024.0 * sample_rate as f64 / 48000.0;
    let p = ideal.log2().round().clamp(6.0, 16.0);
    1usize << (p as u32)
}

/// The power of two nearest (in ratio) to `ms` milliseconds at `sample_rate`, within 16
/// to `MAX_FRAME_SIZE` samples.
pub(crate) fn frame_size_for_ms(ms: f64, sample_rate: u32) -> usize {
    let ideal = (ms * sample_rate as f64 / 1000.0).max(1.0);
    let p = ideal
        .log2()
        .round()
        .clamp(4.0, MAX_FRAME_SIZE.trailing_zeros() as f64);
    1usize << (p as u32)
}

/// Parameters that cannot be used with this array at this sample rate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsError {
    /// The frame size is odd, under 16 samples, or over `MAX_FRAME_SIZE`.
    #[error(
        "the frame size must be an even number of samples from 16 to {MAX_FRAME_SIZE}, got {0}"
    )]
    FrameSize(usize),
    /// The frame length in milliseconds is not a positive number.
    #[error("the frame length must be a positive number of milliseconds, got {}", crate::text::BriefNumber(*.0))]
    FrameMs(f64),
    /// The frame length in milliseconds is not 16 to `MAX_FRAME_SIZE` samples at the
    /// recording's rate.
    #[error("a frame of {} ms at {sample_rate} Hz would be {} samples; frames are 16 to {MAX_FRAME_SIZE} samples ({:.2} to {:.0} ms at this rate)", crate::text::BriefNumber(*ms), crate::text::BriefNumber(ms * *sample_rate as f64 / 1000.0), 16000.0 / *sample_rate as f64, MAX_FRAME_SIZE as f64 * 1000.0 / *sample_rate as f64)]
    FrameMsRange {
        /// The frame length asked for (ms).
        ms: f64,
        /// The recording's sample rate (Hz).
        sample_rate: u32,
    },
    /// `--start` and `--end` do not give a span of the recording.
    #[error("--start must be 0 s or more and --end after it (got {start_s} s and {})", end_s.map_or("the end".to_string(), |e| format!("{e} s")))]
    Span {
        /// The start (seconds).
        start_s: f64,
        /// The end (seconds), if given.
        end_s: Option<f64>,
    },
    /// `--band` is not a range of frequencies.
    #[error("the band must be LOW-HIGH in Hz with 0 <= LOW < HIGH, got {}-{}", crate::text::BriefNumber(*low), crate::text::BriefNumber(*high))]
    Band {
        /// Its lower edge (Hz).
        low: f64,
        /// Its upper edge (Hz).
        high: f64,
    },
    /// `--band` holds too few of the frame's frequency bins at the recording's rate.
    #[error("the band {}-{} Hz holds {bins} frequency bin(s) of a {frame_size}-sample frame at {sample_rate} Hz (one every {} Hz, up to {} Hz); at least {MIN_BAND_BINS} are needed: widen the band or lengthen the frame (--frame-size)", crate::text::BriefNumber(*low), crate::text::BriefNumber(*high), crate::text::BriefNumber(crate::text::fixed(*sample_rate as f64 / *frame_size as f64, 2)), sample_rate / 2)]
    BandTooNarrow {
        /// Its lower edge (Hz).
        low: f64,
        /// Its upper edge (Hz).
        high: f64,
        /// The bins it holds.
        bins: usize,
        /// The recording's rate (Hz).
        sample_rate: u32,
        /// The frame size.
        frame_size: usize,
    },
    /// The frame cannot hold the array's largest delay on both sides of lag 0.
    #[error("the array's largest delay ({delay} samples at {sample_rate} Hz) does not fit in a frame of {frame_size} samples: a frame of {needed} samples or more is needed")]
    FrameTooShort {
        /// The largest lag searched, in samples.
        delay: usize,
        /// The recording's sample rate (Hz).
        sample_rate: u32,
        /// The frame size asked for.
        frame_size: usize,
        /// The smallest power of two that fits.
        needed: usize,
    },
    /// The input's dereverberation (`wpe`) would need more memory than it may take: its
    /// filters grow as the square of the microphones.
    #[error("dereverberating the input (wpe) with {mics} microphones at {sample_rate} Hz needs about {mb:.0} MB for its filters, which grow as the square of the microphones; at most {max_mb} MB are taken: dereverberate with fewer microphones (a geometry of a subset)")]
    WpeTooLarge {
        /// Microphones filtered.
        mics: usize,
        /// The recording's sample rate (Hz).
        sample_rate: u32,
        /// Megabytes the filters would take.
        mb: f64,
        /// Megabytes allowed.
        max_mb: usize,
    },
    /// M is 0 or more than `MAX_PEAKS`.
    #[error("the number of peaks per pair must be between 1 and {MAX_PEAKS}, got {0}")]
    Peaks(usize),
    /// The tolerance is negative or not a number.
    #[error("the consistency tolerance must be a non-negative number of samples, got {}", crate::text::BriefNumber(f64::from(*.0)))]
    Tolerance(f32),
    /// The tolerance in microseconds is negative or not a number.
    #[error("the consistency tolerance must be a non-negative number of microseconds, got {}", crate::text::BriefNumber(*.0))]
    ToleranceUs(f64),
    /// The residual gate is negative or not a number.
    #[error("the residual gate must be a number of microseconds, 0 or more (0: none), got {}", crate::text::BriefNumber(*.0))]
    ResidualGate(f64),
    /// The number of frames averaged is 0 or more than 64.
    #[error("the number of frames to average must be between 1 and {MAX_AVERAGE_FRAMES}, got {0}")]
    AverageFrames(usize),
    /// The most sources per frame is out of range.
    #[error("the most sources per frame must be 1 to 4, got {0}")]
    MaxSources(usize),
    /// The candidates' share of the threshold is not in (0, 1].
    #[error("the candidates' share of the threshold must be over 0 and at most 1, got {}", crate::text::BriefNumber(*.0))]
    Candidates(f64),
    /// The riders' share of the threshold is not in (0, 1].
    #[error("the riders' share of the threshold must be over 0 and at most 1, got {}", crate::text::BriefNumber(*.0))]
    Riders(f64),
    /// The threshold's allowance for chance is negative or not a number.
    #[error("the threshold's allowance for chance must be a non-negative number of standard deviations, got {}", crate::text::BriefNumber(*.0))]
    ThresholdSigmas(f64),
    /// The reverberation share is outside 0 to 1.
    #[error("the share of late reverberation must be between 0 and 1, got {}", crate::text::BriefNumber(f64::from(*.0)))]
    ReverbLevel(f32),
    /// The background's time constant is negative or not a number.
    #[error("the background's time constant must be a number of seconds, 0 or more (0: none), got {}", crate::text::BriefNumber(*.0))]
    BackgroundS(f64),
    /// The learned patterns' time constant is negative or not a number.
    #[error("the time constant of the average the talkers' patterns are removed from must be a number of seconds, 0 or more (0: none), got {}", crate::text::BriefNumber(*.0))]
    PatternsS(f64),
    /// The threshold is not a number.
    #[error("the detection threshold must be a number, got {}", crate::text::BriefNumber(*.0))]
    MinScore(f64),
    /// The speed of sound is outside `SPEED_OF_SOUND_RANGE`.
    #[error("the speed of sound must be {low} to {high} m/s, got {0:e}", low = SPEED_OF_SOUND_RANGE.0, high = SPEED_OF_SOUND_RANGE.1)]
    SpeedOfSound(f64),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_length_in_milliseconds_is_the_nearest_power_of_two() {
        assert_eq!(frame_size_for_ms(21.3, 48000), 1024);
        assert_eq!(frame_size_for_ms(21.3, 16000), 256);
        assert_eq!(frame_size_for_ms(32.0, 16000), 512);
        assert_eq!(frame_size_for_ms(64.0, 8000), 512);
        // 16 ms at 44.1 kHz is 705.6 samples: 512 is 1.38x away, 1024 1.45x.
        assert_eq!(frame_size_for_ms(16.0, 44100), 512);
        assert_eq!(frame_size_for_ms(0.01, 8000), 16);
        assert_eq!(frame_size_for_ms(1e6, 192000), MAX_FRAME_SIZE);
    }

    #[test]
    fn default_frame_size_scales_with_rate() {
        assert_eq!(default_frame_size(8000), 128);
        assert_eq!(default_frame_size(16000), 256);
        assert_eq!(default_frame_size(44100), 1024);
        assert_eq!(default_frame_size(48000), 1024);
        assert_eq!(default_frame_size(96000), 2048);
        assert_eq!(default_frame_size(192000), 4096);
    }
}
