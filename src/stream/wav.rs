//! Audio input: multichannel WAV, streamed, cut into frames of `N` samples with 50%
//! overlap (the paper's Section II opening).
//!
//! The RIFF header is read here so that unsupported inputs (64-bit float, RF64,
//! compressed formats, other file types) get a precise message, and so that headers with
//! placeholder lengths (written by `sox`/`ffmpeg` into pipes, or by recorders that stopped
//! before finishing the file) are read to the end of the data. Samples are decoded in
//! blocks from little-endian bytes (8-bit unsigned, 16/24/32-bit signed, 32-bit float;
//! containers wider than their valid bits are left-justified, so scaling by the
//! container is exact); the tests check this decoder against hound's for every encoding.
//! Memory does not depend on the length of the recording.

use super::clock::{ClockOrigin, TimeReference, BEXT_TIME_END};
pub use super::header::WavFormat;
use super::header::{not_wav, parse_fmt};
use super::source::{open_input, read_full, SampleSource};
use super::InputError;
use multiversion::multiversion;
use std::io::{self, Read};

/// A streaming WAV reader producing interleaved `f32` samples in [-1, 1).
pub struct WavStream {
    name: String,
    /// What the header says.
    pub format: WavFormat,
    block_align: usize,
    input: Box<dyn Read>,
    /// Raw bytes of the block being decoded (grows once to the largest request).
    raw: Vec<u8>,
    frames_read: u64,
    done: bool,
    /// An error to report on the next read, after the frames before it were delivered.
    pending: Option<InputError>,
    /// Remarks about the file (sizes that wrapped at 4 GiB).
    notes: Vec<String>,
    /// A live input (a pipe, a device, standard input): reads return what has arrived,
    /// so that frames are analysed as soon as they are complete.
    live: bool,
    /// Bytes of an incomplete sample frame at the start of `raw` (live inputs).
    partial: usize,
    /// Bytes after the last whole sample frame of the data, when its length is known up
    /// front (the header's, or a file's remainder when the header has a placeholder).
    tail: u64,
    /// Whether the data's length is whole sample frames. When not, the length is not
    /// promised to the analysis, which reads to the end and reports the damage, from a
    /// file as from a pipe (whose length is the header's alone).
    whole: bool,
}

impl WavStream {
    /// Opens a WAV file, or standard input for `-`.
    pub fn open(path: &str) -> Result<Self, InputError> {
        let (name, input, size) = open_input(path)?;
        Self::from_reader(name, input, size)
    }

