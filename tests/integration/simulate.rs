//! `ssl simulate` and `ssl evaluate` end to end: reproducible scenes, truth in the array
//! frame, a reverberant scene localized and scored, background alone, bad scenes.

use crate::support;

use std::path::Path;
use support::*;

fn prism_file(dir: &Path) {
    write(dir, "prism.toml", geometry_toml(&prism(), ""));
}

#[test]
fn same_scene_and_seed_give_the_same_bytes() {
    let dir = tempdir();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("testdata/scene.toml");
    let (a, b) = (dir.path().join("a.wav"), dir.path().join("b.wav"));
    for out in [&a, &b] {
        let o = run(&["simulate", s(&scene), "-o", s(out)]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // The truth goes beside the WAV by default.
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("a.truth.json")).unwrap())
            .unwrap();
    assert_eq!(truth["sources"].as_array().unwrap().len(), 2);
    let measured = truth["room"]["rt60_measured"].as_f64().unwrap();
    assert!((measured - 0.35).abs() < 0.02, "{measured}");
}

#[test]
fn truth_directions_are_in_the_array_frame() {
    let dir = tempdir();
    prism_file(dir.path());
    // The array faces +y of the room (yaw 90): a source due +y in the room is straight
    // ahead (azimuth 0) for the array; one due -x of the room is to its left (+90),
    // 1 m above the array centre at 2 m horizontal distance: elevation atan(1/2).
    let scene = r#"
sample_rate = 16000
duration = 1.0
[room]
dimensions = [6.0, 6.0, 3.0]
rt60 = 0.2
[array]
geometry = "prism.toml"
position = [3.0, 3.0, 1.0]
yaw_deg = 90.0
[[source]]
position = [3.0, 5.0, 1.0]
signal = "white"
active = [[0.1, 0.4]]
[[source]]
position = [1.0, 3.0, 2.0]
signal = "white"
active = [[0.5, 0.9]]
"#;
    let path = write(dir.path(), "scene.toml", scene);
    let out = dir.path().join("out.wav");
    let truth_path = dir.path().join("t.json");
    let o = run(&[
        "simulate",
        s(&path),
        "-o",
        s(&out),
        "--truth",
        s(&truth_path),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truth_path).unwrap()).unwrap();
    let src = &t["sources"];
    assert!(src[0]["azimuth_deg"].as_f64().unwrap().abs() < 1e-9);
    assert!((src[0]["distance_m"].as_f64().unwrap() - 2.0).abs() < 1e-9);
    assert!((src[1]["azimuth_deg"].as_f64().unwrap() - 90.0).abs() < 1e-9);
    let el = src[1]["elevation_deg"].as_f64().unwrap();
    assert!((el - 0.5f64.atan().to_degrees()).abs() < 1e-9, "{el}");
    // Active intervals are as heard at the array: shifted by distance / c.
    let start = src[0]["active"][0][0].as_f64().unwrap();
    assert!((start - (0.1 + 2.0 / 343.0)).abs() < 1e-6, "{start}");
}

