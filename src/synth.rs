//! Synthetic free-field recordings with known truth, for tests, examples and
//! measurements: broadband noise, clicks or tones from known directions (far field) or
//! positions (near field), delayed by exact fractional delays, plus independent sensor
//! noise. Delays are applied in the frequency domain (a linear phase on the spectrum of
//! the whole signal), which is exact for band-limited signals. The same seed gives the
//! same samples.

use anyhow::{Context, Result};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;
use std::path::Path;

/// What a source emits while it is active.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// White Gaussian noise.
    WhiteNoise,
    /// Short decaying noise bursts (2 ms) at this many per second; the level is the RMS
    /// during a burst.
    Clicks { per_second: f64 },
    /// A sine at this frequency (Hz).
    Tone { hz: f64 },
    /// Pink (1/f power) noise above 50 Hz: the spectrum of fans and ventilation.
    PinkNoise,
    /// Speech-like: noise with a low-pass, speech-shaped spectrum (flat to 500 Hz, then
    /// falling 6 dB per octave) under a 4 Hz syllabic envelope with pauses.
    SpeechLike,
}

/// Where a source is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Place {
    /// Far field: a unit vector from the array centre.
    Direction(Vector3<f64>),
    /// Near field: a point in the array frame (metres), with 1/r spreading.
    Position(Vector3<f64>),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    pub place: Place,
    pub signal: Signal,
    /// Active interval in seconds.
    pub start_s: f64,
    pub end_s: f64,
    /// RMS level of the emitted signal at the array centre (full scale = 1).
    pub level: f64,
}

#[derive(Debug, Clone)]
pub struct Scene {
    pub sample_rate: u32,
    pub duration_s: f64,
    pub mics: Vec<Vector3<f64>>,
    pub speed_of_sound: f64,
    pub sources: Vec<Source>,
    /// RMS of independent Gaussian noise added to every channel.
    pub sensor_noise: f64,
    pub seed: u64,
}

impl Source {
    /// The unit vector from `centre` toward the source.
    pub fn direction_from(&self, centre: &Vector3<f64>) -> Vector3<f64> {
        match self.place {
            Place::Direction(u) => u.normalize(),
            Place::Position(p) => (p - centre).normalize(),
        }
    }
}

/// Renders the scene: one `Vec<f32>` per microphone.
pub fn render(scene: &Scene) -> Vec<Vec<f32>> {
    let fs = scene.sample_rate as f64;
    let len = (scene.duration_s * fs).round() as usize;
    let centre = scene.mics.iter().sum::<Vector3<f64>>() / scene.mics.len() as f64;
    let aperture = scene
        .mics
        .iter()
        .map(|p| (p - centre).norm())
        .fold(0.0, f64::max);
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    let mut out = vec![vec![0.0f64; len]; scene.mics.len()];
    // Room for the longest delay plus a margin, so circular wrap-around stays silent.
    let pad = ((2.0 * aperture / scene.speed_of_sound) * fs).ceil() as usize + 64;
    let size = (len + 2 * pad).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(size);
    let inv = planner.plan_fft_inverse(size);
    for src in &scene.sources {
        let mut s = vec![0.0f64; size];
        emit(src, fs, len, &mut s[pad..pad + len], &mut rng);
        let mut spec = fwd.make_output_vec();
        fwd.process(&mut s, &mut spec).expect("sizes match");
        for (m, p) in scene.mics.iter().enumerate() {
            // Arrival time relative to the centre (seconds) and gain.
            let (t, g) = match src.place {
                Place::Direction(u) => (
                    -(u.normalize().dot(&(p - centre))) / scene.speed_of_sound,
                    1.0,
                ),
                Place::Position(q) => {
                    let r0 = (q - centre).norm();
                    let r = (q - p).norm();
                    ((r - r0) / scene.speed_of_sound, r0 / r)
                }
            };
            let shift = t * fs;
            let mut shifted: Vec<Complex64> = spec
                .iter()
                .enumerate()
                .map(|(k, x)| {
                    let ph = -std::f64::consts::TAU * k as f64 * shift / size as f64;
                    x * Complex64::from_polar(g / size as f64, ph)
                })
                .collect();
            let last = shifted.len() - 1;
            shifted[0].im = 0.0;
            shifted[last] = Complex64::new(0.0, 0.0);
            let mut y = vec![0.0f64; size];
            inv.process(&mut shifted, &mut y).expect("sizes match");
            for (o, v) in out[m].iter_mut().zip(&y[pad..pad + len]) {
                *o += v;
            }
        }
    }
    out.into_iter()
        .map(|ch| {
            ch.into_iter()
                .map(|v| {
                    let noise: f64 = StandardNormal.sample(&mut rng);
                    (v + scene.sensor_noise * noise) as f32
                })
                .collect()
        })
        .collect()
}

