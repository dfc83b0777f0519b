//! The command line's handling of inputs good and bad: every bad input gets one clear
//! line on stderr naming the file and a non-zero exit, never a panic or NaN.

use crate::support;

use ssl::sim::freefield as synth;
use ssl::sim::signals::Signal;
use ssl::sim::{write_wav, Encoding};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use support::*;

/// A 0.6 s prism recording of one noise source at azimuth 30, elevation 10.
fn base_scene() -> ssl::sim::freefield::Scene {
    scene(
        prism(),
        48000,
        &[(30.0, 10.0, Signal::WhiteNoise)],
        0.4,
        0.005,
        1,
    )
}

fn setup() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempdir();
    let wav = render_wav(dir.path(), "rec.wav", &base_scene(), Encoding::Int16);
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    (dir, wav, geo)
}

/// Runs `ssl analyze FILE --geometry GEO`, expects exit 1 and one stderr error line that
/// names `name` and contains every needle.
fn expect_error(file: &str, geo: &Path, name: &str, needles: &[&str]) -> String {
    let out = run(&["analyze", file, "--geometry", s(geo)]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("ssl: error:"))
        .collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains(name), "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "missing {n:?} in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    err
}

fn detections_near_truth(stdout: &[u8]) -> Vec<Row> {
    let rows = parse_csv(std::str::from_utf8(stdout).unwrap());
    let truth = ssl::geometry::unit_from_angles(30.0, 10.0);
    for r in &rows {
        assert!(
            ssl::geometry::angle_between_deg(&r.u, &truth) < 2.0,
            "{r:?}"
        );
    }
    rows
}

#[test]
fn missing_file() {
    let (dir, _, geo) = setup();
    let missing = dir.path().join("nope.wav");
    expect_error(s(&missing), &geo, "nope.wav", &["no such file"]);
}

#[test]
fn directory_and_empty_file() {
    let (dir, _, geo) = setup();
    // A directory without recordings (its recordings are analysed: tests/batch.rs).
    let nothing = dir.path().join("nothing");
    std::fs::create_dir(&nothing).unwrap();
    expect_error(
        s(&nothing),
        &geo,
        s(&nothing),
        &["directory with no file matching"],
    );
    let empty = write(dir.path(), "empty.wav", b"");
    expect_error(s(&empty), &geo, "empty.wav", &["empty"]);
}

#[test]
fn not_a_wav() {
    let (dir, _, geo) = setup();
    let txt = write(
        dir.path(),
        "notes.wav",
        "this is not audio at all, just text\n",
    );
    expect_error(s(&txt), &geo, "notes.wav", &["not a WAV"]);
    let flac = write(
        dir.path(),
        "a.flac",
        b"fLaC\0\0\0\x22 and so on and so forth",
    );
    expect_error(s(&flac), &geo, "a.flac", &["FLAC"]);
}

#[test]
fn truncated_wav_keeps_what_is_there_and_fails() {
    let (dir, wav, geo) = setup();
    let bytes = std::fs::read(&wav).unwrap();
    let cut = write(dir.path(), "cut.wav", &bytes[..bytes.len() * 2 / 3]);
    let out = run(&["analyze", s(&cut), "--geometry", s(&geo)]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("cut.wav") && err.contains("truncated"),
        "{err}"
    );
    // The frames before the cut were analysed.
    assert!(!detections_near_truth(&out.stdout).is_empty());
    // Cut inside the header.
    let head = write(dir.path(), "head.wav", &bytes[..30]);
    expect_error(s(&head), &geo, "head.wav", &["truncated"]);
}

#[test]
fn float64_and_compressed_say_how_to_convert() {
    let (dir, _, geo) = setup();
    let f64wav = write(
        dir.path(),
        "f64.wav",
        raw_wav(
            b"RIFF",
            &fmt_body(3, 8, 48000, 64),
            &[0u8; 64 * 8 * 8],
            None,
        ),
    );
    expect_error(
        s(&f64wav),
        &geo,
        "f64.wav",
        &["64-bit float", "sox", "ffmpeg"],
    );
    let mulaw = write(
        dir.path(),
        "mulaw.wav",
        raw_wav(b"RIFF", &fmt_body(7, 8, 48000, 8), &[0u8; 64], None),
    );
    expect_error(s(&mulaw), &geo, "mulaw.wav", &["compressed", "0x0007"]);
}

