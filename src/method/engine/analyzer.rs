//! The whole method over a recording's frames: the one way through the stages for every
//! entry point ([`Analysis`](crate::stream::Analysis) drives it for files, readers and
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
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The method's state over one recording: the checked setup, one [`Worker`] per thread,
/// the noise estimate and the counters.
pub(crate) struct Analyzer {
    setup: Setup,
    workers: Vec<Mutex<(Worker, StageTimes)>>,
    sequential: Sequential,
    /// The coherent background subtracted from the correlations, in frame order.
    background: Option<Background>,
    /// Each talker's learned pattern and the second look for others, in frame order.
    patterns: Option<Patterns>,
    /// The last `average_frames - 1` frames of the previous block, then this block's.
    states: Vec<FrameState>,
    live: Vec<bool>,
    /// Per frame (as `states`), whether its own weights rule out a detection.
    hopeless: Vec<bool>,
    /// Per frame of the block, whether its correlations can be left out.
    skip: Vec<bool>,
    outcomes: Vec<Outcome>,
    /// Per frame of the block, its dereverberated correlations (swapped into its state)
    /// and the most they can be.
    dereverbed: Vec<Vec<f32>>,
    reach: Vec<(f64, Edges)>,
    detections: Vec<Detections>,
    times: Option<StageTimes>,
}

impl Analyzer {
    /// Checks `params` against the array and the sample rate, and plans every stage.
    pub fn new(
        geometry: &Geometry,
        sample_rate: u32,
        params: &Params,
    ) -> Result<Self, ParamsError> {
        let setup = Setup::new(geometry, sample_rate, params)?;
        Ok(Analyzer {
            workers: (0..rayon::current_num_threads())
                .map(|_| Mutex::new((Worker::new(&setup), StageTimes::default())))
                .collect(),
            sequential: Sequential::new(&setup),
            background: Background::new(&setup),
            patterns: Patterns::new(&setup, &setup.threshold),
            states: (0..BLOCK + setup.params.average_frames - 1)
                .map(|_| FrameState::new(&setup))
                .collect(),
            live: vec![false; BLOCK + setup.params.average_frames - 1],
            hopeless: vec![false; BLOCK + setup.params.average_frames - 1],
            skip: vec![false; BLOCK],
            outcomes: vec![Outcome::Silent; BLOCK],
            reach: vec![(0.0, Edges::default()); BLOCK],
            dereverbed: if setup.dereverb.is_some() {
                vec![vec![0.0; setup.windows_len]; BLOCK]
            } else {
                Vec::new()
            },
            detections: vec![Detections::default(); BLOCK],
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

    /// Analyses the frames of `block` and returns their detections in frame order (frame
    /// `block.first + i` at `i`). `meanwhile` runs on the calling thread while the pool
    /// works, when there is more than one thread (the caller reads the next block).
    pub fn analyse(&mut self, block: &FrameBlock, meanwhile: impl FnOnce()) -> &[Detections] {
        let count = block.count;
        if rayon::current_num_threads() > 1 {
            rayon::in_place_scope(|scope| {
                scope.spawn(|_| self.analyse_block(block));
                meanwhile();
            });
        } else {
            self.analyse_block(block);
            meanwhile();
        }
        for (detection, &outcome) in self.detections.iter_mut().zip(&self.outcomes[..count]) {
            *detection = self.sequential.stats.tally(outcome);
        }
        &self.detections[..count]
    }

    fn analyse_block(&mut self, block: &FrameBlock) {
        let count = block.count;
        let (setup, workers) = (&self.setup, &self.workers);
        let worker = || {
            let i = rayon::current_thread_index().unwrap_or(0) % workers.len();
            workers[i].lock().expect("a worker panicked")
        };
        // The frames before this block that the first frames average with.
        let carried = setup.params.average_frames - 1;
        let (states, live) = (
            &mut self.states[..carried + count],
            &mut self.live[..carried + count],
        );
        // Spectra, in parallel.
        let clock = Instant::now();
        states[carried..]
            .par_iter_mut()
            .zip(live[carried..].par_iter_mut())
            .enumerate()
            .for_each(|(i, (state, live))| {
                *live = worker().0.spectra(setup, block.frame(i), state);
            });
        let spectra = clock.elapsed();
        // The noise estimate, in frame order, then the weights.
        self.sequential.estimate_noise(
            setup.params.weighting,
            &mut states[carried..],
            &live[carried..],
        );
        let noise = clock.elapsed();
        states[carried..]
            .par_iter_mut()
            .zip(live[carried..].par_iter())
            .filter(|(_, &live)| live)
            .for_each(|(state, _)| Worker::weigh(setup, state));
        if let Some(times) = self.times.as_mut() {
            times.spectra += spectra;
            times.noise += noise - spectra;
            times.weighting += clock.elapsed() - noise;
        }
        // Which frames' correlations no detection can need.
        let prune = workers[0].lock().expect("a worker panicked").0.prune;
        let hopeless = &mut self.hopeless[..carried + count];
        for (c, hopeless) in hopeless.iter_mut().enumerate() {
            // A frame its own weights rule out has no detection (`Worker::decide`).
            *hopeless =
                c < carried || !live[c] || states[c].steady || states[c].ceiling < states[c].floor;
        }
        for (i, skip) in self.skip[..count].iter_mut().enumerate() {
            let c = carried + i;
            states[c].teaches = live[c]
                && Background::teaches(
                    &setup.params,
                    setup.background_gate,
                    &states[c],
                    block.first + i as u64,
                );
            *skip = prune
                && !states[c].teaches
                && c + carried < carried + count
                && hopeless[c..=c + carried].iter().all(|&h| h);
        }
        // Correlations, in parallel.
        let timing = self.times.is_some();
        if setup.dereverb.is_some() {
            // From the spectra of each frame and the ones before it, then into the frames.
            let (frozen, live) = (&*states, &*live);
            let skip = &self.skip[..count];
            self.dereverbed[..count]
                .par_iter_mut()
                .zip(self.reach[..count].par_iter_mut())
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
            for (i, out) in self.dereverbed[..count].iter_mut().enumerate() {
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
                .zip(self.skip[..count].par_iter())
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
        self.outcomes[..count]
            .par_iter_mut()
            .zip(live[carried..].par_iter())
            .enumerate()
            .for_each(|(i, (outcome, &live))| {
                let index = block.first + i as u64;
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
            patterns.apply(
                setup,
                states,
                carried,
                &mut self.outcomes[..count],
                block.first,
            );
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
        // The last frames go before the next block's.
        self.states[..carried + count].rotate_left(count);
        self.live[..carried + count].rotate_left(count);
    }
}

#[cfg(all(test, feature = "simulate"))]
#[path = "analyzer_tests.rs"]
mod tests;
