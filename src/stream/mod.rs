//! Streaming: samples in, detections out, with memory that does not grow with the
//! recording.
//!
//! - `wav`: WAV files and WAV bytes from any reader (pipes included), decoded a block
//!   at a time; `flac`: FLAC the same way; `audio`: either, told by its first bytes.
//! - `source`: the [`SampleSource`] every input is, channels already in memory, and the
//!   framer that cuts any source into blocks of overlapping frames.
//! - `summary`: what an analysed recording reports, and its warnings.
//!
//! One recording through the method is `crate::localize::Analysis`.

mod audio;
mod clock;
mod flac;
mod header;
pub(crate) mod source;
mod summary;
mod wav;
pub(crate) mod wpe;

#[cfg(feature = "cli")]
pub(crate) use crate::text::read_text_from;
pub(crate) use crate::text::{io_reason, read_text};
pub use audio::AudioStream;
pub use clock::ClockOrigin;
#[doc(hidden)]
pub use clock::TimeReference;
#[doc(hidden)]
pub use flac::FlacStream;
pub use source::{Channels, SampleSource};
pub use summary::{Summary, Warning};
#[doc(hidden)]
pub use wav::{WavFormat, WavStream};

use std::io;

/// Why samples could not be read.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The file could not be opened.
    #[error("cannot open: {}", io_reason(.0))]
    Open(io::Error),
    /// The path is a directory.
    #[error("is a directory, not a recording")]
    Directory,
    /// Reading failed (the reason is the operating system's).
    #[error("{}", io_reason(.0))]
    Io(io::Error),
    /// Reading the samples failed.
    #[error("read error: {}", io_reason(.0))]
    Read(io::Error),
    /// Not a WAV or FLAC file; the message names what it is when that is recognised.
    #[error("{0}")]
    NotWav(String),
    /// A WAV encoding this tool does not decode; the message says how to convert it.
    #[error("{0}")]
    Unsupported(String),
    /// A damaged or cut-short header, or channels that do not make a recording.
    #[error("{0}")]
    Corrupt(String),
    /// The data ends before the sample frames its header promises.
    #[error("truncated WAV: the header promises {promised} sample frames ({:.3} s) but the data ends after {read} ({:.3} s)", *promised as f64 / *sample_rate as f64, *read as f64 / *sample_rate as f64)]
    Truncated {
        /// Sample frames the header promises.
        promised: u64,
        /// Sample frames read.
        read: u64,
        /// Sample rate (Hz).
        sample_rate: u32,
    },
    /// The data ends inside a sample frame: bytes of a frame whose other channels or
    /// bytes never came.
    #[error("truncated WAV: the data ends {bytes} bytes into a sample frame of {block_align} bytes, after {read} whole frames ({:.3} s)", *read as f64 / *sample_rate as f64)]
    PartialFrame {
        /// Bytes of the incomplete frame.
        bytes: u64,
        /// Bytes of one sample frame (all channels).
        block_align: u64,
        /// Whole sample frames read.
        read: u64,
        /// Sample rate (Hz).
        sample_rate: u32,
    },
    /// A sample is NaN or infinite.
    #[error("sample {frame} of channel {channel} is {} (at {:.6} s): the recording is corrupt", if *nan { "NaN" } else { "infinite" }, *frame as f64 / *sample_rate as f64)]
    NonFinite {
        /// Sample frame index.
        frame: u64,
        /// 0-based channel.
        channel: usize,
        /// NaN (else infinite).
        nan: bool,
        /// Sample rate (Hz).
        sample_rate: u32,
    },
}

impl InputError {
    pub(crate) fn non_finite(frame: u64, channel: usize, value: f32, sample_rate: u32) -> Self {
        InputError::NonFinite {
            frame,
            channel,
            nan: value.is_nan(),
            sample_rate,
        }
    }
}
