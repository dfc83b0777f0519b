//! Audio input: multichannel FLAC, decoded one FLAC block at a time by `claxon` (a
//! pure-Rust decoder of the whole format up to 24 bits and 8 channels, fuzzed by its
//! authors), so memory does not grow with the recording. Labs archive multichannel
//! audio in FLAC; converting hours of it to WAV first doubles the disk it takes.

use super::source::SampleSource;
use super::InputError;
use claxon::FlacReader;
use std::io::Read;

/// A streaming FLAC reader producing interleaved `f32` samples in [-1, 1).
pub struct FlacStream {
    name: String,
    reader: FlacReader<Box<dyn Read>>,
    channels: usize,
    sample_rate: u32,
    bits: u32,
    /// Sample frames the stream header promises (`None`: not given, as from a live
    /// encoder).
    frames: Option<u64>,
    /// The decoded block being handed out, its length in sample frames, and how many
    /// of them are handed out already.
    block: Vec<i32>,
    block_len: usize,
    used: usize,
    frames_read: u64,
    done: bool,
    /// An error to report on the next read, after the frames before it were delivered.
    pending: Option<InputError>,
    live: bool,
}

/// A claxon error as a message for the user.
fn flac_error(e: claxon::Error) -> InputError {
    match e {
        claxon::Error::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            InputError::Corrupt("truncated FLAC: the file ends inside a block".into())
        }
        claxon::Error::IoError(e) => InputError::Read(e),
        claxon::Error::FormatError(what) => InputError::Corrupt(format!("corrupt FLAC: {what}")),
        claxon::Error::Unsupported(what) => InputError::Unsupported(format!(
            "FLAC feature not supported: {what}; convert it, e.g. `sox in.flac out.wav`"
        )),
    }
}

/// The most metadata read ahead to find the first frame (pictures included).
const MAX_METADATA: usize = 16 << 20;

/// Reads ahead of the decoder to the first frame's header (the metadata blocks kept and
/// handed back in front of the rest) and returns the sample rate that header gives,
/// when it gives one (`None`: "as the stream header", a rate code it cannot read, or
/// metadata past [`MAX_METADATA`]). claxon does not compare the two.
fn first_frame_rate(mut input: Box<dyn Read>) -> Result<(Box<dyn Read>, Option<u32>), InputError> {
    use super::source::read_full;
    let mut kept = vec![0u8; 4];
    let n = read_full(&mut input, &mut kept).map_err(InputError::Io)?;
    kept.truncate(n);
    let back = |kept: Vec<u8>, input: Box<dyn Read>| -> Box<dyn Read> {
        Box::new(std::io::Cursor::new(kept).chain(input))
    };
    if kept != b"fLaC" {
        return Ok((back(kept, input), None));
    }
    loop {
        let mut head = [0u8; 4];
        let n = read_full(&mut input, &mut head).map_err(InputError::Io)?;
        kept.extend_from_slice(&head[..n]);
        if n < 4 {
            return Ok((back(kept, input), None));
        }
        let len = u32::from_be_bytes([0, head[1], head[2], head[3]]) as usize;
        if kept.len() + len > MAX_METADATA {
            return Ok((back(kept, input), None));
        }
        let at = kept.len();
        kept.resize(at + len, 0);
        let n = read_full(&mut input, &mut kept[at..]).map_err(InputError::Io)?;
        kept.truncate(at + n);
        if n < len {
            return Ok((back(kept, input), None));
        }
        if head[0] & 0x80 != 0 {
            break;
        }
    }
    // The frame header: sync (14 bits) and blocking (2), block size and rate codes,
    // channels and sample size, the coded frame number (1-7 bytes), then an 8- or
    // 16-bit block size and an 8- or 16-bit rate when their codes say so.
    let at = kept.len();
    kept.resize(at + 16, 0);
    let n = read_full(&mut input, &mut kept[at..]).map_err(InputError::Io)?;
    kept.truncate(at + n);
    let h = &kept[at..];
    if h.len() < 5 || h[0] != 0xFF || h[1] & 0xFC != 0xF8 {
        return Ok((back(kept, input), None));
    }
    let (size_code, rate_code) = (h[2] >> 4, h[2] & 0x0F);
    let fixed = [
        0, 88_200, 176_400, 192_000, 8_000, 16_000, 22_050, 24_000, 32_000, 44_100, 48_000, 96_000,
    ];
    let rate = match rate_code {
        1..=11 => Some(fixed[rate_code as usize]),
        12..=14 => {
            let coded = h[4].leading_ones() as usize;
            let mut i = 4 + coded.max(1);
            i += match size_code {
                6 => 1,
                7 => 2,
                _ => 0,
            };
            match rate_code {
                12 => h.get(i).map(|&k| k as u32 * 1000),
                13 => h
                    .get(i..i + 2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]]) as u32),
                _ => h
                    .get(i..i + 2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]]) as u32 * 10),
            }
        }
        _ => None,
    };
    Ok((back(kept, input), rate))
}

