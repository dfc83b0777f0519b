//! One analysis frame through the method, in the paper's order: spectra, weighting
//! (eq. 4-5), weighted PHAT correlation of every pair (eq. 6), the M highest peaks
//! (eq. 7), the consistency search (eq. 8), the direction (eq. 13).
//!
//! Everything is planned and allocated in [`Analyzer::new`]; processing a frame does not
//! allocate (apart from a first-time direction solver for a new set of live microphones).

use crate::correlation::{self, Correlator, ForwardFft, Interpolation, Peak, Window, MAX_PEAKS};
use crate::direction::{angles_deg, pair_count, pair_index, DirectionSolver};
use crate::geometry::Geometry;
use crate::search::Searcher;
use crate::weighting::{enhanced_weights, NoiseEstimator, NoiseSettings};
use anyhow::{bail, Result};
use multiversion::multiversion;
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
    /// Pair correlations computed.
    pub correlated_pairs: u64,
    /// Pair correlations left out because the weights' ceiling proved that the frame
    /// could not reach the detection threshold (see [`correlation::peak_ceiling`]).
    pub skipped_pairs: u64,
}

impl StageTimes {
    /// Adds another record's times and counts to this one.
    pub fn add(&mut self, other: &StageTimes) {
        self.spectra += other.spectra;
        self.weighting += other.weighting;
        self.correlation += other.correlation;
        self.peaks += other.peaks;
        self.search += other.search;
        self.direction += other.direction;
        self.correlated_pairs += other.correlated_pairs;
        self.skipped_pairs += other.skipped_pairs;
    }
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
/// (seconds; see [`Sequential::prime`] and `FileAnalysis::run`).
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
#[derive(Debug, Clone, Copy, PartialEq)]
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
    /// Frames with no consistent delay set (among the frames that could reach the
    /// threshold).
    pub inconsistent_frames: u64,
    /// Frames whose best set scored below the threshold, or that the weights' ceiling
    /// showed could not reach it before every pair was correlated (those are not
    /// searched, so whether they held a consistent set is not known).
    pub below_threshold_frames: u64,
}

/// What the method needs that does not change during a run (shared by all threads).
pub struct Setup {
    geometry: Geometry,
    params: Params,
    n: usize,
    hop: usize,
    rate: f64,
    speed: f64,
    /// Lag search range per global pair (samples).
    max_lag: Vec<usize>,
}

impl Setup {
    pub fn new(geometry: &Geometry, sample_rate: u32, params: &Params) -> Result<Self> {
        let n = params
            .frame_size
            .unwrap_or_else(|| default_frame_size(sample_rate));
        if n < 16 || n % 2 != 0 {
            bail!("the frame size must be an even number of at least 16 samples, got {n}");
        }
        if params.peaks == 0 || params.peaks > MAX_PEAKS {
            bail!("--peaks must be between 1 and {MAX_PEAKS}");
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
        Ok(Setup {
            geometry: geometry.clone(),
            params: params.clone(),
            n,
            hop: n / 2,
            rate,
            speed,
            max_lag,
        })
    }

    pub fn frame_size(&self) -> usize {
        self.n
    }

    pub fn hop(&self) -> usize {
        self.hop
    }

    fn bins(&self) -> usize {
        self.n / 2 + 1
    }

    /// Number of microphones.
    pub fn geometry_mics(&self) -> usize {
        self.geometry.mics.len()
    }
}

/// One frame between the stages: its live microphones, spectra, `X(k)`, and the noise
/// estimate `X_n(k)` of the frames before it.
pub struct FrameState {
    live: Vec<usize>,
    spectra: Vec<Vec<Complex32>>,
    power: Vec<f32>,
    noise: Vec<f32>,
}

impl FrameState {
    pub fn new(setup: &Setup) -> Self {
        let mics = setup.geometry.mics.len();
        FrameState {
            live: Vec::with_capacity(mics),
            spectra: vec![vec![Complex32::default(); setup.bins()]; mics],
            power: vec![0.0; setup.bins()],
            noise: vec![0.0; setup.bins()],
        }
    }
}

/// How a frame ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// Every channel constant.
    Silent,
    /// Fewer than two live microphones, or no direction from the delays.
    Unsolved,
    /// No consistent set of delays (`true`: the search hit its node budget).
    Inconsistent(bool),
    /// The best set scored under the threshold, or no set could reach it (the frame was
    /// decided by the weights' ceiling, see [`correlation::peak_ceiling`]).
    BelowThreshold(bool),
    Detected(Detection, bool),
}

