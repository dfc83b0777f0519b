//! Writing simulated channels to WAV files.

use super::scene::SampleFormat;
use std::path::Path;

/// Sample encodings [`write_wav`] can produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// 8-bit unsigned PCM.
    Int8,
    /// 16-bit PCM.
    Int16,
    /// 24-bit PCM.
    Int24,
    /// 32-bit PCM.
    Int32,
    /// 32-bit float.
    Float32,
}

impl From<SampleFormat> for Encoding {
    fn from(f: SampleFormat) -> Self {
        match f {
            SampleFormat::Int16 => Encoding::Int16,
            SampleFormat::Int24 => Encoding::Int24,
            SampleFormat::Int32 => Encoding::Int32,
            SampleFormat::Float32 => Encoding::Float32,
        }
    }
}

/// Writes channels to a WAV file (clipping integer formats at full scale).
pub fn write_wav(
    path: &Path,
    channels: &[Vec<f32>],
    sample_rate: u32,
    encoding: Encoding,
) -> Result<(), hound::Error> {
    let (bits, float) = match encoding {
        Encoding::Int8 => (8, false),
        Encoding::Int16 => (16, false),
        Encoding::Int24 => (24, false),
        Encoding::Int32 => (32, false),
        Encoding::Float32 => (32, true),
    };
    let spec = hound::WavSpec {
        channels: channels.len() as u16,
        sample_rate,
        bits_per_sample: bits,
        sample_format: if float {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut w = hound::WavWriter::create(path, spec)?;
    let len = channels.iter().map(Vec::len).min().unwrap_or(0);
    let full = ((1i64 << (bits - 1)) - 1) as f64;
    for i in 0..len {
        for ch in channels {
            let v = ch[i];
            if float {
                w.write_sample(v)?;
            } else {
                let q = (v as f64 * (full + 1.0)).round().clamp(-full - 1.0, full) as i32;
                match bits {
                    8 => w.write_sample(q as i8)?,
                    16 => w.write_sample(q as i16)?,
                    _ => w.write_sample(q)?,
                }
            }
        }
    }
    w.finalize()?;
    Ok(())
}