/// Writes the source's signal (at the array centre) into `buf` (the whole duration).
fn emit(src: &Source, fs: f64, len: usize, buf: &mut [f64], rng: &mut ChaCha8Rng) {
    let a = ((src.start_s * fs).round().max(0.0) as usize).min(len);
    let b = ((src.end_s * fs).round().max(0.0) as usize).min(len);
    if a >= b {
        return;
    }
    generate(&src.signal, src.level, fs, &mut buf[a..b], rng);
}

/// Fills `active` with `signal` at RMS `level` (clicks: RMS over each 2 ms click),
/// with 5 ms fades at both ends of continuous signals.
pub fn generate(signal: &Signal, level: f64, fs: f64, active: &mut [f64], rng: &mut ChaCha8Rng) {
    let src = Source {
        place: Place::Direction(Vector3::x()),
        signal: signal.clone(),
        start_s: 0.0,
        end_s: 0.0,
        level,
    };
    match src.signal {
        Signal::WhiteNoise => {
            for v in active.iter_mut() {
                let x: f64 = StandardNormal.sample(rng);
                *v = x * src.level;
            }
        }
        Signal::Tone { hz } => {
            let phase0: f64 = rng.random::<f64>() * std::f64::consts::TAU;
            for (i, v) in active.iter_mut().enumerate() {
                *v = src.level
                    * std::f64::consts::SQRT_2
                    * (std::f64::consts::TAU * hz * i as f64 / fs + phase0).sin();
            }
        }
        Signal::PinkNoise | Signal::SpeechLike => {
            for v in active.iter_mut() {
                let x: f64 = StandardNormal.sample(rng);
                *v = x;
            }
            let corner = if src.signal == Signal::PinkNoise {
                50.0
            } else {
                500.0
            };
            shape_spectrum(active, fs, |f| {
                if src.signal == Signal::PinkNoise {
                    if f < corner {
                        0.0
                    } else {
                        (corner / f).sqrt()
                    }
                } else if f < 80.0 {
                    0.0
                } else {
                    1.0 / (1.0 + (f / corner).powi(2)).sqrt()
                }
            });
            if src.signal == Signal::SpeechLike {
                let phase: f64 = rng.random::<f64>() * std::f64::consts::TAU;
                for (i, v) in active.iter_mut().enumerate() {
                    let t = i as f64 / fs;
                    // Syllables at 4 Hz, and every third syllable silent (a pause).
                    let syll = (std::f64::consts::TAU * 4.0 * t + phase).sin().max(0.0);
                    let cycle =
                        ((4.0 * t + phase / std::f64::consts::TAU).floor() as i64).rem_euclid(3);
                    *v *= if cycle == 2 { 0.0 } else { syll.sqrt() };
                }
            }
            let rms = (active.iter().map(|v| v * v).sum::<f64>() / active.len() as f64).sqrt();
            if rms > 0.0 {
                let g = src.level / rms;
                active.iter_mut().for_each(|v| *v *= g);
            }
        }
        Signal::Clicks { per_second } => {
            let period = (fs / per_second).max(1.0) as usize;
            let decay = 0.0005 * fs; // 0.5 ms time constant
            let burst = (0.002 * fs) as usize;
            // Scaled so that the RMS over each 2 ms click is `level`.
            let energy: f64 = (0..burst).map(|i| (-2.0 * i as f64 / decay).exp()).sum();
            let gain = src.level * (burst as f64 / energy).sqrt();
            let mut start = 0;
            while start < active.len() {
                for i in 0..burst.min(active.len() - start) {
                    let x: f64 = StandardNormal.sample(rng);
                    active[start + i] = gain * x * (-(i as f64) / decay).exp();
                }
                start += period;
            }
        }
    }
    // 5 ms raised-cosine fades at both ends of a continuous source.
    if !matches!(src.signal, Signal::Clicks { .. }) {
        let fade = ((0.005 * fs) as usize).min(active.len() / 2);
        let n = active.len();
        for i in 0..fade {
            let g = 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / fade as f64).cos();
            active[i] *= g;
            active[n - 1 - i] *= g;
        }
    }
}

