//! One frequency bin's prediction of its late reverberation (see [`super`]): a
//! multichannel linear prediction filter learned by recursive least squares.

use super::{DELAY, FORGET, TAPS};
use multiversion::multiversion;
use realfft::num_complex::Complex64;

/// The inverse correlation matrix starts at this times the identity (the filter starts
/// from no prediction and learns within tens of frames).
const P_START: f64 = 100.0;

/// One bin's prediction filter and what it learns from.
pub(super) struct Bin {
    /// The last `DELAY + TAPS - 1` observed frames, newest first, `mics` values each.
    past: Vec<Complex64>,
    /// The prediction filter, `mics * TAPS` rows of `mics`.
    filter: Vec<Complex64>,
    /// The inverse of the weighted correlation of the past frames.
    p: Vec<Complex64>,
    last_power: f64,
    stacked: Vec<Complex64>,
    p_stacked: Vec<Complex64>,
    gain: Vec<Complex64>,
    out: Vec<Complex64>,
}

impl Bin {
    pub(super) fn new(mics: usize) -> Self {
        let l = mics * TAPS;
        let mut bin = Bin {
            past: vec![Complex64::default(); mics * (DELAY + TAPS - 1)],
            filter: vec![Complex64::default(); l * mics],
            p: vec![Complex64::default(); l * l],
            last_power: 0.0,
            stacked: vec![Complex64::default(); l],
            p_stacked: vec![Complex64::default(); l],
            gain: vec![Complex64::default(); l],
            out: vec![Complex64::default(); mics],
        };
        bin.restart();
        bin
    }

    /// The past frames forgotten (the filter kept), for the input's start again.
    pub(super) fn rewind(&mut self) {
        self.past.fill(Complex64::default());
        self.last_power = 0.0;
    }

    /// No prediction, and the inverse correlation at its start.
    fn restart(&mut self) {
        let l = self.stacked.len();
        self.filter.fill(Complex64::default());
        self.p.fill(Complex64::default());
        for i in 0..l {
            self.p[i * l + i] = Complex64::new(P_START, 0.0);
        }
    }

    /// Dereverberates `y` (this frame of every microphone) and learns from it.
    pub(super) fn step(&mut self, y: &mut [Complex64], share: f64) {
        let m = y.len();
        let l = self.stacked.len();
        for k in 0..TAPS {
            let s = (DELAY - 1 + k) * m;
            self.stacked[k * m..(k + 1) * m].copy_from_slice(&self.past[s..s + m]);
        }
        let power_now = y.iter().map(|v| v.norm_sqr()).sum::<f64>() / m as f64;
        let power = 0.5 * (power_now + self.last_power);
        self.last_power = power_now;
        let len = self.past.len();
        self.past.copy_within(..len - m, m);
        self.past[..m].copy_from_slice(y);
        if power <= 0.0 {
            // Digital silence: nothing to learn.
            return;
        }
        // P x, read off P's rows (P is Hermitian, so row j holds column j conjugated):
        // contiguous multiply-adds instead of a sum per row.
        hermitian_times(&self.p, &self.stacked, &mut self.p_stacked);
        let denominator = FORGET * power
            + self
                .stacked
                .iter()
                .zip(&self.p_stacked)
                .map(|(x, v)| (x.conj() * v).re)
                .sum::<f64>();
        if !(denominator.is_finite() && denominator > 0.0) {
            self.restart();
            return;
        }
        for (g, v) in self.gain.iter_mut().zip(&self.p_stacked) {
            *g = v / denominator;
        }
        let (mut before, mut after) = (0.0, 0.0);
        for (mic, out) in self.out.iter_mut().enumerate() {
            let prediction: Complex64 = (0..l)
                .map(|i| self.filter[i * m + mic].conj() * self.stacked[i])
                .sum();
            *out = y[mic] - prediction;
            before += y[mic].norm_sqr();
            after += out.norm_sqr();
        }
        for (i, g) in self.gain.iter().enumerate() {
            for (f, out) in self.filter[i * m..(i + 1) * m].iter_mut().zip(&self.out) {
                *f += g * out.conj();
            }
        }
        let trace = rank_one_down(&mut self.p, &self.gain, &self.p_stacked);
        // What the input does not excite grows by 1 / FORGET a hop (a dead microphone,
        // a band with nothing in it): kept from overflowing.
        let cap = l as f64 * P_START;
        if trace > cap {
            let s = cap / trace;
            self.p.iter_mut().for_each(|v| *v *= s);
        }
        if after <= before && after.is_finite() {
            for (y, out) in y.iter_mut().zip(&self.out) {
                *y += share * (out - *y);
            }
        }
    }
}

/// `out = P x` for a Hermitian `P` (rows of `x.len()`), read off its rows (row `j` holds
/// column `j` conjugated): contiguous multiply-adds instead of a sum per row.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn hermitian_times(p: &[Complex64], x: &[Complex64], out: &mut [Complex64]) {
    out.fill(Complex64::default());
    for (row, x) in p.chunks_exact(x.len()).zip(x) {
        for (acc, pji) in out.iter_mut().zip(row) {
            *acc += pji.conj() * x;
        }
    }
}

/// The recursive least squares' update of the inverse correlation, `P = (P - g v^H) /
/// FORGET`, computed on and above the diagonal and mirrored below it, so that `P` stays
/// exactly Hermitian (rounding would otherwise let it drift, which recursive least
/// squares with forgetting amplifies); its trace after.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn rank_one_down(p: &mut [Complex64], gain: &[Complex64], v: &[Complex64]) -> f64 {
    let l = gain.len();
    let mut trace = 0.0;
    for (i, g) in gain.iter().enumerate() {
        let row = &mut p[i * l..(i + 1) * l];
        for (pij, pj) in row[i..].iter_mut().zip(&v[i..]) {
            *pij = (*pij - g * pj.conj()) * (1.0 / FORGET);
        }
        row[i].im = 0.0;
        trace += row[i].re;
        for j in i + 1..l {
            p[j * l + i] = p[i * l + j].conj();
        }
    }
    trace
}
