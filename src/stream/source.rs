//! Where samples come from, and how they become blocks of overlapping frames.
//!
//! Every input (a WAV file, WAV bytes from any reader, channels already in memory, or a
//! source of the caller's own) is a [`SampleSource`]: interleaved `f32` samples read a
//! chunk at a time. The framer cuts any source into the same blocks of frames, so the
//! method sees the same frames whatever the input.

use super::InputError;
use crate::method::frames::FrameBlock;
use multiversion::multiversion;
use std::fs::File;
use std::io::{self, BufReader, Read};

/// An opened input: its name in messages, a reader, and its size when known.
pub(super) type Input<'a> = (&'a str, Box<dyn Read>, Option<u64>);

/// The input at `path` (standard input for `-`): its name in messages, a buffered
/// reader, and its size when it is a regular file (a pipe or a device has none and is
/// read as it arrives).
pub(super) fn open_input(path: &str) -> Result<Input<'_>, InputError> {
    if path == "-" {
        let stdin = BufReader::with_capacity(1 << 16, io::stdin());
        return Ok(("<stdin>", Box::new(stdin), None));
    }
    let file = File::open(path).map_err(InputError::Open)?;
    let meta = file.metadata().map_err(InputError::Io)?;
    if meta.is_dir() {
        return Err(InputError::Directory);
    }
    // A named pipe or a device (`/dev/stdin`) has no length: read it to its end, as `-`.
    let size = meta.is_file().then_some(meta.len());
    let file = BufReader::with_capacity(1 << 16, file);
    Ok((path, Box::new(file), size))
}

/// A stream of interleaved samples in [-1, 1), read a chunk at a time.
pub trait SampleSource {
    /// The name used in messages (a path, `<stdin>`, or the caller's choice).
    fn name(&self) -> &str;
    /// Channels per sample frame.
    fn channels(&self) -> usize;
    /// Sample frames per second.
    fn sample_rate(&self) -> u32;
    /// Sample frames the source promises, when known in advance.
    fn frames(&self) -> Option<u64>;
    /// Reads up to `out.len() / channels` sample frames into `out`, interleaved, and
    /// returns how many were read; 0 at the end. Samples must be finite.
    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError>;
    /// Whether samples arrive as they are recorded (a pipe, a device): the framer then
    /// hands on each frame as soon as it is complete, instead of filling whole blocks.
    fn is_live(&self) -> bool {
        false
    }
    /// Remarks for the user about the source (a WAV whose sizes wrapped at 4 GiB).
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// When the first sample was recorded, on the recorder's clock (a Broadcast WAV
    /// `bext` time reference with a date), if the source says.
    fn clock_origin(&self) -> Option<super::clock::ClockOrigin> {
        None
    }
    /// The source's time reference, dated or not, if it has one.
    fn time_reference(&self) -> Option<super::clock::TimeReference> {
        None
    }
    /// The sample format in words, for reports.
    fn describe(&self) -> String {
        format!(
            "{} ch, {} Hz, 32-bit float",
            self.channels(),
            self.sample_rate()
        )
    }
}

/// Channels already in memory, one slice per channel, all of the same length.
#[derive(Debug, Clone)]
pub struct Channels<'a> {
    name: String,
    channels: Vec<&'a [f32]>,
    sample_rate: u32,
    position: usize,
}

impl<'a> Channels<'a> {
    /// Channels named `name` in messages. Fails when there is no channel or when the
    /// channels differ in length.
    pub fn new(name: &str, channels: Vec<&'a [f32]>, sample_rate: u32) -> Result<Self, InputError> {
        let len = channels.first().map_or(0, |c| c.len());
        if channels.is_empty() || channels.iter().any(|c| c.len() != len) {
            return Err(InputError::Corrupt(
                "channels in memory must be at least one, all of the same length".into(),
            ));
        }
        if sample_rate == 0 {
            return Err(InputError::Corrupt("a sample rate of 0 Hz".into()));
        }
        Ok(Channels {
            name: name.to_string(),
            channels,
            sample_rate,
            position: 0,
        })
    }
}

