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

use multiversion::multiversion;
use realfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
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

/// Forward FFTs of windowed real frames, two channels per complex FFT, planned once.
///
/// With `z = x_a + i x_b`, `X_a(k) = (Z(k) + Z(N-k)*) / 2` and
/// `X_b(k) = (Z(k) - Z(N-k)*) / 2i`: one complex FFT of N gives two real spectra for
/// about half the cost of two real FFTs of N (see [`Correlator`] on why).
pub struct ForwardFft {
    plan: Arc<dyn Fft<f32>>,
    window: Vec<f32>,
    buffer: Vec<Complex32>,
    spare: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

impl ForwardFft {
    pub fn new(n: usize, window: Window) -> Self {
        let plan = FftPlanner::<f32>::new().plan_fft_forward(n);
        ForwardFft {
            window: window.coefficients(n),
            buffer: vec![Complex32::default(); n],
            spare: vec![Complex32::default(); n / 2 + 1],
            scratch: vec![Complex32::default(); plan.get_inplace_scratch_len()],
            plan,
        }
    }

    /// The spectrum `X(k)`, `k = 0..=N/2`, of `frame` times the window.
    pub fn transform(&mut self, frame: &[f32], out: &mut [Complex32]) {
        let mut spare = std::mem::take(&mut self.spare);
        self.transform_two(frame, frame, out, &mut spare);
        self.spare = spare;
    }

    /// The spectra of two frames (each times the window) in one complex FFT.
    pub fn transform_two(
        &mut self,
        a: &[f32],
        b: &[f32],
        out_a: &mut [Complex32],
        out_b: &mut [Complex32],
    ) {
        interleave(a, b, &self.window, &mut self.buffer);
        self.plan
            .process_with_scratch(&mut self.buffer, &mut self.scratch);
        split(&self.buffer, out_a, out_b);
    }
}

/// `z = (a + i b) w`, the two windowed frames as one complex signal.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn interleave(a: &[f32], b: &[f32], window: &[f32], z: &mut [Complex32]) {
    for (((z, &a), &b), &w) in z.iter_mut().zip(a).zip(b).zip(window) {
        *z = Complex32::new(a * w, b * w);
    }
}

/// The two real spectra in the complex FFT `z` of `a + i b`: `X_a(k) = (Z(k) + Z(N-k)*) / 2`
/// and `X_b(k) = (Z(k) - Z(N-k)*) / 2i`, for `k = 0..=N/2`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn split(z: &[Complex32], out_a: &mut [Complex32], out_b: &mut [Complex32]) {
    let h = z.len() / 2;
    for k in [0, h] {
        // Z(N - k) = Z(k) at DC and Nyquist.
        out_a[k] = Complex32::new(z[k].re, 0.0);
        out_b[k] = Complex32::new(z[k].im, 0.0);
    }
    for (((x_a, x_b), zk), zr) in out_a[1..h]
        .iter_mut()
        .zip(&mut out_b[1..h])
        .zip(&z[1..h])
        .zip(z[h + 1..].iter().rev())
    {
        *x_a = Complex32::new(0.5 * (zk.re + zr.re), 0.5 * (zk.im - zr.im));
        *x_b = Complex32::new(0.5 * (zk.im + zr.im), 0.5 * (zr.re - zk.re));
    }
}

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

/// An upper bound on every value of a pair's weighted PHAT correlation and on its
/// refined peaks, from the weights alone. A whitened spectrum has `|Y_i(k)| <= w_e(k)`, so
/// by eq. (6) `|R_ij(tau)| <= (1/N) sum_{k=0}^{N-1} w_e(k)^2 = E`; a parabola through a
/// local maximum and its neighbours peaks at most `(|prev| + |next|) / 8 <= E / 4` above
/// it. `weights` holds `w_e(k)` for `k = 0..=N/2`; a margin covers rounding.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub fn peak_ceiling(weights: &[f32], n: usize, interp: Interpolation) -> f64 {
    let last = weights.len() - 1;
    let inner: f64 = weights[1..last].iter().map(|&w| (w * w) as f64).sum();
    let edges = (weights[0] * weights[0]) as f64 + (weights[last] * weights[last]) as f64;
    let e = (edges + 2.0 * inner) / n as f64;
    let overshoot = match interp {
        Interpolation::None => 1.0,
        Interpolation::Parabolic => 1.25,
    };
    e * overshoot * (1.0 + 1e-3)
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
        let n = self.n;
        assert!(half < n / 2, "lag window {half} too wide for N = {n}");
        out.clear();
        out.resize(2 * half + 1, 0.0);
        let (negative, positive) = out.split_at_mut(half);
        pick_part(&self.buffer[n - half..], second, negative);
        pick_part(&self.buffer[..=half], second, positive);
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

/// One candidate delay of a pair: its lag in samples (sub-sample refined) and the value of
/// the correlation there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    pub lag: f32,
    pub value: f32,
}

