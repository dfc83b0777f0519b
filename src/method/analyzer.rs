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
//! Priming: the first [`PRIMING_S`](super::PRIMING_S) of a recording are folded into the noise estimate
//! before any frame is weighed. Otherwise the first frames are weighed against an
//! estimate that has not formed yet, and a fan that is on from the start is reported
//! there (README, "Choices and evidence").

use super::background::Background;
use super::frames::{FrameBlock, BLOCK};
use super::outcome::{Detections, FrameStats, Outcome, StageTimes};
use super::params::{Params, ParamsError, Setup};
use super::sequential::Sequential;
use super::worker::{FrameState, Worker};
use crate::geometry::Geometry;
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::Instant;

/// The method's state over one recording: the checked setup, one [`Worker`] per thread,
/// the noise estimate and the counters.
pub(crate) struct Analyzer {
    setup: Setup,
    workers: Vec<Mutex<(Worker, StageTimes)>>,
    sequential: Sequential,
    /// The coherent background subtracted from the correlations, in frame order.
    background: Option<Background>,
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
    reach: Vec<f64>,
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
            states: (0..BLOCK + setup.params.average_frames - 1)
                .map(|_| FrameState::new(&setup))
                .collect(),
            live: vec![false; BLOCK + setup.params.average_frames - 1],
            hopeless: vec![false; BLOCK + setup.params.average_frames - 1],
            skip: vec![false; BLOCK],
            outcomes: vec![Outcome::Silent; BLOCK],
            reach: vec![0.0; BLOCK],
            dereverbed: if setup.dereverb {
                (0..BLOCK)
                    .map(|_| FrameState::new(&setup).windows)
                    .collect()
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
        states[carried..]
            .par_iter_mut()
            .zip(live[carried..].par_iter())
            .filter(|(_, &live)| live)
            .for_each(|(state, _)| Worker::weigh(setup, state));
        if let Some(times) = self.times.as_mut() {
            times.spectra += spectra;
            times.weighting += clock.elapsed() - spectra;
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
            states[c].teaches =
                live[c] && Background::teaches(setup, &states[c], block.first + i as u64);
            *skip = prune
                && !states[c].teaches
                && c + carried < carried + count
                && hopeless[c..=c + carried].iter().all(|&h| h);
        }
        // Correlations, in parallel.
        let timing = self.times.is_some();
        if setup.dereverb {
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
                    super::worker::Correlated::No
                } else if self.skip[i] {
                    super::worker::Correlated::Skipped
                } else {
                    std::mem::swap(&mut state.windows, out);
                    state.reach = self.reach[i];
                    super::worker::Correlated::Yes
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
                        state.correlated = super::worker::Correlated::No;
                    }
                });
        }
        // The coherent background, in frame order.
        if let Some(background) = self.background.as_mut() {
            background.apply(setup, &mut states[carried..]);
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
        if let Some(times) = self.times.as_mut() {
            for w in workers {
                times.add(&std::mem::take(&mut w.lock().expect("a worker panicked").1));
            }
        }
        // The last frames go before the next block's.
        self.states[..carried + count].rotate_left(count);
        self.live[..carried + count].rotate_left(count);
    }
}

#[cfg(all(test, feature = "simulate"))]
mod tests {
    use super::*;
    use crate::method::direction::unit_from_angles;
    use crate::method::outcome::Detection;
    use crate::method::Interpolation;
    use crate::sim::freefield::{render, Place, Scene, Source};
    use crate::sim::signals::Signal;
    use crate::stream::source::{Channels, Framer};

    /// Every frame's detection (or none), in order.
    fn run(analyzer: &mut Analyzer, channels: &[Vec<f32>]) -> Vec<Option<Detection>> {
        let mics = channels.len();
        let mut source = Channels::new("t", channels.iter().map(|c| &c[..]).collect(), 48000)
            .expect("channels of one length");
        let mut framer = Framer::new(analyzer.frame_size(), (0..mics).collect(), mics, 1);
        let mut block = analyzer.block();
        let mut all = Vec::new();
        loop {
            assert!(framer.fill(&mut source, &mut block).is_none());
            if block.count == 0 {
                return all;
            }
            all.extend(
                analyzer
                    .analyse(&block, || {})
                    .iter()
                    .map(|d| d.as_slice().first().copied()),
            );
        }
    }

