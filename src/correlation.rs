//! Spectra, the weighted PHAT cross-correlation of eq. (6), and its peaks (eq. 7).
//!
//! Each channel's windowed frame is transformed once (real FFT, `N/2 + 1` bins). The
//! weights and the PHAT normalisation are folded into one whitened spectrum per channel,
//! `Y_i(k) = w_e(k) X_i(k) / |X_i(k)|`, so that the cross-spectrum of eq. (6) is
//! `Y_i(k) Y_j(k)*` and costs one complex multiply per bin and pair, followed by one
//! inverse real FFT per pair. Plans and buffers are made once.
//!
//! Scale: the pipeline divides eq. (6) by `N`, so plain PHAT (`w_e = 1`) peaks at 1 for
//! a perfectly coherent pair. With the weighting, peaks scale with `w_e^2`: a frame of
//! stationary noise alone (`X ~ X_n`, `w_e ~ 0.6`) peaks near 0.36 per pair, while a source
//! that stands out of the noise (`w_e > 1` in its bins) peaks higher. That is what lets a
//! score threshold reject the background (see `pipeline::DEFAULT_MIN_SCORE_PER_PAIR`).

use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

/// The analysis window applied to each frame before its FFT.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Window {
    /// Periodic Hann window (the default; see the README for the measurement).
    Hann,
    /// Periodic Hamming window.
    Hamming,
    /// No window (rectangular).
    Rectangular,
}

impl Window {
    pub fn coefficients(self, n: usize) -> Vec<f32> {
        let tau = std::f64::consts::TAU;
        (0..n)
            .map(|i| {
                let phase = tau * i as f64 / n as f64;
                (match self {
                    Window::Hann => 0.5 - 0.5 * phase.cos(),
                    Window::Hamming => 0.54 - 0.46 * phase.cos(),
                    Window::Rectangular => 1.0,
                }) as f32
            })
            .collect()
    }
}

/// How a peak's lag is refined between samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Integer lags only.
    None,
    /// A parabola through the peak and its two neighbours (the default).
    Parabolic,
}

/// Forward real FFT of windowed frames, planned once.
pub struct ForwardFft {
    plan: Arc<dyn RealToComplex<f32>>,
    window: Vec<f32>,
    input: Vec<f32>,
    scratch: Vec<Complex32>,
}

impl ForwardFft {
    pub fn new(n: usize, window: Window) -> Self {
        let plan = RealFftPlanner::<f32>::new().plan_fft_forward(n);
        let scratch = plan.make_scratch_vec();
        ForwardFft {
            window: window.coefficients(n),
            input: vec![0.0; n],
            scratch,
            plan,
        }
    }

    /// The spectrum `X(k)`, `k = 0..=N/2`, of `frame` times the window.
    pub fn transform(&mut self, frame: &[f32], out: &mut [Complex32]) {
        for ((d, s), w) in self.input.iter_mut().zip(frame).zip(&self.window) {
            *d = s * w;
        }
        self.plan
            .process_with_scratch(&mut self.input, out, &mut self.scratch)
            .expect("buffer sizes are fixed at construction");
    }
}

/// The whitened, weighted spectrum `Y(k) = w_e(k) X(k) / |X(k)|` (0 where `X(k) = 0`).
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

/// Cross-correlation by inverse real FFT of a cross-spectrum, planned once.
pub struct Correlator {
    plan: Arc<dyn ComplexToReal<f32>>,
    spectrum: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

impl Correlator {
    pub fn new(n: usize) -> Self {
        let plan = RealFftPlanner::<f32>::new().plan_fft_inverse(n);
        Correlator {
            spectrum: plan.make_input_vec(),
            scratch: plan.make_scratch_vec(),
            plan,
        }
    }

    /// `out[tau] = (1/norm) sum_{k=0}^{N-1} Y_i(k) Y_j(k)* e^{i 2 pi k tau / N}` (eq. 6 with
    /// whitened spectra), for `tau = 0..N`; negative lags are at `N - |tau|`.
    pub fn correlate(&mut self, yi: &[Complex32], yj: &[Complex32], norm: f32, out: &mut [f32]) {
        let scale = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        for ((s, a), b) in self.spectrum.iter_mut().zip(yi).zip(yj) {
            *s = a * b.conj() * scale;
        }
        // The DC and Nyquist bins of a real signal's spectrum are real.
        let last = self.spectrum.len() - 1;
        self.spectrum[0].im = 0.0;
        self.spectrum[last].im = 0.0;
        self.plan
            .process_with_scratch(&mut self.spectrum, out, &mut self.scratch)
            .expect("buffer sizes are fixed and edge bins are real");
    }
}

/// One candidate delay of a pair: its lag in samples (sub-sample refined) and the value of
/// the correlation there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    pub lag: f32,
    pub value: f32,
}

