//! The diffuse part of each pair's cross-spectrum removed before eq. (6) (beyond the
//! paper).
//!
//! In a room, each bin's cross-spectrum between microphones `a` and `b` holds the direct
//! sound, `S_d e^{-i w dT}`, plus the reverberation, which is close to a spherically
//! diffuse field: `S_r G(w)` with the real coherence `G(w) = sin(w d / c) / (w d / c)`
//! for microphones `d` apart. PHAT keeps only the phase of the sum, and the real diffuse
//! term pulls every bin's phase toward zero: the peak of eq. (6) comes out at a delay a
//! few percent short of the direct sound's (measured with 32-fold upsampled PHAT of 16 ms
//! frames on a 6-mic circle of radius 4.63 cm at 16 kHz, real speech at 1.5 m: 1.8% short
//! at RT60 0.2 s, 3.4% at 0.35 s, 5.7% at 0.5 s, 0.2% long in free field; docs/field.md).
//! A 3-D array's direction
//! hardly moves, since the normalisation of eq. (13) absorbs a uniform shortening, but a
//! planar array reads its elevation from how long its delays are (`cos` of the
//! elevation), so that a talker in its plane came out 13 deg above it.
//!
//! The stage follows the coherent-to-diffuse ratio estimation of Schwarz and Kellermann
//! ("Coherent-to-diffuse power ratio estimation for dereverberation", IEEE/ACM TASLP
//! 2015; their DOA-independent estimator): the coherence `g` of each pair, from the
//! cross- and auto-spectra summed over the frame and the ones before it (the frames
//! [`Room::average_frames`](crate::method::Room::average_frames) averages), is modelled as
//! `g = (c e^{-i w dT} + G) / (c + 1)` with `c` the ratio of direct to diffuse power.
//! `|g (c + 1) - G| = c` is a quadratic in `c`; with its larger root, `g (c + 1) - G`
//! is the direct sound's cross-spectrum up to a positive factor, and its phase replaces
//! the frame's in eq. (6), weighted by `w_e(k)^2` averaged over the same frames. In free
//! field a source's coherence is near 1 and its phase is kept (a planar array's
//! directions move by under 0.02 deg, tests/integration/accuracy.rs); a bin with no direct sound
//! gives a phase at random, as PHAT does.

use super::edges::Edges;
use crate::geometry::Geometry;
use crate::method::layout::Layout;
use crate::method::paper::correlation::{peak_ceiling, window_max, Correlator};
use crate::method::paper::pairs::pair_index;
use crate::method::state::FrameState;
use multiversion::multiversion;
use realfft::num_complex::Complex32;

/// The stage's buffers, one set per thread (the diffuse coherences are the run's,
/// [`Layout::dereverb`]).
pub(crate) struct Dereverberator {
    /// Per microphone, its power summed over the frames.
    power: Vec<Vec<f32>>,
    /// Two pairs' corrected cross-spectra (one inverse FFT gives both correlations).
    cross: [Vec<Complex32>; 2],
    /// All ones: eq. (6) of `cross` against it is `cross`'s correlation.
    ones: Vec<Complex32>,
    /// The root of `w_e(k)^2` averaged over the frames.
    weights: Vec<f32>,
}

impl Dereverberator {
    pub fn new(setup: &Layout) -> Self {
        let bins = setup.bins();
        Dereverberator {
            power: vec![vec![0.0; bins]; setup.mics()],
            cross: [
                vec![Complex32::default(); bins],
                vec![Complex32::default(); bins],
            ],
            ones: vec![Complex32::new(1.0, 0.0); bins],
            weights: vec![0.0; bins],
        }
    }

