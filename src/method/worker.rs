//! One frame through the stages, in the paper's order, with buffers planned once per
//! thread: spectra (eq. 2), weights (eq. 4-5), the weighted PHAT correlation of every
//! pair (eq. 6), its M peaks (eq. 7), the consistency search (eq. 8), the direction
//! (eq. 13). The noise estimate `X_n(k)` that the weights need depends on every earlier
//! frame, so [`Analyzer`](super::Analyzer) computes it in frame order between
//! [`Worker::spectra`] and [`Worker::localize`].

use super::correlation::{peak_ceiling, whiten, Correlator};
use super::direction::{angles_deg, DirectionSolver};
use super::outcome::{Clock, Detection, Outcome, StageTimes};
use super::pairs::{pair_count, pair_index};
use super::params::Setup;
use super::peaks::{find_peaks, Peak};
use super::search::{Searcher, Solution};
use super::spectrum::{frame_spectra, ForwardFft};
use super::weighting::enhanced_weights;
use realfft::num_complex::Complex32;
use std::collections::HashMap;

/// One frame between the stages: its live microphones, spectra, `X(k)`, and the noise
/// estimate `X_n(k)` of the frames before it.
pub(crate) struct FrameState {
    pub live: Vec<usize>,
    spectra: Vec<Vec<Complex32>>,
    pub power: Vec<f32>,
    pub noise: Vec<f32>,
}

impl FrameState {
    pub fn new(setup: &Setup) -> Self {
        let mics = setup.mics();
        FrameState {
            live: Vec::with_capacity(mics),
            spectra: vec![vec![Complex32::default(); setup.bins()]; mics],
            power: vec![0.0; setup.bins()],
            noise: vec![0.0; setup.bins()],
        }
    }
}

/// Per-thread plans and buffers for the stages that are independent per frame.
pub(crate) struct Worker {
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
    pub prune: bool,
}

impl Worker {
    pub fn new(setup: &Setup) -> Self {
        let mics = setup.mics();
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

    /// The first stage: live microphones, spectra and `X(k)`. Mic `m`'s samples are
    /// `frame[m * stride..][..N]`. Returns `false` when no microphone is live.
    pub fn spectra(
        &mut self,
        setup: &Setup,
        frame: (&[f32], usize),
        state: &mut FrameState,
    ) -> bool {
        frame_spectra(
            &mut self.fft,
            frame,
            setup.n,
            &mut state.live,
            &mut state.spectra,
            &mut state.power,
        );
        !state.live.is_empty()
    }

    /// The stages after the noise estimate: weights (eq. 4-5), whitening, correlations
    /// (eq. 6), peaks (eq. 7), search (eq. 8), direction (eq. 13).
    ///
    /// A set's score is one peak value per pair, and no peak can exceed the ceiling the
    /// weights set: when even that cannot reach the threshold, the frame has no detection
    /// whatever the correlations are, and they are not computed. The same test is
    /// repeated as pairs are correlated, with their actual best peaks.
    pub fn localize(
        &mut self,
        setup: &Setup,
        state: &FrameState,
        index: u64,
        times: Option<&mut StageTimes>,
    ) -> Outcome {
        let mut clock = Clock::new(times);
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
        let threshold = setup.params.min_score_per_pair * pair_count(k) as f64;
        let ceiling = peak_ceiling(&self.weights, setup.n, setup.params.interpolation);
        let cut = Cut {
            prune: self.prune,
            threshold,
            ceiling,
        };
        let pairs = pair_count(k) as f64;
        if cut.skip(&mut clock, pair_count(k), 0.0) {
            return Outcome::BelowThreshold(false, ceiling, false);
        }
        for &m in &state.live {
            whiten(&state.spectra[m], &self.weights, &mut self.whitened[m]);
        }
        clock.lap(|t| &mut t.weighting);
        if let Err(bound) = self.correlate_pairs(setup, state, &cut, &mut clock) {
            return Outcome::BelowThreshold(false, bound / pairs, false);
        }
        self.searcher.search(k, &self.peaks);
        clock.lap(|t| &mut t.search);
        let budget = self.searcher.exhausted();
        let Some(solution) = self.searcher.solution() else {
            return Outcome::Inconsistent(budget);
        };
        if solution.score < threshold {
            return Outcome::BelowThreshold(budget, solution.score / pairs, true);
        }
        let outcome = match direction(&mut self.solvers, setup, state, index, solution) {
            Direction::Found(detection) => Outcome::Detected(detection, budget),
            // A set no single source explains is no more consistent than none.
            Direction::Gated => Outcome::Inconsistent(budget),
            Direction::None => Outcome::Unsolved,
        };
        clock.lap(|t| &mut t.direction);
        outcome
    }

    /// Eq. (6) divided by N (see [`correlation`](super::correlation) on the scale) for
    /// every live pair, two pairs per inverse FFT in the order of [`pair_index`], and the
    /// M peaks of each (eq. 7). Stops as soon as the frame is shown unable to reach the
    /// threshold, with the most it could still have scored.
    fn correlate_pairs(
        &mut self,
        setup: &Setup,
        state: &FrameState,
        cut: &Cut,
        clock: &mut Clock,
    ) -> Result<(), f64> {
        let (k, mics) = (state.live.len(), setup.mics());
        let norm = setup.n as f32;
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
            if done > 0 && cut.skip(clock, left, best_possible) {
                return Err(best_possible + left as f64 * cut.ceiling);
            }
            self.correlator
                .correlate(spectra(two[0]), two.get(1).map(|&p| spectra(p)), norm);
            clock.lap(|t| &mut t.correlation);
            for (second, &(a, b)) in two.iter().enumerate() {
                let (i, j) = (state.live[a], state.live[b]);
                let half = setup.max_lag[pair_index(i, j, mics)] + 1;
                self.correlator.lags(second == 1, half, &mut self.window);
                let peaks = &mut self.peaks[pair_index(a, b, k)];
                find_peaks(
                    &self.window,
                    setup.params.peaks,
                    setup.params.interpolation,
                    peaks,
                );
                // A pair without peaks leaves no consistent set (the search says so).
                best_possible += peaks.first().map_or(cut.ceiling, |p| p.value as f64);
            }
            clock.lap(|t| &mut t.peaks);
        }
        Ok(())
    }
}