impl FlacStream {
    /// Reads the stream header from `input` (which starts with `fLaC`); `live` when the
    /// input is a pipe or a device.
    pub fn from_reader(name: &str, input: Box<dyn Read>, live: bool) -> Result<Self, InputError> {
        let (input, first_frame_rate) = first_frame_rate(input)?;
        let reader = FlacReader::new(input).map_err(flac_error)?;
        let info = reader.streaminfo();
        if info.channels == 0 || info.sample_rate == 0 {
            return Err(InputError::Corrupt(format!(
                "corrupt FLAC: {} channel(s) at {} Hz",
                info.channels, info.sample_rate
            )));
        }
        if let Some(rate) = first_frame_rate.filter(|&r| r != info.sample_rate) {
            return Err(InputError::Corrupt(format!(
                "corrupt FLAC: the stream header says {} Hz but its frames say {rate} Hz (which one is right cannot be told)",
                info.sample_rate
            )));
        }
        Ok(FlacStream {
            name: name.to_string(),
            reader,
            channels: info.channels as usize,
            sample_rate: info.sample_rate,
            bits: info.bits_per_sample,
            frames: info.samples.filter(|&s| s > 0),
            block: Vec::new(),
            block_len: 0,
            used: 0,
            frames_read: 0,
            done: false,
            pending: None,
            live,
        })
    }

    /// Decodes the next block into `self.block` (channel after channel); `false` at the
    /// end of the stream.
    fn next_block(&mut self) -> Result<bool, InputError> {
        let buffer = std::mem::take(&mut self.block);
        // A frame reader holds no state between blocks: one is made per block.
        let block = self
            .reader
            .blocks()
            .read_next_or_eof(buffer)
            .map_err(flac_error)?;
        let Some(block) = block else {
            return Ok(false);
        };
        if block.channels() as usize != self.channels {
            return Err(InputError::Corrupt(format!(
                "corrupt FLAC: a block of {} channel(s) in a stream of {}",
                block.channels(),
                self.channels
            )));
        }
        self.block_len = block.duration() as usize;
        self.used = 0;
        self.block = block.into_buffer();
        Ok(true)
    }
}

impl SampleSource for FlacStream {
    fn name(&self) -> &str {
        &self.name
    }

    fn channels(&self) -> usize {
        self.channels
    }

    fn sample_rate(&self) -> u32 {
        self.sample_rate
    }

    fn frames(&self) -> Option<u64> {
        self.frames
    }

    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        let ch = self.channels;
        let want = out.len() / ch;
        let scale = 1.0 / (1u64 << (self.bits - 1)) as f32;
        let mut done = 0;
        if self.used == self.block_len {
            if let Some(e) = self.pending.take() {
                return Err(e);
            }
        }
        while done < want && !self.done {
            if self.used == self.block_len {
                // Live input: hand on what is decoded before waiting for more.
                if self.live && done > 0 {
                    break;
                }
                match self.next_block() {
                    Ok(true) => {}
                    Ok(false) => {
                        self.done = true;
                        if let Some(promised) = self.frames.filter(|&p| self.frames_read < p) {
                            self.pending = Some(InputError::Corrupt(format!(
                                "truncated FLAC: the header promises {promised} sample frames ({:.3} s) but the blocks end after {} ({:.3} s)",
                                promised as f64 / self.sample_rate as f64,
                                self.frames_read,
                                self.frames_read as f64 / self.sample_rate as f64
                            )));
                        }
                        break;
                    }
                    Err(e) => {
                        // The frames decoded before the damage are delivered first.
                        self.done = true;
                        let at = format!(
                            ", after {} sample frames ({:.3} s)",
                            self.frames_read,
                            self.frames_read as f64 / self.sample_rate as f64
                        );
                        self.pending = Some(match e {
                            InputError::Corrupt(m) => InputError::Corrupt(m + &at),
                            other => other,
                        });
                        break;
                    }
                }
            }
            let take = (self.block_len - self.used).min(want - done);
            for c in 0..ch {
                let src = &self.block[c * self.block_len + self.used..][..take];
                for (i, &v) in src.iter().enumerate() {
                    out[(done + i) * ch + c] = v as f32 * scale;
                }
            }
            self.used += take;
            done += take;
            self.frames_read += take as u64;
        }
        if done == 0 {
            if let Some(e) = self.pending.take() {
                return Err(e);
            }
        }
        Ok(done)
    }

    fn is_live(&self) -> bool {
        self.live
    }

    fn describe(&self) -> String {
        format!(
            "{} ch, {} Hz, {}-bit FLAC",
            self.channels, self.sample_rate, self.bits
        )
    }
}
