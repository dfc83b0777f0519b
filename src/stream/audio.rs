//! An audio file of either kind this tool reads, told apart by its first bytes: WAV
//! ([`WavStream`]) or FLAC ([`FlacStream`]). Anything else gets the WAV reader's message,
//! which names what the file is.

use super::flac::FlacStream;
use super::source::{open_input, read_full, SampleSource};
use super::wav::WavStream;
use super::InputError;
use std::io::{Cursor, Read};

/// A WAV or FLAC recording, streamed.
pub enum AudioStream {
    /// A WAV file (or RF64/BW64).
    Wav(WavStream),
    /// A FLAC file.
    Flac(FlacStream),
}

impl AudioStream {
    /// Opens a WAV or FLAC file, or standard input for `-`.
    pub fn open(path: &str) -> Result<Self, InputError> {
        let (name, input, size) = open_input(path)?;
        Self::from_reader(name, input, size)
    }

    /// Reads a WAV or FLAC header from `input`; `size` is the total byte size when known
    /// (a file; `None`: a pipe, read as it arrives).
    pub fn from_reader(
        name: &str,
        mut input: Box<dyn Read>,
        size: Option<u64>,
    ) -> Result<Self, InputError> {
        let mut head = [0u8; 4];
        let got = read_full(&mut input, &mut head).map_err(InputError::Io)?;
        let whole: Box<dyn Read> = Box::new(Cursor::new(head[..got].to_vec()).chain(input));
        if &head[..got] == b"fLaC" {
            FlacStream::from_reader(name, whole, size.is_none()).map(AudioStream::Flac)
        } else {
            WavStream::from_reader(name, whole, size).map(AudioStream::Wav)
        }
    }

    fn inner(&self) -> &dyn SampleSource {
        match self {
            AudioStream::Wav(s) => s,
            AudioStream::Flac(s) => s,
        }
    }
}

impl SampleSource for AudioStream {
    fn name(&self) -> &str {
        self.inner().name()
    }

    fn channels(&self) -> usize {
        self.inner().channels()
    }

    fn sample_rate(&self) -> u32 {
        self.inner().sample_rate()
    }

    fn frames(&self) -> Option<u64> {
        self.inner().frames()
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        match self {
            AudioStream::Wav(s) => SampleSource::read(s, out),
            AudioStream::Flac(s) => s.read(out),
        }
    }

    fn is_live(&self) -> bool {
        self.inner().is_live()
    }

    fn notes(&self) -> Vec<String> {
        self.inner().notes()
    }

    fn describe(&self) -> String {
        self.inner().describe()
    }

    fn clock_origin(&self) -> Option<super::clock::ClockOrigin> {
        self.inner().clock_origin()
    }

    fn time_reference(&self) -> Option<super::clock::TimeReference> {
        self.inner().time_reference()
    }
}
