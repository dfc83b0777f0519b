//! The method's parameters, their defaults, and their validation against an array and a
//! sample rate.

use super::beyond::threshold::Threshold;
use super::beyond::{
    Dereverb, DEFAULT_AVERAGE_FRAMES, DEFAULT_BACKGROUND_S, DEFAULT_RESIDUAL_GATE_US,
    MAX_AVERAGE_FRAMES, MAX_SOURCES,
};
use super::paper::frames::FrameSize;
use super::paper::peaks::{Interpolation, DEFAULT_PEAKS, MAX_PEAKS};
use super::paper::search::Tolerance;
use super::paper::spectrum::Window;
use super::paper::weighting::NoiseSettings;
use super::paper::weighting::DEFAULT_REVERB_LEVEL;
use crate::geometry::{speed_of_sound_ok, SPEED_OF_SOUND_RANGE};

/// The method's parameters as its stages read them: a [`Config`](crate::Config) resolved
/// ([`Config::settings`](crate::Config::settings)), flat, with the tuning a configuration
/// does not reach. Each field is declared, with its unit, default and flag, in the
/// configuration's section named beside it. `Params::default()` is the method alone, as
/// `ssl analyze --no-track` runs it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub struct Params {
    /// Frame size N ([`Framing::size`](crate::method::Framing::size)): about 21 ms at
    /// each rate (`default_frame_size`), a number of samples, or the power of two
    /// nearest a length in milliseconds (`frame_size_for_ms`).
    pub frame_size: FrameSize,
    /// `alpha` of eq. (4) ([`Weighting::alpha`](crate::method::Weighting::alpha)).
    pub alpha: f32,
    /// `gamma` of eq. (5) ([`Weighting::gamma`](crate::method::Weighting::gamma)).
    pub gamma: f32,
    /// The spectral weighting on ([`Weighting::on`](crate::method::Weighting::on)).
    pub weighting: bool,
    /// M, peaks kept per pair, 1 to `MAX_PEAKS` ([`Peaks::count`](crate::method::Peaks::count)).
    pub peaks: usize,
    /// Consistency tolerance of eq. (8) ([`Tolerance`](crate::method::Tolerance)); the
    /// layout has it in samples at the recording's rate.
    pub tolerance: Tolerance,
    /// The residual gate in microseconds (`None`: none; [`Room::residual_gate_us`](crate::method::Room::residual_gate_us)).
    pub residual_gate_us: Option<f64>,
    /// Overrides the geometry's speed of sound (m/s).
    pub speed_of_sound: Option<f64>,
    /// When a frame's best set is a detection ([`Threshold`](crate::method::Threshold)).
    pub threshold: Threshold,
    /// Late reverberation's share in the noise estimate, smoothed over `REVERB_TAU_S`
    /// ([`Weighting::reverb_level`](crate::method::Weighting::reverb_level)).
    pub reverb_level: f32,
    /// The analysis window ([`Framing::window`](crate::method::Framing::window)).
    pub window: Window,
    /// Sub-sample refinement of the peaks ([`Peaks::interpolation`](crate::method::Peaks::interpolation)).
    pub interpolation: Interpolation,
    /// The consistency search's budget per frame, in candidate matches
    /// ([`Searcher::work`](crate::method::search::Searcher::work)); a frame that reaches
    /// it gives the best set found so far, and the run warns.
    pub max_work: u64,
    /// The noise estimator behind `X_n(k)`.
    pub noise: NoiseSettings,
    /// Frames each pair's correlation is averaged over ([`Room::average_frames`](crate::method::Room::average_frames)).
    pub average_frames: usize,
    /// The coherent background's time constant (`None`: none; [`Room::background_s`](crate::method::Room::background_s)).
    pub background_s: Option<f64>,
    /// The steered response: a direction for frames whose pairs do not all agree, and
    /// further sources (on with a tracker under the calibrated threshold).
    pub steered: bool,
    /// The most sources one frame gives ([`Talkers::max_sources`](crate::method::Talkers::max_sources)).
    pub max_sources: usize,
    /// Further sources from each frame's own correlations beside the averaged ones' (on
    /// with a tracker under the calibrated threshold).
    pub frame_sources: bool,
    /// The talkers' patterns' time constant (`None`: none; [`Talkers::patterns_s`](crate::method::Talkers::patterns_s)).
    pub patterns_s: Option<f64>,
    /// Candidates' share of the threshold (1: none; [`Talkers::candidates`](crate::method::Talkers::candidates)),
    /// reported with [`Detection::margin`](super::Detection::margin) under 1.
    pub candidates: f64,
    /// Riders' share of the threshold (1: none; [`Talkers::riders`](crate::method::Talkers::riders)),
    /// reported as [`Detection::rider`](super::Detection::rider).
    pub riders: f64,
    /// When the diffuse part is removed ([`Room::dereverb`](crate::method::Room::dereverb)).
    pub dereverb: Dereverb,
    /// The input dereverberated first ([`Room::wpe`](crate::method::Room::wpe)).
    pub wpe: bool,
    /// Where the analysis starts (seconds), rounded down to a whole hop
    /// ([`Framing::start_s`](crate::method::Framing::start_s)).
    pub start_s: f64,
    /// Where it ends (seconds; `None`: the end; [`Framing::end_s`](crate::method::Framing::end_s)).
    pub end_s: Option<f64>,
    /// Riders from single frequency bins, with a tracker to ride along
    /// ([`Talkers::bin_votes`](crate::method::Talkers::bin_votes)).
    pub bin_votes: bool,
    /// The frequencies analysed, `(low, high)` in Hz ([`Weighting::band_hz`](crate::method::Weighting::band_hz)).
    pub band_hz: Option<(f64, f64)>,
}

