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

    /// Reads an open file, named `name` in messages: a regular file is read with its
    /// length, anything else to its end as a pipe.
    pub fn from_file(name: &str, file: std::fs::File) -> Result<Self, InputError> {
        let meta = file.metadata().map_err(InputError::Io)?;
        if meta.is_dir() {
            return Err(InputError::Directory);
        }
        let size = meta.is_file().then_some(meta.len());
        let input = std::io::BufReader::with_capacity(1 << 16, file);
        Self::from_reader(name, Box::new(input), size)
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
        if got == 4 && &head[..3] == b"ID3" {
            // An ID3v2 tag before the audio, as tag editors put before FLAC: skipped
            // when FLAC follows; otherwise the bytes are what they are (an MP3).
            let mut tag = [0u8; 10];
            tag[..4].copy_from_slice(&head);
            let more = read_full(&mut input, &mut tag[4..]).map_err(InputError::Io)?;
            let syncsafe = |b: &[u8]| b.iter().fold(0u64, |n, &x| n << 7 | (x & 0x7F) as u64);
            if more == 6 {
                let footer = if tag[5] & 0x10 != 0 { 10 } else { 0 };
                let skip = syncsafe(&tag[6..10]) + footer;
                let skipped = std::io::copy(&mut (&mut input).take(skip), &mut std::io::sink())
                    .map_err(InputError::Io)?;
                let mut after = [0u8; 4];
                let n = read_full(&mut input, &mut after).map_err(InputError::Io)?;
                if skipped == skip && &after[..n] == b"fLaC" {
                    let whole: Box<dyn Read> = Box::new(Cursor::new(after.to_vec()).chain(input));
                    return FlacStream::from_reader(name, whole, size.is_none())
                        .map(AudioStream::Flac);
                }
            }
            let whole: Box<dyn Read> = Box::new(Cursor::new(tag[..4 + more].to_vec()).chain(input));
            return WavStream::from_reader(name, whole, size).map(AudioStream::Wav);
        }
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
