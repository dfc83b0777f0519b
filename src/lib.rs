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
//!
//! ```
//! use ssl::{FileAnalysis, Geometry, Params};
//!
//! let geometry = Geometry::from_file("testdata/prism.toml".as_ref())?;
//! let analysis = FileAnalysis::open("testdata/example.wav", &geometry, &Params::default())?;
//! let mut detections = Vec::new();
//! let (summary, result) = analysis.run(|_frame, detection| {
//!     detections.extend(detection.cloned());
//!     Ok(())
//! });
//! result?;
//! // The example's first source is at azimuth 30, elevation 10 (testdata/example.truth.json).
//! let first = &detections[0];
//! assert!((first.azimuth_deg - 30.0).abs() < 1.0 && (first.elevation_deg - 10.0).abs() < 1.0);
//! assert_eq!(summary.stats.detections as usize, detections.len());
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod audio;
pub mod benchmark;
pub mod cli;
pub mod correlation;
pub mod direction;
pub mod evaluate;
pub mod geometry;
pub mod output;
pub mod pipeline;
pub mod room;
pub mod scene;
pub mod search;
pub mod session;
pub mod synth;
pub mod weighting;

pub use geometry::Geometry;
pub use pipeline::{Analyzer, Detection, Params};
pub use session::FileAnalysis;