/// The largest M that [`find_peaks`] accepts.
pub const MAX_PEAKS: usize = 64;

/// The `m` highest local maxima of a correlation (eq. 7), ranked by their sample value,
/// each refined per `interp`, then ordered by refined value, highest first (ties: smaller
/// lag first). `window` holds `r(tau)` for `tau = -h..=h` (odd length `2h + 1`, from
/// [`Correlator::lags`]); peaks are looked for at `|tau| < h`, the outer two samples
/// being their neighbours. A plateau counts once, at its first sample. `out` is cleared
/// and refilled; it does not allocate once its capacity reaches `m` (`1..=`[`MAX_PEAKS`]).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub fn find_peaks(window: &[f32], m: usize, interp: Interpolation, out: &mut Vec<Peak>) {
    assert!(m <= MAX_PEAKS, "at most {MAX_PEAKS} peaks per pair");
    out.clear();
    if m == 0 || window.len() < 3 {
        return;
    }
    // The best m are the first m of the best 8, 16, 32 or 64 (same order, same ties).
    let h = window.len() / 2;
    match m {
        1..=8 => Top::<8>::select(window).write(m, h, out),
        9..=16 => Top::<16>::select(window).write(m, h, out),
        17..=32 => Top::<32>::select(window).write(m, h, out),
        _ => Top::<64>::select(window).write(m, h, out),
    }
    if interp == Interpolation::Parabolic {
        let h = h as isize;
        for p in out.iter_mut() {
            let i = (p.lag as isize + h) as usize;
            let (prev, here, next) = (window[i - 1], p.value, window[i + 1]);
            let denom = prev - 2.0 * here + next;
            let delta = if denom < 0.0 {
                (0.5 * (prev - next) / denom).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            *p = Peak {
                lag: p.lag + delta,
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

/// The `K` highest local maxima of a window seen so far: values, highest first (ties in
/// scan order, i.e. smaller lag first), and their indices; empty places hold -inf.
struct Top<const K: usize> {
    values: [f32; K],
    index: [u32; K],
}

impl<const K: usize> Top<K> {
    #[inline(always)]
    fn select(window: &[f32]) -> Self {
        let mut top = Top {
            values: [f32::NEG_INFINITY; K],
            index: [0; K],
        };
        // A floor before the scan: the local maxima at indices of each residue mod K
        // (one SIMD lane each) have their highest; those K are distinct local maxima, so
        // no sample below the lowest of them is among the best K. It spares most of the
        // insertions a scan from -inf makes while the list fills.
        let mut lanes = [f32::NEG_INFINITY; K];
        for chunk in window.windows(K + 2).step_by(K) {
            for (lane, w) in lanes.iter_mut().zip(chunk.windows(3)) {
                let hit = (w[1] > w[0]) & (w[1] >= w[2]);
                *lane = lane.max(if hit { w[1] } else { f32::NEG_INFINITY });
            }
        }
        let prefloor = lanes.iter().fold(f32::INFINITY, |a, &b| a.min(b));
        // Candidates are marked 32 samples at a time without branches (the compiler
        // vectorises the comparisons); only samples that may enter the list are marked,
        // and `insert` has the final word, so blocking does not change the result.
        let interior = window.len() - 2;
        let mut start = 0;
        while start < interior {
            let len = (interior - start).min(32);
            let floor = top.values[K - 1];
            let mut mask = 0u32;
            for (b, w) in window[start..start + len + 2].windows(3).enumerate() {
                let hit = (w[1] > floor) & (w[1] >= prefloor) & (w[1] > w[0]) & (w[1] >= w[2]);
                mask |= (hit as u32) << b;
            }
            while mask != 0 {
                let i = start + mask.trailing_zeros() as usize + 1;
                mask &= mask - 1;
                top.insert(window[i], i as u32);
            }
            start += len;
        }
        top
    }

    /// Inserts a candidate that comes after every one inserted so far (in lag order), if
    /// it beats the last. No data-dependent branches: the place is a count and the shift
    /// a fixed sequence of selects, which the compiler unrolls for the constant `K`.
    #[inline(always)]
    fn insert(&mut self, value: f32, index: u32) {
        // The list is sorted, so `ahead` is true for a prefix: the entries that stay.
        // The candidate goes to the first place not ahead, the rest move down one.
        // Selects are bit masks, so that the compiler keeps the list in vector registers.
        let (values, indices) = (self.values, self.index);
        let ahead: [u32; K] =
            std::array::from_fn(|j| 0u32.wrapping_sub((values[j] >= value) as u32));
        let place: [u32; K] =
            std::array::from_fn(|j| !ahead[j] & if j == 0 { u32::MAX } else { ahead[j - 1] });
        let blend = |stay: u32, put: u32, moved: u32, j: usize| {
            (stay & ahead[j]) | (put & place[j]) | (moved & !(ahead[j] | place[j]))
        };
        self.values = std::array::from_fn(|j| {
            f32::from_bits(blend(
                values[j].to_bits(),
                value.to_bits(),
                values[j.saturating_sub(1)].to_bits(),
                j,
            ))
        });
        self.index =
            std::array::from_fn(|j| blend(indices[j], index, indices[j.saturating_sub(1)], j));
    }

    /// Writes the first `m` kept peaks to `out`, with lags counted from index `centre`.
    fn write(&self, m: usize, centre: usize, out: &mut Vec<Peak>) {
        out.extend(
            self.values
                .iter()
                .zip(&self.index)
                .take(m)
                .take_while(|(v, _)| **v > f32::NEG_INFINITY)
                .map(|(&value, &i)| Peak {
                    lag: i as f32 - centre as f32,
                    value,
                }),
        );
    }
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
    fn window(h: isize, samples: &[(isize, f32)]) -> Vec<f32> {
        let mut w = vec![0.0; (2 * h + 1) as usize];
        for &(lag, v) in samples {
            w[(lag + h) as usize] = v;
        }
        w
    }

    #[test]
    fn peaks_are_the_highest_local_maxima_in_range_with_parabolic_refinement() {
        // A parabola peaking at lag 5.19 (samples 4, 5, 6), a peak at -3, and at lag 11
        // the window's edge, which is a neighbour, not a candidate.
        let r = window(
            11,
            &[
                (4, 0.91),
                (5, 1.0),
                (6, 0.96),
                (-3, 0.5),
                (11, 2.0),
                (-11, 2.0),
            ],
        );
        let mut peaks = Vec::with_capacity(4);
        find_peaks(&r, 4, Interpolation::Parabolic, &mut peaks);
        assert_eq!(peaks.len(), 2, "{peaks:?}");
        // delta = 0.5 (0.91 - 0.96) / (0.91 - 2 + 0.96) = 0.1923
        assert!((peaks[0].lag - 5.1923).abs() < 1e-3, "{peaks:?}");
        assert!(peaks[0].value >= 1.0);
        assert_eq!(peaks[1].lag, -3.0);
        find_peaks(&r, 1, Interpolation::None, &mut peaks);
        assert_eq!(
            peaks,
            vec![Peak {
                lag: 5.0,
                value: 1.0
            }]
        );
    }

    #[test]
    fn peaks_next_to_lag_zero_and_the_range_ends_are_found() {
        for lag in [-5isize, -2, -1, 0, 1, 2, 5] {
            let r = window(6, &[(lag, 1.0)]);
            let mut peaks = Vec::with_capacity(1);
            find_peaks(&r, 1, Interpolation::None, &mut peaks);
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

    /// The blocked, branch-free selection equals the definition: every local maximum
    /// (first sample of a plateau), stably sorted by value, the first m kept, refined,
    /// stably sorted again. Random windows of up to 300 lags (several 32-lag blocks) with
    /// coarse values, so that ties and plateaus are common.
    #[test]
    fn peak_selection_equals_brute_force() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            seed >> 33
        };
        let mut got = Vec::new();
        for case in 0..3000 {
            let h = 1 + (next() % 150) as usize;
            let levels = 2 + next() % 12;
            let r: Vec<f32> = (0..2 * h + 1)
                .map(|_| (next() % levels) as f32 / levels as f32 - 0.3)
                .collect();
            let m = [1, 2, 3, 5, 8, 9, 12, 16, 17, 30, 33, 64][(next() % 12) as usize];
            for interp in [Interpolation::None, Interpolation::Parabolic] {
                let mut want: Vec<(usize, Peak)> = (1..2 * h)
                    .filter(|&i| r[i] > r[i - 1] && r[i] >= r[i + 1])
                    .map(|i| {
                        let p = Peak {
                            lag: i as f32 - h as f32,
                            value: r[i],
                        };
                        (i, p)
                    })
                    .collect();
                want.sort_by(|a, b| b.1.value.total_cmp(&a.1.value));
                want.truncate(m);
                let mut want: Vec<Peak> = want
                    .into_iter()
                    .map(|(i, p)| {
                        let (prev, here, next) = (r[i - 1], r[i], r[i + 1]);
                        let denom = prev - 2.0 * here + next;
                        match interp {
                            Interpolation::Parabolic if denom < 0.0 => {
                                let d = (0.5 * (prev - next) / denom).clamp(-0.5, 0.5);
                                Peak {
                                    lag: p.lag + d,
                                    value: here - 0.25 * (prev - next) * d,
                                }
                            }
                            _ => p,
                        }
                    })
                    .collect();
                want.sort_by(|a, b| b.value.total_cmp(&a.value));
                find_peaks(&r, m, interp, &mut got);
                assert_eq!(got, want, "case {case}, h {h}, m {m}, {interp:?}: {r:?}");
            }
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
