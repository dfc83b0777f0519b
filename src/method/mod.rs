//! The method of Valin, Michaud, Rouat and Létourneau (IROS 2003), one file per stage in
//! the paper's order:
//!
//! | stage | module | paper |
//! |---|---|---|
//! | frames of N samples, 50% overlap | [`frames`] | Sec. II |
//! | windowed spectra `X_i(k)`, mean power `X(k)` | [`spectrum`] | eq. (2) |
//! | noise estimate `X_n(k)` and weights `w_e(k)` | [`weighting`] | eq. (4), (5) |
//! | weighted PHAT cross-correlation of every pair | [`correlation`] | eq. (6) |
//! | the M highest peaks of each pair | [`peaks`] | eq. (7) |
//! | microphone pairs, numbered once | [`pairs`] | |
//! | the consistent set of delays with the greatest correlation | [`search`] | eq. (8) |
//! | far-field least-squares direction | [`direction`] | eq. (9)-(13) |
//! | the coherent background, subtracted from the correlations | [`background`] | beyond the paper |
//! | the detection threshold, calibrated against the background | [`threshold`] | beyond the paper |
//! | steered response: partial agreement and several sources | [`steered`] | beyond the paper |
//! | further sources from a frame's own correlations | [`frame_sources`] | beyond the paper |
//! | each talker's pattern removed before a second look for others | [`patterns`] | beyond the paper |
//!
//! [`Params`] holds the parameters; one frame goes through the stages in `worker.rs`, and
//! the analyzer (`analyzer.rs`) runs a recording's frames through them in blocks on
//! several threads, with the noise estimate in frame order. Every entry point of the
//! library, and the command line, goes through that one analyzer (see
//! [`Analysis`](crate::stream::Analysis)).

pub(crate) mod analyzer;
pub mod background;
pub mod correlation;
pub mod dereverb;
mod detect;
pub mod direction;
pub mod frame_sources;
pub mod frames;
mod outcome;
pub mod pairs;
mod params;
pub mod patterns;
pub mod peaks;
pub mod search;
mod sequential;
mod setup;
pub mod spectrum;
mod state;
pub mod steered;
pub mod threshold;
pub mod votes;
pub mod weighting;
mod worker;

pub(crate) use analyzer::Analyzer;
pub use outcome::{Detection, Detections, FrameStats, StageTimes};
pub use params::{
    default_frame_size, frame_size_for_ms, Dereverb, Params, ParamsError, DEFAULT_AVERAGE_FRAMES,
    DEFAULT_BACKGROUND_S, DEFAULT_CANDIDATES, DEFAULT_MAX_SOURCES, DEFAULT_MIN_SCORE_PER_PAIR,
    DEFAULT_PATTERNS_S, DEFAULT_PEAKS, DEFAULT_RESIDUAL_GATE_US, DEFAULT_REVERB_LEVEL,
    DEFAULT_RIDERS, DEFAULT_THRESHOLD_SIGMAS, DEFAULT_TOLERANCE, DEFAULT_TOLERANCE_US,
    MAX_AVERAGE_FRAMES, MAX_FRAME_SIZE, MAX_PEAKS, MAX_SOURCES, PRIMING_S, REVERB_TAU_S,
};
pub use peaks::Interpolation;
pub use spectrum::Window;
pub use threshold::DIFFUSE_MARGIN;
