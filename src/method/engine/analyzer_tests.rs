//! Tests of the analyzer (`analyzer.rs`).

use super::*;
use crate::method::outcome::Detection;
use crate::method::paper::direction::unit_from_angles;
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
        .filter(|d| crate::method::paper::direction::angle_between_deg(&d.direction, &talker) < 5.0)
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
