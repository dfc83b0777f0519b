//! Source signals for simulated scenes: noise, clicks, tones and speech-like noise at a
//! given level. The same random generator state gives the same samples.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::RealFftPlanner;

/// What a source emits while it is active.
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// White Gaussian noise.
    WhiteNoise,
    /// Short decaying noise bursts (2 ms) at this many per second; the level is the RMS
    /// during a burst.
    Clicks {
        /// Clicks per second.
        per_second: f64,
    },
    /// A sine at this frequency (Hz).
    Tone {
        /// Frequency (Hz).
        hz: f64,
    },
    /// Pink (1/f power) noise above 50 Hz: the spectrum of fans and ventilation.
    PinkNoise,
    /// Speech-like: noise with a low-pass, speech-shaped spectrum (flat to 500 Hz, then
    /// falling 6 dB per octave) under a 4 Hz syllabic envelope with pauses.
    SpeechLike,
    /// Recorded samples at the scene's rate (real speech, say), repeated as needed and
    /// scaled to the level over the whole interval.
    Recording(Vec<f64>),
}

/// Fills `active` with `signal` at RMS `level` (clicks: RMS over each 2 ms click),
/// with 5 ms fades at both ends of continuous signals.
pub(crate) fn generate(
    signal: &Signal,
    level: f64,
    fs: f64,
    active: &mut [f64],
    rng: &mut ChaCha8Rng,
) {
    match signal {
        Signal::Recording(samples) => {
            if samples.is_empty() {
                active.iter_mut().for_each(|v| *v = 0.0);
                return;
            }
            for (i, v) in active.iter_mut().enumerate() {
                *v = samples[i % samples.len()];
            }
            let rms = (active.iter().map(|v| v * v).sum::<f64>() / active.len() as f64).sqrt();
            if rms > 0.0 {
                active.iter_mut().for_each(|v| *v *= level / rms);
            }
            return;
        }
        Signal::WhiteNoise => {
            for v in active.iter_mut() {
                let x: f64 = StandardNormal.sample(rng);
                *v = x * level;
            }
        }
        Signal::Tone { hz } => {
            let phase0: f64 = rng.random::<f64>() * std::f64::consts::TAU;
            for (i, v) in active.iter_mut().enumerate() {
                *v = level
                    * std::f64::consts::SQRT_2
                    * (std::f64::consts::TAU * hz * i as f64 / fs + phase0).sin();
            }
        }
        Signal::PinkNoise | Signal::SpeechLike => {
            for v in active.iter_mut() {
                let x: f64 = StandardNormal.sample(rng);
                *v = x;
            }
            let corner = if *signal == Signal::PinkNoise {
                50.0
            } else {
                500.0
            };
            shape_spectrum(active, fs, |f| {
                if *signal == Signal::PinkNoise {
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
            if *signal == Signal::SpeechLike {
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
                let g = level / rms;
                active.iter_mut().for_each(|v| *v *= g);
            }
        }
        Signal::Clicks { per_second } => {
            let period = (fs / per_second).max(1.0) as usize;
            let decay = 0.0005 * fs; // 0.5 ms time constant
            let burst = (0.002 * fs) as usize;
            // Scaled so that the RMS over each 2 ms click is `level`.
            let energy: f64 = (0..burst).map(|i| (-2.0 * i as f64 / decay).exp()).sum();
            let gain = level * (burst as f64 / energy).sqrt();
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
    if !matches!(*signal, Signal::Clicks { .. }) {
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
