//! The WAV header: what the `fmt ` chunk says, checked, and what other files are
//! recognised as, with the command that converts them.

use super::InputError;

/// The most channels a WAV file may have (larger headers are refused before anything is
/// allocated for them).
pub(crate) const MAX_CHANNELS: usize = 1024;
/// The lowest sample rate read (Hz).
pub(crate) const MIN_RATE: u32 = 1000;
/// The highest sample rate read (Hz).
pub(crate) const MAX_RATE: u32 = 768_000;

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
    /// The Broadcast WAV `bext` chunk's time reference, when a `bext` chunk comes before
    /// the data.
    pub time_reference: Option<super::clock::TimeReference>,
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

/// Why bytes that do not start a WAV file are refused: what they are, when recognised,
/// and how to convert them.
pub(super) fn not_wav(start: &[u8]) -> InputError {
    let convert = |what: &str, ext: &str| {
        InputError::NotWav(format!(
            "this is {what}, not WAV: convert it, e.g. `sox in.{ext} out.wav` or `ffmpeg -i in.{ext} out.wav`"
        ))
    };
    if start.is_empty() {
        return InputError::NotWav("empty file, not a WAV recording".into());
    }
    let at = |i: usize, tag: &[u8]| start.len() >= i + tag.len() && &start[i..i + tag.len()] == tag;
    if at(0, b"RIFX") {
        InputError::Unsupported(
            "big-endian WAV (RIFX) is not supported: convert it, e.g. `sox in.wav -L out.wav`"
                .into(),
        )
    } else if at(0, b"fLaC") {
        convert("a FLAC file", "flac")
    } else if at(0, b"OggS") {
        convert("an Ogg file", "ogg")
    } else if at(0, b"riff") {
        convert("a Sony Wave64 (W64) file", "w64")
    } else if at(0, b"ID3") || (start.len() >= 2 && start[0] == 0xFF && start[1] & 0xE0 == 0xE0) {
        convert("an MP3 file", "mp3")
    } else if at(0, b"FORM") && (at(8, b"AIFF") || at(8, b"AIFC")) {
        convert("an AIFF file", "aiff")
    } else if at(0, b"caff") {
        convert("a Core Audio (CAF) file", "caf")
    } else if at(4, b"ftyp") {
        convert("an MP4/M4A file", "m4a")
    } else if at(0, b"RIFF") {
        InputError::NotWav("a RIFF file that is not WAVE audio".into())
    } else {
        InputError::NotWav("not a WAV file (no RIFF/WAVE header)".into())
    }
}

/// Parses a `fmt ` chunk body; returns the format and the block alignment in bytes.
pub(super) fn parse_fmt(b: &[u8]) -> Result<(WavFormat, u64), InputError> {
    let corrupt = |msg: String| Err(InputError::Corrupt(format!("corrupt WAV: {msg}")));
    let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
    let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let mut tag = u16_at(0);
    let channels = u16_at(2) as usize;
    let sample_rate = u32_at(4);
    let block_align = u16_at(12) as u64;
    let container_bits = u16_at(14);
    let mut valid_bits = container_bits;
    if tag == 0xFFFE {
        if b.len() < 40 {
            return corrupt("WAVE_FORMAT_EXTENSIBLE header is too short".into());
        }
        if u16_at(18) > 0 {
            valid_bits = u16_at(18);
        }
        tag = u16_at(24);
    }
    if channels == 0 {
        return corrupt("the header says 0 channels".into());
    }
    if channels > MAX_CHANNELS {
        return Err(InputError::Unsupported(format!(
            "the header says {channels} channels; at most {MAX_CHANNELS} are supported"
        )));
    }
    if sample_rate == 0 {
        return corrupt("the header says a sample rate of 0 Hz".into());
    }
    if !(MIN_RATE..=MAX_RATE).contains(&sample_rate) {
        return Err(InputError::Unsupported(format!(
            "a sample rate of {sample_rate} Hz; {MIN_RATE} to {MAX_RATE} Hz are supported"
        )));
    }
    // Every sample fills a container of whole bytes: the block holds one per channel.
    let width = (container_bits as u64).div_ceil(8);
    if container_bits == 0 || block_align != width * channels as u64 {
        return corrupt(format!(
            "the block size {block_align} disagrees with {channels} channel(s) of {container_bits}-bit samples ({} bytes)",
            width * channels as u64
        ));
    }
    if valid_bits > container_bits {
        return corrupt(format!(
            "{valid_bits} valid bits in {container_bits}-bit containers"
        ));
    }
    let float = match tag {
        1 => {
            // Valid bits narrower than the container (20 in 24, 12 in 16) are left-justified:
            // decoding by the container is exact.
            if !matches!(container_bits, 8 | 16 | 24 | 32) {
                return Err(InputError::Unsupported(format!(
                    "{container_bits}-bit integer PCM containers are not supported (8, 16, 24 or 32 bits are)"
                )));
            }
            false
        }
        3 => {
            if container_bits == 64 {
                return Err(InputError::Unsupported("64-bit float WAV is not supported: convert it to 32-bit float, e.g. `sox in.wav -e floating-point -b 32 out.wav` or `ffmpeg -i in.wav -c:a pcm_f32le out.wav`".into()));
            }
            if container_bits != 32 || valid_bits != 32 {
                return Err(InputError::Unsupported(format!(
                    "{valid_bits}-bit float WAV is not supported (32-bit float is)"
                )));
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
            bits_per_sample: valid_bits,
            float,
            frames: None,
            time_reference: None,
        },
        block_align,
    ))
}