impl Params {
    /// Checks every parameter that needs no recording (the frame against the array's
    /// delays is checked when a recording's sample rate is known).
    pub fn check(&self) -> Result<(), ParamsError> {
        match self.frame_size {
            FrameSize::Ms(ms) if !(ms.is_finite() && ms > 0.0) => {
                return Err(ParamsError::FrameMs(ms))
            }
            FrameSize::Samples(n) if !(16..=MAX_FRAME_SIZE).contains(&n) || n % 2 != 0 => {
                return Err(ParamsError::FrameSize(n))
            }
            _ => {}
        }
        if self.peaks == 0 || self.peaks > MAX_PEAKS {
            return Err(ParamsError::Peaks(self.peaks));
        }
        if !(1..=MAX_AVERAGE_FRAMES).contains(&self.average_frames) {
            return Err(ParamsError::AverageFrames(self.average_frames));
        }
        if !(self.candidates > 0.0 && self.candidates <= 1.0) {
            return Err(ParamsError::Candidates(self.candidates));
        }
        if !(self.riders > 0.0 && self.riders <= 1.0) {
            return Err(ParamsError::Riders(self.riders));
        }
        if !(1..=MAX_SOURCES).contains(&self.max_sources) {
            return Err(ParamsError::MaxSources(self.max_sources));
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
        if let Some(g) = self.residual_gate_us.filter(|g| g.is_nan() || *g <= 0.0) {
            return Err(ParamsError::ResidualGate(g));
        }
        if !(self.start_s.is_finite() && self.start_s >= 0.0)
            || self
                .end_s
                .is_some_and(|e| !(e.is_finite() && e > self.start_s))
        {
            return Err(ParamsError::Span {
                start_s: self.start_s,
                end_s: self.end_s,
            });
        }
        if let Some((low, high)) = self
            .band_hz
            .filter(|&(l, h)| !(l.is_finite() && h.is_finite() && l >= 0.0 && h > l))
        {
            return Err(ParamsError::Band { low, high });
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
        if !(0.0..=1.0).contains(&self.reverb_level) {
            return Err(ParamsError::ReverbLevel(self.reverb_level));
        }
        if let Some(s) = self.background_s.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(ParamsError::BackgroundS(s));
        }
        if let Some(s) = self.patterns_s.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return Err(ParamsError::PatternsS(s));
        }
        if let Some(c) = self.speed_of_sound.filter(|&c| !speed_of_sound_ok(c)) {
            return Err(ParamsError::SpeedOfSound(c));
        }
        Ok(())
    }

    /// Whether riders come from the bins' directions: [`Params::bin_votes`], and a
    /// tracker to ride along (`candidates` under 1). On arrays too large for them there
    /// are none either way (see `method/beyond/votes.rs`).
    pub fn bin_votes_on(&self) -> bool {
        self.bin_votes && self.candidates < 1.0
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            frame_size: FrameSize::Auto,
            alpha: crate::method::weighting::ALPHA as f32,
            gamma: crate::method::weighting::GAMMA as f32,
            weighting: true,
            peaks: DEFAULT_PEAKS,
            tolerance: Tolerance::default(),
            residual_gate_us: Some(DEFAULT_RESIDUAL_GATE_US),
            speed_of_sound: None,
            window: Window::Hann,
            interpolation: Interpolation::Cosine,
            max_work: DEFAULT_MAX_WORK,
            noise: NoiseSettings::default(),
            average_frames: DEFAULT_AVERAGE_FRAMES,
            threshold: Threshold::default(),
            reverb_level: DEFAULT_REVERB_LEVEL as f32,
            background_s: Some(DEFAULT_BACKGROUND_S),
            steered: false,
            max_sources: 1,
            frame_sources: false,
            patterns_s: None,
            candidates: 1.0,
            riders: 1.0,
            dereverb: Dereverb::Auto,
            wpe: false,
            start_s: 0.0,
            end_s: None,
            bin_votes: false,
            band_hz: None,
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
    /// The residual gate is not a positive number of microseconds.
    #[error("the residual gate must be a positive number of microseconds, got {}", crate::text::BriefNumber(*.0))]
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
    /// The background's time constant is not a positive number of seconds.
    #[error("the background's time constant must be a positive number of seconds, got {}", crate::text::BriefNumber(*.0))]
    BackgroundS(f64),
    /// The learned patterns' longer average has no positive time constant.
    #[error("the time constant of the average the talkers' patterns are removed from must be a positive number of seconds, got {}", crate::text::BriefNumber(*.0))]
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