#[test]
fn wrong_channel_count() {
    let (dir, _, geo) = setup();
    let six = scene(
        prism()[..6].to_vec(),
        48000,
        &[(0.0, 0.0, Signal::WhiteNoise)],
        0.1,
        0.01,
        2,
    );
    let wav = render_wav(dir.path(), "six.wav", &six, Encoding::Int16);
    expect_error(s(&wav), &geo, "six.wav", &["6 channel", "8 microphones"]);
    // More channels than microphones and no `channel` keys: say how to pick them.
    let mut ten = synth::render(&base_scene());
    ten.push(vec![0.0; ten[0].len()]);
    ten.push(vec![0.0; ten[0].len()]);
    let wav = dir.path().join("ten.wav");
    write_wav(&wav, &ten, 48000, Encoding::Int16).unwrap();
    expect_error(s(&wav), &geo, "ten.wav", &["10 channel", "channel = N"]);
    // A geometry that names a channel the file lacks.
    let channels: Vec<usize> = (0..8).map(|i| i + 5).collect();
    let toml = geometry_toml_with_channels(&prism(), &channels);
    let picky = write(dir.path(), "picky.toml", toml);
    expect_error(s(&wav), &picky, "ten.wav", &["channel 10", "10 channel"]);
}

#[test]
fn channel_keys_pick_channels_from_a_wider_file() {
    let (dir, _, _) = setup();
    // Channels 0 and 1 are junk; the mics are on channels 2..9 in reverse order.
    let mics = synth::render(&base_scene());
    let len = mics[0].len();
    let mut chans = vec![vec![0.3; len], vec![0.0; len]];
    chans.extend(mics.iter().rev().cloned());
    let wav = dir.path().join("wide.wav");
    write_wav(&wav, &chans, 48000, Encoding::Int16).unwrap();
    let channels: Vec<usize> = (0..8).map(|i| 9 - i).collect();
    let toml = geometry_toml_with_channels(&prism(), &channels);
    let geo = write(dir.path(), "wide.toml", toml);
    let out = run(&["analyze", s(&wav), "--geometry", s(&geo)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(detections_near_truth(&out.stdout).len() > 20);
}

#[test]
fn shorter_than_one_frame() {
    let (dir, _, geo) = setup();
    let short: Vec<Vec<f32>> = synth::render(&base_scene())
        .into_iter()
        .map(|c| c[..1000].to_vec())
        .collect();
    let wav = dir.path().join("short.wav");
    write_wav(&wav, &short, 48000, Encoding::Int16).unwrap();
    expect_error(
        s(&wav),
        &geo,
        "short.wav",
        &["shorter than one analysis frame", "1024"],
    );
}

#[test]
fn nan_and_infinite_samples() {
    let (dir, _, geo) = setup();
    for (name, bad, word) in [
        ("nan.wav", f32::NAN, "NaN"),
        ("inf.wav", f32::INFINITY, "infinite"),
    ] {
        let mut chans = synth::render(&base_scene());
        chans[3][5000] = bad;
        let wav = dir.path().join(name);
        write_wav(&wav, &chans, 48000, Encoding::Float32).unwrap();
        let err = expect_error(s(&wav), &geo, name, &[word, "channel 3"]);
        assert!(!err.contains("NaN,") && !err.contains("null"));
    }
}

#[test]
fn digital_silence_runs_with_no_detections() {
    let (dir, _, geo) = setup();
    let wav = dir.path().join("zero.wav");
    write_wav(&wav, &vec![vec![0.0; 48000]; 8], 48000, Encoding::Int16).unwrap();
    let out = run(&["analyze", s(&wav), "--geometry", s(&geo)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().count(),
        1,
        "header only"
    );
    assert!(stderr(&out).contains("digital silence"));
}

#[test]
fn dead_and_stuck_channels_are_named_and_left_out() {
    let (dir, _, geo) = setup();
    for (name, value) in [("dead.wav", 0.0f32), ("stuck.wav", 0.25)] {
        let mut chans = synth::render(&base_scene());
        chans[5].iter_mut().for_each(|v| *v = value);
        let wav = dir.path().join(name);
        write_wav(&wav, &chans, 48000, Encoding::Int16).unwrap();
        let out = run(&["analyze", s(&wav), "--geometry", s(&geo)]);
        assert!(out.status.success(), "{}", stderr(&out));
        let err = stderr(&out);
        assert!(
            err.contains("mic 6 (channel 5)") && err.contains("constant"),
            "{err}"
        );
        let rows = detections_near_truth(&out.stdout);
        assert!(rows.len() > 20, "{}", rows.len());
        assert!(rows.iter().all(|r| r.mics == 7));
    }
}

#[test]
fn stdin_with_placeholder_lengths_matches_the_file() {
    let (_dir, wav, geo) = setup();
    let from_file = run(&["analyze", s(&wav), "--geometry", s(&geo)]);
    assert!(from_file.status.success());
    let bytes = std::fs::read(&wav).unwrap();
    // hound wrote WAVE_FORMAT_EXTENSIBLE: find the data chunk's length field.
    let data_at = bytes.windows(4).position(|w| w == b"data").unwrap();
    for placeholder in [0xFFFF_FFFFu32, 0] {
        let mut piped = bytes.clone();
        piped[4..8].copy_from_slice(&placeholder.to_le_bytes());
        piped[data_at + 4..data_at + 8].copy_from_slice(&placeholder.to_le_bytes());
        let out = run_with_stdin(&["analyze", "-", "--geometry", s(&geo)], piped);
        assert!(out.status.success(), "{}", stderr(&out));
        let text = String::from_utf8(out.stdout).unwrap();
        let expect = String::from_utf8(from_file.stdout.clone())
            .unwrap()
            .replace(s(&wav), "<stdin>");
        assert_eq!(text, expect);
    }
}

/// `ssl analyze` of `bytes` written as a file, and through a pipe (see
/// [`analyze_file_and_pipe`]).
fn file_and_pipe(dir: &Path, geo: &Path, bytes: &[u8]) -> [(Option<i32>, String, String); 2] {
    let path = dir.join("cut.wav");
    std::fs::write(&path, bytes).unwrap();
    analyze_file_and_pipe(&path, &["-g", s(geo)])
}

#[test]
fn truncation_is_an_error_the_same_from_a_file_and_a_pipe() {
    // Issue 31, item 6: through a pipe, and from a file cut at a read-block boundary,
    // a truncated recording ended with exit 0 and no message; a trailing partial sample
    // frame vanished.
    let (dir, wav, geo) = setup();
    let bytes = std::fs::read(&wav).unwrap();
    let data_at = bytes.windows(4).position(|w| w == b"data").unwrap() + 8;
    let block = 16; // 8 channels of 16 bits
                    // A cut inside a frame, at whole frames, and at the reader's block boundaries
                    // (4128 frames, and multiples).
    for cut in [
        data_at + 1000 * block + 7,
        data_at + 1000 * block,
        data_at + 4128 * block,
        data_at + 2 * 4128 * block,
        data_at + 3 * 4128 * block,
    ] {
        let [file, pipe] = file_and_pipe(dir.path(), &geo, &bytes[..cut]);
        assert_eq!(
            file, pipe,
            "cut at {cut}: the same answer from a file and a pipe"
        );
        assert_eq!(file.0, Some(1), "cut at {cut}: {}", file.2);
        assert!(
            file.2.contains("IN: truncated WAV"),
            "cut at {cut}: {}",
            file.2
        );
    }
    // A placeholder length (a streaming writer's) with a partial frame at the end.
    let mut streamed = bytes.clone();
    streamed[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    streamed[data_at - 4..data_at].copy_from_slice(&u32::MAX.to_le_bytes());
    streamed.extend_from_slice(&[0; 5]);
    let [file, pipe] = file_and_pipe(dir.path(), &geo, &streamed);
    assert_eq!(file, pipe);
    assert_eq!(file.0, Some(1));
    assert!(
        file.2
            .contains("truncated WAV: the data ends 5 bytes into a sample frame of 16 bytes"),
        "{}",
        file.2
    );
    // A declared length that is not whole frames.
    let mut odd = bytes.clone();
    let declared = u32::from_le_bytes(odd[data_at - 4..data_at].try_into().unwrap()) - 3;
    odd[data_at - 4..data_at].copy_from_slice(&declared.to_le_bytes());
    let [file, pipe] = file_and_pipe(dir.path(), &geo, &odd);
    assert_eq!(file, pipe);
    assert!(
        file.2.contains("13 bytes into a sample frame"),
        "{}",
        file.2
    );
    // The whole file: the same rows, exit 0, from both.
    let [file, pipe] = file_and_pipe(dir.path(), &geo, &bytes);
    assert_eq!(file, pipe);
    assert_eq!(file.0, Some(0), "{}", file.2);
}

#[test]
fn several_files_in_order_and_a_failure_does_not_stop_the_others() {
    let (dir, wav, geo) = setup();
    let other = render_wav(
        dir.path(),
        "other.wav",
        &scene(
            prism(),
            48000,
            &[(-100.0, -20.0, Signal::WhiteNoise)],
            0.3,
            0.005,
            9,
        ),
        Encoding::Int16,
    );
    let missing = dir.path().join("missing.wav");
    let out = run(&[
        "analyze",
        s(&wav),
        s(&missing),
        s(&other),
        "--geometry",
        s(&geo),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.contains("missing.wav"), "{err}");
    let rows = parse_csv(&String::from_utf8(out.stdout).unwrap());
    let first_other = rows
        .iter()
        .position(|r| r.file.ends_with("other.wav"))
        .unwrap();
    assert!(first_other > 10);
    assert!(rows[..first_other]
        .iter()
        .all(|r| r.file.ends_with("rec.wav")));
    assert!(rows[first_other..]
        .iter()
        .all(|r| r.file.ends_with("other.wav")));
}

#[test]
fn output_file_is_written_atomically() {
    let (dir, wav, geo) = setup();
    let out_path = dir.path().join("out.csv");
    std::fs::write(&out_path, "previous contents\n").unwrap();
    // A run that fails before it starts leaves the old file alone and no temp files.
    let bad_geo = write(
        dir.path(),
        "bad.toml",
        "[[mic]]\nposition = [0.0, 0.0, 0.0]\n",
    );
    let out = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&bad_geo),
        "-o",
        s(&out_path),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(&out_path).unwrap(),
        "previous contents\n"
    );
    // A successful run replaces it whole.
    let out = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&geo),
        "-o",
        s(&out_path),
        "--format",
        "json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
    assert!(doc["detections"].as_array().unwrap().len() > 20);
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
    // An output directory that does not exist is an error naming it.
    let nowhere = dir.path().join("no/such/dir/out.csv");
    let out = run(&["analyze", s(&wav), "--geometry", s(&geo), "-o", s(&nowhere)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("out.csv"), "{}", stderr(&out));
}

#[cfg(unix)]
#[test]
fn output_to_a_device_or_through_a_link_keeps_them() {
    use std::os::unix::fs::FileTypeExt;
    let (dir, wav, geo) = setup();
    // -o /dev/null writes into the device; an atomic rename would replace it with a file.
    let out = run(&["analyze", s(&wav), "--geometry", s(&geo), "-o", "/dev/null"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let meta = std::fs::metadata("/dev/null").unwrap();
    assert!(
        meta.file_type().is_char_device(),
        "/dev/null is no longer a device"
    );
    // A symlinked output stays a link; its target gets the detections.
    let real = dir.path().join("real.csv");
    std::fs::write(&real, "old\n").unwrap();
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let out = run(&["analyze", s(&wav), "--geometry", s(&geo), "-o", s(&link)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&real)
        .unwrap()
        .starts_with("time_s,"));
}

#[test]
fn json_and_ndjson_carry_the_contract_fields_in_order() {
    let (_dir, wav, geo) = setup();
    let csv = run(&["analyze", s(&wav), "--geometry", s(&geo)]);
    let rows = parse_csv(&String::from_utf8(csv.stdout).unwrap());
    let nd = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&geo),
        "--format",
        "ndjson",
    ]);
    assert!(nd.status.success());
    let text = String::from_utf8(nd.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), rows.len());
    for (line, row) in lines.iter().zip(&rows) {
        assert!(line.starts_with("{\"time_s\":"), "{line}");
        let keys: Vec<usize> = [
            "\"time_s\"",
            "\"azimuth_deg\"",
            "\"elevation_deg\"",
            "\"x\"",
            "\"y\"",
            "\"z\"",
            "\"score\"",
        ]
        .iter()
        .map(|k| line.find(k).unwrap())
        .collect();
        assert!(keys.windows(2).all(|w| w[0] < w[1]), "{line}");
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        assert_eq!(v["time_s"].as_f64().unwrap(), row.time_s);
        assert_eq!(v["azimuth_deg"].as_f64().unwrap(), row.azimuth_deg);
    }
    let js = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&geo),
        "--format",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&js.stdout).unwrap();
    assert_eq!(doc["tool"]["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(doc["geometry"]["shape"], "3-D");
    assert_eq!(doc["parameters"]["weighting"]["alpha"], 0.4);
    assert_eq!(doc["files"][0]["sample_rate"], 48000);
    assert_eq!(doc["detections"].as_array().unwrap().len(), rows.len());
}

#[test]
fn planar_metadata_says_which_side() {
    let (dir, wav, _) = setup();
    let mics: Vec<_> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0;
            nalgebra::Vector3::new(0.1 * a.cos(), 0.1 * a.sin(), 0.0)
        })
        .collect();
    let geo = write(dir.path(), "ring.toml", geometry_toml(&mics, ""));
    let js = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&geo),
        "--format",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&js.stdout).unwrap();
    assert_eq!(doc["geometry"]["shape"], "planar");
    assert!(doc["geometry"]["note"]
        .as_str()
        .unwrap()
        .contains("mirror image"));
}

