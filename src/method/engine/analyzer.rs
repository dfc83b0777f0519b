//! The whole method over a recording's frames: the one way through the stages for every
//! entry point ([`Analysis`](crate::localize::Analysis) drives it for files, readers and
//! channels in memory, on one thread or several).
//!
//! Frames are analysed in blocks of [`BLOCK`] on the threads of the current rayon pool:
//! spectra in parallel; the noise estimate `X_n(k)`, which depends on every previous frame,
//! in frame order, exactly as one thread would; then weights and correlations in
//! parallel; the coherent background subtracted from them, in frame order; then peaks,
//! search and direction in parallel; then the outcomes in frame order. The output is the same for
//! any number of threads.
//!
//! Priming: the first [`PRIMING_S`](crate::method::PRIMING_S) of a recording are folded into the noise estimate
//! before any frame is weighed. Otherwise the first frames are weighed against an
//! estimate that has not formed yet, and a fan that is on from the start is reported
//! there (docs/method.md, "Choices and evidence").

use super::sequential::Sequential;
use super::setup::Setup;
use super::worker::Worker;
use crate::geometry::Geometry;
use crate::method::beyond::background::Background;
use crate::method::beyond::edges::Edges;
use crate::method::beyond::patterns::Patterns;
use crate::method::outcome::{Detections, FrameStats, Outcome, StageTimes};
use crate::method::paper::frames::{FrameBlock, BLOCK};
use crate::method::params::{Params, ParamsError};
use crate::method::state::{Correlated, FrameState};
use rayon::prelude::*;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The method's state over one recording: the checked setup, one [`Worker`] per thread,
/// the noise estimate and the counters.
pub(crate) struct Engine {
    setup: Setup,
    workers: Vec<Mutex<(Worker, StageTimes)>>,
    sequential: Sequential,
    /// The coherent background subtracted from the correlations, in frame order.
    background: Option<Background>,
    /// Each talker's learned pattern and the second look for others, in frame order.
    patterns: Option<Patterns>,
    /// The last `average_frames - 1` frames finished (the spans of the next), then the
    /// frames weighed and waiting for the frames after them, then a block's.
    states: Vec<FrameState>,
    live: Vec<bool>,
    /// Per frame (as `states`), whether its own weights rule out a detection.
    hopeless: Vec<bool>,
    /// Frames weighed and not finished (at most `average_frames - 1` between blocks).
    waiting: usize,
    /// The index of the first of them.
    first_waiting: u64,
    /// Per frame being finished, whether its correlations can be left out.
    skip: Vec<bool>,
    outcomes: Vec<Outcome>,
    /// Per frame being finished, its dereverberated correlations (swapped into its
    /// state) and the most they can be.
    dereverbed: Vec<Vec<f32>>,
    reach: Vec<(f64, Edges)>,
    detections: Vec<Detections>,
    times: Option<StageTimes>,
}

impl Engine {
    /// Checks `params` against the array and the sample rate, and plans every stage.
    pub fn new(
        geometry: &Geometry,
        sample_rate: u32,
        params: &Params,
    ) -> Result<Self, ParamsError> {
        let setup = Setup::new(geometry, sample_rate, params)?;
        // The frames finished before a call (spans), those waiting, a block's.
        let carried = setup.params.room.average_frames - 1;
        let (span, most) = (2 * carried, carried + BLOCK);
        Ok(Engine {
            workers: (0..rayon::current_num_threads())
                .map(|_| Mutex::new((Worker::new(&setup), StageTimes::default())))
                .collect(),
            sequential: Sequential::new(&setup),
            background: Background::new(&setup),
            patterns: Patterns::new(&setup, &setup.threshold),
            states: (0..span + BLOCK).map(|_| FrameState::new(&setup)).collect(),
            live: vec![false; span + BLOCK],
            hopeless: vec![false; span + BLOCK],
            waiting: 0,
            first_waiting: 0,
            skip: vec![false; most],
            outcomes: vec![Outcome::Silent; most],
            reach: vec![(0.0, Edges::default()); most],
            dereverbed: if setup.dereverb.is_some() {
                vec![vec![0.0; setup.windows_len]; most]
            } else {
                Vec::new()
            },
            detections: vec![Detections::default(); most],
            times: None,
            setup,
        })
    }

