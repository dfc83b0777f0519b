//! `ssl`: sound source localization with a microphone array, after Valin, Michaud, Rouat
//! and Létourneau, "Robust Sound Source Localization Using a Microphone Array on a Mobile
//! Robot" (IROS 2003).
//!
//! The pipeline reads like the paper, one module per stage:
//!
//! | stage | module | paper |
//! |---|---|---|
//! | array geometry | [`geometry`] | Sec. III, `p_i` |
//! | audio frames | [`audio`] | Sec. II: frames of N samples, 50% overlap |
//! | spectral weighting | [`weighting`] | eq. (4), (5) |
//! | cross-correlation and peaks | [`correlation`] | eq. (6), (7) |
//! | consistency search | [`search`] | eq. (8) |
//! | direction | [`direction`] | eq. (9)-(13) |
//! | output | [`output`] | |
//!
//! [`pipeline::Analyzer`] runs one frame through the stages; [`session::FileAnalysis`]
//! streams one file through it. The `ssl` binary is a thin layer over [`cli`].

pub mod audio;
pub mod cli;
pub mod correlation;
pub mod direction;
pub mod geometry;
pub mod output;
pub mod pipeline;
pub mod search;
pub mod session;
pub mod synth;
pub mod weighting;

pub use geometry::Geometry;
pub use pipeline::{Analyzer, Detection, Params};
pub use session::FileAnalysis;
