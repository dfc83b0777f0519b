//! The weighted PHAT cross-correlation of eq. (6).
//!
//! The weights and the PHAT normalisation are folded into one whitened spectrum per channel,
//! `Y_i(k) = w_e(k) X_i(k) / |X_i(k)|`, so that the cross-spectrum of eq. (6) is
//! `Y_i(k) Y_j(k)*` and costs one complex multiply per bin and pair, followed by one
//! inverse FFT for every two pairs. Plans and buffers are made once.
//!
//! Scale: the analyzer divides eq. (6) by `N`, so plain PHAT (`w_e = 1`) peaks at 1 for
//! a perfectly coherent pair. With the weighting, peaks scale with `w_e^2`: a frame of
//! stationary noise alone (`X ~ X_n`, `w_e ~ 0.6`) peaks near 0.36 per pair, while a source
//! that stands out of the noise (`w_e > 1` in its bins) peaks higher. That is what lets a
//! score threshold reject the background (see [`Threshold::Fixed`]).
//!
//! [`Threshold::Fixed`]: crate::method::Threshold::Fixed

use super::peaks::Interpolation;
use multiversion::multiversion;
use realfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The whitened, weighted spectrum `Y(k) = w_e(k) X(k) / |X(k)|` (0 where `X(k) = 0`).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub fn whiten(x: &[Complex32], we: &[f32], out: &mut [Complex32]) {
    for ((o, &v), &w) in out.iter_mut().zip(x).zip(we) {
        // |X| of an audio spectrum is far below f32's overflow, so no hypot is needed.
        let mag = v.norm_sqr().sqrt();
        *o = if mag > 0.0 && mag.is_finite() {
            v * (w / mag)
        } else {
            Complex32::new(0.0, 0.0)
        };
    }
}

/// The largest of `init` and the values of `w` (finite: a correlation's lags, the
/// steered response's grid). Eight running maxima side by side, which the compiler
/// turns into vector instructions, where a fold of `f32::max` (which must handle NaN)
/// runs one value at a time.
pub(crate) fn window_max(w: &[f32], init: f32) -> f32 {
    lanes_max(w, init, |&v| v)
}

/// The largest of `init` and `value` of each of `items` (all finite), in eight running
/// maxima side by side: [`window_max`] and [`part_max`].
#[inline(always)]
fn lanes_max<T>(items: &[T], init: f32, value: impl Fn(&T) -> f32) -> f32 {
    let mut lanes = [init; 8];
    let chunks = items.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (m, v) in lanes.iter_mut().zip(chunk.iter().map(&value)) {
            *m = if v > *m { v } else { *m };
        }
    }
    rest.iter()
        .map(&value)
        .chain(lanes)
        .fold(init, |m, v| if v > m { v } else { m })
}

/// An upper bound on every value of a pair's weighted PHAT correlation and on its
/// refined peaks, from the weights alone. A whitened spectrum has `|Y_i(k)| <= w_e(k)`, so
/// by eq. (6) `|R_ij(tau)| <= (1/N) sum_{k=0}^{N-1} w_e(k)^2 = E`; a parabola through a
/// local maximum and its neighbours peaks at most `(|prev| + |next|) / 8 <= E / 4` above
/// it. `weights` holds `w_e(k)` for `k = 0..=N/2`; a margin covers rounding.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub(crate) fn peak_ceiling(weights: &[f32], n: usize, interp: Interpolation) -> f64 {
    debug_assert_eq!(weights.len(), n / 2 + 1);
    weight_energy(weights.iter().map(|&w| (w * w) as f64), n) * interp.overshoot() * (1.0 + 1e-3)
}

/// The sum over eq. (6)'s N bins of `squares` (one value per bin 0..=N/2), divided by
/// N: bins 0 and N/2 count once, the others twice (the spectrum's mirror half).
pub(crate) fn weight_energy(squares: impl Iterator<Item = f64>, n: usize) -> f64 {
    let sum: f64 = squares
        .enumerate()
        .map(|(k, x)| if k == 0 || k == n / 2 { x } else { 2.0 * x })
        .sum();
    sum / n as f64
}

/// The weighted PHAT correlations of eq. (6), two microphone pairs per inverse FFT.
///
/// A real signal's spectrum is Hermitian, so two real correlations fit in one complex
/// inverse FFT: with `C_p(k)` and `C_q(k)` the cross-spectra of pairs p and q, the inverse
/// FFT over all N bins of `Z(k) = C_p(k) + i C_q(k)` is `r_p(tau) + i r_q(tau)`. One
/// complex FFT of N costs about half as much as two real inverse FFTs of N, because a
/// real inverse FFT is a complex FFT of N/2 behind a pre-processing pass that costs as
/// much as the FFT itself (measured in docs/speed.md). The plan and buffers are made once.
pub struct Correlator {
    n: usize,
    plan: Arc<dyn Fft<f32>>,
    buffer: Vec<Complex32>,
    mirror: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

impl Correlator {
    /// Plans the inverse FFTs for frames of `n` samples.
    pub fn new(n: usize) -> Self {
        let plan = FftPlanner::<f32>::new().plan_fft_inverse(n);
        Correlator {
            n,
            buffer: vec![Complex32::default(); n],
            mirror: vec![Complex32::default(); n / 2],
            scratch: vec![Complex32::default(); plan.get_inplace_scratch_len()],
            plan,
        }
    }