/// When a frame can be decided without the rest of its correlations.
struct Cut {
    prune: bool,
    threshold: f64,
    /// The most any pair's peak can add (from the weights).
    ceiling: f64,
}

impl Cut {
    /// Whether `left` pairs still to correlate, each adding at most the ceiling to
    /// `best_possible`, cannot reach the threshold; counts the pairs skipped or about to
    /// be correlated.
    fn skip(&self, clock: &mut Clock, left: usize, best_possible: f64) -> bool {
        let skip = self.prune && best_possible + left as f64 * self.ceiling < self.threshold;
        clock.count(if skip { (0, left) } else { (left.min(2), 0) });
        skip
    }
}

/// The direction of eq. (13) for the frame's set of live microphones (the solver is
/// made once per set), as a detection.
/// What the direction stage makes of a consistent set.
enum Direction {
    Found(Detection),
    /// No single source explains the delays (the residual gate).
    Gated,
    /// The system gives no direction.
    None,
}

fn direction(
    solvers: &mut HashMap<u64, Option<DirectionSolver>>,
    setup: &Setup,
    state: &FrameState,
    index: u64,
    solution: &Solution,
) -> Direction {
    let mask = state.live.iter().fold(0u64, |acc, &m| acc | (1u64 << m));
    let solver = solvers
        .entry(mask)
        .or_insert_with(|| DirectionSolver::new(&setup.geometry, mask, setup.rate, setup.speed));
    let Some(u) = solver.as_ref().and_then(|s| s.solve(&solution.lags)) else {
        return Direction::None;
    };
    if let (Some(gate), Some(solver)) = (setup.params.residual_gate_us, solver.as_ref()) {
        if solver.residual_m(&solution.lags, &u) / setup.speed * 1e6 > gate {
            return Direction::Gated;
        }
    }
    let (azimuth_deg, elevation_deg) = angles_deg(&u);
    Direction::Found(Detection {
        frame: index,
        time_s: (index as f64 * setup.hop as f64 + setup.n as f64 / 2.0) / setup.rate,
        azimuth_deg,
        elevation_deg,
        direction: u,
        score: solution.score,
        mics: state.live.len(),
    })
}