    /// Reads the header from `input`; `size` is the total byte size when known (a file).
    pub fn from_reader(
        name: &str,
        mut input: Box<dyn Read>,
        size: Option<u64>,
    ) -> Result<Self, InputError> {
        let mut riff = [0u8; 12];
        let got = read_full(&mut input, &mut riff).map_err(InputError::Io)?;
        let rf64 = match (&riff[0..4], &riff[8..12]) {
            _ if got < 12 => return Err(not_wav(&riff[..got])),
            (b"RIFF", b"WAVE") => false,
            (b"RF64" | b"BW64", b"WAVE") => true,
            _ => return Err(not_wav(&riff)),
        };
        let mut consumed: u64 = 12;
        let mut fmt: Option<Vec<u8>> = None;
        let mut ds64_data: Option<u64> = None;
        let mut bext: Option<TimeReference> = None;
        let mut bext_seen = false;
        let declared = loop {
            let mut head = [0u8; 8];
            if read_full(&mut input, &mut head).map_err(InputError::Io)? < 8 {
                return Err(InputError::Corrupt(if fmt.is_none() {
                    "truncated WAV: the header ends before the format chunk".into()
                } else {
                    "truncated WAV: no data chunk (the file ends in the header)".into()
                }));
            }
            consumed += 8;
            let len = u32::from_le_bytes([head[4], head[5], head[6], head[7]]) as u64;
            match &head[0..4] {
                b"fmt " | b"ds64" => {
                    if !(16..=1024).contains(&len) {
                        return Err(InputError::Corrupt(format!(
                            "corrupt WAV: {} chunk of {len} bytes",
                            String::from_utf8_lossy(&head[0..4]).trim()
                        )));
                    }
                    let mut body = vec![0u8; len as usize + (len % 2) as usize];
                    if read_full(&mut input, &mut body).map_err(InputError::Io)? < body.len() {
                        return Err(InputError::Corrupt(
                            "truncated WAV: the file ends in the header".into(),
                        ));
                    }
                    consumed += body.len() as u64;
                    body.truncate(len as usize);
                    if &head[0..4] == b"fmt " {
                        if fmt.is_some() {
                            return Err(InputError::Corrupt(
                                "corrupt WAV: two format chunks (which one describes the data cannot be told)".into(),
                            ));
                        }
                        fmt = Some(body);
                    } else if len >= 16 {
                        // ds64: the 64-bit RIFF size, then the 64-bit data size.
                        ds64_data =
                            Some(u64::from_le_bytes(body[8..16].try_into().expect("8 bytes")));
                    }
                }
                b"data" if rf64 && len == 0xFFFF_FFFF => {
                    break ds64_data.ok_or_else(|| {
                        InputError::Corrupt(
                            "corrupt RF64: the data chunk's size is in a ds64 chunk, and there is none".into(),
                        )
                    })?;
                }
                b"data" => break len,
                b"bext" if len as usize >= BEXT_TIME_END => {
                    let mut body = vec![0u8; BEXT_TIME_END];
                    if read_full(&mut input, &mut body).map_err(InputError::Io)? < body.len() {
                        return Err(InputError::Corrupt(
                            "truncated WAV: the file ends in the header".into(),
                        ));
                    }
                    if bext_seen {
                        return Err(InputError::Corrupt(
                            "corrupt WAV: two bext chunks (which one dates the recording cannot be told)".into(),
                        ));
                    }
                    bext_seen = true;
                    bext = TimeReference::from_bext(&body);
                    let skip = len + (len % 2) - BEXT_TIME_END as u64;
                    let skipped = io::copy(&mut (&mut input).take(skip), &mut io::sink())
                        .map_err(InputError::Io)?;
                    if skipped < skip {
                        return Err(InputError::Corrupt(
                            "truncated WAV: no data chunk (the file ends in the header)".into(),
                        ));
                    }
                    consumed += len + (len % 2);
                }
                _ => {
                    let skip = len + (len % 2);
                    let skipped = io::copy(&mut (&mut input).take(skip), &mut io::sink())
                        .map_err(InputError::Io)?;
                    if skipped < skip {
                        return Err(InputError::Corrupt(
                            "truncated WAV: no data chunk (the file ends in the header)".into(),
                        ));
                    }
                    consumed += skip;
                }
            }
        };
        let fmt = fmt.ok_or_else(|| {
            InputError::Corrupt("corrupt WAV: the data chunk comes before any format chunk".into())
        })?;
        let (mut format, block_align) = parse_fmt(&fmt)?;
        let available = size.map(|s| s.saturating_sub(consumed));
        let mut notes = Vec::new();
        let data_bytes = match (declared, available) {
            // 0 and 0xFFFFFFFF are the placeholders streaming writers leave: read to the end.
            (0 | 0xFFFF_FFFF, _) if !rf64 => available,
            // 32-bit sizes wrap at 4 GiB: a regular file holding more than 4 GiB of data
            // beyond what the header says is read to its end.
            (d, Some(a)) if !rf64 && a >= 1 << 32 && a > d => {
                notes.push(format!(
                    "the header's 32-bit data size ({d} bytes) wrapped past 4 GiB: read to the end of the file ({} sample frames)",
                    a / block_align
                ));
                Some(a)
            }
            (d, _) => Some(d),
        };
        format.frames = data_bytes.map(|d| d / block_align);
        format.time_reference = bext;
        let tail = data_bytes.map_or(0, |d| d % block_align);
        let whole = tail == 0;
        Ok(WavStream {
            name: name.to_string(),
            format,
            block_align: block_align as usize,
            input,
            raw: Vec::new(),
            frames_read: 0,
            done: false,
            pending: None,
            notes,
            live: size.is_none(),
            partial: 0,
            tail,
            whole,
        })
    }

    /// The name used in messages (path, or `<stdin>`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Sample frames delivered so far.
    pub fn frames_read(&self) -> u64 {
        self.frames_read
    }