impl SampleSource for Channels<'_> {
    fn name(&self) -> &str {
        &self.name
    }

    fn channels(&self) -> usize {
        self.channels.len()
    }

    fn sample_rate(&self) -> u32 {
        self.sample_rate
    }

    fn frames(&self) -> Option<u64> {
        Some(self.channels[0].len() as u64)
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        let ch = self.channels.len();
        let frames = (out.len() / ch).min(self.channels[0].len() - self.position);
        for (c, channel) in self.channels.iter().enumerate() {
            let part = &channel[self.position..self.position + frames];
            if let Some(i) = part.iter().position(|v| !v.is_finite()) {
                return Err(InputError::non_finite(
                    (self.position + i) as u64,
                    c,
                    part[i],
                    self.sample_rate,
                ));
            }
            for (o, &v) in out[c..].iter_mut().step_by(ch).zip(part) {
                *o = v;
            }
        }
        self.position += frames;
        Ok(frames)
    }
}

/// Cuts a source into [`FrameBlock`]s, picking the geometry's channels; the last
/// `n - hop` samples of each block start the next.
pub(crate) struct Framer {
    n: usize,
    hop: usize,
    channels: Vec<usize>,
    source_channels: usize,
    /// Decoded interleaved samples, read a chunk at a time.
    interleaved: Vec<f32>,
    /// Per mic (`n` samples each), the samples read past the last frame handed on: the
    /// part the next frame shares with it, and on a live source what has arrived of the
    /// frames after it.
    carry: Vec<f32>,
    /// Samples per mic in `carry`.
    carried: usize,
    next_index: u64,
    started: bool,
    /// Sample frames read from the source so far.
    pub samples_read: u64,
    /// Frames the first block of a live source waits for.
    first_frames: usize,
    /// Sample frames still to be read and dropped before the first frame (`--start`).
    skip: u64,
    /// Sample frames to read after those, at most (`--end`).
    limit: Option<u64>,
    /// The sample frame the span starts at.
    start: u64,
}

/// Samples (of all channels) read at a time: 4096 sample frames of 8 channels, fewer
/// frames of more channels.
const CHUNK_SAMPLES: usize = 1 << 15;

impl Framer {
    /// `channels[m]` is the source channel of mic `m`; `source_channels` the source's count;
    /// the first block of a live source holds at least `first_frames` frames.
    pub fn new(
        n: usize,
        channels: Vec<usize>,
        source_channels: usize,
        first_frames: usize,
    ) -> Self {
        let mics = channels.len();
        Framer {
            n,
            hop: n / 2,
            interleaved: vec![0.0; chunk_frames(source_channels) * source_channels],
            carry: vec![0.0; mics * n],
            carried: 0,
            channels,
            source_channels,
            next_index: 0,
            started: false,
            samples_read: 0,
            first_frames,
            skip: 0,
            limit: None,
            start: 0,
        }
    }

    /// Starts at frame `first` of the source (the sample frames before it are read and
    /// dropped) and reads at most `limit` sample frames from there.
    pub fn span(mut self, first: u64, limit: Option<u64>) -> Self {
        self.next_index = first;
        self.skip = first * self.hop as u64;
        self.start = self.skip;
        self.limit = limit;
        self
    }

    /// Of a source of `total` sample frames, those the span reads.
    pub fn spanned(&self, total: u64) -> u64 {
        let after = total.saturating_sub(self.start);
        self.limit.map_or(after, |l| after.min(l))
    }

    /// The source channel of mic `m`.
    pub fn channel_of(&self, m: usize) -> usize {
        self.channels[m]
    }

