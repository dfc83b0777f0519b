//! Tests of the analyzer (`analyzer.rs`).

use super::*;
use crate::geometry::unit_from_angles;
use crate::method::beyond::{DEFAULT_CANDIDATES, DEFAULT_MAX_SOURCES, DEFAULT_RIDERS};
use crate::method::outcome::Detection;
use crate::method::{Interpolation, Steering, Threshold};
use crate::sim::freefield::{render, Place, Scene, Source};
use crate::sim::signals::Signal;
use crate::stream::source::{Channels, Framer, SampleSource};
use crate::stream::InputError;

/// Every frame's detection (or none), in order.
fn run(analyzer: &mut Engine, channels: &[Vec<f32>]) -> Vec<Option<Detection>> {
    let mut source = Channels::new("t", channels.iter().map(|c| &c[..]).collect(), 48000)
        .expect("channels of one length");
    run_all(analyzer, &mut source)
        .iter()
        .map(|d| d.as_slice().first().copied())
        .collect()
}

/// Every frame's detections, in order, from `source` a block at a time.
fn run_all(analyzer: &mut Engine, source: &mut dyn SampleSource) -> Vec<Detections> {
    let mics = source.channels();
    let first = analyzer.priming_frames();
    let mut framer = Framer::new(analyzer.frame_size(), (0..mics).collect(), mics, first);
    let mut block = analyzer.block();
    let mut all = Vec::new();
    let mut take = |(first, found): (u64, &[Detections])| {
        assert_eq!(first, all.len() as u64, "frames in order, none left out");
        all.extend_from_slice(found);
    };
    loop {
        assert!(framer.fill(source, &mut block).is_none());
        if block.count == 0 {
            take(analyzer.finish());
            return all;
        }
        take(analyzer.analyse(&block, || {}));
    }
}

/// Channels in memory handed on as a pipe hands them: a few hundred to a few thousand
/// sample frames a read, taken as they come (a live source's blocks are as short).
struct Trickle<'a> {
    inner: Channels<'a>,
    reads: usize,
}

impl SampleSource for Trickle<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn channels(&self) -> usize {
        self.inner.channels()
    }
    fn sample_rate(&self) -> u32 {
        self.inner.sample_rate()
    }
    fn frames(&self) -> Option<u64> {
        None
    }
    fn read(&mut self, out: &mut [f32]) -> Result<usize, InputError> {
        const SIZES: [usize; 5] = [300, 1700, 512, 4000, 77];
        let want = SIZES[self.reads % SIZES.len()] * self.channels();
        self.reads += 1;
        let len = want.min(out.len());
        self.inner.read(&mut out[..len])
    }
    fn is_live(&self) -> bool {
        true
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
    let mut without = Params::default();
    without.room.background_s = 0.0;
    let mut analyzer = Engine::new(&geometry, 48000, &without).unwrap();
    let reported = run(&mut analyzer, &alone).into_iter().flatten().count();
    assert!(
        reported > 200,
        "{reported} of 750 frames without the background"
    );
    let mut analyzer = Engine::new(&geometry, 48000, &Params::default()).unwrap();
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
    let mut analyzer = Engine::new(&geometry, 48000, &Params::default()).unwrap();
    let found: Vec<Detection> = run(&mut analyzer, &with_talker)
        .into_iter()
        .flatten()
        .collect();
    let on_talker = found
        .iter()
        .filter(|d| crate::geometry::angle_between_deg(&d.direction, &talker) < 5.0)
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
    const FIXED: Threshold = Threshold::Fixed { per_pair: 0.5 };
    let cases = [
        (Interpolation::Parabolic, 1, FIXED, 0.0, false),
        (Interpolation::None, 1, FIXED, 0.0, false),
        (
            Interpolation::Parabolic,
            1,
            FIXED,
            default.room.background_s,
            false,
        ),
        (
            Interpolation::Parabolic,
            default.room.average_frames,
            FIXED,
            0.0,
            false,
        ),
        (
            Interpolation::Parabolic,
            default.room.average_frames,
            default.threshold,
            default.room.background_s,
            false,
        ),
        // With further sources and riders (below the candidates' floor).
        (
            Interpolation::Cosine,
            default.room.average_frames,
            default.threshold,
            default.room.background_s,
            true,
        ),
        (Interpolation::Cosine, 1, default.threshold, 0.0, true),
    ];
    for (interpolation, average_frames, threshold, background_s, further) in cases {
        let mut params = Params {
            threshold,
            steered: if further {
                Steering::Partial
            } else {
                Steering::Off
            },
            frame_sources: further,
            ..Params::default()
        };
        params.peaks.interpolation = Some(interpolation);
        params.room.average_frames = average_frames;
        params.room.background_s = background_s;
        // The fixed threshold is meant for the noise estimate without reverberation.
        if !threshold.is_calibrated() {
            params.weighting.reverb_level = Some(0.0);
        }
        if further {
            params.talkers.max_sources = DEFAULT_MAX_SOURCES;
            params.talkers.candidates = Some(DEFAULT_CANDIDATES);
            params.talkers.riders = Some(DEFAULT_RIDERS);
        }
        let mut pruned = Engine::new(&geometry, 48000, &params).unwrap();
        let mut full = Engine::new(&geometry, 48000, &params).unwrap();
        full.disable_pruning();
        pruned.enable_stage_timing();
        full.enable_stage_timing();
        let source = || Channels::new("t", channels.iter().map(|c| &c[..]).collect(), 48000);
        let want = run_all(&mut full, &mut source().unwrap());
        assert_eq!(run_all(&mut pruned, &mut source().unwrap()), want);
        let frames = want.len();
        let detections = want.iter().filter(|d| !d.as_slice().is_empty()).count();
        let riders = want.iter().flat_map(|d| d.as_slice()).filter(|d| d.rider);
        let (p, f) = (pruned.stage_times().unwrap(), full.stage_times().unwrap());
        eprintln!(
            "{interpolation:?}, {average_frames} frames averaged, threshold {threshold:?}, background {background_s:?}, further sources {further}: {detections} of {frames} frames ({} riders), {} of {} pairs skipped",
            riders.count(), p.skipped_pairs, f.correlated_pairs
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
            threshold.is_calibrated()
                || background_s > 0.0
                || p.skipped_pairs * share > f.correlated_pairs,
            "{} of {} skipped",
            p.skipped_pairs,
            f.correlated_pairs
        );
    }
}

