//! One frame through the stages, in the paper's order, with buffers planned once per
//! thread: spectra (eq. 2), weights (eq. 4-5), the weighted PHAT correlation of every
//! pair (eq. 6), its M peaks (eq. 7), the consistency search (eq. 8), the direction
//! (eq. 13). The noise estimate `X_n(k)` that the weights need depends on every earlier
//! frame, so [`Engine`](crate::method::Engine) computes it in frame order between
//! [`Worker::spectra`] and [`Worker::weigh`]; a frame's correlations may be averaged
//! with those of the frames before it, so [`Worker::correlate`] keeps them in the frame's
//! state for [`Worker::decide`].

use super::setup::Setup;
use crate::method::beyond::dereverb::Dereverberator;
use crate::method::beyond::edges::Edges;
use crate::method::beyond::frame_sources::add_further;
use crate::method::beyond::steered::{Query, Steered, Steering, FURTHER_SHARE};
use crate::method::beyond::votes::{add_riders, VotePeak};
use crate::method::detect::{detection, direction, solver, Direction};
use crate::method::outcome::{Clock, Detections, Outcome, StageTimes};
use crate::method::paper::correlation::{peak_ceiling, whiten, window_max, Correlator};
use crate::method::paper::direction::DirectionSolver;
use crate::method::paper::pairs::{pair_count, pair_index};
use crate::method::paper::peaks::{find_peaks, Peak};
use crate::method::paper::search::Searcher;
use crate::method::paper::spectrum::{frame_spectra, ForwardFft};
use crate::method::paper::weighting::enhanced_weights;
use crate::method::state::Vote;
use crate::method::state::{span_ceiling, Correlated, FrameState};
use crate::method::uncertainty::uncertainty_deg;
use realfft::num_complex::Complex32;
use std::collections::HashMap;

/// Per-thread plans and buffers for the stages that are independent per frame.
pub(crate) struct Worker {
    fft: ForwardFft,
    correlator: Correlator,
    /// One pair's correlation at the lags it searches (and their two neighbours).
    window: Vec<f32>,
    whitened: Vec<Vec<Complex32>>,
    peaks: Vec<Vec<Peak>>,
    searcher: Searcher,
    solvers: HashMap<u64, Option<DirectionSolver>>,
    /// Every pair's averaged correlation, laid out as [`FrameState`]'s `windows` (kept
    /// only for the steered response).
    averaged: Vec<f32>,
    /// The steered response's grid and buffers, when it is on (a megabyte at 32
    /// microphones, per thread).
    steered: Option<Steered>,
    /// The directions found in a frame so far.
    directions: Vec<nalgebra::Vector3<f64>>,
    /// The diffuse part removed from the cross-spectra ([`crate::method::beyond::dereverb`]), when on.
    dereverb: Option<Dereverberator>,
    /// The votes of a span and their peaks ([`crate::method::beyond::votes`]).
    votes: Vec<Vote>,
    vote_peaks: Vec<VotePeak>,
    /// Whether the last search's first source came from the steered response (its pairs
    /// did not all agree) rather than from a consistent set.
    steered_first: bool,
    /// Leave out correlations that cannot lead to a detection (always, but in a test).
    pub prune: bool,
}

impl Worker {
    pub fn new(setup: &Setup) -> Self {
        let mics = setup.mics();
        Worker {
            fft: ForwardFft::new(setup.n, setup.params.framing.window),
            correlator: Correlator::new(setup.n),
            window: Vec::with_capacity(setup.n),
            whitened: vec![vec![Complex32::default(); setup.bins()]; mics],
            peaks: (0..pair_count(mics))
                .map(|_| Vec::with_capacity(setup.params.peaks.count))
                .collect(),
            searcher: Searcher::new(setup.tolerance, setup.params.max_work),
            solvers: HashMap::new(),
            averaged: if setup.params.steered.is_on() {
                vec![0.0; setup.windows_len]
            } else {
                Vec::new()
            },
            directions: Vec::with_capacity(crate::method::beyond::MAX_SOURCES),
            steered: setup.params.steered.is_on().then(|| {
                let positions: Vec<_> = setup.geometry.mics.iter().map(|m| m.position).collect();
                Steered::new(&positions, setup.rate, setup.speed, &setup.max_lag)
            }),
            dereverb: setup.dereverb.is_some().then(|| Dereverberator::new(setup)),
            votes: Vec::new(),
            vote_peaks: Vec::new(),
            steered_first: false,
            prune: true,
        }
    }