    /// Reads up to `out.len() / channels` sample frames into `out` (interleaved, in
    /// [-1, 1)) and returns how many were read; 0 at the end. A truncated file or a
    /// non-finite sample is an error.
    pub fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        let ch = self.format.channels;
        let mut want = out.len() / ch;
        if let Some(total) = self.format.frames {
            want = want.min((total - self.frames_read.min(total)) as usize);
        }
        if !self.done && self.format.frames == Some(self.frames_read) {
            // Every promised frame is read: what follows is checked once.
            self.done = true;
            self.pending = if self.tail > 0 {
                Some(self.partial_frame(self.tail))
            } else {
                self.check_after_data()
            };
        }
        if let Some(e) = self.pending.take() {
            return Err(e);
        }
        if self.done || want == 0 {
            return Ok(0);
        }
        let bytes = want * self.block_align;
        if self.raw.len() < bytes {
            self.raw.resize(bytes, 0);
        }
        let (got, ended) = if self.live {
            self.read_available(bytes)?
        } else {
            let got =
                read_full(&mut self.input, &mut self.raw[..bytes]).map_err(InputError::Read)?;
            (got, got < bytes)
        };
        let frames = got / self.block_align;
        decode(
            &self.raw[..frames * self.block_align],
            self.block_align / ch,
            self.format.float,
            &mut out[..frames * ch],
        );
        if self.format.float {
            if let Some(i) = out[..frames * ch].iter().position(|v| !v.is_finite()) {
                let frame = self.frames_read + (i / ch) as u64;
                return Err(InputError::non_finite(
                    frame,
                    i % ch,
                    out[i],
                    self.format.sample_rate,
                ));
            }
        }
        self.frames_read += frames as u64;
        if self.live {
            // Bytes of an incomplete sample frame wait for the rest.
            let used = frames * self.block_align;
            self.raw.copy_within(used..got, 0);
            self.partial = got - used;
        }
        if ended {
            // The input ended before the request was met: the frames read are delivered,
            // and the truncation is reported on the next read (at once when there are
            // none, so that no caller takes the end for a complete file).
            self.done = true;
            let leftover = (got - frames * self.block_align) as u64;
            if let Some(promised) = self.format.frames.filter(|&p| self.frames_read < p) {
                self.pending = Some(InputError::Truncated {
                    promised,
                    read: self.frames_read,
                    sample_rate: self.format.sample_rate,
                });
            } else if leftover > 0 {
                self.pending = Some(self.partial_frame(leftover));
            }
        }
        if frames == 0 {
            if let Some(e) = self.pending.take() {
                return Err(e);
            }
        }
        Ok(frames)
    }

    fn partial_frame(&self, bytes: u64) -> InputError {
        InputError::PartialFrame {
            bytes,
            block_align: self.block_align as u64,
            read: self.frames_read,
            sample_rate: self.format.sample_rate,
        }
    }

    /// Reads what a live input has (at least one sample frame, unless it ends) into
    /// `raw`, after the bytes of an incomplete frame kept from the last read. Returns the
    /// bytes now in `raw` and whether the input ended.
    fn read_available(&mut self, bytes: usize) -> Result<(usize, bool), InputError> {
        let mut got = self.partial;
        while got < self.block_align.min(bytes) || got == self.partial {
            match self.input.read(&mut self.raw[got..bytes]) {
                Ok(0) => return Ok((got, true)),
                Ok(k) => got += k,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(InputError::Read(e)),
            }
            if got >= self.block_align {
                break;
            }
        }
        Ok((got, false))
    }

    /// After the last sample the header promised: a second data chunk would hold samples
    /// this reader does not analyse, so it is refused rather than silently left out.
    fn check_after_data(&mut self) -> Option<InputError> {
        let data_bytes = self.frames_read * self.block_align as u64;
        let mut head = [0u8; 9];
        let want = if data_bytes % 2 == 1 { 9 } else { 8 };
        let got = read_full(&mut self.input, &mut head[..want]).ok()?;
        let id = &head[want - 8..want - 4];
        (got == want && id == b"data").then(|| {
            InputError::Unsupported(
                "a second data chunk follows the first: WAV files with several data chunks are not supported; rewrite the file, e.g. `sox in.wav out.wav`".into(),
            )
        })
    }
}

impl SampleSource for WavStream {
    fn name(&self) -> &str {
        &self.name
    }

    fn channels(&self) -> usize {
        self.format.channels
    }

    fn sample_rate(&self) -> u32 {
        self.format.sample_rate
    }

    fn frames(&self) -> Option<u64> {
        self.format.frames.filter(|_| self.whole)
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        WavStream::read(self, out)
    }

    fn describe(&self) -> String {
        self.format.describe()
    }

    fn notes(&self) -> Vec<String> {
        self.notes.clone()
    }

    fn is_live(&self) -> bool {
        self.live
    }

    fn clock_origin(&self) -> Option<ClockOrigin> {
        ClockOrigin::new(
            self.format.time_reference.as_ref()?,
            self.format.sample_rate,
        )
    }

    fn time_reference(&self) -> Option<TimeReference> {
        self.format.time_reference
    }
}

/// Decodes little-endian samples of `width` bytes into `out` in [-1, 1).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn decode(raw: &[u8], width: usize, float: bool, out: &mut [f32]) {
    match (width, float) {
        (4, true) => {
            for (o, b) in out.iter_mut().zip(raw.chunks_exact(4)) {
                *o = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        (1, _) => {
            for (o, &b) in out.iter_mut().zip(raw) {
                *o = (b as f32 - 128.0) / 128.0;
            }
        }
        (2, _) => {
            for (o, b) in out.iter_mut().zip(raw.chunks_exact(2)) {
                *o = i16::from_le_bytes([b[0], b[1]]) as f32 / 32768.0;
            }
        }
        (3, _) => {
            for (o, b) in out.iter_mut().zip(raw.chunks_exact(3)) {
                // The 24-bit value in the top of an i32, then scaled by 2^31.
                *o = i32::from_le_bytes([0, b[0], b[1], b[2]]) as f32 / 2_147_483_648.0;
            }
        }
        (4, false) => {
            for (o, b) in out.iter_mut().zip(raw.chunks_exact(4)) {
                *o = i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32 / 2_147_483_648.0;
            }
        }
        _ => unreachable!("parse_fmt admits only 1-4 byte integer and 4-byte float containers"),
    }
}

#[cfg(all(test, feature = "simulate"))]
#[path = "wav_tests.rs"]
mod tests;