    /// Every live pair's correlation for the last frame of `span` (eq. 6 divided by N,
    /// as [`Correlator`] computes it), each bin's phase that of the direct sound
    /// ([`direct_phase`]) from the spectra of the frames of `span` that are `live` and
    /// hear both microphones, weighted by `w_e(k)^2` averaged over the live frames.
    /// Written to `out` laid out as a frame's windows ([`Layout::window_starts`]). Returns the
    /// most any value (or refined peak) can be, as [`peak_ceiling`] bounds it for the
    /// averaged weights. `edges` counts the pairs that peak past their window.
    #[allow(clippy::too_many_arguments)]
    pub fn correlate(
        &mut self,
        setup: &Layout,
        coherence: &DiffuseCoherence,
        span: &[FrameState],
        live: &[bool],
        correlator: &mut Correlator,
        out: &mut [f32],
        edges: &mut Edges,
    ) -> f64 {
        let state = span.last().expect("a frame");
        let mics = setup.mics();
        for &m in &state.live {
            let power = &mut self.power[m];
            power.iter_mut().for_each(|p| *p = 0.0);
            for (f, _) in span
                .iter()
                .zip(live)
                .filter(|(f, &l)| l && f.mask & (1 << m) != 0)
            {
                add_power(power, &f.spectra[m]);
            }
        }
        self.weights.iter_mut().for_each(|w| *w = 0.0);
        let mut frames = 0.0;
        for (f, _) in span.iter().zip(live).filter(|(_, &l)| l) {
            frames += 1.0;
            for (s, &w) in self.weights.iter_mut().zip(&f.weights) {
                *s += w * w;
            }
        }
        // As roots, for the ceiling (which squares them); squared again below.
        self.weights
            .iter_mut()
            .for_each(|w| *w = (*w / frames).sqrt());
        let reach = peak_ceiling(&self.weights, setup.n, setup.params.peaks.refinement());
        let k = state.live.len();
        let mut list = (0..k).flat_map(|a| (a + 1..k).map(move |b| (a, b)));
        while let Some(first) = list.next() {
            let second = list.next();
            for (which, &(a, b)) in [Some(first), second].iter().flatten().enumerate() {
                let (i, j) = (state.live[a], state.live[b]);
                let both = (1u64 << i) | (1u64 << j);
                let cross = &mut self.cross[which];
                cross.iter_mut().for_each(|c| *c = Complex32::default());
                for (f, _) in span
                    .iter()
                    .zip(live)
                    .filter(|(f, &l)| l && f.mask & both == both)
                {
                    add_cross(cross, &f.spectra[i], &f.spectra[j]);
                }
                let diffuse = coherence.pair(pair_index(i, j, mics));
                remove_diffuse(
                    cross,
                    (&self.power[i], &self.power[j]),
                    diffuse,
                    &self.weights,
                );
            }
            let [c0, c1] = &self.cross;
            let ones = &self.ones[..];
            correlator.correlate((c0, ones), second.map(|_| (&c1[..], ones)), setup.n as f32);
            for (which, &(a, b)) in [Some(first), second].iter().flatten().enumerate() {
                let pair = pair_index(state.live[a], state.live[b], mics);
                let half = setup.max_lag[pair] + 1;
                let start = setup.window_starts[pair];
                let window = &mut out[start..start + 2 * half + 1];
                correlator.lags_into(which == 1, window);
                edges.add(
                    window_max(window, f32::NEG_INFINITY),
                    correlator.beyond_max(which == 1, half, 2 * half + 2),
                    state.clear,
                );
            }
        }
        reach
    }
}

/// The diffuse coherence `G_ab(k)` of every pair at every bin, computed once per run.
#[derive(Debug, Clone)]
pub(crate) struct DiffuseCoherence {
    /// Per pair (in the order of [`pair_index`] over all microphones), per bin.
    table: Vec<Vec<f32>>,
}

impl DiffuseCoherence {
    pub fn new(geometry: &Geometry, n: usize, rate: f64, speed: f64) -> Self {
        let mics = geometry.mics.len();
        let bins = n / 2 + 1;
        let mut table = vec![Vec::new(); mics * (mics - 1) / 2];
        for a in 0..mics {
            for b in a + 1..mics {
                let d = (geometry.mics[b].position - geometry.mics[a].position).norm();
                table[pair_index(a, b, mics)] = (0..bins)
                    .map(|k| {
                        let x = std::f64::consts::TAU * (k as f64 * rate / n as f64) * d / speed;
                        if x.abs() < 1e-9 {
                            1.0
                        } else {
                            (x.sin() / x) as f32
                        }
                    })
                    .collect();
            }
        }
        DiffuseCoherence { table }
    }

