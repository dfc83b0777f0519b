//! Audio input: multichannel WAV, streamed, cut into frames of `N` samples with 50%
//! overlap (the paper's Section II opening).
//!
//! The RIFF header is read here so that unsupported inputs (64-bit float, RF64,
//! compressed formats, other file types) get a precise message, and so that headers with
//! placeholder lengths (written by `sox`/`ffmpeg` into pipes, or by recorders that stopped
//! before finishing the file) are read to the end of the data. Samples are decoded in
//! blocks from little-endian bytes (8-bit unsigned, 16/24/32-bit signed, 32-bit float;
//! containers wider than their valid bits are left-justified, so scaling by the
//! container is exact). hound decoded them one call per sample, which cost 30% of a run;
//! the tests check this decoder against hound's for every encoding. Memory does not
//! depend on the length of the recording.

use anyhow::{bail, Result};
use multiversion::multiversion;
use std::fs::File;
use std::io::{self, BufReader, Read};

/// What the header says about the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct WavFormat {
    pub channels: usize,
    pub sample_rate: u32,
    pub bits_per_sample: u16,
    pub float: bool,
    /// Sample frames the header promises (`None`: placeholder length, read to the end).
    pub frames: Option<u64>,
}

impl WavFormat {
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
    pub fn open(path: &str) -> Result<Self> {
        if path == "-" {
            return Self::from_reader(
                "<stdin>",
                Box::new(BufReader::with_capacity(1 << 16, io::stdin())),
                None,
            );
        }
        let file = File::open(path)
            .map_err(|e| anyhow::anyhow!("{path}: cannot open: {}", io_reason(&e)))?;
        let meta = file
            .metadata()
            .map_err(|e| anyhow::anyhow!("{path}: {}", io_reason(&e)))?;
        if meta.is_dir() {
            bail!("{path}: is a directory, not a WAV file");
        }
        Self::from_reader(
            path,
            Box::new(BufReader::with_capacity(1 << 16, file)),
            Some(meta.len()),
        )
    }