    /// A steady fan next to the array, heard without reflections, correlates fully in every
    /// bin and passes the calibrated threshold in about half its frames; with its steady
    /// background subtracted from the correlations (the default) it is not reported, and
    /// over it a talker-like source 6 dB louder is found in its direction.
    #[test]
    fn a_steady_fan_in_free_field_is_background() {
        let geometry = Geometry::from_file(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/prism.toml"),
        )
        .unwrap();
        let fan = Source {
            place: Place::Direction(unit_from_angles(80.0, 40.0)),
            signal: Signal::PinkNoise,
            start_s: 0.0,
            end_s: 8.0,
            level: 0.02,
        };
        let talker = unit_from_angles(-100.0, 5.0);
        let scene = |sources: Vec<Source>| {
            render(&Scene {
                sample_rate: 48000,
                duration_s: 8.0,
                mics: geometry.positions(),
                speed_of_sound: 343.0,
                sources,
                sensor_noise: 0.0005,
                seed: 9,
            })
        };
        let alone = scene(vec![fan.clone()]);
        let without = Params {
            background_s: None,
            ..Params::default()
        };
        let mut analyzer = Analyzer::new(&geometry, 48000, &without).unwrap();
        let reported = run(&mut analyzer, &alone).into_iter().flatten().count();
        assert!(
            reported > 200,
            "{reported} of 750 frames without the background"
        );
        let mut analyzer = Analyzer::new(&geometry, 48000, &Params::default()).unwrap();
        let found: Vec<Detection> = run(&mut analyzer, &alone).into_iter().flatten().collect();
        assert!(
            found.len() <= 1,
            "{} detections of the fan alone: {:?}",
            found.len(),
            found.iter().map(|d| (d.frame, d.score)).collect::<Vec<_>>()
        );
        let with_talker = scene(vec![
            fan,
            Source {
                place: Place::Direction(talker),
                signal: Signal::SpeechLike,
                start_s: 3.0,
                end_s: 6.0,
                level: 0.04,
            },
        ]);
        let mut analyzer = Analyzer::new(&geometry, 48000, &Params::default()).unwrap();
        let found: Vec<Detection> = run(&mut analyzer, &with_talker)
            .into_iter()
            .flatten()
            .collect();
        let on_talker = found
            .iter()
            .filter(|d| crate::method::direction::angle_between_deg(&d.direction, &talker) < 5.0)
            .count();
        eprintln!("{} detections, {on_talker} on the talker", found.len());
        assert!(on_talker > 30, "{on_talker} of {}", found.len());
        assert!(
            on_talker * 10 >= found.len() * 9,
            "{on_talker} of {}",
            found.len()
        );
    }

    /// Leaving out the correlations that the weights' ceiling rules out changes no
    /// frame's detection: a scene whose sources sit below, near and above the threshold
    /// (a fan throughout, speech-like and noise sources at -12 to +6 dB against it),
    /// analysed with and without pruning, with and without sub-sample refinement and averaging.
    #[test]
    fn pruning_changes_no_detection() {
        let geometry = Geometry::from_file(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/prism.toml"),
        )
        .unwrap();
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
            mics: geometry.positions(),
            speed_of_sound: 343.0,
            sources,
            sensor_noise: 0.001,
            seed: 3,
        });
        // The fixed threshold prunes most; the calibrated one is lower and prunes less;
        // the frames the steady background learns from are never left out.
        let default = Params::default();
        let cases = [
            (Interpolation::Parabolic, 1, None, None),
            (Interpolation::None, 1, None, None),
            (Interpolation::Parabolic, 1, None, default.background_s),
            (Interpolation::Parabolic, default.average_frames, None, None),
            (
                Interpolation::Parabolic,
                default.average_frames,
                default.threshold_sigmas,
                default.background_s,
            ),
        ];
        for (interpolation, average_frames, threshold_sigmas, background_s) in cases {
            let params = Params {
                interpolation,
                average_frames,
                threshold_sigmas,
                background_s,
                // The fixed threshold is meant for the noise estimate without reverberation.
                reverb_level: if threshold_sigmas.is_some() {
                    default.reverb_level
                } else {
                    0.0
                },
                ..Params::default()
            };
            let mut pruned = Analyzer::new(&geometry, 48000, &params).unwrap();
            let mut full = Analyzer::new(&geometry, 48000, &params).unwrap();
            full.disable_pruning();
            pruned.enable_stage_timing();
            full.enable_stage_timing();
            let want = run(&mut full, &channels);
            assert_eq!(run(&mut pruned, &channels), want);
            let frames = want.len();
            let detections = want.iter().flatten().count();
            let (p, f) = (pruned.stage_times().unwrap(), full.stage_times().unwrap());
            eprintln!(
                "{interpolation:?}, {average_frames} frames averaged, calibrated {threshold_sigmas:?}, background {background_s:?}: {detections} of {frames} frames, {} of {} pairs skipped",
                p.skipped_pairs, f.correlated_pairs
            );
            assert_eq!(f.skipped_pairs, 0);
            assert_eq!(p.correlated_pairs + p.skipped_pairs, f.correlated_pairs);
            // Both outcomes occur, and pruning does real work.
            assert!(
                detections > 30 && detections < frames - 30,
                "{detections} of {frames}"
            );
            // Averaged frames need their neighbours' correlations, so fewer are left out.
            let share = if average_frames == 1 { 5 } else { 100 };
            assert!(
                threshold_sigmas.is_some()
                    || background_s.is_some()
                    || p.skipped_pairs * share > f.correlated_pairs,
                "{} of {} skipped",
                p.skipped_pairs,
                f.correlated_pairs
            );
        }
    }
}