/// Multiplies the spectrum of `x` by `gain(frequency in Hz)`.
fn shape_spectrum(x: &mut [f64], fs: f64, gain: impl Fn(f64) -> f64) {
    let n = x.len();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(n);
    let mut spec = fwd.make_output_vec();
    fwd.process(x, &mut spec).expect("sizes match");
    for (k, s) in spec.iter_mut().enumerate() {
        *s *= gain(k as f64 * fs / n as f64) / n as f64;
    }
    spec[0].im = 0.0;
    if n % 2 == 0 {
        let last = spec.len() - 1;
        spec[last].im = 0.0;
    }
    inv.process(&mut spec, x).expect("sizes match");
}

/// Sample encodings [`write_wav`] can produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Int8,
    Int16,
    Int24,
    Int32,
    Float32,
}

/// Writes channels to a WAV file (clipping integer formats at full scale).
pub fn write_wav(
    path: &Path,
    channels: &[Vec<f32>],
    sample_rate: u32,
    encoding: Encoding,
) -> Result<()> {
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
    let mut w = hound::WavWriter::create(path, spec)
        .with_context(|| format!("{}: cannot create", path.display()))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_and_levels_follow_the_geometry() {
        // Two mics 0.5 m apart on x, a far source on +x: mic at +x hears it first by
        // 0.5/343 s = 69.97 samples at 48 kHz.
        let scene = Scene {
            sample_rate: 48000,
            duration_s: 0.5,
            mics: vec![Vector3::new(0.25, 0.0, 0.0), Vector3::new(-0.25, 0.0, 0.0)],
            speed_of_sound: 343.0,
            sources: vec![Source {
                place: Place::Direction(Vector3::x()),
                signal: Signal::WhiteNoise,
                start_s: 0.0,
                end_s: 0.5,
                level: 0.1,
            }],
            sensor_noise: 0.0,
            seed: 1,
        };
        let ch = render(&scene);
        let expect = 0.5 / 343.0 * 48000.0;
        // Cross-correlate by brute force around the expected lag.
        let corr = |lag: i64| -> f64 {
            (200..23000)
                .map(|t| ch[0][t] as f64 * ch[1][(t as i64 + lag) as usize] as f64)
                .sum()
        };
        let best = (60..80)
            .max_by(|&a, &b| corr(a).total_cmp(&corr(b)))
            .unwrap();
        assert!((best as f64 - expect).abs() <= 0.5, "{best} vs {expect}");
        let rms = (ch[0][2000..22000]
            .iter()
            .map(|v| (*v as f64).powi(2))
            .sum::<f64>()
            / 20000.0)
            .sqrt();
        assert!((rms - 0.1).abs() < 0.005, "{rms}");
        // Same seed, same samples.
        assert_eq!(render(&scene), ch);
    }
}
