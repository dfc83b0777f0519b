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

use super::source::SampleSource;
use super::InputError;
use multiversion::multiversion;
use std::fs::File;
use std::io::{self, BufReader, Read};

/// What the header says about the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct WavFormat {
    /// Channels per sample frame.
    pub channels: usize,
    /// Sample frames per second.
    pub sample_rate: u32,
    /// Valid bits per sample.
    pub bits_per_sample: u16,
    /// IEEE float samples (else integer PCM).
    pub float: bool,
    /// Sample frames the header promises (`None`: placeholder length, read to the end).
    pub frames: Option<u64>,
}

impl WavFormat {
    /// A short description, e.g. `8 ch, 48000 Hz, 16-bit PCM`.
    pub fn describe(&self) -> String {
        format!(
            "{} ch, {} Hz, {}-bit {}",
            self.channels,
            self.sample_rate,
            self.bits_per_sample,
            if self.float { "float" } else { "PCM" }
        )
    }
}

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
}

impl WavStream {
    /// Opens a WAV file, or standard input for `-`.
    pub fn open(path: &str) -> Result<Self, InputError> {
        if path == "-" {
            return Self::from_reader(
                "<stdin>",
                Box::new(BufReader::with_capacity(1 << 16, io::stdin())),
                None,
            );
        }
        let file = File::open(path).map_err(InputError::Open)?;
        let meta = file.metadata().map_err(InputError::Io)?;
        if meta.is_dir() {
            return Err(InputError::Directory);
        }
        Self::from_reader(
            path,
            Box::new(BufReader::with_capacity(1 << 16, file)),
            Some(meta.len()),
        )
    }