/// Per-thread buffers for the parallel stages (plans, scratch, peak tables, search).
pub struct Worker {
    fft: ForwardFft,
    correlator: Correlator,
    /// `w_e(k)` of the frame (all 1 without weighting).
    weights: Vec<f32>,
    /// One pair's correlation at the lags it searches (and their two neighbours).
    window: Vec<f32>,
    /// The live pairs `(a, b)`, indices into the live microphones.
    pairs: Vec<(usize, usize)>,
    whitened: Vec<Vec<Complex32>>,
    peaks: Vec<Vec<Peak>>,
    searcher: Searcher,
    solvers: HashMap<u64, Option<DirectionSolver>>,
    /// Leave out correlations that cannot lead to a detection (always, but in a test).
    prune: bool,
}

impl Worker {
    pub fn new(setup: &Setup) -> Self {
        let mics = setup.geometry.mics.len();
        Worker {
            fft: ForwardFft::new(setup.n, setup.params.window),
            correlator: Correlator::new(setup.n),
            weights: vec![1.0; setup.bins()],
            window: Vec::with_capacity(setup.n),
            pairs: Vec::with_capacity(pair_count(mics)),
            whitened: vec![vec![Complex32::default(); setup.bins()]; mics],
            peaks: (0..pair_count(mics))
                .map(|_| Vec::with_capacity(setup.params.peaks))
                .collect(),
            searcher: Searcher::new(setup.params.tolerance, setup.params.max_nodes),
            solvers: HashMap::new(),
            prune: true,
        }
    }

    /// Stage 1 (independent per frame): live microphones, spectra and `X(k)`, the mean
    /// power spectrum over the live microphones. Mic `m`'s samples are
    /// `frame[m * stride..][..N]`. Returns `false` when none is live.
    pub fn spectra(
        &mut self,
        setup: &Setup,
        (frame, stride): (&[f32], usize),
        state: &mut FrameState,
    ) -> bool {
        let n = setup.n;
        let channel = |m: usize| &frame[m * stride..m * stride + n];
        // Live microphones: a channel stuck at one value carries no delay information.
        state.live.clear();
        for m in 0..setup.geometry.mics.len() {
            let s = channel(m);
            let first = s[0];
            if s.iter().any(|&v| v != first) {
                state.live.push(m);
            }
        }
        if state.live.is_empty() {
            return false;
        }
        // Two channels per complex FFT.
        for two in state.live.chunks(2) {
            match *two {
                [a, b] => {
                    let (low, high) = state.spectra.split_at_mut(b);
                    self.fft
                        .transform_two(channel(a), channel(b), &mut low[a], &mut high[0]);
                }
                [a] => self.fft.transform(channel(a), &mut state.spectra[a]),
                _ => unreachable!("chunks of two"),
            }
        }
        state.power.fill(0.0);
        for &m in &state.live {
            add_power(&state.spectra[m], &mut state.power);
        }
        let inv = 1.0 / state.live.len() as f32;
        state.power.iter_mut().for_each(|p| *p *= inv);
        true
    }

