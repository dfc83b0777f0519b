//! Recorded source signals: a mono WAV file at any rate, resampled to the scene's.

use super::SceneError;
use crate::stream::WavStream;
use std::path::Path;

/// Reads a mono WAV as f64 samples at the scene's rate (resampled when the file has
/// another rate).
pub fn read_mono(path: &Path, rate: u32, needed_s: f64) -> Result<Vec<f64>, SceneError> {
    let name = path.display().to_string();
    let input = |error| SceneError::Input {
        path: path.to_path_buf(),
        error,
    };
    let mut stream = WavStream::open(&name).map_err(input)?;
    if stream.format.channels != 1 {
        fail!(
            SceneError::Invalid,
            "{name}: a source file must be mono; it has {} channels",
            stream.format.channels
        );
    }
    // Only the first `needed_s` seconds are ever played (and a margin that keeps the
    // resampler's output the same up to them): a long file is not read whole.
    let from = stream.format.sample_rate;
    let limit = ((needed_s * from as f64).ceil() as usize).saturating_add(RESAMPLER_MARGIN);
    let mut all = Vec::new();
    let mut buf = vec![0.0f32; 65536];
    while all.len() < limit {
        let n = stream.read(&mut buf).map_err(input)?;
        if n == 0 {
            break;
        }
        all.extend(buf[..n].iter().map(|&v| v as f64));
    }
    all.truncate(limit);
    if all.is_empty() {
        fail!(SceneError::Invalid, "{name}: no samples");
    }
    if from == rate {
        return Ok(all);
    }
    resample(&all, from, rate).map_err(|e| {
        SceneError::Invalid(format!(
            "{name}: cannot resample from {from} to {rate} Hz: {e}"
        ))
    })
}

/// Samples read past what is played, so that resampling ends the same: several of the
/// resampler's 1024-sample chunks.
const RESAMPLER_MARGIN: usize = 16384;

/// `x` at `from` Hz resampled to `to` Hz (rubato's synchronous FFT resampler, whose
/// anti-aliasing filter removes what the lower rate cannot hold; its delay is removed).
fn resample(x: &[f64], from: u32, to: u32) -> Result<Vec<f64>, Box<dyn std::error::Error>> {
    use rubato::audioadapter_buffers::direct::InterleavedSlice;
    use rubato::{Fft, FixedSync, Resampler};
    let mut resampler = Fft::<f64>::new(from as usize, to as usize, 1024, 1, FixedSync::Both)?;
    let len = resampler.process_all_needed_output_len(x.len());
    let mut out = vec![0.0; len];
    let input = InterleavedSlice::new(x, 1, x.len())?;
    let mut output = InterleavedSlice::new_mut(&mut out, 1, len)?;
    let (_, written) = resampler.process_all_into_buffer(&input, &mut output, x.len(), None)?;
    out.truncate(written);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tone resampled from 16 to 48 kHz keeps its frequency, level and timing; a tone
    /// above the lower rate's Nyquist frequency is removed going down.
    #[test]
    fn resampling_keeps_what_the_rates_can_hold() {
        let tone = |hz: f64, fs: f64, n: usize| -> Vec<f64> {
            (0..n)
                .map(|i| (std::f64::consts::TAU * hz * i as f64 / fs).sin())
                .collect()
        };
        let up = resample(&tone(1000.0, 16000.0, 16000), 16000, 48000).unwrap();
        assert!((up.len() as i64 - 48000).abs() <= 2, "{}", up.len());
        let want = tone(1000.0, 48000.0, 48000);
        let err = up[2000..46000]
            .iter()
            .zip(&want[2000..46000])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-3, "{err}");
        let down = resample(&tone(12000.0, 48000.0, 48000), 48000, 16000).unwrap();
        let rms = (down[1000..15000].iter().map(|v| v * v).sum::<f64>() / 14000.0).sqrt();
        assert!(rms < 1e-3, "{rms}");
    }
}