    /// Correlates the pair of whitened spectra `first = (Y_i, Y_j)` and, if given, a
    /// second pair: `r(tau) = (1/norm) sum_{k=0}^{N-1} Y_i(k) Y_j(k)* e^{i 2 pi k tau / N}`
    /// (eq. 6 with whitened spectra; `k > N/2` by Hermitian symmetry). Read the results
    /// with [`Correlator::lags`].
    pub fn correlate(
        &mut self,
        first: (&[Complex32], &[Complex32]),
        second: Option<(&[Complex32], &[Complex32])>,
        norm: f32,
    ) {
        let scale = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        let (a, b) = first;
        let (c, d) = second.unwrap_or(first);
        cross_spectra([a, b, c, d], scale, &mut self.buffer, &mut self.mirror);
        self.plan
            .process_with_scratch(&mut self.buffer, &mut self.scratch);
    }

    /// Copies `r(tau)` for `tau = -half..=half` of the first pair (or the second) of the
    /// last [`Correlator::correlate`] into `out` (cleared first; `half < N/2`).
    pub fn lags(&self, second: bool, half: usize, out: &mut Vec<f32>) {
        out.clear();
        out.resize(2 * half + 1, 0.0);
        self.lags_into(second, out);
    }

    /// As [`Correlator::lags`], into a slice of `2 * half + 1` values.
    pub fn lags_into(&self, second: bool, out: &mut [f32]) {
        let (n, half) = (self.n, out.len() / 2);
        assert!(half < n / 2, "lag window {half} too wide for N = {n}");
        let (negative, positive) = out.split_at_mut(half);
        pick_part(&self.buffer[n - half..], second, negative);
        pick_part(&self.buffer[..=half], second, positive);
    }
}

impl Correlator {
    /// The largest value of the first pair (or the second) of the last
    /// [`Correlator::correlate`] at the lags `half < |tau| <= reach` (`reach < N/2`): past
    /// a window of `half` lags each side.
    pub fn beyond_max(&self, second: bool, half: usize, reach: usize) -> f32 {
        let n = self.n;
        let reach = reach.min(n / 2 - 1);
        if reach <= half {
            return f32::NEG_INFINITY;
        }
        let low = part_max(&self.buffer[half + 1..=reach], second, f32::NEG_INFINITY);
        part_max(&self.buffer[n - reach..n - half], second, low)
    }
}

/// The largest of `init` and the real parts of `z` (or the imaginary ones, when
/// `imaginary`), all finite, as [`window_max`].
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn part_max(z: &[Complex32], imaginary: bool, init: f32) -> f32 {
    if imaginary {
        lanes_max(z, init, |z| z.im)
    } else {
        lanes_max(z, init, |z| z.re)
    }
}

/// `out[i] = z[i].re` (or `.im` when `imaginary`).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn pick_part(z: &[Complex32], imaginary: bool, out: &mut [f32]) {
    if imaginary {
        out.iter_mut().zip(z).for_each(|(o, z)| *o = z.im);
    } else {
        out.iter_mut().zip(z).for_each(|(o, z)| *o = z.re);
    }
}