#[test]
fn closing_the_pipe_early_is_not_a_panic() {
    let dir = tempdir();
    let long = scene(
        prism(),
        48000,
        &[(10.0, 5.0, Signal::WhiteNoise)],
        12.0,
        0.005,
        3,
    );
    let wav = render_wav(dir.path(), "long.wav", &long, Encoding::Int16);
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    for format in ["csv", "ndjson", "json"] {
        let mut child = ssl()
            .args([
                "analyze",
                s(&wav),
                "--geometry",
                s(&geo),
                "--format",
                format,
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut stdout = child.stdout.take().unwrap();
        let mut first = [0u8; 100];
        stdout.read_exact(&mut first).unwrap();
        drop(stdout);
        let out = child.wait_with_output().unwrap();
        let err = stderr(&out);
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(out.status.code(), Some(0), "{format}: {err}");
    }
}

#[test]
fn output_is_the_same_for_any_number_of_threads() {
    // Several sources, a dead channel in part of the file, and more than one block of
    // frames, in every format.
    let dir = tempdir();
    let dirs = [
        (10.0, 5.0, Signal::WhiteNoise),
        (-120.0, 30.0, Signal::Clicks { per_second: 10.0 }),
        (80.0, -20.0, Signal::WhiteNoise),
    ];
    let sc = scene(prism(), 48000, &dirs, 1.0, 0.005, 12);
    let mut chans = synth::render(&sc);
    chans[2][20000..60000].iter_mut().for_each(|v| *v = 0.0);
    let wav = dir.path().join("threads.wav");
    write_wav(&wav, &chans, 48000, Encoding::Int16).unwrap();
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    // The diffuse part's removal (off by default on a 3-D array) reads the frames
    // before each one's: in one format with it on.
    for (format, dereverb) in [
        ("csv", "auto"),
        ("json", "auto"),
        ("ndjson", "auto"),
        ("csv", "on"),
    ] {
        let outputs: Vec<Vec<u8>> = ["1", "2", "3"]
            .iter()
            .map(|t| {
                let o = run(&[
                    "analyze",
                    s(&wav),
                    "--geometry",
                    s(&geo),
                    "--format",
                    format,
                    "--threads",
                    t,
                    "--dereverb",
                    dereverb,
                ]);
                assert!(o.status.success(), "{}", stderr(&o));
                o.stdout
            })
            .collect();
        assert!(
            outputs[0].len() > 1000,
            "{format}: {} bytes",
            outputs[0].len()
        );
        assert_eq!(outputs[0], outputs[1], "{format}: 1 vs 2 threads");
        assert_eq!(outputs[0], outputs[2], "{format}: 1 vs 3 threads");
    }
}

#[test]
fn bad_geometry_file() {
    let (dir, wav, _) = setup();
    let bad = write(
        dir.path(),
        "bad.toml",
        "[[mic]]\nposition = [0.0, 0.0, oops]\n",
    );
    let out = run(&["analyze", s(&wav), "--geometry", s(&bad)]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("bad.toml") && err.contains("line 2"), "{err}");
    let missing = dir.path().join("none.toml");
    let out = run(&["analyze", s(&wav), "--geometry", s(&missing)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("none.toml"));
}

#[test]
fn usage_errors_exit_2() {
    let (_dir, wav, geo) = setup();
    for args in [
        vec!["analyze", s(&wav)],
        vec!["analyze", s(&wav), "--geometry", s(&geo), "--alpha", "2"],
        vec!["analyze", s(&wav), "--geometry", s(&geo), "--peaks", "0"],
        vec![
            "analyze",
            s(&wav),
            "--geometry",
            s(&geo),
            "--tolerance",
            "-1",
        ],
        vec!["analyze", s(&wav), "--geometry", s(&geo), "--format", "xml"],
        vec![
            "analyze",
            s(&wav),
            "--geometry",
            s(&geo),
            "--patterns-s",
            "-0.1",
        ],
        vec![
            "analyze",
            s(&wav),
            "--geometry",
            s(&geo),
            "--no-track",
            "--patterns-s",
            "0.2",
        ],
        vec!["analyze", s(&wav), "--geometry", s(&geo), "--riders", "0"],
        vec!["analyze", s(&wav), "--geometry", s(&geo), "--riders", "1.5"],
        vec![
            "analyze",
            s(&wav),
            "--geometry",
            s(&geo),
            "--no-track",
            "--riders",
            "0.3",
        ],
        vec!["frobnicate"],
    ] {
        let out = run(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
    }
}

/// Rows wait in memory as long as the tracker's delay (and its confirmation window):
/// more than 10 s is refused, naming the limit, so that memory stays bounded.
#[test]
fn a_tracker_delay_past_its_limit_is_refused() {
    let (_dir, wav, geo) = setup();
    for option in ["--delay-s", "--confirm-s"] {
        for value in ["10.5", "1e9"] {
            let out = run(&["analyze", s(&wav), "--geometry", s(&geo), option, value]);
            assert_eq!(out.status.code(), Some(2), "{option} {value}");
            assert!(stderr(&out).contains("over 10 s"), "{}", stderr(&out));
        }
        let out = run(&["analyze", s(&wav), "--geometry", s(&geo), option, "10"]);
        assert!(out.status.success(), "{option} 10: {}", stderr(&out));
    }
    // The library's own check says the same.
    let track = {
        let mut p = ssl::track::TrackParams::default();
        p.delay_s = 11.0;
        p
    };
    let err = track.check().unwrap_err().to_string();
    assert!(err.contains("at most 10 s"), "{err}");
    assert!(ssl::track::TrackParams::default().check().is_ok());
}

#[test]
fn frame_too_small_for_the_array_is_explained() {
    let (_dir, wav, geo) = setup();
    let out = run(&[
        "analyze",
        s(&wav),
        "--geometry",
        s(&geo),
        "--frame-size",
        "128",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("--frame-size 256"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn geometry_command_reports_what_it_understood() {
    let (dir, _, geo) = setup();
    let out = run(&["geometry", s(&geo), "--rate", "16000"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("microphones:     8"), "{text}");
    assert!(text.contains("shape:           3-D"));
    assert!(text.contains("aperture:        0.7346 m"));
    // Largest lag between opposite corners at 16 kHz: 0.7346 / 343 * 16000 = 34.27.
    assert!(text.contains("34.27"), "{text}");
    let line = write(
        dir.path(),
        "line.toml",
        "[[mic]]\nposition=[0.0,0,0]\n[[mic]]\nposition=[0.1,0,0]\n",
    );
    let text = String::from_utf8(run(&["geometry", s(&line)]).stdout).unwrap();
    assert!(
        text.contains("linear") && text.contains("angle to the axis"),
        "{text}"
    );
}
