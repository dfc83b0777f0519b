//! `ssl check` (docs/interface.md, "Checking an array"): on recordings whose faults are
//! made on purpose (channels swapped, one inverted, dead or duplicated, a microphone
//! moved, positions in centimetres or too small), it names each fault and exits 1; on the
//! recording as it is, it says it fits and exits 0; an unreadable input is exit 2.

use crate::support;

use nalgebra::Vector3;
use ssl::sim::freefield::render;
use ssl::sim::signals::Signal;
use ssl::sim::{write_wav, Encoding};
use support::*;

/// A 6-mic circle of 5 cm at 16 kHz hearing three noise sources in turn, in free field:
/// the directory, the positions and the channels.
fn recording() -> (tempfile::TempDir, Vec<Vector3<f64>>, Vec<Vec<f32>>) {
    let dir = tempdir();
    let mics = circle(6, 0.05);
    let dirs = [
        (30.0, 10.0, Signal::WhiteNoise),
        (-100.0, 25.0, Signal::WhiteNoise),
        (130.0, 5.0, Signal::WhiteNoise),
    ];
    let channels = render(&scene(mics.clone(), 16000, &dirs, 0.6, 0.003, 21));
    (dir, mics, channels)
}

/// `ssl check` of `channels` against `positions`: exit status, the findings' kinds, and
/// the text report.
fn check(
    dir: &std::path::Path,
    channels: &[Vec<f32>],
    positions: &[Vector3<f64>],
) -> (i32, Vec<String>, String) {
    let wav = dir.join("rec.wav");
    write_wav(&wav, channels, 16000, Encoding::Float32).unwrap();
    let geometry = write(dir, "array.toml", geometry_toml(positions, ""));
    // The circle's symmetry hides its rotations and mirror images: the second source's
    // known direction settles them (the first's, azimuth 30, is on a mirror of the
    // hexagon, which no sound there can settle; and no other source is an image of
    // -100 under the hexagon's rotations and mirrors).
    let json = run(&[
        "check",
        s(&wav),
        "-g",
        s(&geometry),
        "--format",
        "json",
        "--expect",
        "-100/25",
    ]);
    let report: serde_json::Value =
        serde_json::from_slice(&json.stdout).unwrap_or_else(|_| panic!("{}", stderr(&json)));
    let kinds = report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["kind"].as_str().unwrap().to_string())
        .collect();
    let text = run(&["check", s(&wav), "-g", s(&geometry), "--expect", "-100/25"]);
    assert_eq!(text.status.code(), json.status.code());
    (
        json.status.code().unwrap(),
        kinds,
        String::from_utf8(text.stdout).unwrap(),
    )
}

#[test]
fn a_recording_that_fits_its_geometry_is_said_to() {
    let (dir, mics, channels) = recording();
    let (code, kinds, text) = check(dir.path(), &channels, &mics);
    assert_eq!((code, kinds.len()), (0, 0), "{text}");
    assert!(text.contains("fits:"), "{text}");
}

#[test]
fn swapped_channels_are_named_with_the_order_that_fits() {
    let (dir, mics, mut channels) = recording();
    channels.swap(1, 2);
    let (code, kinds, text) = check(dir.path(), &channels, &mics);
    assert_eq!((code, kinds), (1, vec!["order".to_string()]), "{text}");
    assert!(text.contains("channels 1 and 2 look swapped"), "{text}");
}

#[test]
fn an_inverted_a_dead_and_a_duplicated_channel_are_named() {
    let (dir, mics, channels) = recording();
    let mut inverted = channels.clone();
    inverted[3].iter_mut().for_each(|v| *v = -*v);
    let (code, kinds, text) = check(dir.path(), &inverted, &mics);
    assert_eq!((code, kinds), (1, vec!["inverted".to_string()]), "{text}");
    assert!(
        text.contains("channel 3 (mic 4) is polarity-inverted"),
        "{text}"
    );

    let mut dead = channels.clone();
    dead[4].iter_mut().for_each(|v| *v = 0.0);
    let (code, kinds, text) = check(dir.path(), &dead, &mics);
    assert_eq!(code, 1);
    assert_eq!(kinds[0], "dead", "{text}");
    assert!(text.contains("channel 4 (mic 5) is dead"), "{text}");

    let mut twice = channels.clone();
    twice[5] = twice[0].clone();
    let (code, kinds, text) = check(dir.path(), &twice, &mics);
    assert_eq!(code, 1);
    assert!(kinds.contains(&"duplicated".to_string()), "{text}");
    assert!(
        text.contains("channel 0 (mic 1) and channel 5 (mic 6) carry the same signal"),
        "{text}"
    );
}

#[test]
fn a_moved_microphone_is_named() {
    let (dir, mut mics, channels) = recording();
    mics[2].x += 0.02;
    let (code, kinds, text) = check(dir.path(), &channels, &mics);
    assert_eq!((code, kinds), (1, vec!["moved".to_string()]), "{text}");
    assert!(
        text.contains("mic 3 (channel 2) does not fit its position"),
        "{text}"
    );
}