/// The `m` highest local maxima of the circular correlation `r` with `|lag| <= max_lag`
/// (ranked by their sample value), each refined per `interp`, then ordered by refined
/// value, highest first (ties: smaller lag first). `out` is cleared and refilled; it does
/// not allocate once its capacity reaches `m`. Only the `m` kept peaks are refined.
pub fn find_peaks(r: &[f32], max_lag: usize, m: usize, interp: Interpolation, out: &mut Vec<Peak>) {
    out.clear();
    let n = r.len();
    let max_lag = max_lag.min(n / 2 - 1) as isize;
    // Negative lags sit at the end of the buffer (a branch is far cheaper than a modulo).
    let at = |lag: isize| {
        r[if lag < 0 {
            (n as isize + lag) as usize
        } else {
            lag as usize
        }]
    };
    // A plateau counts once, at its first sample. Candidates are marked 32 lags at a time
    // without branches (the compiler vectorises the comparisons); only samples above the
    // lowest peak kept so far (`floor`, once `m` are kept) are marked, and those go to
    // `insert_top`, which has the final word, so the result does not depend on blocking.
    let mut floor = f32::NEG_INFINITY;
    let mut scan = |samples: &[f32], first_lag: isize| {
        // samples[i + 1] is the sample at lag first_lag + i; its neighbours are i and i + 2.
        let count = samples.len() - 2;
        let mut start = 0;
        while start < count {
            let len = (count - start).min(32);
            let mut mask = 0u32;
            for (b, w) in samples[start..start + len + 2].windows(3).enumerate() {
                let hit = (w[1] > floor) & (w[1] > w[0]) & (w[1] >= w[2]);
                mask |= (hit as u32) << b;
            }
            while mask != 0 {
                let b = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let i = start + b;
                let peak = Peak {
                    lag: (first_lag + i as isize) as f32,
                    value: samples[i + 1],
                };
                insert_top(out, peak, m);
                if out.len() == m {
                    floor = out[m - 1].value;
                }
            }
            start += len;
        }
    };
    // Lags -max_lag..=-2 and 1..=max_lag as contiguous runs; -1 and 0 across the wrap.
    let l = max_lag as usize;
    scan(&r[n - l - 1..n], -max_lag);
    scan(&[r[n - 2], r[n - 1], r[0], r[1]], -1);
    scan(&r[0..l + 2], 1);
    if interp == Interpolation::Parabolic {
        for p in out.iter_mut() {
            let lag = p.lag as isize;
            let (prev, here, next) = (at(lag - 1), p.value, at(lag + 1));
            let denom = prev - 2.0 * here + next;
            let delta = if denom < 0.0 {
                (0.5 * (prev - next) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            *p = Peak {
                lag: lag as f32 + delta,
                value: here - 0.25 * (prev - next) * delta,
            };
        }
        // Refinement can reorder close peaks; the search expects highest first. (A stable
        // insertion sort of at most M entries: no allocation.)
        for i in 1..out.len() {
            let mut j = i;
            while j > 0 && out[j - 1].value < out[j].value {
                out.swap(j - 1, j);
                j -= 1;
            }
        }
    }
}

/// Inserts `p` into `list` (sorted by value, highest first) keeping at most `m` entries.
#[inline]
fn insert_top(list: &mut Vec<Peak>, p: Peak, m: usize) {
    if m == 0 {
        return;
    }
    if list.len() == m {
        if list[m - 1].value >= p.value {
            return;
        }
        list.pop();
    }
    // Equal values keep their scan order (increasing lag).
    let pos = list
        .iter()
        .position(|q| q.value < p.value)
        .unwrap_or(list.len());
    list.insert(pos, p);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noise(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) as f32 / (1u64 << 24) as f32) - 0.5
            })
            .collect()
    }

    /// Plain cross-correlation through the FFT path (no whitening, unit weights) equals
    /// the circular form of eq. (1): R(tau) = sum_n x_i[n] x_j[(n - tau) mod N].
    #[test]
    fn fft_correlation_matches_time_domain_definition() {
        let n = 64;
        let xi = noise(n, 1);
        let xj = noise(n, 2);
        let mut fwd = ForwardFft::new(n, Window::Rectangular);
        let (mut si, mut sj) = (
            vec![Complex32::default(); n / 2 + 1],
            vec![Complex32::default(); n / 2 + 1],
        );
        fwd.transform(&xi, &mut si);
        fwd.transform(&xj, &mut sj);
        let mut corr = Correlator::new(n);
        let mut out = vec![0.0; n];
        // norm = N undoes realfft's unnormalised inverse.
        corr.correlate(&si, &sj, n as f32, &mut out);
        for (tau, got) in out.iter().enumerate() {
            let naive: f32 = (0..n).map(|t| xi[t] * xj[(t + n - tau) % n]).sum();
            assert!((got - naive).abs() < 1e-4, "tau {tau}: {got} vs {naive}");
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
        let mut out = vec![0.0; n];
        Correlator::new(n).correlate(&yi, &yj, n as f32, &mut out);

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
        for (tau, got) in out.iter().enumerate() {
            let mut acc = 0.0;
            for k in 0..n {
                let (ar, ai) = dft(&xi, k);
                let (br, bi) = dft(&xj, k);
                let (mi, mj) = ((ar * ar + ai * ai).sqrt(), (br * br + bi * bi).sqrt());
                // Xi Xj* / (|Xi||Xj|) e^{i 2 pi k tau / N}, real part
                let (cr, ci) = (ar * br + ai * bi, ai * br - ar * bi);
                let ph = std::f64::consts::TAU * (k * tau) as f64 / n as f64;
                acc += w_full(k).powi(2) * (cr * ph.cos() - ci * ph.sin()) / (mi * mj);
            }
            let direct = acc / norm;
            assert!(
                (*got as f64 - direct).abs() < 1e-4,
                "tau {tau}: {got} vs {direct}"
            );
        }
    }

    #[test]
    fn peaks_are_the_highest_local_maxima_in_range_with_parabolic_refinement() {
        let n = 64;
        let mut r = vec![0.0f32; n];
        // A parabola peaking at lag 5.3 (samples 4, 5, 6), a peak at -3, one out of range at 20.
        for (lag, v) in [(4isize, 0.91f32), (5, 1.0), (6, 0.96)] {
            r[lag as usize] = v;
        }
        r[(n as isize - 3) as usize] = 0.5;
        r[20] = 2.0;
        let mut peaks = Vec::with_capacity(4);
        find_peaks(&r, 10, 4, Interpolation::Parabolic, &mut peaks);
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        // delta = 0.5 (0.91 - 0.96) / (0.91 - 2 + 0.96) = 0.1923
        assert!((peaks[0].lag - 5.1923).abs() < 1e-3, "{peaks:?}");
        assert!(peaks[0].value >= 1.0);
        assert_eq!(peaks[1].lag, -3.0);
        find_peaks(&r, 10, 1, Interpolation::None, &mut peaks);
        assert_eq!(
            peaks,
            vec![Peak {
                lag: 5.0,
                value: 1.0
            }]
        );
    }

    #[test]
    fn peaks_next_to_lag_zero_are_found() {
        for lag in [-2isize, -1, 0, 1, 2] {
            let n = 32;
            let mut r = vec![0.0f32; n];
            r[lag.rem_euclid(n as isize) as usize] = 1.0;
            let mut peaks = Vec::with_capacity(1);
            find_peaks(&r, 5, 1, Interpolation::None, &mut peaks);
            assert_eq!(
                peaks,
                vec![Peak {
                    lag: lag as f32,
                    value: 1.0
                }],
                "lag {lag}"
            );
        }
    }

    #[test]
    fn whitening_guards_zero_bins() {
        let x = [Complex32::new(0.0, 0.0), Complex32::new(3.0, 4.0)];
        let mut y = [Complex32::default(); 2];
        whiten(&x, &[2.0, 2.0], &mut y);
        assert_eq!(y[0], Complex32::new(0.0, 0.0));
        assert!((y[1] - Complex32::new(1.2, 1.6)).norm() < 1e-6);
    }
}