    /// The coherence of pair `pair` (as numbered by [`pair_index`]).
    pub fn pair(&self, pair: usize) -> &[f32] {
        &self.table[pair]
    }
}

/// `sum += x y*`, bin by bin.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn add_cross(sum: &mut [Complex32], x: &[Complex32], y: &[Complex32]) {
    for ((s, x), y) in sum.iter_mut().zip(x).zip(y) {
        s.re += x.re * y.re + x.im * y.im;
        s.im += x.im * y.re - x.re * y.im;
    }
}

/// `sum += |x|^2`, bin by bin.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn add_power(sum: &mut [f32], x: &[Complex32]) {
    for (s, x) in sum.iter_mut().zip(x) {
        *s += x.re * x.re + x.im * x.im;
    }
}

/// Every bin of a pair's summed cross-spectrum `cross` replaced by [`direct_phase`]
/// times `weights` squared (`w_e(k)^2`), in single precision and without branches so
/// that it vectorises; `power` holds the two microphones' summed auto-spectra,
/// `diffuse` the pair's diffuse coherence.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn remove_diffuse(
    cross: &mut [Complex32],
    (power_a, power_b): (&[f32], &[f32]),
    diffuse: &[f32],
    weights: &[f32],
) {
    for ((((c, &a), &b), &d), &w) in cross
        .iter_mut()
        .zip(power_a)
        .zip(power_b)
        .zip(diffuse)
        .zip(weights)
    {
        let norm2 = a * b;
        let heard = norm2 > 0.0 && norm2 < f32::INFINITY;
        let inv = if heard { norm2.sqrt().recip() } else { 0.0 };
        let (gr, gi) = (c.re * inv, c.im * inv);
        let g2 = (gr * gr + gi * gi).min(MAX_COHERENCE2);
        let (qa, qb, qc) = (g2 - 1.0, 2.0 * (g2 - gr * d), g2 - 2.0 * gr * d + d * d);
        let disc = (qb * qb - 4.0 * qa * qc).max(0.0);
        let ratio = ((-qb - disc.sqrt()) / (2.0 * qa)).max(0.0);
        let (re, im) = (gr * (ratio + 1.0) - d, gi * (ratio + 1.0));
        let m2 = re * re + im * im;
        let scale = if heard && m2 > 1e-20 {
            w * w / m2.sqrt()
        } else {
            0.0
        };
        *c = Complex32::new(re * scale, im * scale);
    }
}

/// The largest squared coherence the model is solved with: 1 exactly (one frame, or a
/// single source in free field) leaves the quadratic's leading term zero.
const MAX_COHERENCE2: f32 = 1.0 - 1e-6;