    /// Reads the header from `input`; `size` is the total byte size when known (a file).
    pub fn from_reader(
        name: &str,
        mut input: Box<dyn Read>,
        size: Option<u64>,
    ) -> Result<Self, InputError> {
        let mut riff = [0u8; 12];
        let got = read_full(&mut input, &mut riff).map_err(InputError::Io)?;
        if got == 0 {
            return Err(InputError::NotWav("empty file, not a WAV recording".into()));
        }
        if got < 12 || &riff[8..12] != b"WAVE" || &riff[0..4] != b"RIFF" {
            let unsupported = InputError::Unsupported;
            return Err(match &riff[0..4] {
                b"RF64" | b"BW64" => unsupported("RF64/BW64 WAV (for files over 4 GB) is not supported: split it into WAV files under 4 GB, e.g. `sox in.wav out.wav trim 0 3600 : newfile : restart`".into()),
                b"RIFX" => unsupported("big-endian WAV (RIFX) is not supported: convert it, e.g. `sox in.wav -L out.wav`".into()),
                b"fLaC" => InputError::NotWav("this is a FLAC file, not WAV: convert it, e.g. `sox in.flac out.wav` or `ffmpeg -i in.flac out.wav`".into()),
                b"OggS" => InputError::NotWav("this is an Ogg file, not WAV: convert it, e.g. `ffmpeg -i in.ogg out.wav`".into()),
                _ => InputError::NotWav("not a WAV file (no RIFF/WAVE header)".into()),
            });
        }
        let mut consumed: u64 = 12;
        let mut fmt: Option<Vec<u8>> = None;
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
                b"fmt " => {
                    if !(16..=1024).contains(&len) {
                        return Err(InputError::Corrupt(format!(
                            "corrupt WAV: format chunk of {len} bytes"
                        )));
                    }
                    let mut body = vec![0u8; len as usize];
                    if read_full(&mut input, &mut body).map_err(InputError::Io)? < body.len() {
                        return Err(InputError::Corrupt(
                            "truncated WAV: the file ends in the format chunk".into(),
                        ));
                    }
                    consumed += len;
                    if len % 2 == 1 {
                        let mut pad = [0u8; 1];
                        read_full(&mut input, &mut pad).map_err(InputError::Io)?;
                        consumed += 1;
                    }
                    fmt = Some(body);
                }
                b"data" => break len,
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
        let available = size.map(|s| s.saturating_sub(consumed) / block_align);
        // 0 and 0xFFFFFFFF are the placeholders streaming writers leave.
        format.frames = if declared == 0 || declared == 0xFFFF_FFFF {
            available
        } else {
            Some(declared / block_align)
        };
        Ok(WavStream {
            name: name.to_string(),
            format,
            block_align: block_align as usize,
            input,
            raw: Vec::new(),
            frames_read: 0,
            done: false,
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
        if self.done || want == 0 {
            return Ok(0);
        }
        let bytes = want * self.block_align;
        if self.raw.len() < bytes {
            self.raw.resize(bytes, 0);
        }
        let got = read_full(&mut self.input, &mut self.raw[..bytes]).map_err(InputError::Read)?;
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
        if got < bytes {
            // The input ended before the request was met.
            self.done = true;
            if let Some(promised) = self.format.frames {
                if self.frames_read < promised {
                    return Err(InputError::Truncated {
                        promised,
                        read: self.frames_read,
                        sample_rate: self.format.sample_rate,
                    });
                }
            }
        }
        Ok(frames)
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
        self.format.frames
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        WavStream::read(self, out)
    }

    fn describe(&self) -> String {
        self.format.describe()
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

/// Parses a `fmt ` chunk body; returns the format and the block alignment in bytes.
fn parse_fmt(b: &[u8]) -> Result<(WavFormat, u64), InputError> {
    let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
    let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let mut tag = u16_at(0);
    let channels = u16_at(2) as usize;
    let sample_rate = u32_at(4);
    let block_align = u16_at(12) as u64;
    let container_bits = u16_at(14);
    let mut bits = container_bits;
    if tag == 0xFFFE {
        if b.len() < 40 {
            return Err(InputError::Corrupt(
                "corrupt WAV: WAVE_FORMAT_EXTENSIBLE header is too short".into(),
            ));
        }
        let valid = u16_at(18);
        if valid > 0 {
            bits = valid;
        }
        tag = u16_at(24);
    }
    if channels == 0 {
        return Err(InputError::Corrupt(
            "corrupt WAV: the header says 0 channels".into(),
        ));
    }
    if sample_rate == 0 {
        return Err(InputError::Corrupt(
            "corrupt WAV: the header says a sample rate of 0 Hz".into(),
        ));
    }
    if block_align == 0
        || block_align % channels as u64 != 0
        || block_align / channels as u64 * 8 < container_bits as u64
    {
        return Err(InputError::Corrupt(format!("corrupt WAV: inconsistent block size {block_align} for {channels} channels of {container_bits} bits")));
    }
    let width = block_align / channels as u64;
    let float = match tag {
        1 => {
            if !matches!(bits, 8 | 16 | 24 | 32) || !(1..=4).contains(&width) || (width == 1 && bits != 8) {
                return Err(InputError::Unsupported(format!(
                    "{bits}-bit integer PCM in {width}-byte containers is not supported (8, 16, 24 or 32 bits are)"
                )));
            }
            false
        }
        3 => {
            if bits == 64 {
                return Err(InputError::Unsupported("64-bit float WAV is not supported: convert it to 32-bit float, e.g. `sox in.wav -e floating-point -b 32 out.wav` or `ffmpeg -i in.wav -c:a pcm_f32le out.wav`".into()));
            }
            if bits != 32 || width != 4 {
                return Err(InputError::Unsupported(format!("{bits}-bit float WAV is not supported (32-bit float is)")));
            }
            true
        }
        other => {
            return Err(InputError::Unsupported(format!(
                "compressed WAV (format tag 0x{other:04x}) is not supported: convert it to PCM, e.g. `sox in.wav -e signed-integer -b 16 out.wav`"
            )))
        }
    };
    Ok((
        WavFormat {
            channels,
            sample_rate,
            bits_per_sample: bits,
            float,
            frames: None,
        },
        block_align,
    ))
}

/// Like `read_exact`, but returns how many bytes were read before the end of input.
fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(all(test, feature = "simulate"))]
mod tests {
    use super::*;
    use crate::sim::{write_wav, Encoding};

    /// Our block decoder against hound's per-sample reader, for every encoding hound
    /// writes, over the full range including the extremes.
    #[test]
    fn decoder_matches_hound_for_every_encoding() {
        let dir = tempfile::tempdir().unwrap();
        let n = 5000;
        let ch: Vec<Vec<f32>> = (0..3)
            .map(|c| {
                (0..n)
                    .map(|i| {
                        let x = ((i * 7919 + c * 104_729) % 20001) as f32 / 10000.0 - 1.0;
                        if i == 0 {
                            -1.0
                        } else if i == 1 {
                            0.999_99
                        } else {
                            x
                        }
                    })
                    .collect()
            })
            .collect();
        for (enc, bits) in [
            (Encoding::Int8, 8),
            (Encoding::Int16, 16),
            (Encoding::Int24, 24),
            (Encoding::Int32, 32),
            (Encoding::Float32, 32),
        ] {
            let path = dir.path().join(format!("{enc:?}.wav"));
            write_wav(&path, &ch, 16000, enc).unwrap();
            let mut hound_reader = hound::WavReader::open(&path).unwrap();
            let reference: Vec<f32> = if enc == Encoding::Float32 {
                hound_reader.samples::<f32>().map(|s| s.unwrap()).collect()
            } else {
                let scale = (1i64 << (bits - 1)) as f32;
                hound_reader
                    .samples::<i32>()
                    .map(|s| s.unwrap() as f32 / scale)
                    .collect()
            };
            let mut ours = WavStream::open(path.to_str().unwrap()).unwrap();
            assert_eq!(ours.format.frames, Some(n as u64));
            let mut got = vec![0.0f32; 3 * n];
            // Odd block sizes exercise the block boundaries.
            let mut filled = 0;
            while filled < 3 * n {
                let k = ours
                    .read(&mut got[filled..(filled + 3 * 333).min(3 * n)])
                    .unwrap();
                assert!(k > 0);
                filled += 3 * k;
            }
            assert_eq!(ours.read(&mut got[..3]).unwrap(), 0);
            for (i, (a, b)) in got.iter().zip(&reference).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-7 * b.abs().max(1.0),
                    "{enc:?} sample {i}: {a} vs {b}"
                );
            }
        }
    }
}