    /// Frame size N.
    pub fn frame_size(&self) -> usize {
        self.setup.n
    }

    /// Hop between frames, N / 2.
    pub fn hop(&self) -> usize {
        self.setup.hop
    }

    /// Frames folded into the noise estimate before the first is weighed (all in the
    /// first block).
    pub fn priming_frames(&self) -> usize {
        self.sequential.priming
    }

    /// The largest delay between two microphones of the array, in samples.
    pub fn largest_delay_samples(&self) -> f64 {
        let s = &self.setup;
        s.geometry.aperture().0 * s.rate / s.speed
    }

    /// How many frequency bins the analysis reads (`--band`; `N/2 + 1` without one).
    pub fn band_bins(&self) -> usize {
        let (first, last) = self.setup.band;
        last + 1 - first
    }

    /// The parameters, as checked.
    pub fn params(&self) -> &Params {
        &self.setup.params
    }

    /// An empty block of frames for this analysis.
    pub fn block(&self) -> FrameBlock {
        FrameBlock::new(self.setup.n, self.setup.mics(), BLOCK)
    }

    /// Measures the time spent in each stage from now on (about 1 us a frame).
    pub fn enable_stage_timing(&mut self) {
        self.times.get_or_insert_with(StageTimes::default);
    }

    /// The time spent in each stage, when stage timing is on. Stages after the noise
    /// estimate add up the threads' time; the first two are wall time.
    pub fn stage_times(&self) -> Option<&StageTimes> {
        self.times.as_ref()
    }

    /// Adds `time` to the stage `pick` selects, when stage timing is on (for the stages
    /// its callers run: reading).
    pub fn add_time(&mut self, pick: fn(&mut StageTimes) -> &mut Duration, time: Duration) {
        if let Some(times) = self.times.as_mut() {
            *pick(times) += time;
        }
    }

    /// The counters so far.
    pub fn stats(&self) -> &FrameStats {
        &self.sequential.stats
    }

    /// Leaves every correlation in, even those the weights' ceiling rules out.
    #[cfg(test)]
    pub fn disable_pruning(&mut self) {
        for w in &mut self.workers {
            w.get_mut().expect("a worker panicked").0.prune = false;
        }
    }

    /// Analyses the frames of `block` and returns the detections of the frames it
    /// finishes, in frame order, with the index of the first. A frame is finished once
    /// the [`Room::average_frames`](crate::method::Room::average_frames)` - 1` frames
    /// after it are weighed (whether its correlations can be left out depends on them),
    /// so the last of a block wait for the next block or for [`Engine::finish`]:
    /// the output does not depend on where blocks end. `meanwhile` runs on the calling
    /// thread while the pool works, when there is more than one thread (the caller
    /// reads the next block).
    pub fn analyse(
        &mut self,
        block: &FrameBlock,
        meanwhile: impl FnOnce(),
    ) -> (u64, &[Detections]) {
        let mut done = 0;
        if rayon::current_num_threads() > 1 {
            rayon::in_place_scope(|scope| {
                scope.spawn(|_| done = self.analyse_block(Some(block)));
                meanwhile();
            });
        } else {
            done = self.analyse_block(Some(block));
            meanwhile();
        }
        self.tally(done)
    }

    /// Finishes the frames still waiting for the frames after them (at the end of the
    /// recording) and returns their detections as [`Engine::analyse`] does.
    pub fn finish(&mut self) -> (u64, &[Detections]) {
        let done = self.analyse_block(None);
        self.tally(done)
    }

    /// Counts the outcomes of the `done` frames just finished; returns their detections.
    fn tally(&mut self, done: usize) -> (u64, &[Detections]) {
        for (detection, &outcome) in self.detections.iter_mut().zip(&self.outcomes[..done]) {
            *detection = self.sequential.stats.tally(outcome);
        }
        (self.first_waiting - done as u64, &self.detections[..done])
    }