    /// The correlations of the last frame of `span` with the diffuse part of every
    /// pair's cross-spectrum removed ([`crate::method::beyond::dereverb`]; `live` says which frames of
    /// `span` are), into `out`, laid out as a frame's windows; returns the most any of
    /// its values can be (see [`FrameState::reach`]).
    pub fn correlate_dereverbed(
        &mut self,
        setup: &Setup,
        span: &[FrameState],
        live: &[bool],
        out: &mut [f32],
        times: Option<&mut StageTimes>,
    ) -> (f64, Edges) {
        let mut clock = Clock::new(times);
        let k = span.last().map_or(0, |s| s.live.len());
        clock.count((pair_count(k), 0));
        let dereverb = self.dereverb.as_mut().expect("dereverberation planned");
        let coherence = setup.dereverb.as_ref().expect("dereverberation planned");
        let mut edges = Edges::default();
        let reach = dereverb.correlate(
            setup,
            coherence,
            span,
            live,
            &mut self.correlator,
            out,
            &mut edges,
        );
        clock.charge(|t| &mut t.correlation);
        (reach, edges)
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
        state.mask = state.live.iter().fold(0u64, |acc, &m| acc | (1u64 << m));
        !state.live.is_empty()
    }

    /// After the noise estimate: the weights of eq. (4)-(5), and from them the ceiling
    /// no correlation value of the frame can exceed and the frame's threshold.
    pub fn weigh(setup: &Setup, state: &mut FrameState) {
        if setup.params.weighting.on {
            enhanced_weights(
                &state.power,
                &state.noise,
                setup.params.weighting.alpha as f32,
                setup.params.weighting.gamma as f32,
                &mut state.weights,
            );
        }
        let (first, last) = setup.band;
        if (first, last) != (0, setup.n / 2) {
            // Outside `--band`, nothing: eq. (6) sums the band's bins alone.
            state.weights[..first].fill(0.0);
            state.weights[last + 1..].fill(0.0);
        }
        state.ceiling = peak_ceiling(&state.weights, setup.n, setup.params.peaks.refinement());
        state.reach = state.ceiling;
        state.threshold = setup.threshold.per_pair(&state.weights);
        state.clear = setup.threshold.clear_per_pair(&state.weights);
        // Every frame's direction: nothing is held back; the threshold only says which
        // rows the run vouches for (their cones).
        let every_frame = setup.params.steered == Steering::EveryFrame;
        state.floor = if every_frame {
            0.0
        } else {
            state.threshold * setup.params.talkers.candidate_share()
        };
        // Riders only beside candidates (with a tracker): without one, nothing to ride.
        let riders = if setup.params.talkers.candidate_share() < 1.0 {
            setup
                .params
                .talkers
                .rider_share()
                .min(setup.params.talkers.candidate_share())
        } else {
            setup.params.talkers.candidate_share()
        };
        state.rider_floor = if every_frame {
            0.0
        } else {
            state.threshold * riders
        };
        state.steady = !every_frame
            && setup.params.threshold.is_calibrated()
            && setup.params.weighting.on
            && state.ceiling <= setup.threshold.steady_ceiling;
        if let Some(votes) = &setup.votes {
            let mut out = std::mem::take(&mut state.votes);
            votes.collect(state, setup.rate, setup.n, setup.speed, &mut out);
            state.votes = out;
        }
    }

