//! Noise for simulated scenes: coloured noise for point sources (fans), a spherically
//! isotropic (diffuse) field, and mixing components at given weights.

use super::scene::Colour;
use super::signals::{generate, Signal};
use nalgebra::{DMatrix, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;

/// Mean power over every sample of every channel.
pub(crate) fn mean_power(channels: &[Vec<f64>]) -> f64 {
    let n: usize = channels.iter().map(Vec::len).sum();
    channels.iter().flatten().map(|v| v * v).sum::<f64>() / n.max(1) as f64
}

/// Adds `part`, scaled to unit mean power and then by `weight_db`, to `total`.
pub(crate) fn add_normalised(total: &mut [Vec<f64>], part: Vec<&[f64]>, weight_db: f64) {
    let n: usize = part.iter().map(|p| p.len()).sum();
    let power = part
        .iter()
        .flat_map(|p| p.iter())
        .map(|v| v * v)
        .sum::<f64>()
        / n.max(1) as f64;
    if power <= 0.0 {
        return;
    }
    let g = 10f64.powf(weight_db / 20.0) / power.sqrt();
    for (t, p) in total.iter_mut().zip(part) {
        for (a, b) in t.iter_mut().zip(p) {
            *a += g * b;
        }
    }
}

/// Unit-level noise of `colour`.
pub(crate) fn colour_noise(colour: Colour, fs: f64, out: &mut [f64], rng: &mut ChaCha8Rng) {
    let signal = match colour {
        Colour::White => Signal::WhiteNoise,
        Colour::Pink => Signal::PinkNoise,
    };
    generate(&signal, 1.0, fs, out, rng);
}

/// A spherically isotropic (diffuse) noise field at the microphones: in every frequency
/// bin, independent complex Gaussians shaped by the Cholesky factor of the field's
/// coherence `sin(k d_ij) / (k d_ij)` (Habets & Gannot 2007), coloured per `colour`.
#[allow(clippy::needless_range_loop)] // bins index several spectra at once
pub(crate) fn diffuse_noise(
    mics: &[Vector3<f64>],
    colour: Colour,
    fs: f64,
    c: f64,
    len: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<f64>> {
    let m = mics.len();
    let n = len.next_power_of_two().max(2);
    let bins = n / 2 + 1;
    let mut spectra = vec![vec![Complex64::new(0.0, 0.0); bins]; m];
    for k in 1..bins - 1 {
        let f = k as f64 * fs / n as f64;
        let gain = match colour {
            Colour::White => 1.0,
            Colour::Pink => {
                if f < 50.0 {
                    0.0
                } else {
                    (50.0 / f).sqrt()
                }
            }
        };
        let wave = std::f64::consts::TAU * f / c;
        let coherence = DMatrix::from_fn(m, m, |i, j| {
            let x = wave * (mics[i] - mics[j]).norm();
            let g = if x.abs() < 1e-9 { 1.0 } else { x.sin() / x };
            if i == j {
                g + 1e-6
            } else {
                g
            }
        });
        let l = coherence
            .cholesky()
            .map(|ch| ch.l())
            .unwrap_or_else(|| DMatrix::identity(m, m));
        let z: Vec<Complex64> = (0..m)
            .map(|_| {
                let (re, im): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
                Complex64::new(re, im)
            })
            .collect();
        for i in 0..m {
            let mut acc = Complex64::new(0.0, 0.0);
            for (j, zj) in z.iter().enumerate().take(i + 1) {
                acc += zj * l[(i, j)];
            }
            spectra[i][k] = acc * gain;
        }
    }
    let inv = RealFftPlanner::<f64>::new().plan_fft_inverse(n);
    spectra
        .into_iter()
        .map(|mut s| {
            let mut y = vec![0.0; n];
            inv.process(&mut s, &mut y).expect("sizes match");
            y.truncate(len);
            y
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn diffuse_noise_has_the_diffuse_coherence() {
        // Two mics 10 cm apart: kd = 2 pi f d / c is 1.832 at 1 kHz and 5.496 at 3 kHz, so
        // the coherence sin(kd)/(kd) is 0.527 and -0.129.
        let mics = vec![Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.0)];
        let fs = 16000.0;
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let field = diffuse_noise(&mics, Colour::White, fs, 343.0, 1 << 18, &mut rng);
        // Welch estimate of the real part of the coherence in 256-sample blocks.
        let n = 256;
        let fwd = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        let mut sxy = vec![Complex64::new(0.0, 0.0); n / 2 + 1];
        let (mut sxx, mut syy) = (vec![0.0; n / 2 + 1], vec![0.0; n / 2 + 1]);
        for b in 0..(1 << 18) / n {
            let mut a = field[0][b * n..(b + 1) * n].to_vec();
            let mut c = field[1][b * n..(b + 1) * n].to_vec();
            let (mut fa, mut fc) = (fwd.make_output_vec(), fwd.make_output_vec());
            fwd.process(&mut a, &mut fa).unwrap();
            fwd.process(&mut c, &mut fc).unwrap();
            for k in 0..=n / 2 {
                sxy[k] += fa[k] * fc[k].conj();
                sxx[k] += fa[k].norm_sqr();
                syy[k] += fc[k].norm_sqr();
            }
        }
        for (hz, expect) in [(1000.0, 0.527), (3000.0, -0.129)] {
            let k = (hz / fs * n as f64) as usize;
            let coh = sxy[k].re / (sxx[k] * syy[k]).sqrt();
            assert!((coh - expect).abs() < 0.05, "{hz} Hz: {coh} vs {expect}");
        }
    }
}
