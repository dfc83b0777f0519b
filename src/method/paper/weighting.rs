//! SNR-based spectral weighting: the paper's eq. (4) and (5).
//!
//! `X(k)` is the mean power spectrum over the (live) microphones of the current frame and
//! `X_n(k)` a noise estimate from previous frames. The paper only says "time average of
//! previous X(k)"; a plain average climbs to the level of any source that lasts a few
//! seconds and so erases it. We use minima-controlled recursive averaging (MCRA, Cohen &
//! Berdugo 2002): `X_n` is a recursive average of `X` that is frozen in proportion to the
//! probability that a bin holds signal, and that probability comes from comparing a
//! smoothed `X` with its minimum over the last few seconds. A source is only absorbed
//! into the noise once it has been on without a pause for longer than the minimum
//! window ([`NoiseSettings::min_window_s`]).

use multiversion::multiversion;

/// `alpha` of eq. (4): the share of the noise estimate `X_n` subtracted from `X`
/// (`w = (X - alpha X_n) / X`).
pub(crate) const ALPHA: f64 = 0.4;
/// `gamma` of eq. (5): the exponent of the bin's SNR that enhances strong bins
/// (`w_e = w (X / X_n)^gamma`).
pub(crate) const GAMMA: f64 = 0.3;

/// The share of the recent frames' power taken as late reverberation by default
/// (measured on real speech in the paper's room, docs/field.md).
pub(crate) const DEFAULT_REVERB_LEVEL: f64 = 0.5;

/// The spectral weighting `w_e(k)` of eq. (4) and (5), the noise estimate under it, and
/// the frequencies it lets through.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "flags", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
#[non_exhaustive]
pub struct Weighting {
    /// Plain PHAT: skip the spectral weighting (w_e = 1), for comparison
    #[cfg_attr(feature = "flags", arg(long = "no-weighting", id = "no_weighting", action = clap::ArgAction::SetFalse, hide_short_help = true))]
    pub on: bool,
    /// Noise over-subtraction alpha of the spectral weighting (paper eq. 4)
    #[cfg_attr(feature = "flags", arg(long, default_value_t = ALPHA, value_parser = crate::flags::unit_interval, hide_short_help = true))]
    pub alpha: f64,
    /// Exponent gamma that favours high-SNR bins (paper eq. 5)
    #[cfg_attr(feature = "flags", arg(long, default_value_t = GAMMA, value_parser = crate::flags::unit_interval, hide_short_help = true))]
    pub gamma: f64,
    /// Share of the recent frames' power taken as late reverberation in the noise estimate [default: 0.5; 0 with --min-score or --paper]
    #[cfg_attr(feature = "flags", arg(long, value_name = "SHARE", value_parser = crate::flags::unit_interval, hide_short_help = true))]
    pub reverb_level: Option<f64>,
    /// Analyse only these frequencies, LOW-HIGH in Hz (2k-8k for birds; to shut out a noise that owns a band, such as 200-20k above mains hum). Not for speech: the weighting already favours the bins a talker stands out in, and 300-3400 found fewer of a talker's words and twice the error on small arrays; HIGH beyond half the sample rate is taken as it
    #[cfg_attr(feature = "flags", arg(long = "band", value_name = "LOW-HIGH", value_parser = band, allow_hyphen_values = true))]
    pub band_hz: Option<(f64, f64)>,
}

impl Default for Weighting {
    fn default() -> Self {
        Weighting {
            on: true,
            alpha: ALPHA,
            gamma: GAMMA,
            reverb_level: None,
            band_hz: None,
        }
    }
}

impl Weighting {
    /// The share of late reverberation in the noise estimate as the stages read it (a
    /// resolved configuration always gives one; none reads as 0).
    pub(crate) fn reverb_share(&self) -> f32 {
        self.reverb_level.unwrap_or(0.0) as f32
    }
}

/// A band of frequencies `LOW-HIGH` in Hz (`--band 300-3400`; a `k` suffix is kHz:
/// `2k-8k`).
#[cfg(feature = "flags")]
pub(crate) fn band(s: &str) -> Result<(f64, f64), String> {
    use crate::flags::parse_f64;
    let Some((low, high)) = s.split_once('-') else {
        return Err(format!("`{s}` is not LOW-HIGH in Hz (like 300-3400)"));
    };
    let hz = |t: &str| match t.trim().strip_suffix(['k', 'K']) {
        Some(k) => parse_f64(k).map(|v| v * 1000.0),
        None => parse_f64(t.trim()),
    };
    let (low, high) = (hz(low)?, hz(high)?);
    if low < 0.0 || high <= low {
        return Err(format!(
            "{low}-{high} Hz is not a band: LOW must be 0 or more and under HIGH"
        ));
    }
    Ok((low, high))
}

