//! One analysis frame through the method, in the paper's order: spectra, weighting
//! (eq. 4-5), weighted PHAT correlation of every pair (eq. 6), the M highest peaks
//! (eq. 7), the consistency search (eq. 8), the direction (eq. 13).
//!
//! Everything is planned and allocated in [`Analyzer::new`]; processing a frame does not
//! allocate (apart from a first-time direction solver for a new set of live microphones).

use crate::correlation::{self, Correlator, ForwardFft, Interpolation, Peak, Window};
use crate::direction::{angles_deg, pair_count, pair_index, DirectionSolver};
use crate::geometry::Geometry;
use crate::search::Searcher;
use crate::weighting::{enhanced_weights, NoiseEstimator, NoiseSettings};
use anyhow::{bail, Result};
use nalgebra::Vector3;
use realfft::num_complex::Complex32;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Time spent in each stage (only measured after [`Analyzer::enable_stage_timing`]).
#[derive(Debug, Clone, Default)]
pub struct StageTimes {
    /// Live-channel check, forward FFTs, mean power spectrum.
    pub spectra: Duration,
    /// Weights (eq. 4-5), noise estimate update, whitening.
    pub weighting: Duration,
    /// Cross-spectra and inverse FFTs of every pair (eq. 6).
    pub correlation: Duration,
    /// The M highest peaks of every pair (eq. 7).
    pub peaks: Duration,
    /// The consistency search (eq. 8).
    pub search: Duration,
    /// Direction (eq. 13) and the detection record.
    pub direction: Duration,
}

/// The method's parameters (defaults are the paper's where it gives them).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Params {
    /// Frame size N in samples (`None`: [`default_frame_size`] of the sample rate).
    pub frame_size: Option<usize>,
    /// `alpha` of eq. (4).
    pub alpha: f32,
    /// `gamma` of eq. (5).
    pub gamma: f32,
    /// Apply the spectral weighting (`false`: plain PHAT, `w_e = 1`, for comparison).
    pub weighting: bool,
    /// M, peaks kept per pair.
    pub peaks: usize,
    /// Consistency tolerance of eq. (8), in samples.
    pub tolerance: f32,
    /// Overrides the geometry's speed of sound (m/s).
    pub speed_of_sound: Option<f64>,
    /// Detections with a lower score are dropped (`None`: [`DEFAULT_MIN_SCORE_PER_PAIR`]
    /// times the number of microphone pairs in the frame).
    pub min_score: Option<f64>,
    pub window: Window,
    pub interpolation: Interpolation,
    /// Node budget of the consistency search per frame.
    pub max_nodes: u64,
    /// The noise estimator behind `X_n(k)`.
    pub noise: NoiseSettings,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            frame_size: None,
            alpha: 0.4,
            gamma: 0.3,
            weighting: true,
            peaks: 8,
            tolerance: DEFAULT_TOLERANCE,
            speed_of_sound: None,
            min_score: None,
            window: Window::Hann,
            interpolation: Interpolation::Parabolic,
            max_nodes: 1_000_000,
            noise: NoiseSettings::default(),
        }
    }
}

/// How much of the start of a file primes the noise estimate before it is analysed
/// (seconds; see [`Analyzer::prime`]).
pub const PRIMING_S: f64 = 0.25;

/// Default consistency tolerance in samples (see the README for how it was chosen).
pub const DEFAULT_TOLERANCE: f32 = 2.0;

/// Default detection threshold per microphone pair. Stationary background alone gives
/// weights near 0.6 and so correlation peaks near 0.36 or below per pair; a source that
/// stands out of the background scores higher (see the README for the measurement).
pub const DEFAULT_MIN_SCORE_PER_PAIR: f64 = 0.5;