    /// Weighs the frames of `block`, then finishes every frame whose next frames are
    /// weighed (with `None`, at the end: every frame waiting); returns how many it
    /// finished.
    fn analyse_block(&mut self, block: Option<&FrameBlock>) -> usize {
        let carried = self.setup.params.room.average_frames - 1;
        let waiting = self.waiting;
        if let Some(block) = block {
            // Frames are contiguous: the block's first follows those waiting.
            self.first_waiting = block.first - waiting as u64;
            self.weigh(block, carried + waiting);
        }
        let count = block.map_or(0, |b| b.count);
        // Frames weighed and not finished, and those that can be finished now.
        let open = waiting + count;
        let done = if block.is_some() {
            open.saturating_sub(carried)
        } else {
            open
        };
        self.finish_frames(carried, open, done);
        // The last frames go before the next block's: the `carried` finished last,
        // then those still waiting.
        self.states[..carried + open].rotate_left(done);
        self.live[..carried + open].rotate_left(done);
        self.hopeless[..carried + open].rotate_left(done);
        self.waiting = open - done;
        self.first_waiting += done as u64;
        done
    }

    /// Spectra, noise estimate, weights, and whether each frame teaches the background
    /// and can give a detection, for the frames of `block`, into the states from `at`.
    fn weigh(&mut self, block: &FrameBlock, at: usize) {
        let count = block.count;
        let (setup, workers) = (&self.setup, &self.workers);
        let worker = || this_threads(workers);
        let (states, live) = (
            &mut self.states[at..at + count],
            &mut self.live[at..at + count],
        );
        // Spectra, in parallel.
        let clock = Instant::now();
        states
            .par_iter_mut()
            .zip(live.par_iter_mut())
            .enumerate()
            .for_each(|(i, (state, live))| {
                *live = worker().0.spectra(setup, block.frame(i), state);
            });
        let spectra = clock.elapsed();
        // The noise estimate, in frame order, then the weights.
        self.sequential
            .estimate_noise(setup.params.weighting.on, states, live);
        let noise = clock.elapsed();
        states
            .par_iter_mut()
            .zip(live.par_iter())
            .filter(|(_, &live)| live)
            .for_each(|(state, _)| Worker::weigh(setup, state));
        if let Some(times) = self.times.as_mut() {
            times.spectra += spectra;
            times.noise += noise - spectra;
            times.weighting += clock.elapsed() - noise;
        }
        for (i, ((state, &live), hopeless)) in states
            .iter_mut()
            .zip(live.iter())
            .zip(&mut self.hopeless[at..at + count])
            .enumerate()
        {
            state.teaches = live
                && Background::teaches(
                    &setup.params,
                    setup.background_gate,
                    state,
                    block.first + i as u64,
                );
            // A frame its own weights rule out has no detection (`Worker::decide`).
            *hopeless = !live || state.steady || state.ceiling < state.floor.min(state.rider_floor);
        }
    }