/// Time constant of the smoothing of `X` before minimum tracking (seconds).
pub(crate) const SMOOTH_TAU_S: f64 = 0.04;
/// The minimum window is tracked as this many sub-windows (so it slides in steps of
/// `min_window_s / SUBWINDOWS`).
pub(crate) const SUBWINDOWS: usize = 8;
/// Time constant of the signal-presence probability (seconds).
pub(crate) const PRESENCE_TAU_S: f64 = 0.01;

/// The noise estimator's settings. The defaults were chosen by measurement (docs/method.md,
/// "Choices and evidence"): Cohen's speech settings (ratio 5, 0.5 s) let a steady source
/// 3 dB above the floor be absorbed within a second; these keep it for the whole window
/// without letting stationary background through.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct NoiseSettings {
    /// Length of the minimum-tracking window (seconds): a source that stays on without a
    /// pause for longer than this is taken as background.
    pub min_window_s: f64,
    /// A bin whose smoothed power exceeds this multiple of its minimum holds signal.
    pub presence_ratio: f32,
    /// Time constant of the noise average in bins without signal (seconds).
    pub noise_tau_s: f64,
}

impl Default for NoiseSettings {
    fn default() -> Self {
        NoiseSettings {
            min_window_s: 4.0,
            presence_ratio: 2.0,
            noise_tau_s: 2.0,
        }
    }
}
/// Largest `X / X_n` the enhancement of eq. (5) uses (60 dB): keeps `w_e` finite when the
/// noise estimate is zero (after digital silence).
pub(crate) const MAX_SNR_RATIO: f32 = 1e6;

/// The smoothing coefficient for a time constant at a given frame hop.
fn coefficient(tau_s: f64, hop_s: f64) -> f32 {
    (-hop_s / tau_s).exp() as f32
}

/// Minima-controlled recursive average noise estimate `X_n(k)`.
#[derive(Clone)]
pub struct NoiseEstimator {
    a_s: f32,
    a_p: f32,
    a_d: f32,
    frames_per_sub: usize,
    delta: f32,
    /// Per bin, how many frames the noise average holds (frames judged to be without
    /// signal): until it reaches the time constant the average is a plain mean.
    count: Vec<f32>,
    /// Frequency- and time-smoothed power.
    smooth: Vec<f32>,
    scratch: Vec<f32>,
    /// Minimum of the current sub-window.
    sub_min: Vec<f32>,
    /// Minima of the last `SUBWINDOWS` complete sub-windows, `SUBWINDOWS` rows of `bins`
    /// (infinite until filled, so that they do not take part in the minimum).
    ring: Vec<f32>,
    ring_pos: usize,
    frame_in_sub: usize,
    presence: Vec<f32>,
    noise: Vec<f32>,
    started: bool,
}

impl NoiseEstimator {
    /// An estimator for `bins` frequency bins updated every `hop_s` seconds.
    pub fn new(bins: usize, hop_s: f64, settings: NoiseSettings) -> Self {
        let frames_per_sub = ((settings.min_window_s / SUBWINDOWS as f64) / hop_s)
            .round()
            .max(1.0) as usize;
        NoiseEstimator {
            count: vec![0.0; bins],
            a_s: coefficient(SMOOTH_TAU_S, hop_s),
            a_p: coefficient(PRESENCE_TAU_S, hop_s),
            a_d: coefficient(settings.noise_tau_s, hop_s),
            delta: settings.presence_ratio,
            frames_per_sub,
            smooth: vec![0.0; bins],
            scratch: vec![0.0; bins],
            sub_min: vec![0.0; bins],
            ring: vec![0.0; bins * SUBWINDOWS],
            ring_pos: 0,
            frame_in_sub: 0,
            presence: vec![0.0; bins],
            noise: vec![0.0; bins],
            started: false,
        }
    }

    /// Whether any frame has been seen.
    pub fn started(&self) -> bool {
        self.started
    }

    /// The current estimate `X_n(k)` from the frames seen so far. Before the first frame
    /// it is zero; call [`NoiseEstimator::start`] with the first frame's `X(k)`.
    pub fn noise(&self) -> &[f32] {
        &self.noise
    }