    /// Stage 3 (independent per frame, given the noise estimate of the frames before it):
    /// the weights (eq. 4-5), whitening, the correlation of every live pair (eq. 6), its
    /// M peaks (eq. 7), the search (eq. 8), the direction (eq. 13).
    pub fn localize(
        &mut self,
        setup: &Setup,
        state: &FrameState,
        index: u64,
        times: Option<&mut StageTimes>,
    ) -> Outcome {
        let mut clock = Clock::new(times);
        let (n, mics) = (setup.n, setup.geometry.mics.len());
        let k = state.live.len();
        if k < 2 {
            return Outcome::Unsolved;
        }
        if setup.params.weighting {
            enhanced_weights(
                &state.power,
                &state.noise,
                setup.params.alpha,
                setup.params.gamma,
                &mut self.weights,
            );
        }
        let threshold = setup
            .params
            .min_score
            .unwrap_or(DEFAULT_MIN_SCORE_PER_PAIR * pair_count(k) as f64);
        // A set's score is one peak value per pair, and no peak can exceed the ceiling
        // the weights set: when even that cannot reach the threshold, the frame has no
        // detection whatever the correlations are, and they are not computed. The same
        // test is repeated as pairs are correlated, with their actual best peaks.
        let ceiling = correlation::peak_ceiling(&self.weights, n, setup.params.interpolation);
        let prune = self.prune;
        let skip = |clock: &mut Clock, left: usize, best_possible: f64| {
            let skip = prune && best_possible + left as f64 * ceiling < threshold;
            clock.count(if skip { (0, left) } else { (left.min(2), 0) });
            skip
        };
        if skip(&mut clock, pair_count(k), 0.0) {
            return Outcome::BelowThreshold(false);
        }
        for &m in &state.live {
            correlation::whiten(&state.spectra[m], &self.weights, &mut self.whitened[m]);
        }
        clock.lap(|t| &mut t.weighting);
        // Eq. (6) divided by N (see the `correlation` module on the scale), two pairs per
        // inverse FFT, in the order of `pair_index`.
        let norm = n as f32;
        self.pairs.clear();
        for a in 0..k {
            for b in a + 1..k {
                self.pairs.push((a, b));
            }
        }
        let whitened = &self.whitened;
        let spectra =
            |(a, b): (usize, usize)| (&whitened[state.live[a]][..], &whitened[state.live[b]][..]);
        let mut best_possible = 0.0;
        for (done, two) in self.pairs.chunks(2).enumerate() {
            let left = self.pairs.len() - 2 * done;
            if done > 0 && skip(&mut clock, left, best_possible) {
                return Outcome::BelowThreshold(false);
            }
            self.correlator
                .correlate(spectra(two[0]), two.get(1).map(|&p| spectra(p)), norm);
            clock.lap(|t| &mut t.correlation);
            for (second, &(a, b)) in two.iter().enumerate() {
                let (i, j) = (state.live[a], state.live[b]);
                let half = setup.max_lag[pair_index(i, j, mics)] + 1;
                self.correlator.lags(second == 1, half, &mut self.window);
                let peaks = &mut self.peaks[pair_index(a, b, k)];
                correlation::find_peaks(
                    &self.window,
                    setup.params.peaks,
                    setup.params.interpolation,
                    peaks,
                );
                // A pair without peaks leaves no consistent set (the search says so).
                best_possible += peaks.first().map_or(ceiling, |p| p.value as f64);
            }
            clock.lap(|t| &mut t.peaks);
        }
        // The consistent delay set with the greatest correlation (eq. 8).
        self.searcher.search(k, &self.peaks);
        clock.lap(|t| &mut t.search);
        let budget = self.searcher.exhausted();
        let Some(solution) = self.searcher.solution() else {
            return Outcome::Inconsistent(budget);
        };
        if solution.score < threshold {
            return Outcome::BelowThreshold(budget);
        }
        // Direction (eq. 13) for this set of live microphones.
        let mask = state.live.iter().fold(0u64, |acc, &m| acc | (1u64 << m));
        let solver = self.solvers.entry(mask).or_insert_with(|| {
            DirectionSolver::new(&setup.geometry, mask, setup.rate, setup.speed).ok()
        });
        let Some(u) = solver.as_ref().and_then(|s| s.solve(&solution.lags)) else {
            return Outcome::Unsolved;
        };
        let (azimuth_deg, elevation_deg) = angles_deg(&u);
        let detection = Detection {
            frame: index,
            time_s: (index as f64 * setup.hop as f64 + n as f64 / 2.0) / setup.rate,
            azimuth_deg,
            elevation_deg,
            direction: u,
            score: solution.score,
            mics: k,
        };
        clock.lap(|t| &mut t.direction);
        Outcome::Detected(detection, budget)
    }
}

/// Stage timing inside [`Worker::localize`] (a no-op without a `StageTimes`).
struct Clock<'a> {
    times: Option<&'a mut StageTimes>,
    last: Option<Instant>,
}

impl<'a> Clock<'a> {
    fn new(times: Option<&'a mut StageTimes>) -> Self {
        let last = times.is_some().then(Instant::now);
        Clock { times, last }
    }

    /// Adds the time since the last lap to the stage `pick` selects.
    fn lap(&mut self, pick: fn(&mut StageTimes) -> &mut Duration) {
        if let (Some(t), Some(times)) = (self.last.as_mut(), self.times.as_deref_mut()) {
            let now = Instant::now();
            *pick(times) += now - *t;
            *t = now;
        }
    }