    /// Correlations, background, peaks, search, direction and the second look for the
    /// first `done` of the `open` frames weighed and not finished (states `carried..`,
    /// after the `carried` finished before them). `open - done` are left waiting.
    fn finish_frames(&mut self, carried: usize, open: usize, done: usize) {
        let (setup, workers) = (&self.setup, &self.workers);
        let worker = || this_threads(workers);
        let first = self.first_waiting;
        let (states, live) = (
            &mut self.states[..carried + open],
            &mut self.live[..carried + open],
        );
        // Which frames' correlations no detection can need: the frame and those that
        // average it (the ones weighed, at the end) rule out a detection.
        let prune = workers[0].lock().expect("a worker panicked").0.prune;
        let hopeless = &self.hopeless[..carried + open];
        for (i, skip) in self.skip[..done].iter_mut().enumerate() {
            let c = carried + i;
            let last = (c + carried).min(carried + open - 1);
            *skip = prune && !states[c].teaches && hopeless[c..=last].iter().all(|&h| h);
        }
        let live = &mut live[..carried + done];
        let states = &mut states[..carried + done];
        // Correlations, in parallel.
        let timing = self.times.is_some();
        if setup.dereverb.is_some() {
            // From the spectra of each frame and the ones before it, then into the frames.
            let (frozen, live) = (&*states, &*live);
            let skip = &self.skip[..done];
            self.dereverbed[..done]
                .par_iter_mut()
                .zip(self.reach[..done].par_iter_mut())
                .enumerate()
                .filter(|(i, _)| live[carried + i] && !skip[*i])
                .for_each(|(i, (out, reach))| {
                    let mut guard = worker();
                    let (worker, stage_times) = &mut *guard;
                    let span = i..=carried + i;
                    *reach = worker.correlate_dereverbed(
                        setup,
                        &frozen[span.clone()],
                        &live[span],
                        out,
                        timing.then_some(stage_times),
                    );
                });
            for (i, out) in self.dereverbed[..done].iter_mut().enumerate() {
                let state = &mut states[carried + i];
                state.correlated = if !live[carried + i] {
                    Correlated::No
                } else if self.skip[i] {
                    Correlated::Skipped
                } else {
                    std::mem::swap(&mut state.windows, out);
                    (state.reach, state.edges) = self.reach[i];
                    Correlated::Yes
                };
            }
        } else {
            states[carried..]
                .par_iter_mut()
                .zip(live[carried..].par_iter())
                .zip(self.skip[..done].par_iter())
                .for_each(|((state, &live), &skip)| {
                    if live {
                        let mut guard = worker();
                        let (worker, stage_times) = &mut *guard;
                        worker.correlate(setup, state, skip, timing.then_some(stage_times));
                    } else {
                        state.correlated = Correlated::No;
                    }
                });
        }
        // The coherent background, in frame order.
        if let Some(background) = self.background.as_mut() {
            let clock = Instant::now();
            background.apply(setup, &mut states[carried..]);
            if let Some(times) = self.times.as_mut() {
                times.background += clock.elapsed();
            }
        }
        // Averages, peaks, search, direction, in parallel.
        let states = &*states;
        self.outcomes[..done]
            .par_iter_mut()
            .zip(live[carried..].par_iter())
            .enumerate()
            .for_each(|(i, (outcome, &live))| {
                let index = first + i as u64;
                *outcome = if live {
                    let mut guard = worker();
                    let (worker, stage_times) = &mut *guard;
                    let span = &states[i..=i + carried];
                    worker.decide(setup, span, index, timing.then_some(stage_times))
                } else {
                    Outcome::Silent
                };
            });
        // Each talker's pattern removed before a second look, in frame order.
        if let Some(patterns) = self.patterns.as_mut() {
            let clock = Instant::now();
            patterns.apply(setup, states, carried, &mut self.outcomes[..done], first);
            if let Some(times) = self.times.as_mut() {
                times.patterns += clock.elapsed();
            }
        }
        if let Some(times) = self.times.as_mut() {
            for w in workers {
                times.add(&std::mem::take(&mut w.lock().expect("a worker panicked").1));
            }
        }
        // Pairs whose delays run past the geometry's, over the frames with sound.
        for (state, &live) in states[carried..].iter().zip(&live[carried..]) {
            if live && !state.steady && state.correlated == Correlated::Yes {
                self.sequential.stats.strong_pairs += state.edges.strong as u64;
                self.sequential.stats.edge_pairs += state.edges.beyond as u64;
            }
        }
    }
}

/// The worker of the pool thread that calls (of the calling thread outside the pool).
fn this_threads(workers: &[Mutex<(Worker, StageTimes)>]) -> MutexGuard<'_, (Worker, StageTimes)> {
    let i = rayon::current_thread_index().unwrap_or(0) % workers.len();
    workers[i].lock().expect("a worker panicked")
}

#[cfg(all(test, feature = "simulate"))]
#[path = "analyzer_tests.rs"]
mod tests;