/// One bin's cross-spectrum with the diffuse part removed, as a unit phasor (zero when
/// nothing is left), in double precision: the reference `remove_diffuse` is tested
/// against. `cross` and `power_a`, `power_b` are the pair's cross- and auto-spectra
/// summed over the frames, `diffuse` its diffuse coherence at the bin. The coherence
/// `g = cross / sqrt(power_a power_b)` is modelled as `(c e^{-iwT} + G) / (c + 1)`;
/// `|g (c + 1) - G| = c` gives `(|g|^2 - 1) c^2 + 2 (|g|^2 - Re(g) G) c + |g - G|^2 = 0`,
/// whose larger root (or, with none real, its vertex) is the ratio `c`, and
/// `g (c + 1) - G` is the direct sound's cross-spectrum up to a positive factor.
#[cfg_attr(not(test), allow(dead_code))] // the scalar reference of `dereverberate`, for its tests
pub fn direct_phase(cross: Complex32, power_a: f32, power_b: f32, diffuse: f32) -> Complex32 {
    let norm = (power_a as f64 * power_b as f64).sqrt();
    if !(norm > 0.0 && norm.is_finite()) {
        return Complex32::new(0.0, 0.0);
    }
    let g = (cross.re as f64 / norm, cross.im as f64 / norm);
    // |g| <= 1 by Cauchy-Schwarz.
    let g2 = (g.0 * g.0 + g.1 * g.1).min(MAX_COHERENCE2 as f64);
    let gd = diffuse as f64;
    let (qa, qb, qc) = (
        g2 - 1.0,
        2.0 * (g2 - g.0 * gd),
        g2 - 2.0 * g.0 * gd + gd * gd,
    );
    let disc = (qb * qb - 4.0 * qa * qc).max(0.0);
    // qa < 0: the larger root is (-qb - sqrt(disc)) / (2 qa).
    let ratio = ((-qb - disc.sqrt()) / (2.0 * qa)).max(0.0);
    let (re, im) = (g.0 * (ratio + 1.0) - gd, g.1 * (ratio + 1.0));
    let mag = (re * re + im * im).sqrt();
    if mag > 1e-10 {
        Complex32::new((re / mag) as f32, (im / mag) as f32)
    } else {
        Complex32::new(0.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coherence made of a direct sound at a known phase and a diffuse part in a known
    /// ratio gives back the direct sound's phase exactly, for any ratio.
    #[test]
    fn the_direct_phase_is_recovered_from_a_mixed_coherence() {
        for &(phase, diffuse, ratio) in &[
            (0.7f64, 0.8f64, 0.5f64),
            (-2.0, 0.3, 2.0),
            (2.9, -0.2, 0.1),
            (0.1, 0.95, 4.0),
        ] {
            let direct = Complex32::new(phase.cos() as f32, phase.sin() as f32);
            let mixed = (direct * ratio as f32 + Complex32::new(diffuse as f32, 0.0))
                / (ratio as f32 + 1.0);
            // Auto-spectra of 1: the coherence is the cross-spectrum itself.
            let got = direct_phase(mixed, 1.0, 1.0, diffuse as f32);
            let err = (got.im as f64).atan2(got.re as f64) - phase;
            let err = (err + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(err.abs() < 1e-3, "phase {phase}: got error {err}");
            // The uncorrected phase is pulled toward zero.
            let raw = (mixed.im as f64).atan2(mixed.re as f64);
            assert!(raw.abs() < phase.abs() - 0.01 || diffuse < 0.0);
        }
    }

    /// The vectorised stage gives what the double-precision reference gives, bin by bin,
    /// on sums of random spectra over a few frames (coherences from 0 to nearly 1).
    #[test]
    fn the_vectorised_stage_matches_the_reference() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let bins = 257;
        let mut z = || Complex32::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5);
        let mut cross = vec![Complex32::default(); bins];
        let (mut pa, mut pb) = (vec![0.0; bins], vec![0.0; bins]);
        for _frame in 0..4 {
            // A common part, stronger in some bins, so that coherences spread over (0, 1).
            let (x, y): (Vec<_>, Vec<_>) = (0..bins)
                .map(|k| {
                    let common = z() * (k % 5) as f32;
                    (common + z(), common * Complex32::new(0.6, 0.8) + z())
                })
                .unzip();
            add_cross(&mut cross, &x, &y);
            add_power(&mut pa, &x);
            add_power(&mut pb, &y);
        }
        // A microphone silent in one bin.
        pa[3] = 0.0;
        let diffuse: Vec<f32> = (0..bins)
            .map(|k| (1.0 - k as f32 / 100.0).max(-0.2))
            .collect();
        let weights: Vec<f32> = (0..bins).map(|k| 0.5 + (k % 7) as f32 / 7.0).collect();
        let mut fast = cross.clone();
        remove_diffuse(&mut fast, (&pa, &pb), &diffuse, &weights);
        for k in 0..bins {
            let w2 = weights[k] * weights[k];
            let want = direct_phase(cross[k], pa[k], pb[k], diffuse[k]) * w2;
            assert!(
                (fast[k] - want).norm() < 2e-3 * w2,
                "bin {k}: {} against {want}",
                fast[k]
            );
        }
        assert_eq!(fast[3], Complex32::new(0.0, 0.0));
    }

    /// Nothing to remove: a fully coherent bin keeps its phase, and silence gives zero.
    #[test]
    fn a_coherent_bin_keeps_its_phase_and_silence_gives_nothing() {
        let c = Complex32::new(0.6, -0.8);
        let got = direct_phase(c, 1.0, 1.0, 0.0);
        assert!((got - c).norm() < 1e-4, "{got}");
        assert_eq!(direct_phase(c, 0.0, 1.0, 0.5), Complex32::new(0.0, 0.0));
    }
}