    /// Whitening and the correlation of every live pair (eq. 6 divided by N, see
    /// [`correlation`](crate::method::paper::correlation) on the scale), two pairs per inverse FFT in
    /// the order of [`pair_index`], kept in the frame's state. `skip` leaves them out.
    ///
    /// When frames are not averaged, a frame whose correlated pairs show it cannot reach
    /// the threshold stops there: a pair's refined peaks are at most `5/4` of its largest
    /// value (a parabola through three samples overshoots the middle one by at most a
    /// quarter of the larger neighbour), and the pairs still to do add at most the ceiling.
    pub fn correlate(
        &mut self,
        setup: &Setup,
        state: &mut FrameState,
        skip: bool,
        times: Option<&mut StageTimes>,
    ) {
        let mut clock = Clock::new(times);
        let (k, mics) = (state.live.len(), setup.mics());
        let pairs = pair_count(k);
        if skip {
            clock.count((0, pairs));
            state.correlated = Correlated::Skipped;
            return;
        }
        for &m in &state.live {
            whiten(&state.spectra[m], &state.weights, &mut self.whitened[m]);
        }
        clock.charge(|t| &mut t.weighting);
        let alone = setup.params.room.average_frames == 1 && self.prune && !state.teaches;
        let threshold = state.floor.min(state.rider_floor) * pairs as f64;
        let overshoot = setup.params.peaks.refinement().overshoot() as f32;
        let norm = setup.n as f32;
        let whitened = &self.whitened;
        let live = &state.live;
        let spectra = |(a, b): (usize, usize)| (&whitened[live[a]][..], &whitened[live[b]][..]);
        let mut list = (0..k).flat_map(|a| (a + 1..k).map(move |b| (a, b)));
        let mut best_possible = 0.0;
        let mut done = 0;
        let mut edges = Edges::default();
        while let Some(first) = list.next() {
            let second = list.next();
            if alone
                && done > 0
                && best_possible + (pairs - done) as f64 * state.ceiling < threshold
            {
                clock.count((0, pairs - done));
                state.correlated =
                    Correlated::Stopped(best_possible + (pairs - done) as f64 * state.ceiling);
                state.edges = Edges::default();
                return;
            }
            clock.count((if second.is_some() { 2 } else { 1 }, 0));
            self.correlator
                .correlate(spectra(first), second.map(spectra), norm);
            for (which, (a, b)) in [Some(first), second].into_iter().flatten().enumerate() {
                let pair = pair_index(live[a], live[b], mics);
                let half = setup.max_lag[pair] + 1;
                let start = setup.window_starts[pair];
                let window = &mut state.windows[start..start + 2 * half + 1];
                self.correlator.lags_into(which == 1, window);
                let top = window_max(window, f32::NEG_INFINITY);
                let beyond = self.correlator.beyond_max(which == 1, half, 2 * half + 2);
                edges.add(top, beyond, state.clear);
                best_possible += (top.max(0.0) * overshoot) as f64;
                done += 1;
            }
        }
        clock.charge(|t| &mut t.correlation);
        state.correlated = Correlated::Yes;
        state.edges = edges;
    }

    /// The stages after the correlations for the last frame of `span` (the frame and the
    /// ones before it, [`Room::average_frames`](crate::method::Room::average_frames) in all):
    /// each pair's correlation averaged over the live frames of `span`, its M peaks (eq.
    /// 7), the search (eq. 8), the direction (eq. 13). When the average gives no
    /// detection, the frame's own correlations are tried: averaging steadies the delays
    /// of a sustained source in a reverberant room, but dilutes a click to a fraction of
    /// its frame's score. When the average gives a source and
    /// [`Params::frame_sources`](crate::method::Params::frame_sources) is on, the frame's own
    /// correlations are searched too, for further sources ([`crate::method::beyond::frame_sources`]).
    ///
    /// A frame whose own weights cannot reach the threshold (its ceiling times its pairs)
    /// has no detection, averaged or not: otherwise the average carries a source past
    /// its end into the frames after it. A set's score is one peak value per pair, and no
    /// value of an average exceeds the mean of its frames' ceilings: when even that cannot
    /// reach the threshold, the average is not searched.
    ///
    /// Beside a frame's detection, on a small array, the peaks of its bins' directions
    /// add riders ([`crate::method::beyond::votes`]).
    pub fn decide(
        &mut self,
        setup: &Setup,
        span: &[FrameState],
        index: u64,
        times: Option<&mut StageTimes>,
    ) -> Outcome {
        let outcome = self.decide_frame(setup, span, index, times);
        // Riders from the bins' votes beside what the frame gave (`crate::method::beyond::votes`).
        match (&setup.votes, outcome) {
            (Some(votes), Outcome::Detected(mut found, budget)) => {
                let state = span.last().expect("a frame");
                if let Some(solver) = solver(&mut self.solvers, setup, state) {
                    let scratch = (&mut self.votes, &mut self.vote_peaks);
                    add_riders(setup, solver, votes, span, index, &mut found, scratch);
                }
                Outcome::Detected(found, budget)
            }
            (_, outcome) => outcome,
        }
    }

    fn decide_frame(
        &mut self,
        setup: &Setup,
        span: &[FrameState],
        index: u64,
        times: Option<&mut StageTimes>,
    ) -> Outcome {
        let mut clock = Clock::new(times);
        let state = span.last().expect("a frame");
        if state.live.len() < 2 {
            return Outcome::Unsolved;
        }
        let outcome = self.decide_with_floor(setup, span, index, &mut clock, state.floor);
        // A frame that gives nothing down to the candidates' share is searched again down
        // to the riders' ([`Talkers::riders`](crate::method::Talkers::riders)): what the frames
        // that gave something give is left as it was.
        if matches!(outcome, Outcome::Detected(..)) || state.rider_floor >= state.floor {
            return outcome;
        }
        // From the frame's own correlations only: the averaged ones searched again too
        // found the same windows of the tracking benchmark for 4% more time.
        let own = &span[span.len() - 1..];
        if state.correlated != Correlated::Yes || state.ceiling < state.rider_floor || state.steady
        {
            return outcome;
        }
        match self.decide_over(setup, own, index, &mut clock, state.rider_floor) {
            Outcome::Detected(riders, budget) => Outcome::Detected(riders.riders(), budget),
            _ => outcome,
        }
    }