/// The packed spectrum of two pairs' cross-spectra: bin k holds `C_p + i C_q` and bin
/// N - k holds `conj(C_p) + i conj(C_q)`, with `C_p = a b*`, `C_q = c d*` (times
/// `scale`). The mirror half is written forward into `mirror` and reversed after, so
/// that both loops vectorise.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn cross_spectra(
    [a, b, c, d]: [&[Complex32]; 4],
    scale: f32,
    buffer: &mut [Complex32],
    mirror: &mut [Complex32],
) {
    let h = buffer.len() / 2;
    let (low, high) = buffer.split_at_mut(h + 1);
    // The DC and Nyquist bins of a real signal's spectrum are real.
    for k in [0, h] {
        let (p, q) = (a[k] * b[k].conj(), c[k] * d[k].conj());
        low[k] = Complex32::new(p.re * scale, q.re * scale);
    }
    let mirror = &mut mirror[..h - 1];
    for k in 1..h {
        let (a, b, c, d) = (a[k], b[k], c[k], d[k]);
        let (pr, pi) = (a.re * b.re + a.im * b.im, a.im * b.re - a.re * b.im);
        let (qr, qi) = (c.re * d.re + c.im * d.im, c.im * d.re - c.re * d.im);
        low[k] = Complex32::new((pr - qi) * scale, (pi + qr) * scale);
        mirror[k - 1] = Complex32::new((pr + qi) * scale, (qr - pi) * scale);
    }
    for (hi, m) in high.iter_mut().zip(mirror.iter().rev()) {
        *hi = *m;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::method::paper::peaks::find_peaks;
    use crate::method::paper::spectrum::{ForwardFft, Window};
    use rand::{Rng, SeedableRng};

    /// Uniform noise in [-0.5, 0.5).
    fn noise(n: usize, seed: u64) -> Vec<f32> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| rng.random::<f32>() - 0.5).collect()
    }

    /// `r(tau)` for `tau = -(N/2 - 1)..=N/2 - 1` of the first or second pair.
    fn all_lags(corr: &Correlator, second: bool, n: usize) -> Vec<(isize, f32)> {
        let mut out = Vec::new();
        corr.lags(second, n / 2 - 1, &mut out);
        let h = (n / 2 - 1) as isize;
        out.iter()
            .enumerate()
            .map(|(i, &v)| (i as isize - h, v))
            .collect()
    }

    /// Plain cross-correlation through the FFT path (no whitening, unit weights) equals
    /// the circular form of eq. (1), R(tau) = sum_n x_i[n] x_j[(n - tau) mod N], for a
    /// pair alone and for two pairs sharing one inverse FFT.
    #[test]
    fn fft_correlation_matches_time_domain_definition() {
        let n = 64;
        let x: Vec<Vec<f32>> = (1..=4).map(|seed| noise(n, seed)).collect();
        let mut fwd = ForwardFft::new(n, Window::Rectangular);
        let s: Vec<Vec<Complex32>> = x
            .iter()
            .map(|x| {
                let mut out = vec![Complex32::default(); n / 2 + 1];
                fwd.transform(x, &mut out);
                out
            })
            .collect();
        let naive = |i: usize, j: usize, tau: isize| -> f32 {
            (0..n)
                .map(|t| x[i][t] * x[j][(t as isize - tau).rem_euclid(n as isize) as usize])
                .sum()
        };
        let mut corr = Correlator::new(n);
        // norm = N undoes the unnormalised inverse FFT.
        corr.correlate((&s[0], &s[1]), Some((&s[2], &s[3])), n as f32);
        for (second, (i, j)) in [(false, (0, 1)), (true, (2, 3))] {
            for (tau, got) in all_lags(&corr, second, n) {
                let want = naive(i, j, tau);
                assert!(
                    (got - want).abs() < 1e-4,
                    "{i},{j} tau {tau}: {got} vs {want}"
                );
            }
        }
        corr.correlate((&s[1], &s[3]), None, n as f32);
        for (tau, got) in all_lags(&corr, false, n) {
            let want = naive(1, 3, tau);
            assert!((got - want).abs() < 1e-4, "tau {tau}: {got} vs {want}");
        }
    }

    /// The weighted PHAT correlation equals a direct O(N^2) evaluation of eq. (6).
    #[test]
    fn weighted_phat_matches_direct_evaluation_of_eq6() {
        let n = 32;
        let xi = noise(n, 3);
        let xj = noise(n, 4);
        let we: Vec<f32> = (0..=n / 2)
            .map(|k| 0.1 + (k as f32 * 0.37).sin().abs() * 2.0)
            .collect();
        let mut fwd = ForwardFft::new(n, Window::Hann);
        let (mut si, mut sj) = (
            vec![Complex32::default(); n / 2 + 1],
            vec![Complex32::default(); n / 2 + 1],
        );
        fwd.transform(&xi, &mut si);
        fwd.transform(&xj, &mut sj);
        let (mut yi, mut yj) = (si.clone(), sj.clone());
        whiten(&si, &we, &mut yi);
        whiten(&sj, &we, &mut yj);
        let mut corr = Correlator::new(n);
        // The pair is the second of two (the first is the pair in reverse order).
        corr.correlate((&yj, &yi), Some((&yi, &yj)), n as f32);

        // Direct: naive DFT of the windowed frames, eq. (6) summed over all N bins.
        let win = Window::Hann.coefficients(n);
        let dft = |x: &[f32], k: usize| -> (f64, f64) {
            let mut acc = (0.0, 0.0);
            for (t, v) in x.iter().enumerate() {
                let ph = -std::f64::consts::TAU * (k * t) as f64 / n as f64;
                let v = (*v * win[t]) as f64;
                acc.0 += v * ph.cos();
                acc.1 += v * ph.sin();
            }
            acc
        };
        let w_full = |k: usize| we[if k <= n / 2 { k } else { n - k }] as f64;
        let norm = n as f64;
        for (tau, got) in all_lags(&corr, true, n) {
            let mut acc = 0.0;
            for k in 0..n {
                let (ar, ai) = dft(&xi, k);
                let (br, bi) = dft(&xj, k);
                let (mi, mj) = ((ar * ar + ai * ai).sqrt(), (br * br + bi * bi).sqrt());
                // Xi Xj* / (|Xi||Xj|) e^{i 2 pi k tau / N}, real part
                let (cr, ci) = (ar * br + ai * bi, ai * br - ar * bi);
                let ph = std::f64::consts::TAU * (k as f64 * tau as f64) / n as f64;
                acc += w_full(k).powi(2) * (cr * ph.cos() - ci * ph.sin()) / (mi * mj);
            }
            let direct = acc / norm;
            assert!(
                (got as f64 - direct).abs() < 1e-4,
                "tau {tau}: {got} vs {direct}"
            );
        }
    }

    /// No value of a weighted PHAT correlation, and no refined peak, exceeds the
    /// ceiling that the weights alone set (random spectra with zero bins, random weights).
    #[test]
    fn peak_ceiling_bounds_every_value_and_refined_peak() {
        let n = 64;
        let mut fwd = ForwardFft::new(n, Window::Hann);
        let mut corr = Correlator::new(n);
        let (mut window, mut peaks) = (Vec::new(), Vec::new());
        let mut tightest: f64 = 0.0;
        for case in 0..400u64 {
            let w = noise(n / 2 + 1, 1000 + case);
            let we: Vec<f32> = w.iter().map(|v| (v + 0.5) * 3.0).collect();
            let spectra: Vec<Vec<Complex32>> = (0..2)
                .map(|c| {
                    // A pure tone in one channel makes most of its bins (near) zero.
                    let x: Vec<f32> = if case % 7 == 0 && c == 0 {
                        (0..n).map(|t| (t as f32 * 0.7).sin()).collect()
                    } else {
                        noise(n, 3 * case + c)
                    };
                    let mut s = vec![Complex32::default(); n / 2 + 1];
                    fwd.transform(&x, &mut s);
                    let mut y = s.clone();
                    whiten(&s, &we, &mut y);
                    y
                })
                .collect();
            // The same signal in both channels makes the correlation reach the bound.
            let b = if case % 2 == 0 { 0 } else { 1 };
            corr.correlate((&spectra[0], &spectra[b]), None, n as f32);
            corr.lags(false, n / 2 - 1, &mut window);
            let plain = peak_ceiling(&we, n, Interpolation::None);
            for v in &window {
                assert!((v.abs() as f64) <= plain, "{v} > {plain}");
                tightest = tightest.max(v.abs() as f64 / plain);
            }
            let refined = peak_ceiling(&we, n, Interpolation::Parabolic);
            find_peaks(&window, 8, Interpolation::Parabolic, &mut peaks);
            for p in &peaks {
                assert!((p.value as f64) <= refined, "{p:?} > {refined}");
            }
        }
        // The bound is reached (an autocorrelation at lag 0), so it is not loose.
        assert!(tightest > 0.99, "{tightest}");
    }

    /// A window of lags -h..=h with the given (lag, value) samples, zero elsewhere.
    #[test]
    fn whitening_guards_zero_bins() {
        let x = [Complex32::new(0.0, 0.0), Complex32::new(3.0, 4.0)];
        let mut y = [Complex32::default(); 2];
        whiten(&x, &[2.0, 2.0], &mut y);
        assert_eq!(y[0], Complex32::new(0.0, 0.0));
        assert!((y[1] - Complex32::new(1.2, 1.6)).norm() < 1e-6);
    }

    /// The eight-lane maximum is the plain fold's, at every length around the lanes'
    /// width, with the maximum anywhere, and the initial value when it is the largest.
    #[test]
    fn window_max_and_part_max_match_a_plain_fold() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        for len in 0..40 {
            for _ in 0..20 {
                let w: Vec<f32> = (0..len).map(|_| rng.random_range(-1.0..1.0)).collect();
                for init in [f32::NEG_INFINITY, 0.0, 0.5, 2.0] {
                    let plain = w.iter().copied().fold(init, f32::max);
                    assert_eq!(window_max(&w, init), plain, "{len} {init}");
                    let z: Vec<Complex32> = w.iter().map(|&v| Complex32::new(v, -v)).collect();
                    assert_eq!(part_max(&z, false, init), plain, "{len} {init}");
                    let minus = w.iter().map(|v| -v).fold(init, f32::max);
                    assert_eq!(part_max(&z, true, init), minus, "{len} {init}");
                }
            }
        }
    }
}