/// The detections do not depend on where blocks end: a scene of two talkers who
/// overlap (the second near the threshold), clicks and a fan, analysed a file's blocks
/// at a time (128 frames) and as a pipe hands it on (a frame or a few at a time), gives
/// every frame the same detections, further sources and riders included. (Before frames
/// waited for the frames after them, the last frames of each block were always
/// correlated: 4 frames of this scene differed.)
#[test]
fn the_output_does_not_depend_on_where_blocks_end() {
    let geometry = Geometry::from_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/prism.toml"),
    )
    .unwrap();
    let at = |azimuth: f64, elevation: f64| Place::Direction(unit_from_angles(azimuth, elevation));
    let sources = vec![
        Source {
            place: at(-60.0, 10.0),
            signal: Signal::SpeechLike,
            start_s: 0.4,
            end_s: 3.6,
            level: 0.1,
        },
        Source {
            place: at(70.0, -5.0),
            signal: Signal::SpeechLike,
            start_s: 1.8,
            end_s: 5.2,
            level: 0.02,
        },
        Source {
            place: at(150.0, 30.0),
            signal: Signal::Clicks { per_second: 3.0 },
            start_s: 0.0,
            end_s: 6.0,
            level: 0.05,
        },
        Source {
            place: at(-150.0, 40.0),
            signal: Signal::PinkNoise,
            start_s: 0.0,
            end_s: 6.0,
            level: 0.01,
        },
    ];
    let channels = render(&Scene {
        sample_rate: 48000,
        duration_s: 6.0,
        mics: geometry.positions(),
        speed_of_sound: 343.0,
        sources,
        sensor_noise: 0.001,
        seed: 17,
    });
    // The defaults with the tracker (`ssl analyze`'s): further sources, riders, patterns.
    let mut params = Params {
        steered: Steering::Partial,
        frame_sources: true,
        ..Params::default()
    };
    params.talkers = crate::method::Talkers {
        candidates: Some(crate::method::beyond::DEFAULT_CANDIDATES),
        riders: Some(crate::method::beyond::DEFAULT_RIDERS),
        bin_votes: false,
        ..Default::default()
    };
    let slices = || channels.iter().map(|c| &c[..]).collect::<Vec<_>>();
    let mut whole = Channels::new("t", slices(), 48000).unwrap();
    let mut analyzer = Engine::new(&geometry, 48000, &params).unwrap();
    analyzer.enable_stage_timing();
    let want = run_all(&mut analyzer, &mut whole);
    let skipped = analyzer.stage_times().unwrap().skipped_pairs;
    let mut trickle = Trickle {
        inner: Channels::new("t", slices(), 48000).unwrap(),
        reads: 0,
    };
    let mut analyzer = Engine::new(&geometry, 48000, &params).unwrap();
    let got = run_all(&mut analyzer, &mut trickle);
    let count = |all: &[Detections]| all.iter().map(|d| d.as_slice().len()).sum::<usize>();
    let (detected, found) = (
        want.iter().filter(|d| !d.as_slice().is_empty()).count(),
        count(&want),
    );
    eprintln!(
        "{detected} of {} frames with detections, {found} detections, {skipped} pairs skipped, {} reads",
        want.len(),
        trickle.reads
    );
    // Frames are left out, and frames give more than one source.
    assert!(skipped > 0 && found > detected && trickle.reads > 200);
    for (frame, (w, g)) in want.iter().zip(&got).enumerate() {
        assert_eq!(w, g, "frame {frame}");
    }
    assert_eq!(want.len(), got.len());
}