    /// [`Worker::decide`] with candidates down to `floor` per pair.
    fn decide_with_floor(
        &mut self,
        setup: &Setup,
        span: &[FrameState],
        index: u64,
        clock: &mut Clock,
        floor: f64,
    ) -> Outcome {
        let state = span.last().expect("a frame");
        let k = state.live.len();
        let pairs = pair_count(k) as f64;
        let threshold = floor * pairs;
        // A frame that could not reach the threshold alone, or (calibrated) has nothing
        // above the noise estimate, has no detection: the average would only carry the
        // frames before it past their end.
        let own = state.ceiling * pairs;
        if own < threshold || state.steady {
            return Outcome::BelowThreshold(false, own / pairs, false);
        }
        let bound = span_ceiling(span) * pairs;
        let averaged = if self.prune && bound < threshold {
            Outcome::BelowThreshold(false, bound / pairs, false)
        } else {
            match self.decide_over(setup, span, index, clock, floor) {
                Outcome::Detected(found, budget) => {
                    let span_s = (span.len() - 1) as f64 * setup.hop as f64 / setup.rate;
                    Outcome::Detected(found.spanning(span_s), budget)
                }
                other => other,
            }
        };
        if span.len() == 1 || state.correlated != Correlated::Yes {
            return averaged;
        }
        if let Outcome::Detected(mut found, budget) = averaged {
            // Every frame's direction: where the average's pairs did not agree (its
            // direction is the steered response's), a set the frame's own pairs agree on
            // is the better evidence (an average over an onset spans the silence before
            // it). Under a threshold the average's own direction stands, as before.
            if self.steered_first && setup.params.steered == Steering::EveryFrame {
                // The consistency search alone: without the steered response its grid
                // search, whose answer would be dropped, is not made.
                let own = &span[span.len() - 1..];
                let steered = self.steered.take();
                let consistent = self.decide_over(setup, own, index, clock, floor);
                self.steered = steered;
                if matches!(consistent, Outcome::Detected(..)) {
                    return consistent;
                }
            }
            // Further sources from the frame's own correlations ([`crate::method::beyond::frame_sources`]).
            let wanted = setup.params.talkers.max_sources;
            if setup.params.frame_sources && found.len() < wanted {
                let own = &span[span.len() - 1..];
                if let Outcome::Detected(more, _) =
                    self.decide_over(setup, own, index, clock, floor)
                {
                    add_further(&mut found, &more, wanted);
                }
            }
            return Outcome::Detected(found, budget);
        }
        match self.decide_over(setup, &span[span.len() - 1..], index, clock, floor) {
            own @ Outcome::Detected(..) => own,
            _ => averaged,
        }
    }