#[test]
fn positions_in_the_wrong_unit_or_too_small_are_named() {
    let (dir, mics, channels) = recording();
    // A 3 cm array written in centimetres is 3 "m" across: the delays are 100 times
    // shorter than the positions imply.
    let small: Vec<Vector3<f64>> = circle(6, 0.015);
    let small_channels = render(&scene(
        small.clone(),
        16000,
        &[
            (30.0, 10.0, Signal::WhiteNoise),
            (-100.0, 25.0, Signal::WhiteNoise),
        ],
        0.6,
        0.003,
        22,
    ));
    let cm: Vec<Vector3<f64>> = small.iter().map(|p| p * 100.0).collect();
    let (code, kinds, text) = check(dir.path(), &small_channels, &cm);
    assert_eq!((code, kinds), (1, vec!["unit".to_string()]), "{text}");
    assert!(
        text.contains("they look like centimetres (divide them by 100"),
        "{text}"
    );
    // Positions a third of the truth: delays beyond what the geometry allows.
    let shrunk: Vec<Vector3<f64>> = mics.iter().map(|p| p * 0.3).collect();
    let (code, kinds, text) = check(dir.path(), &channels, &shrunk);
    assert_eq!((code, kinds), (1, vec!["beyond".to_string()]), "{text}");
}

#[test]
fn a_silent_file_is_said_to_be_and_an_unreadable_one_is_exit_2() {
    let (dir, mics, channels) = recording();
    let silent: Vec<Vec<f32>> = channels.iter().map(|c| vec![0.0; c.len()]).collect();
    let (code, kinds, text) = check(dir.path(), &silent, &mics);
    assert_eq!((code, kinds), (1, vec!["silent".to_string()]), "{text}");
    let geometry = write(dir.path(), "array.toml", geometry_toml(&mics, ""));
    let out = run(&["check", "missing.wav", "-g", s(&geometry)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("missing.wav"), "{}", stderr(&out));
    let out = run(&[
        "check",
        s(&dir.path().join("rec.wav")),
        "-g",
        "missing.toml",
    ]);
    assert_eq!(out.status.code(), Some(2));
    // The recording and the geometry the wrong way round: said so, here and in analyze.
    let wav = dir.path().join("rec.wav");
    for cmd in ["check", "analyze"] {
        let out = run(&[cmd, s(&geometry), "-g", s(&wav)]);
        assert_ne!(out.status.code(), Some(0));
        assert!(
            stderr(&out).contains(
                "this is a WAV file, not a geometry (TOML): are the recording and --geometry swapped?"
            ),
            "{}",
            stderr(&out)
        );
    }
}

#[test]
fn analyze_warns_when_the_delays_keep_exceeding_the_geometry() {
    let (dir, wav, geometry) = support::recording(1.5);
    let warned = |g: &std::path::Path| {
        let out = run(&["analyze", s(&wav), "-g", s(g), "-o", "/dev/null"]);
        assert!(out.status.success(), "{}", stderr(&out));
        stderr(&out).contains("the delays keep exceeding what the geometry allows")
    };
    assert!(!warned(&geometry));
    // The prism with its positions 30% too small.
    let small: Vec<_> = prism().iter().map(|p| p * 0.7).collect();
    let small = write(dir.path(), "small.toml", geometry_toml(&small, ""));
    assert!(warned(&small));
}

/// The warning of delays beyond the geometry asks a pair to be clear at the calibrated
/// level whatever threshold detects: in the shipped scene's room, the true prism gets
/// no warning with the paper's method or with every consistent set (`--min-score 0`),
/// where reflections past the direct path's window used to set it off, and the prism
/// 40% too small is warned of under each.
#[test]
fn the_delay_warning_holds_under_any_threshold() {
    let dir = tempdir();
    let d = dir.path();
    let scene = std::fs::read_to_string(testdata("scene.toml")).unwrap();
    let scene = scene.replace(
        "\"prism.toml\"",
        &format!("{:?}", s(&testdata("prism.toml"))),
    );
    let toml = write(d, "scene.toml", scene);
    let wav = d.join("scene.wav");
    let o = run(&["simulate", s(&toml), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let small: Vec<_> = prism().iter().map(|p| p * 0.6).collect();
    let small = write(d, "small.toml", geometry_toml(&small, ""));
    for options in [&[][..], &["--paper"], &["--no-track", "--min-score", "0"]] {
        let warned = |g: &std::path::Path| {
            let mut args = vec!["analyze", s(&wav), "-g", s(g), "-o", "/dev/null"];
            args.extend_from_slice(options);
            let out = run(&args);
            assert!(out.status.success(), "{}", stderr(&out));
            stderr(&out).contains("the delays keep exceeding what the geometry allows")
        };
        assert!(!warned(&testdata("prism.toml")), "{options:?}");
        assert!(warned(&small), "{options:?}");
    }
}
