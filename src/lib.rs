//! `ssl`: sound source localization with a microphone array, after Valin, Michaud, Rouat
//! and Létourneau, "Robust Sound Source Localization Using a Microphone Array on a Mobile
//! Robot" (IROS 2003).
//!
//! The whole path `ssl analyze` runs is one type, [`Localizer`]: open a recording, run
//! it, get the rows and events the command line writes. [`Config`] holds the same
//! choices as the command line's flags, a section per stage, with presets.
//!
//! ```
//! use ssl::localize::{Localizer, Output};
//! use ssl::Config;
//! use ssl::Geometry;
//!
//! let geometry = Geometry::from_file("testdata/prism.toml".as_ref())?;
//! let localizer = Localizer::new(geometry, &Config::default())?;
//! let mut rows = Vec::new();
//! let (_report, result) = localizer.open("testdata/example.wav")?.run(|out| {
//!     if let Output::Row(row) = out {
//!         rows.push(row);
//!     }
//!     Ok(())
//! });
//! result?;
//! // The example's first source is at azimuth 30, elevation 10 (testdata/example.truth.json).
//! assert!((rows[0].azimuth_deg - 30.0).abs() < 1.0 && (rows[0].elevation_deg - 10.0).abs() < 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! The source is laid out by what goes in and out; no file or folder imports another
//! that imports it back (`.ci/cycles.py` checks):
//!
//! ```text
//! src/
//!   lib.rs            this page, the public names
//!   main.rs           the `ssl` binary: calls cli::main
//!   text.rs           text inputs with a size limit, I/O reasons, numbers as written
//!   named.rs          the Named trait: closed sets of named values (window, format)
//!   config.rs         the configuration: one section per stage (each declared in the
//!                     stage's file with its flags), presets, resolution to Params
//!   flags.rs          the flags' value parsers (feature `cli`)
//!   geometry/         the array file: microphones, channels, shape (Sec. III)
//!     mod.rs            reading and validation
//!     shape.rs          3-D, planar or linear, and the side rules
//!   method/           samples in frames -> detections
//!     params.rs         the parameters, their defaults and checks (imports no stage)
//!     layout.rs         what every stage reads: frame size, lags per pair, windows
//!     state.rs          one frame's state between the stages
//!     detect.rs         a set of delays -> a detection (solver, residual gate)
//!     outcome.rs        detections, counters, stage times
//!     paper/            the paper's stages, in its order
//!       frames.rs         frames of N samples, 50% overlap (Sec. II)
//!       spectrum.rs       windowed spectra, mean power (eq. 2)
//!       weighting.rs      noise estimate, weights w_e(k) (eq. 4, 5)
//!       correlation.rs    weighted PHAT cross-correlation (eq. 6)
//!       peaks.rs          the M highest peaks per pair (eq. 7)
//!       pairs.rs          microphone pairs, numbered once
//!       search.rs         the consistent delay set (eq. 8)
//!       direction.rs      far-field least-squares direction (eq. 9-13)
//!     beyond/           the stages beyond the paper
//!       threshold.rs      the threshold calibrated against the background
//!       background.rs     the steady background subtracted from the correlations
//!       dereverb.rs       the reverberation's diffuse part removed before eq. 6
//!       steered.rs        steered response: partial agreement, further sources
//!       frame_sources.rs  further sources from a frame's own correlations
//!       patterns.rs       each talker's pattern removed, a second look for others
//!       votes.rs          directions of single frequency bins (riders)
//!     engine/           what schedules the stages
//!       setup.rs          the run's plan: the layout and each stage's own plan
//!       worker.rs         one frame through the stages
//!       sequential.rs     the noise estimate in frame order
//!       analyzer.rs       a recording's frames in blocks, on several threads, primed
//!   stream/           samples in, a block at a time, memory flat
//!     wav.rs            WAV files and readers (pipes), decoded a block at a time
//!     header.rs         the fmt chunk, checked; other formats named
//!     source.rs         the SampleSource trait, channels in memory, the framer
//!     summary.rs        what an analysed recording reports, its warnings
//!     wpe/              the input dereverberated first (--wpe): a filter over a
//!                       SampleSource, so it sits with the sources, not the stages
//!   track/            detections -> sources and events: the tracker, its candidates,
//!                     a track's motion, floor and ceiling images, the smoother
//!   localize/         the whole path: Analysis (one recording through the analyzer),
//!                     Localizer (the analysis, the tracker, frame times)
//!   record/           records and formats (docs/interface.md): rows, events, metadata,
//!                     truth, one exporter per format behind one trait, reading back
//!   evaluate/         scoring results against a truth; tracks and events
//!   plot/             results drawn as one SVG (feature `plot`)
//!   sim/              the simulator (feature `simulate`): scene, room, array placed,
//!                     sources, signals, noise, limits, WAV writing
//!   cli/              the command line (feature `cli`; main.rs calls it): one file per subcommand, the
//!                     flags (args.rs, man/ is generated from them), the output sink
//! ```
//!
//! Features: `cli` (default) builds the `ssl` binary and enables `simulate` and `plot`.
//! With `default-features = false` the crate is the method, the streaming, the tracker,
//! the records and the evaluation, without clap, indicatif, rand or hound.
//!
//! Lower down, [`Analysis`] runs one recording through the method alone (every frame's
//! detections, no tracker); a file, WAV bytes from a reader and channels in memory give
//! the same detections on any number of threads.

//! The public API is what these pages list (docs/public-api.txt, checked by CI); items
//! hidden from them serve the crate's own tests and benchmarks and are no promise.

#![warn(missing_docs)]

/// Returns `Err(variant(message))` from the enclosing function, the message formatted
/// like `format!`: for errors that are a sentence about what is wrong.
macro_rules! fail {
    ($variant:path, $($arg:tt)*) => {
        return Err($variant(format!($($arg)*)))
    };
}

pub mod check;
#[cfg(feature = "cli")]
#[doc(hidden)]
pub mod cli;
mod config;
pub mod evaluate;
#[cfg(feature = "flags")]
mod flags;
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
mod text;
pub mod track;

pub use config::{Config, Settings, SettingsError};
pub use geometry::{Geometry, GeometryError};
pub use localize::Localizer;
pub use localize::{Analysis, AnalysisError};
pub use method::{Detection, Params, ParamsError};
pub use named::Named;
pub use record::{DetectionRecord, Exporter, Format, OutputError, RunMetadata, Truth};
pub use stream::Summary;