#[test]
fn reverberant_scene_is_localized_and_scored() {
    let dir = tempdir();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let wav = dir.path().join("scene.wav");
    let o = run(&[
        "simulate",
        s(&root.join("testdata/scene.toml")),
        "-o",
        s(&wav),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = dir.path().join("scene.csv");
    let o = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&root.join("testdata/prism.toml")),
        "-o",
        s(&csv),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "evaluate",
        "--truth",
        s(&dir.path().join("scene.truth.json")),
        s(&csv),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(r["mean_error_deg"].as_f64().unwrap() < 2.0, "{r}");
    assert_eq!(r["event_detection_rate"].as_f64().unwrap(), 1.0, "{r}");
    assert!(r["false_per_minute"].as_f64().unwrap() < 1.0, "{r}");
    // The table form names every source.
    let o = run(&[
        "evaluate",
        "--truth",
        s(&dir.path().join("scene.truth.json")),
        s(&csv),
    ]);
    let table = String::from_utf8(o.stdout).unwrap();
    assert!(
        table.contains("speech") && table.contains("clicks") && table.contains("false detections"),
        "{table}"
    );
}

#[test]
fn background_alone_gives_no_detections_from_the_first_frame() {
    // A fan and diffuse noise from time 0; the only source plays in the last 0.2 s.
    let dir = tempdir();
    prism_file(dir.path());
    let scene = r#"
sample_rate = 48000
duration = 8.0
seed = 4
[room]
dimensions = [7.0, 6.0, 3.0]
rt60 = 0.35
[array]
geometry = "prism.toml"
position = [3.5, 3.0, 1.0]
[[source]]
azimuth_deg = 30.0
distance = 2.0
signal = "white"
active = [[7.8, 8.0]]
[noise]
snr_db = 10
sensor_db = -70
[[noise.fan]]
position = [6.5, 1.0, 2.7]
[noise.diffuse]
weight_db = -6
"#;
    let path = write(dir.path(), "noise.toml", scene);
    let wav = dir.path().join("noise.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["analyze", s(&wav), "-g", s(&dir.path().join("prism.toml"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = parse_csv(&String::from_utf8(o.stdout).unwrap());
    let early: Vec<&Row> = rows.iter().filter(|r| r.time_s < 7.7).collect();
    assert!(
        early.is_empty(),
        "{} detections of background: {:?}",
        early.len(),
        &early[..early.len().min(5)]
    );
    // The analysis is live: the source at the end is found.
    let truth = ssl::geometry::unit_from_angles(30.0, 0.0);
    assert!(
        rows.iter()
            .any(|r| r.time_s > 7.8 && ssl::geometry::angle_between_deg(&r.u, &truth) < 5.0),
        "{rows:?}"
    );
}

#[test]
fn bad_scenes_are_explained() {
    let dir = tempdir();
    prism_file(dir.path());
    let base = "sample_rate = 16000\nduration = 1.0\n[room]\ndimensions = [4.0, 4.0, 3.0]\nrt60 = 0.3\n[array]\ngeometry = \"prism.toml\"\nposition = [2.0, 2.0, 1.0]\n";
    let cases = [
        (format!("{base}[[source]]\nposition = [9.0, 2.0, 1.0]\nsignal = \"white\"\n"), "outside the room"),
        (format!("{base}[[source]]\nposition = [3.0, 2.0, 1.0]\nsignal = \"white\"\nloudness = 3\n"), "unknown field"),
        (format!("{base}[[source]]\nposition = [3.0, 2.0, 1.0]\nsignal = \"file\"\n"), "needs `file"),
        (format!("{base}[[source]]\nposition = [3.0, 2.0, 1.0]\nsignal = \"white\"\nactive = [[0.5, 0.2]]\n"), "active interval"),
        (format!("{base}[[source]]\nposition = [3.0, 2.0, 1.0]\nsignal = \"white\"\nlevel_db = 6\n"), "clips"),
        (format!("{base}[[source]]\nposition = [3.0, 2.0, 1.0]\nsignal = \"white\"\nturn_deg_per_s = 30\n"), "turn_deg_per_s moves a source given by azimuth_deg"),
        (format!("{base}[[source]]\nazimuth_deg = 0\ndistance = 1.0\nsignal = \"white\"\nturn_deg_per_s = 1000\n"), "at most 360 deg/s"),
        // Starting inside the room, 2.6 m from the array at [2, 2, 1] toward its corner,
        // and turning toward its wall.
        (format!("{base}[[source]]\nazimuth_deg = 45\ndistance = 2.6\nsignal = \"white\"\nturn_deg_per_s = -90\n"), "outside the room"),
        ("sample_rate = 16000\nduration = 1.0\n[array]\ngeometry = \"missing.toml\"\nposition = [0.0, 0.0, 0.0]\n".to_string(), "missing.toml"),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let path = write(dir.path(), &format!("bad{i}.toml"), text);
        let o = run(&["simulate", s(&path), "-o", s(&dir.path().join("x.wav"))]);
        assert_eq!(o.status.code(), Some(1), "{text}");
        let err = stderr(&o);
        assert!(
            err.contains(needle) && err.lines().count() == 1,
            "{needle}: {err}"
        );
        assert!(!dir.path().join("x.wav").exists());
    }
}

/// Writes a mono 16 kHz recording of `duration` seconds to `path`: white noise over
/// `[start, end]` seconds, silence elsewhere.
fn noise_recording(path: &Path, duration: f64, [start, end]: [f64; 2]) {
    let mono = ssl::sim::freefield::render(&ssl::sim::freefield::Scene {
        sample_rate: 16000,
        duration_s: duration,
        mics: vec![nalgebra::Vector3::zeros()],
        speed_of_sound: 343.0,
        sources: vec![ssl::sim::freefield::Source {
            place: ssl::sim::freefield::Place::Direction(nalgebra::Vector3::x()),
            signal: ssl::sim::signals::Signal::WhiteNoise,
            start_s: start,
            end_s: end,
            level: 0.1,
        }],
        sensor_noise: 0.0,
        seed: 2,
    });
    ssl::sim::write_wav(path, &mono, 16000, ssl::sim::Encoding::Int16).unwrap();
}

#[test]
fn source_from_a_wav_file() {
    let dir = tempdir();
    prism_file(dir.path());
    // A mono noise recording as the source signal.
    noise_recording(&dir.path().join("voice.wav"), 0.5, [0.0, 0.5]);
    let scene = "sample_rate = 16000\nduration = 1.0\n[array]\ngeometry = \"prism.toml\"\nposition = [0.0, 0.0, 0.0]\n[[source]]\nazimuth_deg = -60.0\nelevation_deg = 20.0\ndistance = 3.0\nsignal = \"file\"\nfile = \"voice.wav\"\nactive = [[0.2, 0.9]]\n";
    let path = write(dir.path(), "file.toml", scene);
    let wav = dir.path().join("f.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&dir.path().join("prism.toml")),
        "--min-score",
        "0",
    ]);
    let rows = parse_csv(&String::from_utf8(o.stdout).unwrap());
    let truth = ssl::geometry::unit_from_angles(-60.0, 20.0);
    let inside: Vec<&Row> = rows
        .iter()
        .filter(|r| r.time_s > 0.25 && r.time_s < 0.85)
        .collect();
    assert!(inside.len() > 30, "{}", inside.len());
    assert!(inside
        .iter()
        .all(|r| ssl::geometry::angle_between_deg(&r.u, &truth) < 2.0));
}

/// A recording's own leading and trailing silence is not part of its truth: the truth's
/// active interval is when it sounds; a synthetic signal keeps its interval whole.
#[test]
fn a_recordings_silence_is_left_out_of_its_truth() {
    let dir = tempdir();
    prism_file(dir.path());
    // 0.6 s of file: silence, noise from 0.15 to 0.4 s, silence.
    noise_recording(&dir.path().join("voice.wav"), 0.6, [0.15, 0.4]);
    let scene = "sample_rate = 16000\nduration = 1.5\n[array]\ngeometry = \"prism.toml\"\nposition = [0.0, 0.0, 0.0]\n[[source]]\nazimuth_deg = -60.0\ndistance = 3.43\nsignal = \"file\"\nfile = \"voice.wav\"\nactive = [[0.2, 0.8]]\n[[source]]\nazimuth_deg = 60.0\ndistance = 3.43\nsignal = \"white\"\nactive = [[0.9, 1.4]]\n";
    let path = write(dir.path(), "file.toml", scene);
    let wav = dir.path().join("f.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let truth = ssl::Truth::from_file(&dir.path().join("f.truth.json")).unwrap();
    // Heard 10 ms later at the array centre (3.43 m); found to the 10 ms block.
    let [a, b] = truth.sources[0].active[0];
    assert!((a - (0.2 + 0.15 + 0.01)).abs() <= 0.011, "{a}");
    assert!((b - (0.2 + 0.4 + 0.01)).abs() <= 0.011, "{b}");
    assert_eq!(truth.sources[1].active, vec![[0.91, 1.41]]);
}

/// Real speech recorded at 16 kHz (CMU ARCTIC, shipped in testdata/speech) as the source
/// of a 48 kHz scene: resampled, rendered, and localized in the right direction.
#[test]
fn real_speech_at_another_rate_is_resampled() {
    let dir = tempdir();
    prism_file(dir.path());
    std::fs::copy(
        testdata("speech/cmu_arctic_us_aew_a0001.wav"),
        dir.path().join("speech.wav"),
    )
    .unwrap();
    let scene = "sample_rate = 48000\nduration = 3.5\n[array]\ngeometry = \"prism.toml\"\nposition = [0.0, 0.0, 0.0]\n[[source]]\nazimuth_deg = 75.0\nelevation_deg = -10.0\ndistance = 2.0\nsignal = \"file\"\nfile = \"speech.wav\"\nactive = [[0.3, 3.3]]\n[noise]\nsensor_db = -60\n";
    let path = write(dir.path(), "speech.toml", scene);
    let wav = dir.path().join("s.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["analyze", s(&wav), "-g", s(&dir.path().join("prism.toml"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = parse_csv(&String::from_utf8(o.stdout).unwrap());
    let truth = ssl::geometry::unit_from_angles(75.0, -10.0);
    assert!(rows.len() > 20, "{} detections of real speech", rows.len());
    let good = rows
        .iter()
        .filter(|r| ssl::geometry::angle_between_deg(&r.u, &truth) < 3.0)
        .count();
    assert!(
        good * 10 >= rows.len() * 9,
        "{good} of {} within 3 deg",
        rows.len()
    );
}

/// Three sentences of real speech in the paper's room with its fan, 10 dB below the
/// talker, on the array of `geometry` (a file in `dir`), at `distance` and `elevation`:
/// the recording and its truth.
fn speech_scene(
    dir: &Path,
    geometry: &str,
    rate: u32,
    distance: f64,
    elevation: f64,
) -> (std::path::PathBuf, ssl::Truth) {
    copy_speech(dir).unwrap();
    let mut scene = format!("sample_rate = {rate}\nduration = 15.0\nseed = 3\n[room]\ndimensions = [8.0, 7.0, 3.0]\nrt60 = 0.35\n[array]\ngeometry = \"{geometry}\"\nposition = [4.0, 3.5, 0.8]\n");
    let events = [
        (-140.0, 1.0, "aew_a0001", 3.9),
        (-50.0, 5.4, "axb_a0004", 2.8),
        (40.0, 8.7, "aew_a0001", 3.9),
    ];
    for (az, start, clip, len) in events {
        scene += &format!("[[source]]\nazimuth_deg = {az}\nelevation_deg = {elevation}\ndistance = {distance}\nsignal = \"file\"\nfile = \"cmu_arctic_us_{clip}.wav\"\nactive = [[{start}, {}]]\n", start + len);
    }
    scene += "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n[noise.diffuse]\nweight_db = -6\n";
    let path = write(dir, "speech.toml", &scene);
    let wav = dir.join("speech.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let truth = ssl::Truth::from_file(&dir.join("speech.truth.json")).unwrap();
    (wav, truth)
}

/// A tetrahedron of 6.5 cm edge as `tetra.toml` in `dir`.
fn tetrahedron_file(dir: &Path) {
    write(dir, "tetra.toml", geometry_toml(&tetrahedron(0.065), ""));
}

/// `ssl analyze` of `wav` with the array of `geometry` and `extra` arguments, scored.
fn analyze_and_score(
    dir: &Path,
    wav: &Path,
    geometry: &str,
    truth: &ssl::Truth,
    extra: &[&str],
) -> ssl::evaluate::Report {
    let mut args = vec!["analyze", s(wav), "-g", geometry];
    args.extend_from_slice(extra);
    let o = ssl().current_dir(dir).args(&args).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let records = ssl::record::parse_detections(&String::from_utf8(o.stdout).unwrap()).unwrap();
    ssl::evaluate::evaluate(truth, &records, 0.175).unwrap()
}

/// Real speech in the paper's reverberant room at 16 kHz: with the paper's check
/// (`--paper`: a tolerance of 2 samples, 125 us at 16 kHz, and no gate), sets of delays
/// that mix the direct path with reflections pass and point the wrong way; the defaults'
/// check (a tolerance of 40 us and a gate of 100 us on the residual of a single-source fit)
/// keep the detections on the talker (the paper's method otherwise: frame by frame, the
/// fixed threshold, no background subtraction).
#[test]
fn tolerance_in_time_and_the_residual_gate_keep_reverberant_speech_on_target() {
    let dir = tempdir();
    prism_file(dir.path());
    let (wav, truth) = speech_scene(dir.path(), "prism.toml", 16000, 3.0, -7.0);
    let score = |extra: &[&str]| analyze_and_score(dir.path(), &wav, "prism.toml", &truth, extra);
    let plain = score(&["--paper"]);
    let gated = score(&[
        "--average-frames",
        "1",
        "--min-score",
        "0.5",
        "--background-s",
        "0",
    ]);
    let (p, g) = (plain.mean_error_deg.unwrap(), gated.mean_error_deg.unwrap());
    eprintln!(
        "mean error: {p:.1} deg with the paper's check, {g:.1} deg with the gate; events {:?}",
        gated.event_detection_rate
    );
    assert!(p > 5.0, "the paper's check errs here: {p}");
    assert!(g < 4.0, "{g}");
    assert_eq!(gated.event_detection_rate, Some(1.0));
}

/// On a 6.5 cm tetrahedron at 16 kHz the delays are at most 3 samples, and one frame's
/// correlations in a reverberant room scatter the direction by many degrees. Averaging
/// them over 6 frames (with the fixed threshold of `--min-score`) steadies it; the
/// default threshold, calibrated against the background, with late reverberation in the
/// noise estimate, sharpens it further with every event found and no false detection
/// (measured without the tracker, whose candidates add rows that err more but whose
/// smoothing over each track's rows takes the error down again: 1.3 deg with it). The talker
/// sits 1.5 m away, 15 deg above the array; one recording serves the four analyses.
#[test]
fn averaging_and_the_calibrated_threshold_sharpen_reverberant_speech_on_a_small_array() {
    let dir = tempdir();
    tetrahedron_file(dir.path());
    let (wav, truth) = speech_scene(dir.path(), "tetra.toml", 16000, 1.5, 15.0);
    let score = |extra: &[&str]| analyze_and_score(dir.path(), &wav, "tetra.toml", &truth, extra);
    let error = |report: &ssl::evaluate::Report| report.mean_error_deg.unwrap();
    // Each frame's own direction (`--smooth-s 0`) but for the last run: the stages,
    // through the rules of 0.2.0 as when they were measured (5.3 and 3.6 deg). By the
    // evidence, the default, 4.8 and 3.4: it drops more of the frame-by-frame run's
    // wrong rows than of the averaged run's, and the ratio asserted below misses by
    // 0.01.
    let stages = [
        "--min-score",
        "0.5",
        "--smooth-s",
        "0",
        "--confirm-by",
        "rules",
    ];
    let single = score(&[&["--average-frames", "1"][..], &stages].concat());
    let averaged = score(&stages);
    let calibrated = score(&["--no-track"]);
    let tracked = score(&[]);
    let (one, six) = (error(&single), error(&averaged));
    let (cal, with_tracker) = (error(&calibrated), error(&tracked));
    eprintln!(
        "mean error: {one:.1} deg frame by frame, {six:.1} deg averaged over 6 frames, \
         {cal:.1} deg calibrated, {with_tracker:.1} deg with the tracker"
    );
    assert!(six < 0.7 * one, "{six} vs {one}");
    assert!(six < 9.0, "{six}");
    assert!(cal < 0.6 * six, "{cal} vs {six}");
    assert!(cal < 4.0, "{cal}");
    // With the tracker this run once had to stay under 0.6 of the averaged error (2.2
    // deg here); the candidates' gate that opens to 8 deg on this array (docs/tracking.md)
    // cost it 0.3 deg (2.3), and each row's direction smoothed over its track's
    // (src/track/smoother.rs) took it to 1.3.
    assert!(with_tracker < 2.0, "{with_tracker}");
    for report in [&averaged, &calibrated, &tracked] {
        assert_eq!(report.event_detection_rate, Some(1.0));
        assert_eq!(report.false_per_minute.unwrap_or(0.0), 0.0);
    }
}

/// A horizontal 6-mic circle of radius 4.63 cm at 16 kHz reads a talker's elevation
/// from how long its delays are (their `cos`), and a room's reverberation shortens them
/// by a few percent: with the diffuse part left in (`--dereverb off`), a talker in the
/// array's plane comes out well above it. Removing it (the default for a planar array)
/// brings the rows down toward the talker, with every event found and no false one.
#[test]
fn removing_the_diffuse_part_lowers_a_planar_arrays_elevation_bias() {
    let dir = tempdir();
    write(
        dir.path(),
        "circle.toml",
        geometry_toml(&circle(6, 0.0463), ""),
    );
    let (wav, truth) = speech_scene(dir.path(), "circle.toml", 16000, 1.5, 0.0);
    let score = |extra: &[&str]| analyze_and_score(dir.path(), &wav, "circle.toml", &truth, extra);
    let error = |report: &ssl::evaluate::Report| report.mean_error_deg.unwrap();
    // Each frame's own direction (`--smooth-s 0`): the stage, not the tracker's
    // smoothing, which moves every row of this talker to the same 14 deg too high and
    // with it the few that chance put within 10 deg of it (events found 2 of 3).
    let (kept, removed) = (
        score(&["--dereverb", "off", "--smooth-s", "0"]),
        score(&["--smooth-s", "0"]),
    );
    let (k, r) = (error(&kept), error(&removed));
    eprintln!("mean error: {k:.1} deg with the diffuse part, {r:.1} deg without");
    assert!(r < k - 2.0, "{r} vs {k}");
    for report in [&kept, &removed] {
        assert_eq!(report.event_detection_rate, Some(1.0));
        assert_eq!(report.false_per_minute.unwrap_or(0.0), 0.0);
    }
}