/// The default frame size: the power of two nearest (in ratio) to 1024 samples at
/// 48 kHz, i.e. about 21 ms: 128 at 8 kHz, 256 at 16 kHz, 1024 at 44.1/48 kHz, 2048 at
/// 96 kHz, 4096 at 192 kHz. Keeping the duration fixed keeps the method's time and
/// frequency resolution (and the noise estimator's behaviour) the same at every rate.
pub fn default_frame_size(sample_rate: u32) -> usize {
    let ideal = 1024.0 * sample_rate as f64 / 48000.0;
    let p = ideal.log2().round().clamp(6.0, 16.0);
    1usize << (p as u32)
}

/// One detected source in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Frame index (frame `i` starts at sample `i * N / 2`).
    pub frame: u64,
    /// Centre of the frame, seconds from the start of the file.
    pub time_s: f64,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// Unit vector from the array centre toward the source.
    pub direction: Vector3<f64>,
    /// Summed weighted correlation of the chosen delay set (at most 1 per pair).
    pub score: f64,
    /// Microphones that took part (dead channels are left out).
    pub mics: usize,
}

/// Counters a run reports at the end.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    pub frames: u64,
    pub detections: u64,
    /// Frames where every channel was constant (digital silence).
    pub silent_frames: u64,
    /// Per mic: frames where it was constant while others carried signal.
    pub dead_frames: Vec<u64>,
    /// Frames whose search stopped at the node budget.
    pub budget_frames: u64,
    /// Frames with no consistent delay set.
    pub inconsistent_frames: u64,
    /// Frames whose best set scored below the threshold.
    pub below_threshold_frames: u64,
}

/// The per-frame engine for one geometry and sample rate.
pub struct Analyzer {
    geometry: Geometry,
    params: Params,
    n: usize,
    hop: usize,
    rate: f64,
    speed: f64,
    fft: ForwardFft,
    spectra: Vec<Vec<Complex32>>,
    whitened: Vec<Vec<Complex32>>,
    power: Vec<f32>,
    weights: Vec<f32>,
    noise: NoiseEstimator,
    correlator: Correlator,
    corr: Vec<f32>,
    /// Lag search range per global pair (samples).
    max_lag: Vec<usize>,
    peaks: Vec<Vec<Peak>>,
    searcher: Searcher,
    solvers: HashMap<u64, Option<DirectionSolver>>,
    live: Vec<usize>,
    stats: FrameStats,
    /// Frames folded in by [`Analyzer::prime`] and not yet processed.
    primed: usize,
    timing: bool,
    times: StageTimes,
}

/// Adds the time since `$clock` to `$self.times.$stage` (when timing) and restarts it.
macro_rules! lap {
    ($self:ident, $clock:ident, $stage:ident) => {
        if let Some(t) = $clock.as_mut() {
            let now = Instant::now();
            $self.times.$stage += now - *t;
            *t = now;
        }
    };
}

