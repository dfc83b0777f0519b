//! Spectra of the analysis frames (the paper's Section II: windowed frames of `N`
//! samples, `X_i(k)` the DFT of `x_i[n]`, eq. 2).
//!
//! Each channel's windowed frame is transformed once (`N/2 + 1` bins), two channels per
//! complex FFT. Plans and buffers are made once.

use crate::Named;
use multiversion::multiversion;
use realfft::num_complex::Complex32;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// The analysis window applied to each frame before its FFT.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Window {
    /// Periodic Hann window (the default; docs/method.md gives the measurement).
    Hann,
    /// Periodic Hamming window.
    Hamming,
    /// No window (rectangular).
    Rectangular,
}

impl Named for Window {
    const ALL: &'static [(Window, &'static str, &'static str)] = &[
        (
            Window::Hann,
            "hann",
            "Periodic Hann window (the default; docs/method.md gives the measurement)",
        ),
        (Window::Hamming, "hamming", "Periodic Hamming window"),
        (
            Window::Rectangular,
            "rectangular",
            "No window (rectangular)",
        ),
    ];
}

impl Window {
    /// The `n` coefficients of the window.
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

/// Forward FFTs of windowed real frames, two channels per complex FFT, planned once.
///
/// With `z = x_a + i x_b`, `X_a(k) = (Z(k) + Z(N-k)*) / 2` and
/// `X_b(k) = (Z(k) - Z(N-k)*) / 2i`: one complex FFT of N gives two real spectra for
/// about half the cost of two real FFTs of N (see [`Correlator`](super::correlation::Correlator) on why).
pub struct ForwardFft {
    plan: Arc<dyn Fft<f32>>,
    window: Vec<f32>,
    buffer: Vec<Complex32>,
    spare: Vec<Complex32>,
    scratch: Vec<Complex32>,
}

impl ForwardFft {
    /// Plans the transforms of frames of `n` samples with `window`.
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

/// A frame's spectra and mean power spectrum, the input of every later stage.
///
/// `live` lists the microphones whose channel is not stuck at one value (a dead or
/// disconnected microphone carries no delay information); `spectra[m]` is `X_m(k)` for
/// each of them, and `power` is `X(k)`, the mean power spectrum over them (eq. 4).
pub(crate) fn frame_spectra(
    fft: &mut ForwardFft,
    (frame, stride): (&[f32], usize),
    n: usize,
    live: &mut Vec<usize>,
    spectra: &mut [Vec<Complex32>],
    power: &mut [f32],
) {
    let channel = |m: usize| &frame[m * stride..m * stride + n];
    live.clear();
    for m in 0..spectra.len() {
        let s = channel(m);
        let first = s[0];
        if s.iter().any(|&v| v != first) {
            live.push(m);
        }
    }
    if live.is_empty() {
        return;
    }
    // Two channels per complex FFT.
    for two in live.chunks(2) {
        match *two {
            [a, b] => {
                let (low, high) = spectra.split_at_mut(b);
                fft.transform_two(channel(a), channel(b), &mut low[a], &mut high[0]);
            }
            [a] => fft.transform(channel(a), &mut spectra[a]),
            _ => unreachable!("chunks of two"),
        }
    }
    power.fill(0.0);
    for &m in live.iter() {
        add_power(&spectra[m], power);
    }
    let inv = 1.0 / live.len() as f32;
    power.iter_mut().for_each(|p| *p *= inv);
}

/// `power(k) += |x(k)|^2`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn add_power(x: &[Complex32], power: &mut [f32]) {
    for (p, x) in power.iter_mut().zip(x) {
        *p += x.norm_sqr();
    }
}