    /// Counts pair correlations computed and skipped.
    fn count(&mut self, (correlated, skipped): (usize, usize)) {
        if let Some(times) = self.times.as_deref_mut() {
            times.correlated_pairs += correlated as u64;
            times.skipped_pairs += skipped as u64;
        }
    }
}

/// The sequential part of the method: the noise estimate, which depends on every
/// previous frame in order, and the run's counters.
pub struct Sequential {
    noise: NoiseEstimator,
    stats: FrameStats,
    /// Frames folded in by `prime` and not yet weighed.
    primed: usize,
}

impl Sequential {
    pub fn new(setup: &Setup) -> Self {
        Sequential {
            noise: NoiseEstimator::new(
                setup.bins(),
                setup.hop as f64 / setup.rate,
                setup.params.noise,
            ),
            stats: FrameStats {
                dead_frames: vec![0; setup.geometry.mics.len()],
                ..Default::default()
            },
            primed: 0,
        }
    }

    /// Folds a frame (after stage 1) into the noise estimate only; primed frames must be
    /// weighed next, in order, and are not folded in twice.
    pub fn prime(&mut self, state: &FrameState, live: bool) {
        if live {
            self.noise.update(&state.power);
        }
        self.primed += 1;
    }

    /// Stage 2 (in frame order): the frame keeps the noise estimate of the frames before
    /// it (for its weights, eq. 4-5, in stage 3), then the estimate is updated with its
    /// `X(k)`. Returns `false` for a silent frame.
    pub fn weigh(&mut self, setup: &Setup, state: &mut FrameState, live: bool) -> bool {
        self.stats.frames += 1;
        let primed = self.primed > 0;
        self.primed = self.primed.saturating_sub(1);
        if !live {
            self.stats.silent_frames += 1;
            return false;
        }
        for m in 0..setup.geometry.mics.len() {
            if !state.live.contains(&m) {
                self.stats.dead_frames[m] += 1;
            }
        }
        if !self.noise.started() {
            self.noise.start(&state.power);
        }
        if setup.params.weighting {
            state.noise.copy_from_slice(self.noise.noise());
        }
        if !primed {
            self.noise.update(&state.power);
        }
        true
    }

    /// Counts a frame's outcome (in frame order) and returns its detection.
    pub fn tally(&mut self, outcome: Outcome) -> Option<Detection> {
        let budget = match outcome {
            Outcome::Inconsistent(b) => {
                self.stats.inconsistent_frames += 1;
                b
            }
            Outcome::BelowThreshold(b) => {
                self.stats.below_threshold_frames += 1;
                b
            }
            Outcome::Detected(_, b) => {
                self.stats.detections += 1;
                b
            }
            Outcome::Silent | Outcome::Unsolved => false,
        };
        if budget {
            self.stats.budget_frames += 1;
        }
        match outcome {
            Outcome::Detected(d, _) => Some(d),
            _ => None,
        }
    }

    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }
}

/// The whole method for one frame at a time, on one thread: stage 1, stage 2, stage 3.
/// (`FileAnalysis` runs the same stages over blocks of frames on several threads.)
pub struct Analyzer {
    setup: Setup,
    worker: Worker,
    sequential: Sequential,
    state: FrameState,
    timing: bool,
    times: StageTimes,
}

impl Analyzer {
    pub fn new(geometry: &Geometry, sample_rate: u32, params: &Params) -> Result<Self> {
        let setup = Setup::new(geometry, sample_rate, params)?;
        Ok(Analyzer {
            worker: Worker::new(&setup),
            sequential: Sequential::new(&setup),
            state: FrameState::new(&setup),
            setup,
            timing: false,
            times: StageTimes::default(),
        })
    }

    /// The shared setup, the sequential state and the stage times (when enabled), for
    /// running the stages over blocks of frames on several threads.
    pub fn parts(&mut self) -> (&Setup, &mut Sequential, Option<&mut StageTimes>) {
        (
            &self.setup,
            &mut self.sequential,
            self.timing.then_some(&mut self.times),
        )
    }

    pub fn frame_size(&self) -> usize {
        self.setup.n
    }

    pub fn hop(&self) -> usize {
        self.setup.hop
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
        self.sequential.stats()
    }