impl Analyzer {
    pub fn new(geometry: &Geometry, sample_rate: u32, params: &Params) -> Result<Self> {
        let n = params
            .frame_size
            .unwrap_or_else(|| default_frame_size(sample_rate));
        if n < 16 || n % 2 != 0 {
            bail!("the frame size must be an even number of at least 16 samples, got {n}");
        }
        if params.peaks == 0 {
            bail!("--peaks must be at least 1");
        }
        if !(params.tolerance.is_finite() && params.tolerance >= 0.0) {
            bail!("--tolerance must be a non-negative number of samples");
        }
        let speed = params.speed_of_sound.unwrap_or(geometry.speed_of_sound);
        if !(speed.is_finite() && speed > 0.0) {
            bail!("the speed of sound must be positive, got {speed}");
        }
        let rate = sample_rate as f64;
        let mics = geometry.mics.len();
        let mut max_lag = vec![0; pair_count(mics)];
        let mut widest = 0;
        for a in 0..mics {
            for b in a + 1..mics {
                let lag = lag_range(geometry.max_lag_samples(a, b, rate, speed));
                max_lag[pair_index(a, b, mics)] = lag;
                widest = widest.max(lag);
            }
        }
        if widest + 2 > n / 2 {
            let needed = ((widest + 2) * 2).next_power_of_two();
            bail!(
                "the array's largest delay ({widest} samples at {sample_rate} Hz) does not fit in a frame of {n} samples: use --frame-size {needed} or more"
            );
        }
        let bins = n / 2 + 1;
        let hop = n / 2;
        Ok(Analyzer {
            geometry: geometry.clone(),
            params: params.clone(),
            n,
            hop,
            rate,
            speed,
            fft: ForwardFft::new(n, params.window),
            spectra: vec![vec![Complex32::default(); bins]; mics],
            whitened: vec![vec![Complex32::default(); bins]; mics],
            power: vec![0.0; bins],
            weights: vec![1.0; bins],
            noise: NoiseEstimator::new(bins, hop as f64 / rate, params.noise),
            correlator: Correlator::new(n),
            corr: vec![0.0; n],
            max_lag,
            peaks: (0..pair_count(mics))
                .map(|_| Vec::with_capacity(params.peaks))
                .collect(),
            searcher: Searcher::new(params.tolerance, params.max_nodes),
            solvers: HashMap::new(),
            live: Vec::with_capacity(mics),
            stats: FrameStats {
                dead_frames: vec![0; mics],
                ..Default::default()
            },
            primed: 0,
            timing: false,
            times: StageTimes::default(),
        })
    }

    pub fn frame_size(&self) -> usize {
        self.n
    }

    pub fn hop(&self) -> usize {
        self.hop
    }

    pub fn speed_of_sound(&self) -> f64 {
        self.speed
    }

    /// Starts measuring the time spent in each stage (costs about 1 us a frame).
    pub fn enable_stage_timing(&mut self) {
        self.timing = true;
    }

    pub fn timing_enabled(&self) -> bool {
        self.timing
    }