    /// Fills `block` with the frames that follow the last block filled (frame `i` of
    /// the source starts at sample `i * hop`): as many as fit, fewer at the end of the
    /// source (none after it). A read error keeps the complete frames before it and is
    /// returned.
    pub fn fill(
        &mut self,
        source: &mut dyn SampleSource,
        block: &mut FrameBlock,
    ) -> Option<InputError> {
        assert!(block.n == self.n, "a block for another frame size");
        let (n, stride, ch) = (self.n, block.stride, self.source_channels);
        block.first = self.next_index;
        block.count = 0;
        let mut error = None;
        let filled_before = self.carried;
        for (m, carry) in self.carry.chunks_exact(n).enumerate() {
            block.data[m * stride..m * stride + filled_before]
                .copy_from_slice(&carry[..filled_before]);
        }
        let mut filled = filled_before;
        while self.skip > 0 {
            let want = (self.skip as usize).min(self.interleaved.len() / ch);
            match source.read(&mut self.interleaved[..want * ch]) {
                Ok(0) => {
                    self.skip = 0;
                    break;
                }
                Ok(got) => self.skip -= got as u64,
                Err(e) => return Some(e),
            }
        }
        while filled < stride {
            let left = self
                .limit
                .map_or(usize::MAX, |l| l.saturating_sub(self.samples_read) as usize);
            let want = (stride - filled).min(self.interleaved.len() / ch).min(left);
            if want == 0 {
                break;
            }
            let got = match source.read(&mut self.interleaved[..want * ch]) {
                Ok(0) => break,
                Ok(got) => got,
                Err(e) => {
                    error = Some(e);
                    break;
                }
            };
            let read = &self.interleaved[..got * ch];
            deinterleave(read, ch, &self.channels, &mut block.data, stride, filled);
            filled += got;
            self.samples_read += got as u64;
            // A live source: analyse the frames complete so far without waiting for more
            // (the first block waits for the frames that prime the noise estimate).
            let need = if self.started {
                1
            } else {
                self.first_frames.max(1)
            };
            if source.is_live() && filled >= n + (need - 1) * self.hop {
                break;
            }
        }
        if filled < n {
            return error;
        }
        block.count = (filled - n) / self.hop + 1;
        // The next frame starts `count` hops in: what was read from there on is carried.
        let start = block.count * self.hop;
        self.carried = filled - start;
        for (m, carry) in self.carry.chunks_exact_mut(n).enumerate() {
            carry[..self.carried]
                .copy_from_slice(&block.data[m * stride + start..m * stride + filled]);
        }
        self.started = true;
        self.next_index += block.count as u64;
        error
    }
}

/// Like `read_exact`, but returns how many bytes were read before the end of input.
pub(super) fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> io::Result<usize> {
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

/// Sample frames read at a time from a source of `channels` channels.
fn chunk_frames(channels: usize) -> usize {
    (CHUNK_SAMPLES / channels).clamp(64, 4096)
}

/// Each mic's samples from interleaved sample frames of `channels` channels: mic `m`'s,
/// from channel `picked[m]`, go to `data[m * stride + at..]`. Eight sample frames at a
/// time (a few hundred bytes, in the core's first cache) give every mic its eight samples,
/// written whole; one pass per mic over the whole chunk read it from further away.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn deinterleave(
    interleaved: &[f32],
    channels: usize,
    picked: &[usize],
    data: &mut [f32],
    stride: usize,
    at: usize,
) {
    let frames = interleaved.len() / channels;
    let whole = frames / 8 * 8;
    for (j, block) in interleaved[..whole * channels]
        .chunks_exact(8 * channels)
        .enumerate()
    {
        for (m, &c) in picked.iter().enumerate() {
            let mut row = [0.0f32; 8];
            for (k, r) in row.iter_mut().enumerate() {
                *r = block[k * channels + c];
            }
            let start = m * stride + at + 8 * j;
            data[start..start + 8].copy_from_slice(&row);
        }
    }
    for (m, &c) in picked.iter().enumerate() {
        let row = &mut data[m * stride + at + whole..m * stride + at + frames];
        for (d, frame) in row
            .iter_mut()
            .zip(interleaved[whole * channels..].chunks_exact(channels))
        {
            *d = frame[c];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blocks of overlapping frames hold exactly the file's samples, frame after frame,
    /// across block boundaries, picking and reordering channels, and stop at the last
    /// complete frame (lengths that end mid-hop, exactly on a block, shorter than a frame).
    #[test]
    fn frame_blocks_hold_consecutive_overlapping_frames() {
        let (n, hop) = (8, 4);
        // Three channels and eight, with lengths that end mid-way through eight
        // sample frames and a second chunk.
        for (channels, len) in [5usize, 8, 11, 12, 27, 28, 29, 40, 41]
            .into_iter()
            .flat_map(|len| [(3usize, len), (8, len), (8, len + 4096 + 3)])
        {
            let ch: Vec<Vec<f32>> = (0..channels)
                .map(|c| (0..len).map(|t| (c * 10000 + t) as f32 / 65536.0).collect())
                .collect();
            let mut source =
                Channels::new("ramp", ch.iter().map(|c| &c[..]).collect(), 8000).unwrap();
            let mut framer = Framer::new(n, vec![2, 0], channels, 1);
            let mut block = FrameBlock::new(n, 2, 3);
            let mut seen = 0u64;
            loop {
                assert!(framer.fill(&mut source, &mut block).is_none());
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
}