    /// Starts the estimate at the first frame's spectrum (the only information there is;
    /// the following frames without signal are averaged in with equal weights until the
    /// average spans the noise time constant).
    pub fn start(&mut self, x: &[f32]) {
        smooth_frequency(x, &mut self.smooth);
        self.sub_min.copy_from_slice(&self.smooth);
        self.ring.fill(f32::INFINITY);
        self.noise.copy_from_slice(x);
        self.presence.fill(0.0);
        self.frame_in_sub = 0;
        self.count.fill(1.0);
        self.started = true;
    }

    /// Folds the current frame's `X(k)` into the estimate (after it has been used for the
    /// current frame's weights: the estimate is of *previous* frames).
    pub fn update(&mut self, x: &[f32]) {
        if !self.started {
            self.start(x);
            return;
        }
        update_started(self, x);
    }
}

/// [`NoiseEstimator::update`] after the first frame.
#[allow(clippy::needless_range_loop)] // several arrays indexed by bin, and neighbours
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn update_started(est: &mut NoiseEstimator, x: &[f32]) {
    let n = x.len();
    smooth_frequency(x, &mut est.scratch);
    let (a_s, a_p, a_d) = (est.a_s, est.a_p, est.a_d);
    // Signal presence is judged from the smoothed power of the frames *before* this
    // one: gating the average of X on a statistic that contains X itself would bias
    // the estimate low (updates would favour the frames where X happens to be low).
    for k in 0..n {
        let mut minimum = est.sub_min[k];
        for s in 0..SUBWINDOWS {
            minimum = minimum.min(est.ring[s * n + k]);
        }
        let present = if est.smooth[k] > est.delta * minimum {
            1.0
        } else {
            0.0
        };
        let p = a_p * est.presence[k] + (1.0 - a_p) * present;
        est.presence[k] = p;
        // A plain mean of the frames without signal until it spans the time constant,
        // then the recursive average; frozen in proportion to signal presence.
        let base = a_d.min(1.0 - 1.0 / (est.count[k] + 1.0));
        let a = base + (1.0 - base) * p;
        est.noise[k] = a * est.noise[k] + (1.0 - a) * x[k];
        est.count[k] += 1.0 - p;
    }
    for k in 0..n {
        est.smooth[k] = a_s * est.smooth[k] + (1.0 - a_s) * est.scratch[k];
        est.sub_min[k] = est.sub_min[k].min(est.smooth[k]);
    }
    est.frame_in_sub += 1;
    if est.frame_in_sub == est.frames_per_sub {
        let row = &mut est.ring[est.ring_pos * n..(est.ring_pos + 1) * n];
        row.copy_from_slice(&est.sub_min);
        est.sub_min.copy_from_slice(&est.smooth);
        est.ring_pos = (est.ring_pos + 1) % SUBWINDOWS;
        est.frame_in_sub = 0;
    }
}

/// Smooths a spectrum over frequency with weights (1/4, 1/2, 1/4).
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn smooth_frequency(x: &[f32], out: &mut [f32]) {
    let n = x.len();
    for k in 0..n {
        let lo = x[k.saturating_sub(1)];
        let hi = x[(k + 1).min(n - 1)];
        out[k] = 0.25 * lo + 0.5 * x[k] + 0.25 * hi;
    }
}