    pub fn stage_times(&self) -> &StageTimes {
        &self.times
    }

    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }

    /// The largest lag searched for each pair of the full array (samples).
    pub fn lag_ranges(&self) -> &[usize] {
        &self.max_lag
    }

    /// Analyses frame `index`; `frame[m * N .. (m + 1) * N]` holds mic `m`'s samples.
    /// Folds a frame into the noise estimate only (no detection, no statistics). Files
    /// prime the estimate with their first [`PRIMING_S`] seconds before analysing them,
    /// so that their first frames are weighted against a formed noise estimate.
    /// The primed frames must then be processed, in order, before any other: they are
    /// not folded into the estimate a second time.
    pub fn prime(&mut self, frame: &[f32]) {
        if self.spectra_and_power(frame) {
            self.noise.update(&self.power);
        }
        self.primed += 1;
    }

    /// Finds the live microphones, their spectra and `X(k)`, the mean power spectrum over
    /// them. Returns `false` when no microphone is live (digital silence).
    fn spectra_and_power(&mut self, frame: &[f32]) -> bool {
        let n = self.n;
        // Live microphones: a channel stuck at one value carries no delay information.
        self.live.clear();
        for m in 0..self.geometry.mics.len() {
            let s = &frame[m * n..(m + 1) * n];
            let first = s[0];
            if s.iter().any(|&v| v != first) {
                self.live.push(m);
            }
        }
        if self.live.is_empty() {
            return false;
        }
        self.power.fill(0.0);
        for &m in &self.live {
            self.fft
                .transform(&frame[m * n..(m + 1) * n], &mut self.spectra[m]);
            for (p, x) in self.power.iter_mut().zip(&self.spectra[m]) {
                *p += x.norm_sqr();
            }
        }
        let inv = 1.0 / self.live.len() as f32;
        self.power.iter_mut().for_each(|p| *p *= inv);
        true
    }

    pub fn process(&mut self, index: u64, frame: &[f32]) -> Option<Detection> {
        let n = self.n;
        let mics = self.geometry.mics.len();
        self.stats.frames += 1;
        let primed = self.primed > 0;
        self.primed = self.primed.saturating_sub(1);
        let mut clock = self.timing.then(Instant::now);
        let live = self.spectra_and_power(frame);
        lap!(self, clock, spectra);
        if !live {
            self.stats.silent_frames += 1;
            return None;
        }
        for m in 0..mics {
            if !self.live.contains(&m) {
                self.stats.dead_frames[m] += 1;
            }
        }

        // w_e(k) from X(k) and the noise estimate of previous frames (eq. 4-5).
        if !self.noise.started() {
            self.noise.start(&self.power);
        }
        if self.params.weighting {
            enhanced_weights(
                &self.power,
                self.noise.noise(),
                self.params.alpha,
                self.params.gamma,
                &mut self.weights,
            );
        }
        if !primed {
            self.noise.update(&self.power);
        }
        for &m in &self.live {
            correlation::whiten(&self.spectra[m], &self.weights, &mut self.whitened[m]);
        }
        // Eq. (6) divided by N (see the `correlation` module on the scale).
        let norm = n as f32;
        lap!(self, clock, weighting);

        // R_ij of every live pair (eq. 6) and its M highest peaks (eq. 7).
        let k = self.live.len();
        if k < 2 {
            return None;
        }
        for a in 0..k {
            for b in a + 1..k {
                let (i, j) = (self.live[a], self.live[b]);
                self.correlator.correlate(
                    &self.whitened[i],
                    &self.whitened[j],
                    norm,
                    &mut self.corr,
                );
                lap!(self, clock, correlation);
                correlation::find_peaks(
                    &self.corr,
                    self.max_lag[pair_index(i, j, mics)],
                    self.params.peaks,
                    self.params.interpolation,
                    &mut self.peaks[pair_index(a, b, k)],
                );
                lap!(self, clock, peaks);
            }
        }

        // The consistent delay set with the greatest correlation (eq. 8).
        self.searcher.search(k, &self.peaks);
        lap!(self, clock, search);
        let Some(solution) = self.searcher.solution() else {
            if self.searcher.exhausted() {
                self.stats.budget_frames += 1;
            }
            self.stats.inconsistent_frames += 1;
            return None;
        };
        if !solution.complete {
            self.stats.budget_frames += 1;
        }
        let threshold = self
            .params
            .min_score
            .unwrap_or(DEFAULT_MIN_SCORE_PER_PAIR * pair_count(k) as f64);
        if solution.score < threshold {
            self.stats.below_threshold_frames += 1;
            return None;
        }

        // Direction (eq. 13) for this set of live microphones.
        let mask = self.live.iter().fold(0u64, |acc, &m| acc | (1u64 << m));
        let (geometry, rate, speed) = (&self.geometry, self.rate, self.speed);
        let solver = self
            .solvers
            .entry(mask)
            .or_insert_with(|| DirectionSolver::new(geometry, mask, rate, speed).ok())
            .as_ref()?;
        let u = solver.solve(&solution.lags)?;
        let (azimuth_deg, elevation_deg) = angles_deg(&u);
        self.stats.detections += 1;
        lap!(self, clock, direction);
        Some(Detection {
            frame: index,
            time_s: (index as f64 * self.hop as f64 + n as f64 / 2.0) / self.rate,
            azimuth_deg,
            elevation_deg,
            direction: u,
            score: solution.score,
            mics: k,
        })
    }
}

/// The lags searched for a pair whose largest physical delay is `max_delay` samples: 3%
/// more (the speed of sound varies about that much between 0 and 40 C) and one sample
/// for the peak's neighbours.
fn lag_range(max_delay: f64) -> usize {
    (max_delay * 1.03).ceil() as usize + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_frame_size_scales_with_rate() {
        assert_eq!(default_frame_size(8000), 128);
        assert_eq!(default_frame_size(16000), 256);
        assert_eq!(default_frame_size(44100), 1024);
        assert_eq!(default_frame_size(48000), 1024);
        assert_eq!(default_frame_size(96000), 2048);
        assert_eq!(default_frame_size(192000), 4096);
    }
}