    /// [`Worker::decide`] on the average over `span`, down to `floor` per pair.
    fn decide_over(
        &mut self,
        setup: &Setup,
        span: &[FrameState],
        index: u64,
        clock: &mut Clock,
        floor: f64,
    ) -> Outcome {
        self.steered_first = false;
        let state = span.last().expect("a frame");
        let k = state.live.len();
        let pairs = pair_count(k) as f64;
        let threshold = floor * pairs;
        if let Correlated::Stopped(bound) = state.correlated {
            return Outcome::BelowThreshold(false, bound / pairs, false);
        }
        let mics = setup.mics();
        let frames = span.iter().filter(|f| !f.live.is_empty()).count() as f32;
        let ceiling = span_ceiling(span);
        let mut best_possible = 0.0;
        let mut left = pair_count(k);
        for a in 0..k {
            for b in a + 1..k {
                // The pairs left add at most the ceiling each.
                if self.prune && best_possible + left as f64 * ceiling < threshold {
                    clock.charge(|t| &mut t.peaks);
                    return Outcome::BelowThreshold(
                        false,
                        (best_possible + left as f64 * ceiling) / pairs,
                        false,
                    );
                }
                left -= 1;
                let (i, j) = (state.live[a], state.live[b]);
                let pair = pair_index(i, j, mics);
                let half = setup.max_lag[pair] + 1;
                let start = setup.window_starts[pair];
                let both = (1u64 << i) | (1u64 << j);
                self.window.clear();
                self.window.resize(2 * half + 1, 0.0);
                for f in span {
                    if f.correlated == Correlated::Yes && f.mask & both == both {
                        let w = &f.windows[start..start + 2 * half + 1];
                        self.window.iter_mut().zip(w).for_each(|(s, v)| *s += v);
                    }
                }
                if frames > 1.0 {
                    self.window.iter_mut().for_each(|s| *s /= frames);
                }
                if setup.params.steered.is_on() {
                    self.averaged[start..start + 2 * half + 1].copy_from_slice(&self.window);
                }
                let peaks = &mut self.peaks[pair_index(a, b, k)];
                find_peaks(
                    &self.window,
                    setup.params.peaks.count,
                    setup.params.peaks.refinement(),
                    peaks,
                );
                // A pair without peaks leaves no consistent set (the search says so).
                best_possible += peaks.first().map_or(0.0, |p| p.value as f64);
            }
        }
        clock.charge(|t| &mut t.peaks);
        if self.prune && best_possible < threshold {
            return Outcome::BelowThreshold(false, best_possible / pairs, false);
        }
        self.searcher.search(k, &self.peaks);
        clock.charge(|t| &mut t.search);
        let budget = self.searcher.exhausted();
        let first = match self.searcher.solution() {
            None => Outcome::Inconsistent(budget),
            Some(solution) if solution.score < threshold => {
                Outcome::BelowThreshold(budget, solution.score / pairs, true)
            }
            Some(solution) => match direction(&mut self.solvers, setup, state, index, solution) {
                Direction::Found(detection) => {
                    Outcome::Detected(Detections::one(detection), budget)
                }
                // A set no single source explains is no more consistent than none.
                Direction::Gated => Outcome::Inconsistent(budget),
                Direction::None => Outcome::Unsolved,
            },
        };
        clock.charge(|t| &mut t.direction);
        let outcome = self.steer(setup, state, index, threshold, first);
        clock.charge(|t| &mut t.steered);
        outcome
    }

    /// The steered response ([`crate::method::beyond::steered`]): a direction when the consistency
    /// search found none, and further sources after the first, up to
    /// [`Talkers::max_sources`](crate::method::Talkers::max_sources).
    fn steer(
        &mut self,
        setup: &Setup,
        state: &FrameState,
        index: u64,
        threshold: f64,
        first: Outcome,
    ) -> Outcome {
        let Some(steered) = self.steered.as_mut() else {
            return first;
        };
        let (mut found, budget) = match first {
            Outcome::Detected(found, budget) => (found, budget),
            _ => (Detections::default(), false),
        };
        let wanted = setup.params.talkers.max_sources;
        if found.len() >= wanted {
            return first;
        }
        let Some(solver) = solver(&mut self.solvers, setup, state) else {
            return first;
        };
        let mut directions = std::mem::take(&mut self.directions);
        directions.clear();
        directions.extend(found.as_slice().iter().map(|d| d.direction));
        let k = state.live.len();
        let strong = state.threshold * pair_count(k) as f64;
        while found.len() < wanted {
            // A further source must pass the detection threshold itself (below it, the
            // directions found were mostly the first source's reflections) and
            // [`FURTHER_SHARE`] of the first's score (below that, its side lobes).
            let floor = match found.as_slice().first() {
                None => threshold,
                Some(first) => strong.max(FURTHER_SHARE * first.score),
            };
            let Some(steer) = steered.search(
                &mut self.averaged,
                &Query {
                    live: &state.live,
                    mics: setup.mics(),
                    found: &directions,
                    tolerance: setup.steer_tolerance,
                    floor,
                },
                solver,
            ) else {
                break;
            };
            let accepted = steered.accepts(&steer, floor, pair_count(k), setup.gate(), solver);
            // Every frame's direction: the response's peak even where fewer than half the
            // pairs agree or no plane wave fits (its cone widens with its margin).
            let every_frame = setup.params.steered == Steering::EveryFrame && found.is_empty();
            let Some(residual) =
                accepted.or_else(|| every_frame.then(|| steered.residual_m(&steer, solver)))
            else {
                break;
            };
            let u = steer.direction;
            let uncertainty = uncertainty_deg(solver, &u, Some(residual), setup.speed);
            found.push(detection(setup, state, index, u, steer.score, uncertainty));
            directions.push(u);
        }
        self.directions = directions;
        if found.is_empty() {
            first
        } else {
            self.steered_first = !matches!(first, Outcome::Detected(..));
            Outcome::Detected(found, budget)
        }
    }
}
