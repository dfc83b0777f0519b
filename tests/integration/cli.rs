//! What the command line tells: metadata with stable types, a threshold per microphone
//! pair, a progress bar in audio time with a summary per file, and a reason when a file
//! gives (almost) no detections.

use crate::support;

use ssl::geometry::{angle_between_deg, unit_from_angles};
use ssl::sim::freefield::{Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use std::path::Path;
use std::process::Command;
use support::*;

fn example(args: &[&str]) -> std::process::Output {
    let mut all = vec![
        "analyze",
        "testdata/example.wav",
        "-g",
        "testdata/prism.toml",
    ];
    all.extend_from_slice(args);
    ssl()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(all)
        .output()
        .unwrap()
}

/// The example analysed as one JSON document (`-f json` after `args`); the run must
/// succeed.
fn example_json(args: &[&str]) -> serde_json::Value {
    let out = example(&[args, &["-f", "json"]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The JSON metadata records the configuration resolved: every choice a preset leaves
/// to another made explicit, numbers as given, and it reads back as a configuration
/// that runs the same.
#[test]
fn the_json_metadata_records_the_configuration_resolved() {
    let out = example(&[
        "-f",
        "json",
        "--alpha",
        "0.4",
        "-n",
        "1024",
        "--min-score",
        "0.5",
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("\"alpha\":0.4,"), "{}", &text[..600]);
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let p = &doc["parameters"];
    assert_eq!(p["framing"]["size"]["samples"], 1024);
    assert_eq!(p["threshold"]["fixed"]["per_pair"], 0.5);
    assert_eq!(p["tolerance"]["us"], 50.0);
    assert_eq!(p["weighting"]["reverb_level"], 0.0);
    // Under a fixed threshold, no second look once a talker's pattern is removed, and
    // no candidates nor riders.
    assert_eq!(p["talkers"]["patterns_s"], 0.0);
    assert_eq!(p["talkers"]["candidates"], 1.0);
    assert_eq!(p["talkers"]["riders"], 1.0);
    // The default frame size: "auto" in the parameters, the size used in the file's
    // entry; the default threshold is calibrated, with late reverberation.
    let doc = example_json(&[]);
    let p = &doc["parameters"];
    assert_eq!(p["framing"]["size"], "auto");
    assert_eq!(doc["files"][0]["frame_size"], 1024);
    assert_eq!(p["threshold"]["calibrated"]["sigmas"], 6.0);
    assert_eq!(p["weighting"]["reverb_level"], 0.5);
    assert_eq!(p["room"]["background_s"], 2.0);
    assert_eq!(p["talkers"]["patterns_s"], 0.17);
    assert_eq!(p["talkers"]["candidates"], 0.4);
    assert_eq!(p["talkers"]["riders"], 0.3);
    assert_eq!(p["speed_of_sound"], 343.0);
    let mut config: ssl::Config = serde_json::from_value(p.clone()).unwrap();
    config.speed_of_sound = None;
    assert_eq!(config.resolved(), config);
    assert_eq!(
        config.settings().unwrap().method,
        ssl::Config::default().settings().unwrap().method.clone()
    );
    let doc = example_json(&["--riders", "0.35"]);
    assert_eq!(doc["parameters"]["talkers"]["riders"], 0.35);
    // The paper's method: the published choices, each written out.
    let p = &example_json(&["--paper"])["parameters"];
    assert_eq!(p["tolerance"]["samples"], 2.0);
    assert_eq!(p["threshold"]["fixed"]["per_pair"], 0.5);
    assert_eq!(p["peaks"]["interpolation"], "parabolic");
    assert_eq!(p["room"]["dereverb"], "off");
}

/// The diffuse part is removed by default only for planar and linear arrays: the
/// example's prism (3-D) gives the same bytes with it off, and other rows with it on.
#[test]
fn the_diffuse_part_is_removed_for_a_3d_array_only_when_asked() {
    let default = example(&[]);
    let off = example(&["--dereverb", "off"]);
    let on = example(&["--dereverb", "on"]);
    for o in [&default, &off, &on] {
        assert!(o.status.success(), "{}", stderr(o));
    }
    assert!(default.stdout.len() > 1000);
    assert_eq!(default.stdout, off.stdout);
    assert_ne!(default.stdout, on.stdout);
}

/// The single bins' riders are on with the tracker and say so in the JSON document, off
/// with `--no-bin-votes`, `--no-track` and `--paper`; on the example's prism (pairs of
/// 36-71 cm, too long for a bin's phase to be its delay) they change no row.
#[test]
fn the_single_bins_riders_leave_the_prism_as_it_was() {
    let on = example_json(&[]);
    let off = example_json(&["--no-bin-votes"]);
    assert_eq!(on["parameters"]["talkers"]["bin_votes"], true);
    assert_eq!(off["parameters"]["talkers"]["bin_votes"], false);
    assert_eq!(
        example_json(&["--no-track"])["parameters"]["talkers"]["bin_votes"],
        false
    );
    assert_eq!(
        example_json(&["--paper"])["parameters"]["talkers"]["bin_votes"],
        false
    );
    assert!(!on["detections"].as_array().unwrap().is_empty());
    assert_eq!(on["detections"], off["detections"]);
}

/// The example's true sources' directions (`testdata/example.truth.json`).
fn example_sources() -> Vec<[f64; 3]> {
    let truth: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata/example.truth.json"),
        )
        .unwrap(),
    )
    .unwrap();
    truth["sources"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            [
                s["x"].as_f64().unwrap(),
                s["y"].as_f64().unwrap(),
                s["z"].as_f64().unwrap(),
            ]
        })
        .collect()
}

/// How far (degrees) a JSON row's direction is from the nearest of `sources`.
fn off_nearest(sources: &[[f64; 3]], r: &serde_json::Value) -> f64 {
    let v = [
        r["x"].as_f64().unwrap(),
        r["y"].as_f64().unwrap(),
        r["z"].as_f64().unwrap(),
    ];
    sources
        .iter()
        .map(|s| {
            (s[0] * v[0] + s[1] * v[1] + s[2] * v[2])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Each tracked row's direction is its track's around it (`--smooth-s`, 0.2 s by
/// default): the same rows as with `--smooth-s 0` (frames, sources, scores), as near the
/// example's true sources; the JSON document says which; a window over 1 s
/// is refused, and so is smoothing without a tracker.
#[test]
fn tracked_rows_are_smoothed_over_their_track() {
    let smooth = example_json(&[]);
    let raw = example_json(&["--smooth-s", "0"]);
    assert_eq!(smooth["parameters"]["tracking"]["smooth_s"], 0.2);
    assert_eq!(raw["parameters"]["tracking"]["smooth_s"], 0.0);
    let (a, b) = (
        smooth["detections"].as_array().unwrap(),
        raw["detections"].as_array().unwrap(),
    );
    assert!(a.len() > 50, "{}", a.len());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        for field in ["time_s", "frame", "source", "score"] {
            assert_eq!(x[field], y[field], "{field}");
        }
    }
    let sources = example_sources();
    let mean = |rows: &[serde_json::Value]| {
        rows.iter().map(|r| off_nearest(&sources, r)).sum::<f64>() / rows.len() as f64
    };
    let (smoothed, own) = (mean(a), mean(b));
    eprintln!("mean error {smoothed:.3} deg smoothed, {own:.3} deg each frame's own");
    // The example's rows are exact to a few hundredths of a degree: the mean of
    // neighbours keeps them so (tests/integration/talkers_at_once.rs shows what it gains where
    // frames scatter).
    assert!(smoothed < own + 0.02, "{smoothed} vs {own}");
    assert!(a.iter().all(|r| off_nearest(&sources, r) < 0.5));
    let long = example(&["--smooth-s", "2"]);
    assert!(!long.status.success());
    assert!(stderr(&long).contains("--smooth-s"), "{}", stderr(&long));
    let untracked = example(&["--smooth-s", "0.2", "--no-track"]);
    assert!(!untracked.status.success());
}

/// `--wpe` says so in the JSON document, and the example's sources are still found where
/// they are (the truth beside it), on one thread as on two.
#[test]
fn the_input_dereverberated_keeps_the_example_s_sources() {
    let one = example(&["--wpe", "-f", "json", "-j", "1"]);
    let two = example(&["--wpe", "-f", "json", "-j", "2"]);
    assert!(one.status.success(), "{}", stderr(&one));
    assert_eq!(one.stdout, two.stdout);
    let doc: serde_json::Value = serde_json::from_slice(&one.stdout).unwrap();
    assert_eq!(doc["parameters"]["room"]["wpe"], true);
    let plain: serde_json::Value =
        serde_json::from_slice(&example(&["-f", "json"]).stdout).unwrap();
    assert_eq!(plain["parameters"]["room"]["wpe"], false);
    let sources = example_sources();
    let rows = doc["detections"].as_array().unwrap();
    let near = |r: &serde_json::Value| off_nearest(&sources, r);
    let plain_rows = plain["detections"].as_array().unwrap().len();
    eprintln!("{} rows with --wpe, {plain_rows} without", rows.len());
    assert!(rows.len() * 10 >= plain_rows * 8);
    assert!(rows.iter().all(|r| near(r) < 5.0));
}

#[test]
fn min_score_is_per_microphone_pair() {
    // Frame by frame: averaging over frames already finds the example's one weak frame.
    // Without tracking: no candidates under the threshold.
    let rows = |args: &[&str]| {
        let out = example(&[args, &["--average-frames", "1", "--no-track"]].concat());
        assert!(out.status.success());
        parse_csv(&String::from_utf8(out.stdout).unwrap())
    };
    let default = rows(&["--min-score", "0.5"]);
    assert!(!default.is_empty());
    let lower = rows(&["--min-score", "0.3"]);
    assert!(
        lower.len() > default.len(),
        "{} vs {}",
        lower.len(),
        default.len()
    );
    assert!(lower.iter().all(|r| r.score >= 0.3 * 28.0 - 1e-3));
    assert!(lower.iter().any(|r| r.score < 0.5 * 28.0));
}

/// Runs `ssl args` with stderr on a terminal (util-linux `script`), the rows to
/// out.csv; returns what it shows.
fn on_terminal(dir: &Path, args: &str) -> String {
    on_terminal_raw(dir, &format!("{args} -o {}", s(&dir.join("out.csv"))))
}

/// Runs `ssl args` with stdout and stderr on a terminal; returns what it shows.
fn on_terminal_raw(dir: &Path, args: &str) -> String {
    let cmd = format!("{} {args}", env!("CARGO_BIN_EXE_ssl"));
    let out = Command::new("script")
        .args(["-qec", &cmd, "/dev/null"])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8_lossy(&out.stdout).replace('\r', "\n")
}

#[test]
fn the_progress_bar_counts_audio_time_and_each_file_ends_with_a_summary() {
    let dir = tempdir();
    let sc = scene(
        prism(),
        48000,
        &[(30.0, 10.0, Signal::WhiteNoise)],
        20.0,
        0.005,
        1,
    );
    render_wav(dir.path(), "long.wav", &sc, Encoding::Int16);
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let shown = on_terminal(dir.path(), "analyze long.wav -g prism.toml -j 1");
    assert!(
        shown.contains("of 0:20.3"),
        "audio time of the total: {shown}"
    );
    assert!(shown.contains("x real time"), "{shown}");
    assert!(shown.contains("ETA"), "{shown}");
    let summary = shown
        .lines()
        .find(|l| l.contains("of audio in"))
        .unwrap_or_else(|| panic!("a summary line: {shown}"));
    assert!(
        summary.contains("long.wav: 0:20.3 of audio in"),
        "{summary}"
    );
    assert!(
        summary.contains(" rows (") && summary.contains("frames with a detection)"),
        "{summary}"
    );
    // Rows on the terminal: no bar to tear them, no summary line among them.
    let shown = on_terminal_raw(dir.path(), "analyze long.wav -g prism.toml -j 1");
    assert!(
        !shown.contains("ETA") && !shown.contains("of audio in"),
        "{shown}"
    );
    assert!(shown.contains("time_s,azimuth_deg"), "{shown}");
}

#[test]
fn no_detections_come_with_a_reason() {
    let dir = tempdir();
    // A loudspeaker calibration: white noise from the first sample to the last.
    let u = unit_from_angles(-40.0, 15.0);
    let steady = Scene {
        sample_rate: 48000,
        duration_s: 3.0,
        mics: prism(),
        speed_of_sound: 343.0,
        sources: vec![Source {
            place: Place::Direction(u),
            signal: Signal::WhiteNoise,
            start_s: 0.0,
            end_s: 3.0,
            level: 0.05,
        }],
        sensor_noise: 0.002,
        seed: 4,
    };
    let wav = render_wav(dir.path(), "calibration.wav", &steady, Encoding::Int16);
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    // Without tracking: its candidates under the threshold find the loudspeaker in
    // about a tenth of the frames.
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geo),
        "-f",
        "json",
        "--no-track",
    ]);
    assert!(out.status.success());
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let err = stderr(&out);
    assert!(
        doc["detections"].as_array().unwrap().len() * 100
            < doc["files"][0]["frames"].as_u64().unwrap() as usize,
        "few detections"
    );
    assert!(
        err.contains("steady from start to end") && err.contains("--no-weighting"),
        "{err}"
    );
    let entry = doc["files"][0]["warnings"].to_string();
    assert!(entry.contains("steady from start to end"), "{entry}");
    // And --no-weighting localizes it, as the message says.
    let out = run(&["analyze", s(&wav), "-g", s(&geo), "--no-weighting"]);
    let rows = parse_csv(&String::from_utf8(out.stdout).unwrap());
    assert!(rows.len() > 200, "{} detections", rows.len());
    assert!(rows.iter().all(|r| angle_between_deg(&r.u, &u) < 2.0));
    // Sources between pauses under a threshold too high for them: the best score and the
    // threshold are named, and the recording is not called steady.
    let out = example(&["--min-score", "50"]);
    let err = stderr(&out);
    assert!(out.stdout.len() < 100, "no detections");
    assert!(
        err.contains("per microphone pair, against a threshold of 50 per pair"),
        "{err}"
    );
    assert!(
        err.contains("--min-score") && !err.contains("steady"),
        "{err}"
    );
}

#[test]
fn an_array_whose_delays_are_a_few_samples_draws_a_warning() {
    let dir = tempdir();
    // A 4-mic square of 45.7 mm side at 16 kHz: the diagonal is 3.0 samples.
    let h = 0.0457 / 2.0;
    let square = [
        nalgebra::Vector3::new(h, h, 0.0),
        nalgebra::Vector3::new(-h, h, 0.0),
        nalgebra::Vector3::new(-h, -h, 0.0),
        nalgebra::Vector3::new(h, -h, 0.0),
    ];
    let sc = scene(
        square.to_vec(),
        16000,
        &[(40.0, 20.0, Signal::WhiteNoise)],
        0.5,
        0.005,
        1,
    );
    let wav = render_wav(dir.path(), "small.wav", &sc, Encoding::Int16);
    let geo = write(dir.path(), "square.toml", geometry_toml(&square, ""));
    let out = run(&["analyze", s(&wav), "-g", s(&geo)]);
    assert!(out.status.success());
    assert!(
        stderr(&out).contains("largest delay is only 3.0 samples at 16000 Hz"),
        "{}",
        stderr(&out)
    );
    // Said once for a run of several files at that rate; a file's own error comes
    // before its remarks.
    let bytes = std::fs::read(&wav).unwrap();
    let cut = write(dir.path(), "cut.wav", &bytes[..bytes.len() / 2]);
    let out = run(&["analyze", s(&wav), s(&wav), s(&cut), "-g", s(&geo)]);
    let err = stderr(&out);
    assert_eq!(err.matches("largest delay is only").count(), 1, "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.contains("cut.wav")).collect();
    assert!(lines[0].starts_with("ssl: error:"), "{err}");
    // `--no-warn coarse-delays` silences it alone: the repeated file is still said,
    // and the cut file's error.
    let out = run(&[
        "analyze",
        s(&wav),
        s(&wav),
        s(&cut),
        "-g",
        s(&geo),
        "--no-warn",
        "coarse-delays",
    ]);
    let err = stderr(&out);
    assert!(!err.contains("largest delay is only"), "{err}");
    assert!(err.contains("the same file as"), "{err}");
    assert!(err.contains("ssl: error:"), "{err}");
    let out = run(&[
        "analyze",
        s(&wav),
        s(&wav),
        "-g",
        s(&geo),
        "--no-warn",
        "coarse-delays",
        "--no-warn",
        "repeat",
    ]);
    assert!(!stderr(&out).contains("warning"), "{}", stderr(&out));
    // The prism at 48 kHz (107 samples) draws none.
    let out = example(&[]);
    assert!(!stderr(&out).contains("largest delay"), "{}", stderr(&out));
}

/// `--frame-ms` picks the power of two nearest to that length at the file's rate (the
/// example is 48 kHz: 32 ms is 1536 samples, nearest 2048), and the metadata says what
/// was asked and what was used.
#[test]
fn frame_length_in_milliseconds() {
    let doc = example_json(&["--frame-ms", "32"]);
    assert_eq!(doc["parameters"]["framing"]["size"]["ms"], 32.0);
    assert_eq!(doc["files"][0]["frame_size"], 2048);
    let out = example(&["--frame-ms", "32", "--frame-size", "512"]);
    assert_eq!(out.status.code(), Some(2));
}

/// A recording the tracker makes nothing of, though the method detected something (a
/// fan in a corner of a small office and a 50 ms blip of speech, on a 6-mic circle at
/// 16 kHz, asking for at most 0.01 false sources an hour): no row, and a line that says
/// why and what shows the detections. At the defaults the blip is a sound, and found.
#[test]
fn a_file_whose_detections_no_track_confirms_says_so() {
    let dir = tempdir();
    let d = dir.path();
    copy_speech(d).unwrap();
    write(d, "circle.toml", geometry_toml(&circle(6, 0.0463), ""));
    write(
        d,
        "bg.toml",
        "sample_rate = 16000\nduration = 5.0\nseed = 11\nformat = \"float32\"\n\
         [room]\ndimensions = [5.0, 4.0, 2.7]\nrt60 = 0.5\n\
         [array]\ngeometry = \"circle.toml\"\nposition = [2.3, 1.9, 0.75]\nyaw_deg = 10.0\n\
         [[source]]\nazimuth_deg = 50.0\nelevation_deg = 15.0\ndistance = 1.5\n\
         signal = \"file\"\nfile = \"cmu_arctic_us_aew_a0001.wav\"\nlevel_db = -26\n\
         active = [[4.9, 4.95]]\n\
         [noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [0.3, 0.4, 2.5]\n\
         signal = \"pink\"\n[noise.diffuse]\nsignal = \"pink\"\nweight_db = -6\n",
    );
    let run = |args: &[&str]| run_ok_in(d, args);
    run(&["simulate", "bg.toml", "-o", "bg.wav"]);
    let found = run(&["analyze", "bg.wav", "-g", "circle.toml"]);
    let rows = parse_csv(&String::from_utf8_lossy(&found.stdout));
    assert!(!rows.is_empty());
    assert!(rows
        .iter()
        .all(|r| (r.azimuth_deg - 50.0).abs() < 10.0 && r.source == Some(1)));
    let strict = ["--false-per-hour", "0.01"];
    let tracked = run(&[&["analyze", "bg.wav", "-g", "circle.toml"][..], &strict].concat());
    assert_eq!(String::from_utf8_lossy(&tracked.stdout).lines().count(), 1);
    let said = stderr(&tracked);
    assert!(
        said.contains("no source confirmed: the tracker dropped all")
            && said.contains("--keep-unconfirmed"),
        "{said}"
    );
    // The JSON document's entry for the file carries the same line.
    let json = run(&[
        &["analyze", "bg.wav", "-g", "circle.toml", "-f", "json", "-q"][..],
        &strict,
    ]
    .concat());
    let doc: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let warnings = doc["files"][0]["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.as_str().unwrap().contains("no source confirmed")),
        "{warnings:?}"
    );
    let kept = run(&[
        &[
            "analyze",
            "bg.wav",
            "-g",
            "circle.toml",
            "--keep-unconfirmed",
        ][..],
        &strict,
    ]
    .concat());
    let rows = String::from_utf8_lossy(&kept.stdout).lines().count() - 1;
    assert!(rows > 0);
    assert!(
        stderr(&kept).contains(&format!("all {rows} detections")),
        "{}",
        stderr(&kept)
    );
}

/// The help says what a row holds (`source`, `uncertainty_deg`, the calibrated threshold)
/// and `ssl geometry --help` shows the file format with an example that parses.
#[test]
fn the_help_names_every_field_and_shows_the_geometry_format() {
    let help = String::from_utf8(run(&["analyze", "--help"]).stdout).unwrap();
    for needle in [
        "source (the tracked source",
        "uncertainty_deg",
        "calibrated against each file's background",
    ] {
        assert!(help.contains(needle), "{needle}");
    }
    let help = String::from_utf8(run(&["geometry", "--help"]).stdout).unwrap();
    assert!(help.contains("x forward, y left, z up"));
    let example: String = help
        .lines()
        .skip_while(|l| !l.starts_with("The file (TOML)"))
        .skip(1)
        .take_while(|l| !l.starts_with("Without channel keys"))
        .map(|l| l.split('#').next().unwrap().trim().to_string() + "\n")
        .collect();
    let g = ssl::Geometry::from_toml_str(&example).unwrap_or_else(|e| panic!("{e}: {example}"));
    assert_eq!(g.mics.len(), 2);
    assert_eq!(g.name.as_deref(), Some("my-circle"));
}

/// `--timings` prints every stage's time after the file, the stages the run goes
/// through above zero and the shares summing to the whole; the output is as without it.
#[test]
fn timings_show_every_stage_and_leave_the_output_as_it_was() {
    let plain = example(&["-q", "-j", "1"]);
    let timed = example(&["-q", "-j", "1", "--timings"]);
    assert!(plain.status.success() && timed.status.success());
    assert_eq!(plain.stdout, timed.stdout);
    assert!(stderr(&plain).is_empty(), "{}", stderr(&plain));
    let text = stderr(&timed);
    assert!(
        text.starts_with("ssl: testdata/example.wav: stage times (186 frames, 2.0 s of audio; "),
        "{text}"
    );
    let mut shares = 0.0;
    for stage in [
        "read",
        "spectra",
        "noise",
        "weighting",
        "correlation",
        "background",
        "peaks",
        "search",
        "direction",
        "steered",
        "patterns",
        "tracking",
        "output",
    ] {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(stage))
            .unwrap_or_else(|| panic!("no {stage} in {text}"));
        let fields: Vec<&str> = line.split_whitespace().collect();
        let seconds: f64 = fields[1].parse().unwrap();
        let share: f64 = fields[2].trim_end_matches('%').parse().unwrap();
        let per_frame: f64 = fields[3].parse().unwrap();
        assert!(seconds >= 0.0 && per_frame >= 0.0, "{line}");
        // Every file is read, transformed, correlated and searched; the tracker runs on
        // every frame; the example's talker has a second look.
        if [
            "read",
            "spectra",
            "correlation",
            "peaks",
            "tracking",
            "output",
        ]
        .contains(&stage)
        {
            assert!(per_frame > 0.0, "{line}");
        }
        shares += share;
    }
    assert!((shares - 100.0).abs() < 0.5, "{shares}: {text}");
}