    /// Analyses frame `index`; `frame[m * N .. (m + 1) * N]` holds mic `m`'s samples.
    pub fn process(&mut self, index: u64, frame: &[f32]) -> Option<Detection> {
        let start = self.timing.then(Instant::now);
        let n = self.setup.n;
        let live = self
            .worker
            .spectra(&self.setup, (frame, n), &mut self.state);
        let mid = self.timing.then(Instant::now);
        let live = self.sequential.weigh(&self.setup, &mut self.state, live);
        if let (Some(a), Some(b)) = (start, mid) {
            self.times.spectra += b - a;
            self.times.weighting += b.elapsed();
        }
        let outcome = if live {
            let times = self.timing.then_some(&mut self.times);
            self.worker.localize(&self.setup, &self.state, index, times)
        } else {
            Outcome::Silent
        };
        self.sequential.tally(outcome)
    }
}

/// `power(k) += |x(k)|^2`.
#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+popcnt"))]
fn add_power(x: &[Complex32], power: &mut [f32]) {
    for (p, x) in power.iter_mut().zip(x) {
        *p += x.norm_sqr();
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
    use crate::direction::unit_from_angles;
    use crate::geometry::PAPER_PRISM;
    use crate::synth::{render, Place, Scene, Signal, Source};

    /// Leaving out the correlations that the weights' ceiling rules out changes no
    /// frame's detection: a scene whose sources sit below, near and above the threshold
    /// (a fan throughout, speech-like and noise sources at -12 to +6 dB against it),
    /// analysed with and without pruning, with and without sub-sample refinement.
    #[test]
    fn pruning_changes_no_detection() {
        let source = |i: usize, signal, level| Source {
            place: Place::Direction(unit_from_angles(-120.0 + 70.0 * i as f64, 10.0)),
            signal,
            start_s: 0.5 + 0.8 * i as f64,
            end_s: 1.1 + 0.8 * i as f64,
            level,
        };
        let mut sources = vec![
            source(0, Signal::WhiteNoise, 0.005),
            source(1, Signal::SpeechLike, 0.01),
            source(2, Signal::WhiteNoise, 0.02),
            source(3, Signal::SpeechLike, 0.04),
        ];
        sources.push(Source {
            place: Place::Direction(unit_from_angles(80.0, 40.0)),
            signal: Signal::PinkNoise,
            start_s: 0.0,
            end_s: 4.0,
            level: 0.02,
        });
        let channels = render(&Scene {
            sample_rate: 48000,
            duration_s: 4.0,
            mics: PAPER_PRISM.iter().map(|p| Vector3::from(*p)).collect(),
            speed_of_sound: 343.0,
            sources,
            sensor_noise: 0.001,
            seed: 3,
        });
        let g = Geometry::from_positions(&PAPER_PRISM).unwrap();
        for interpolation in [Interpolation::Parabolic, Interpolation::None] {
            let params = Params {
                interpolation,
                ..Params::default()
            };
            let mut pruned = Analyzer::new(&g, 48000, &params).unwrap();
            let mut full = Analyzer::new(&g, 48000, &params).unwrap();
            full.worker.prune = false;
            pruned.enable_stage_timing();
            full.enable_stage_timing();
            let (n, hop) = (pruned.frame_size(), pruned.hop());
            let mut frame = vec![0.0f32; 8 * n];
            let mut detections = 0;
            let mut index = 0;
            while index * hop + n <= channels[0].len() {
                for (m, ch) in channels.iter().enumerate() {
                    frame[m * n..(m + 1) * n].copy_from_slice(&ch[index * hop..index * hop + n]);
                }
                let want = full.process(index as u64, &frame);
                assert_eq!(pruned.process(index as u64, &frame), want, "frame {index}");
                detections += want.is_some() as usize;
                index += 1;
            }
            let (p, f) = (pruned.stage_times(), full.stage_times());
            eprintln!(
                "{interpolation:?}: {detections} of {index} frames, {} of {} pairs skipped",
                p.skipped_pairs, f.correlated_pairs
            );
            assert_eq!(f.skipped_pairs, 0);
            assert_eq!(p.correlated_pairs + p.skipped_pairs, f.correlated_pairs);
            // Both outcomes occur, and pruning does real work.
            assert!(
                detections > 30 && detections < index - 30,
                "{detections} of {index}"
            );
            assert!(
                p.skipped_pairs * 5 > f.correlated_pairs,
                "{} of {} skipped",
                p.skipped_pairs,
                f.correlated_pairs
            );
        }
    }

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
