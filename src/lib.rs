//! `ssl`: sound source localization with a microphone array, after Valin, Michaud, Rouat
//! and Létourneau, "Robust Sound Source Localization Using a Microphone Array on a Mobile
//! Robot" (IROS 2003).
//!
//! The crate is laid out by concern; inside [`method`], one module per stage of the
//! paper, with its equation numbers:
//!
//! ```text
//! src/
//!   lib.rs          this page
//!   main.rs         the `ssl` binary: calls cli::main
//!   geometry/       the array (Sec. III, p_i)
//!     mod.rs          the geometry file, validation
//!     shape.rs        3-D, planar or linear, and the side rules
//!   method/         the paper's method
//!     params.rs       parameters, defaults, validation against array and rate
//!     setup.rs        what a run needs: params checked, lags, thresholds, layout
//!     frames.rs       frames of N samples, 50% overlap (Sec. II)
//!     spectrum.rs     windowed spectra X_i(k), mean power X(k) (eq. 2)
//!     weighting.rs    noise estimate X_n(k), weights w_e(k) (eq. 4, 5)
//!     correlation.rs  weighted PHAT cross-correlation (eq. 6)
//!     dereverb.rs     the reverberation's diffuse part removed before eq. 6 (beyond)
//!     peaks.rs        the M highest peaks per pair (eq. 7)
//!     pairs.rs        microphone pairs, numbered once
//!     search.rs       the consistent delay set with the greatest correlation (eq. 8)
//!     direction.rs    far-field least-squares direction (eq. 9-13)
//!     detect.rs       from a set of delays to a detection (solver, residual gate)
//!     steered.rs      steered response: partial agreement, further sources (beyond)
//!     threshold.rs    the threshold calibrated against the background (beyond the paper)
//!     background.rs   the steady background subtracted from the correlations (beyond)
//!     sequential.rs   the noise estimate in frame order
//!     outcome.rs      detections, counters, stage times
//!     state.rs        one frame's state between the stages
//!     frame_sources.rs further sources from a frame's own correlations (beyond)
//!     worker.rs       one frame through the stages
//!     analyzer.rs     a recording's frames in blocks, on several threads, with priming
//!   stream/         samples in, detections out, memory flat
//!     wav.rs          WAV files and readers (pipes), decoded a block at a time
//!     header.rs       the fmt chunk, checked; other formats named
//!     source.rs       the SampleSource trait, channels in memory, the framer
//!     analysis.rs     one recording through the analyzer: the one entry point
//!   record/         records and output formats (docs/interface.md)
//!     detection.rs    a detection row
//!     metadata.rs     the JSON document's metadata and per-file entries
//!     truth.rs        a simulation's truth
//!     csv.rs json.rs  one exporter per format behind one trait
//!     read.rs         reading results and truth files back
//!   track/          sources, not frames: the tracker and its events
//!   plot/           drawing results as SVG (feature `plot`, `ssl plot`)
//!   named.rs        the Named trait: closed sets of named values
//!   evaluate/       scoring results against a truth (`ssl evaluate`)
//!   sim/            the simulator (feature `simulate`): scene, room, signals, noise
//!   cli/            the command line (binary only): one file per subcommand
//! ```
//!
//! Features: `cli` (default) builds the `ssl` binary and enables `simulate`, the
//! simulator. With `default-features = false` the crate is the method, the streaming,
//! the records and the evaluation, without clap, indicatif, rand or hound.
//!
//! Every entry point goes through [`Analysis`], which drives the one analyzer of the
//! method; a file, WAV bytes from a reader and channels in memory give the same
//! detections on any number of threads.
//!
//! ```
//! use ssl::{Analysis, Geometry, Params};
//! use std::ops::ControlFlow;
//!
//! let geometry = Geometry::from_file("testdata/prism.toml".as_ref())?;
//! let analysis = Analysis::open("testdata/example.wav", &geometry, &Params::default())?;
//! let mut detections = Vec::new();
//! let (summary, result) = analysis.run(|_frame, found| {
//!     detections.extend_from_slice(found);
//!     ControlFlow::Continue(())
//! });
//! result?;
//! // The example's first source is at azimuth 30, elevation 10 (testdata/example.truth.json).
//! let first = &detections[0];
//! assert!((first.azimuth_deg - 30.0).abs() < 1.0 && (first.elevation_deg - 10.0).abs() < 1.0);
//! assert_eq!(summary.stats.detections as usize, detections.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

/// Returns `Err(variant(message))` from the enclosing function, the message formatted
/// like `format!`: for errors that are a sentence about what is wrong.
macro_rules! fail {
    ($variant:path, $($arg:tt)*) => {
        return Err($variant(format!($($arg)*)))
    };
}

pub mod evaluate;
pub mod geometry;
pub mod localize;
pub mod method;
mod named;
#[cfg(feature = "plot")]
pub mod plot;
pub mod record;
#[cfg(feature = "simulate")]
pub mod sim;
pub mod stream;
pub mod track;

pub use geometry::{Geometry, GeometryError};
pub use localize::{Localizer, Options};
pub use method::{Detection, Params, ParamsError};
pub use named::Named;
pub use record::{DetectionRecord, Exporter, Format, OutputError, RunMetadata, Truth};
pub use stream::{Analysis, AnalysisError, Summary};