    /// Reads the header from `input`; `size` is the total byte size when known (a file).
    pub fn from_reader(name: &str, mut input: Box<dyn Read>, size: Option<u64>) -> Result<Self> {
        let fail = |msg: String| anyhow::anyhow!("{name}: {msg}");
        let mut riff = [0u8; 12];
        let got = read_full(&mut input, &mut riff).map_err(|e| fail(io_reason(&e)))?;
        if got == 0 {
            return Err(fail("empty file, not a WAV recording".into()));
        }
        if got < 12 || &riff[8..12] != b"WAVE" || &riff[0..4] != b"RIFF" {
            return Err(fail(match &riff[0..4] {
                b"RF64" | b"BW64" => "RF64/BW64 WAV (for files over 4 GB) is not supported: split it into WAV files under 4 GB, e.g. `sox in.wav out.wav trim 0 3600 : newfile : restart`".into(),
                b"RIFX" => "big-endian WAV (RIFX) is not supported: convert it, e.g. `sox in.wav -L out.wav`".into(),
                b"fLaC" => "this is a FLAC file, not WAV: convert it, e.g. `sox in.flac out.wav` or `ffmpeg -i in.flac out.wav`".into(),
                b"OggS" => "this is an Ogg file, not WAV: convert it, e.g. `ffmpeg -i in.ogg out.wav`".into(),
                _ => "not a WAV file (no RIFF/WAVE header)".into(),
            }));
        }
        let mut consumed: u64 = 12;
        let mut fmt: Option<Vec<u8>> = None;
        let declared = loop {
            let mut head = [0u8; 8];
            if read_full(&mut input, &mut head).map_err(|e| fail(io_reason(&e)))? < 8 {
                return Err(fail(if fmt.is_none() {
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
                        return Err(fail(format!("corrupt WAV: format chunk of {len} bytes")));
                    }
                    let mut body = vec![0u8; len as usize];
                    if read_full(&mut input, &mut body).map_err(|e| fail(io_reason(&e)))?
                        < body.len()
                    {
                        return Err(fail(
                            "truncated WAV: the file ends in the format chunk".into(),
                        ));
                    }
                    consumed += len;
                    if len % 2 == 1 {
                        let mut pad = [0u8; 1];
                        read_full(&mut input, &mut pad).map_err(|e| fail(io_reason(&e)))?;
                        consumed += 1;
                    }
                    fmt = Some(body);
                }
                b"data" => break len,
                _ => {
                    let skip = len + (len % 2);
                    let skipped = io::copy(&mut (&mut input).take(skip), &mut io::sink())
                        .map_err(|e| fail(io_reason(&e)))?;
                    if skipped < skip {
                        return Err(fail(
                            "truncated WAV: no data chunk (the file ends in the header)".into(),
                        ));
                    }
                    consumed += skip;
                }
            }
        };
        let fmt = fmt.ok_or_else(|| {
            fail("corrupt WAV: the data chunk comes before any format chunk".into())
        })?;
        let (mut format, block_align) = parse_fmt(&fmt).map_err(fail)?;
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
    pub fn read(&mut self, out: &mut [f32]) -> Result<usize> {
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
        let got = read_full(&mut self.input, &mut self.raw[..bytes])
            .map_err(|e| anyhow::anyhow!("{}: read error: {}", self.name, io_reason(&e)))?;
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
                bail!(
                    "{}: sample {} of channel {} is {} (at {:.6} s): the recording is corrupt",
                    self.name,
                    frame,
                    i % ch,
                    if out[i].is_nan() { "NaN" } else { "infinite" },
                    frame as f64 / self.format.sample_rate as f64
                );
            }
        }
        self.frames_read += frames as u64;
        if got < bytes {
            // The input ended before the request was met.
            self.done = true;
            if let Some(promised) = self.format.frames {
                if self.frames_read < promised {
                    bail!(
                        "{}: truncated WAV: the header promises {} sample frames ({:.3} s) but the data ends after {} ({:.3} s)",
                        self.name,
                        promised,
                        promised as f64 / self.format.sample_rate as f64,
                        self.frames_read,
                        self.frames_read as f64 / self.format.sample_rate as f64
                    );
                }
            }
        }
        Ok(frames)
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
fn parse_fmt(b: &[u8]) -> std::result::Result<(WavFormat, u64), String> {
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
            return Err("corrupt WAV: WAVE_FORMAT_EXTENSIBLE header is too short".into());
        }
        let valid = u16_at(18);
        if valid > 0 {
            bits = valid;
        }
        tag = u16_at(24);
    }
    if channels == 0 {
        return Err("corrupt WAV: the header says 0 channels".into());
    }
    if sample_rate == 0 {
        return Err("corrupt WAV: the header says a sample rate of 0 Hz".into());
    }
    if block_align == 0
        || block_align % channels as u64 != 0
        || block_align / channels as u64 * 8 < container_bits as u64
    {
        return Err(format!("corrupt WAV: inconsistent block size {block_align} for {channels} channels of {container_bits} bits"));
    }
    let width = block_align / channels as u64;
    let float = match tag {
        1 => {
            if !matches!(bits, 8 | 16 | 24 | 32) || !(1..=4).contains(&width) || (width == 1 && bits != 8) {
                return Err(format!(
                    "{bits}-bit integer PCM in {width}-byte containers is not supported (8, 16, 24 or 32 bits are)"
                ));
            }
            false
        }
        3 => {
            if bits == 64 {
                return Err("64-bit float WAV is not supported: convert it to 32-bit float, e.g. `sox in.wav -e floating-point -b 32 out.wav` or `ffmpeg -i in.wav -c:a pcm_f32le out.wav`".into());
            }
            if bits != 32 || width != 4 {
                return Err(format!("{bits}-bit float WAV is not supported (32-bit float is)"));
            }
            true
        }
        other => {
            return Err(format!(
                "compressed WAV (format tag 0x{other:04x}) is not supported: convert it to PCM, e.g. `sox in.wav -e signed-integer -b 16 out.wav`"
            ))
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

/// An I/O error as a short lower-case reason without the "(os error N)" suffix.
pub fn io_reason(e: &io::Error) -> String {
    match e.kind() {
        io::ErrorKind::NotFound => "no such file".into(),
        io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => {
            let s = e.to_string();
            match s.find(" (os error") {
                Some(i) => s[..i].to_string(),
                None => s,
            }
        }
    }
}

/// Consecutive frames of `n` samples per microphone with a hop of `n / 2`, up to
/// `capacity` of them in one mic-major buffer: mic `m`'s samples of frame `i` are
/// `data[m * stride + i * hop..][..n]`, so overlapping frames share their samples.
pub struct FrameBlock {
    n: usize,
    hop: usize,
    stride: usize,
    data: Vec<f32>,
    /// Index of the block's first frame in the file.
    pub first: u64,
    /// Frames in the block.
    pub count: usize,
    /// The read error that ended the block early (the frames before it are complete).
    pub error: Option<anyhow::Error>,
}

impl FrameBlock {
    pub fn new(n: usize, mics: usize, capacity: usize) -> Self {
        let hop = n / 2;
        let stride = (capacity - 1) * hop + n;
        FrameBlock {
            n,
            hop,
            stride,
            data: vec![0.0; mics * stride],
            first: 0,
            count: 0,
            error: None,
        }
    }

    /// Frame `i` of the block: its samples from `data[0..]`, mic `m` at `m * stride`.
    pub fn frame(&self, i: usize) -> (&[f32], usize) {
        assert!(i < self.count, "frame {i} of a block of {}", self.count);
        (&self.data[i * self.hop..], self.stride)
    }
}

/// Cuts a stream into [`FrameBlock`]s, picking the geometry's channels; the last
/// `n - hop` samples of each block start the next.
pub struct Framer {
    n: usize,
    hop: usize,
    channels: Vec<usize>,
    stream_channels: usize,
    /// Decoded interleaved samples, read a chunk at a time.
    interleaved: Vec<f32>,
    /// Per mic, the samples the next block's first frame shares with the last one.
    carry: Vec<f32>,
    next_index: u64,
    started: bool,
}

/// Sample frames decoded per read.
const CHUNK: usize = 4096;

impl Framer {
    /// `channels[m]` is the WAV channel of mic `m`; `stream_channels` the file's count.
    pub fn new(n: usize, channels: Vec<usize>, stream_channels: usize) -> Self {
        let mics = channels.len();
        Framer {
            n,
            hop: n / 2,
            interleaved: vec![0.0; CHUNK * stream_channels],
            carry: vec![0.0; mics * (n - n / 2)],
            channels,
            stream_channels,
            next_index: 0,
            started: false,
        }
    }

    /// The WAV channel of mic `m`.
    pub fn channel_of(&self, m: usize) -> usize {
        self.channels[m]
    }

    /// Fills `block` with the frames that follow the last block filled (frame `i` of
    /// the file starts at sample `i * hop`): as many as fit, fewer at the end of the
    /// stream (none after it). A read error keeps the complete frames before it and is
    /// left in `block.error`.
    pub fn fill(&mut self, stream: &mut WavStream, block: &mut FrameBlock) {
        assert!(block.n == self.n, "a block for another frame size");
        let (n, keep, stride, ch) = (
            self.n,
            self.n - self.hop,
            block.stride,
            self.stream_channels,
        );
        block.first = self.next_index;
        block.count = 0;
        block.error = None;
        let mut filled = 0;
        if self.started {
            for (m, carry) in self.carry.chunks_exact(keep).enumerate() {
                block.data[m * stride..m * stride + keep].copy_from_slice(carry);
            }
            filled = keep;
        }
        while filled < stride {
            let want = (stride - filled).min(CHUNK);
            let got = match stream.read(&mut self.interleaved[..want * ch]) {
                Ok(0) => break,
                Ok(got) => got,
                Err(e) => {
                    block.error = Some(e);
                    break;
                }
            };
            for (m, &c) in self.channels.iter().enumerate() {
                let row = &mut block.data[m * stride + filled..m * stride + filled + got];
                deinterleave(&self.interleaved[..got * ch], ch, c, row);
            }
            filled += got;
        }
        if filled < n {
            return;
        }
        block.count = (filled - n) / self.hop + 1;
        // The next frame starts `count` hops in; its first `keep` samples are here.
        let start = block.count * self.hop;
        if start + keep <= filled {
            for (m, carry) in self.carry.chunks_exact_mut(keep).enumerate() {
                carry.copy_from_slice(&block.data[m * stride + start..m * stride + start + keep]);
            }
        }
        self.started = true;
        self.next_index += block.count as u64;
    }
}

/// `out[i] = interleaved[i * channels + channel]`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn deinterleave(interleaved: &[f32], channels: usize, channel: usize, out: &mut [f32]) {
    for (d, s) in out.iter_mut().zip(interleaved.chunks_exact(channels)) {
        *d = s[channel];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{write_wav, Encoding};

    /// Blocks of overlapping frames hold exactly the file's samples, frame after frame,
    /// across block boundaries, picking and reordering channels, and stop at the last
    /// complete frame (lengths that end mid-hop, exactly on a block, shorter than a frame).
    #[test]
    fn frame_blocks_hold_consecutive_overlapping_frames() {
        let dir = tempfile::tempdir().unwrap();
        let (n, hop) = (8, 4);
        for len in [5usize, 8, 11, 12, 27, 28, 29, 40, 41] {
            let ch: Vec<Vec<f32>> = (0..3)
                .map(|c| (0..len).map(|t| (c * 1000 + t) as f32 / 4096.0).collect())
                .collect();
            let path = dir.path().join(format!("ramp{len}.wav"));
            write_wav(&path, &ch, 8000, Encoding::Float32).unwrap();
            let mut stream = WavStream::open(path.to_str().unwrap()).unwrap();
            let mut framer = Framer::new(n, vec![2, 0], 3);
            let mut block = FrameBlock::new(n, 2, 3);
            let mut seen = 0u64;
            loop {
                framer.fill(&mut stream, &mut block);
                assert!(block.error.is_none());
                if block.count == 0 {
                    break;
                }
                assert_eq!(block.first, seen);
                for i in 0..block.count {
                    let (data, stride) = block.frame(i);
                    let start = (block.first as usize + i) * hop;
                    for (m, c) in [(0, 2), (1, 0)] {
                        assert_eq!(
                            &data[m * stride..m * stride + n],
                            &ch[c][start..start + n],
                            "len {len}, frame {}",
                            block.first as usize + i
                        );
                    }
                }
                seen += block.count as u64;
            }
            let want = if len < n { 0 } else { (len - n) / hop + 1 };
            assert_eq!(seen, want as u64, "len {len}");
        }
    }

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