/// The enhanced weights `w_e(k)` of eq. (5) from `X(k)` and `X_n(k)`:
/// `w = max(0.1, (X - alpha X_n) / X)` (eq. 4), times `(X / X_n)^gamma` where `X > X_n`.
/// A bin with no power gets the floor 0.1; `X / X_n` is capped at `MAX_SNR_RATIO`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
pub fn enhanced_weights(x: &[f32], xn: &[f32], alpha: f32, gamma: f32, out: &mut [f32]) {
    for ((o, &x), &xn) in out.iter_mut().zip(x).zip(xn) {
        let w = if x > 0.0 {
            ((x - alpha * xn) / x).max(0.1)
        } else {
            0.1
        };
        *o = if x > xn {
            let ratio = if xn > 0.0 {
                (x / xn).min(MAX_SNR_RATIO)
            } else {
                MAX_SNR_RATIO
            };
            w * ratio.powf(gamma)
        } else {
            w
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn weights_match_hand_computed_values() {
        // X, X_n -> w, w_e with alpha = 0.4, gamma = 0.3
        // X=10, Xn=1: w = (10-0.4)/10 = 0.96, w_e = 0.96 * 10^0.3 = 1.915452..
        // X=1,  Xn=1: w = 0.6, X <= Xn so w_e = 0.6
        // X=1,  Xn=5: w = max(0.1, (1-2)/1) = 0.1, w_e = 0.1
        // X=2,  Xn=4: w = max(0.1, (2-1.6)/2) = 0.2, w_e = 0.2
        // X=0,  Xn=1: floor 0.1
        // X=1,  Xn=0: w = 1, ratio capped at 1e6: w_e = 1e6^0.3 = 63.0957..
        let x = [10.0, 1.0, 1.0, 2.0, 0.0, 1.0];
        let xn = [1.0, 1.0, 5.0, 4.0, 1.0, 0.0];
        let mut out = [0.0; 6];
        enhanced_weights(&x, &xn, 0.4, 0.3, &mut out);
        let expect = [0.96 * 10f32.powf(0.3), 0.6, 0.1, 0.2, 0.1, 1e6f32.powf(0.3)];
        for (o, e) in out.iter().zip(expect) {
            assert!((o - e).abs() < 1e-5 * e.max(1.0), "{out:?} vs {expect:?}");
        }
        assert!((out[0] - 1.915_452).abs() < 1e-5);
    }

    #[test]
    fn gamma_zero_and_alpha_zero_reduce_to_plain_whitening() {
        let x = [3.0, 0.5, 7.0];
        let xn = [1.0, 1.0, 1.0];
        let mut out = [0.0; 3];
        enhanced_weights(&x, &xn, 0.0, 0.0, &mut out);
        assert_eq!(out, [1.0, 1.0, 1.0]);
    }

    /// Exponential (periodogram-like) power values of mean 1.
    fn periodogram(rng: &mut ChaCha8Rng) -> f32 {
        rng.sample::<f32, _>(rand_distr::Exp1)
    }

    #[test]
    fn noise_estimate_tracks_noise_and_not_a_long_steady_source() {
        let hop = 512.0 / 48000.0;
        let bins = 64;
        let mut est = NoiseEstimator::new(bins, hop, NoiseSettings::default());
        let mut ema = vec![0.0f32; bins]; // a plain 0.5 s time average, for contrast
        let a = coefficient(0.5, hop);
        let mut seed = ChaCha8Rng::seed_from_u64(1);
        let mut x = vec![0.0f32; bins];
        let frames = |s: f64| (s / hop) as usize;
        // 2 s of noise at power 1 (averaged over 8 mics: 8 exponentials / 8).
        let frame = |level_src: f32, seed: &mut ChaCha8Rng, x: &mut Vec<f32>| {
            for (k, v) in x.iter_mut().enumerate() {
                let noise: f32 = (0..8).map(|_| periodogram(seed)).sum::<f32>() / 8.0;
                *v = noise + if k < bins / 2 { level_src } else { 0.0 };
            }
        };
        for _ in 0..frames(2.0) {
            frame(0.0, &mut seed, &mut x);
            est.update(&x);
            for k in 0..bins {
                ema[k] = a * ema[k] + (1.0 - a) * x[k];
            }
        }
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        let n0 = mean(est.noise());
        assert!((0.7..1.3).contains(&n0), "noise estimate {n0}");
        // A steady source 20 dB above the noise in the lower half for 3 s.
        for _ in 0..frames(3.0) {
            frame(100.0, &mut seed, &mut x);
            est.update(&x);
            for k in 0..bins {
                ema[k] = a * ema[k] + (1.0 - a) * x[k];
            }
        }
        let low = mean(&est.noise()[..bins / 2]);
        let high = mean(&est.noise()[bins / 2..]);
        assert!(low < 3.0, "estimate climbed to the source: {low}");
        assert!((0.7..1.3).contains(&high), "{high}");
        // The plain average would have erased the source.
        assert!(mean(&ema[..bins / 2]) > 90.0);
        // So the source bins keep high weights.
        let mut w = vec![0.0; bins];
        enhanced_weights(&x, est.noise(), 0.4, 0.3, &mut w);
        assert!(mean(&w[..bins / 2]) > 3.0 * mean(&w[bins / 2..]), "{w:?}");
    }

    #[test]
    fn noise_estimate_follows_a_drop_after_a_loud_start() {
        let hop = 512.0 / 48000.0;
        let settings = NoiseSettings::default();
        let mut est = NoiseEstimator::new(4, hop, settings);
        est.update(&[100.0; 4]);
        for _ in 0..(settings.min_window_s * 2.5 / hop) as usize {
            est.update(&[1.0; 4]);
        }
        assert!(
            est.noise().iter().all(|&v| (0.9..1.2).contains(&v)),
            "{:?}",
            est.noise()
        );
    }
}
