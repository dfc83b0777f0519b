//! The method of Valin, Michaud, Rouat and Létourneau (IROS 2003) and the stages beyond
//! it, in three rooms:
//!
//! - [`paper`]: the paper's stages, one file each, in its order;
//! - `beyond`: the stages beyond the paper (crate-private: what they add is reached
//!   through [`Params`]);
//! - `engine`: what schedules them: the run's plan, one frame through every stage, a
//!   recording's frames in blocks on several threads with priming.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | frames of N samples, 50% overlap | [`paper::frames`] | Sec. II |
//! | windowed spectra `X_i(k)`, mean power `X(k)` | [`paper::spectrum`] | eq. (2) |
//! | noise estimate `X_n(k)` and weights `w_e(k)` | [`paper::weighting`] | eq. (4), (5) |
//! | weighted PHAT cross-correlation of every pair | [`paper::correlation`] | eq. (6) |
//! | the M highest peaks of each pair | [`paper::peaks`] | eq. (7) |
//! | microphone pairs, numbered once | [`paper::pairs`] | |
//! | the consistent set of delays with the greatest correlation | [`paper::search`] | eq. (8) |
//! | far-field least-squares direction | [`paper::direction`] | eq. (9)-(13) |
//! | the detection threshold, calibrated against the background | `beyond/threshold.rs` | beyond |
//! | the steady background, subtracted from the correlations | `beyond/background.rs` | beyond |
//! | the reverberation's diffuse part removed from the cross-spectra | `beyond/dereverb.rs` | beyond |
//! | steered response: partial agreement and several sources | `beyond/steered.rs` | beyond |
//! | further sources from a frame's own correlations | `beyond/frame_sources.rs` | beyond |
//! | each talker's pattern removed before a second look for others | `beyond/patterns.rs` | beyond |
//! | the directions of single frequency bins (riders) | `beyond/votes.rs` | beyond |
//!
//! Below the three rooms: [`Params`] and its defaults (`params.rs`, which imports no
//! stage), the frame layout every stage reads (`layout.rs`), one frame's state between
//! the stages (`state.rs`), from a set of delays to a detection (`detect.rs`), and what
//! the method gives out (`outcome.rs`). Every entry point of the library, and the
//! command line, goes through the one analyzer (see [`Localizer`](crate::Localizer)).

pub(crate) mod beyond;
mod detect;
pub(crate) mod engine;
mod layout;
mod outcome;
pub mod paper;
mod params;
mod state;
mod uncertainty;

pub use paper::{correlation, direction, frames, pairs, peaks, search, spectrum, weighting};

pub use beyond::steered::Steering;
pub(crate) use beyond::threshold;
pub use beyond::threshold::Threshold;
pub use beyond::{Dereverb, Room, Talkers};
pub(crate) use engine::analyzer::Engine;
pub use outcome::{Detection, Detections, FrameStats, StageTimes};
pub use paper::frames::{FrameSize, Framing};
pub use paper::peaks::Interpolation;
pub use paper::peaks::Peaks;
pub use paper::search::Tolerance;
pub use paper::spectrum::Window;
pub use paper::weighting::Weighting;
pub(crate) use params::default_frame_size;
pub use params::{Params, ParamsError};
