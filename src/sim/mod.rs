//! The simulator: recordings with known truth, to measure the method where the answer is
//! known (behind the `simulate` feature).
//!
//! - [`scene`]: the scene file (room, array pose, sources, noise).
//! - [`render`]: a scene through a shoebox room, as named steps: place the array, render
//!   each source, add the noise, write down the truth.
//! - [`room`]: the image-source room with fractional-delay taps and RT60 by measurement.
//! - [`signals`], `noise.rs` and `recorded.rs`: what sources and noise emit (a mono WAV
//!   file at any rate is resampled to the scene's).
//! - [`freefield`]: a quick free-field renderer for tests and measurements.
//! - [`wav`]: writing channels to WAV files.

#[doc(hidden)]
pub mod freefield;
pub(crate) mod limits;
mod noise;
mod placed;
#[doc(hidden)]
pub mod recorded;
#[doc(hidden)]
pub mod render;
#[doc(hidden)]
pub mod room;
#[doc(hidden)]
pub mod scene;
#[doc(hidden)]
pub mod signals;
mod source;
#[doc(hidden)]
pub mod wav;

#[cfg(feature = "cli")]
pub(crate) use render::simulate_read;
pub use render::{simulate, simulate_file, Simulation};
pub use scene::SceneFile;
#[doc(hidden)]
pub use wav::{write_wav, Encoding};

use crate::geometry::GeometryError;
use crate::stream::{io_reason, InputError};
use std::path::PathBuf;

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read.
    #[error("{}: cannot read scene file: {}", path.display(), io_reason(error))]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// Not valid TOML, or not the scene schema.
    #[error("{}: invalid scene TOML{}: {message}", path.display(), line.map(|l| format!(" at line {l}")).unwrap_or_default())]
    Toml {
        /// The file.
        path: PathBuf,
        /// 1-based line of the error, when known.
        line: Option<usize>,
        /// The parser's message.
        message: String,
    },
    /// An error in a scene file, with the file's name.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        error: Box<SceneError>,
    },
    /// An error about one part of the scene (`source 2`).
    #[error("{what}: {error}")]
    About {
        /// The part.
        what: String,
        /// What is wrong with it.
        error: Box<SceneError>,
    },
    /// The array's geometry file.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// A source's WAV file.
    #[error("{}: {error}", path.display())]
    Input {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        error: InputError,
    },
    /// A value the simulator cannot use; the message says which and why.
    #[error("{0}")]
    Invalid(String),
}
