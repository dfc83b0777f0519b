//! One way through the method: the same recording through every public entry point (a
//! WAV file, WAV bytes from a reader, channels in memory, and the binary reading a file
//! and standard input) on one thread and several gives identical detections.

use crate::support;

use ssl::geometry::unit_from_angles;
use ssl::method::FrameStats;
use ssl::sim::freefield::{Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use ssl::stream::SampleSource;
use ssl::{Analysis, Detection, Params, Summary};
use std::io::Cursor;
use std::ops::ControlFlow;
use std::process::Stdio;
use support::*;

/// Runs an analysis to its end: every detection and the summary.
fn collect<S: SampleSource>(analysis: Analysis<S>) -> (Vec<Detection>, Summary) {
    let mut all = Vec::new();
    let (summary, result) = analysis.run(|_, d| {
        all.extend_from_slice(d);
        ControlFlow::Continue(())
    });
    result.unwrap();
    (all, summary)
}

fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn every_entry_point_gives_the_same_detections() {
    // Three sources over 6 s: more than one block of frames, a fan throughout so that the
    // noise estimate and its priming matter.
    let sources = vec![
        Source {
            place: Place::Direction(unit_from_angles(40.0, 10.0)),
            signal: Signal::SpeechLike,
            start_s: 0.5,
            end_s: 2.0,
            level: 0.05,
        },
        Source {
            place: Place::Direction(unit_from_angles(-100.0, -15.0)),
            signal: Signal::Clicks { per_second: 12.0 },
            start_s: 2.5,
            end_s: 4.0,
            level: 0.2,
        },
        Source {
            place: Place::Direction(unit_from_angles(170.0, 30.0)),
            signal: Signal::PinkNoise,
            start_s: 0.0,
            end_s: 6.0,
            level: 0.01,
        },
    ];
    let scene = Scene {
        sample_rate: 48000,
        duration_s: 6.0,
        mics: prism(),
        speed_of_sound: 343.0,
        sources,
        sensor_noise: 0.002,
        seed: 11,
    };
    let dir = tempdir();
    let wav = render_wav(dir.path(), "rec.wav", &scene, Encoding::Int16);
    let name = wav.to_str().unwrap();
    let bytes = std::fs::read(&wav).unwrap();
    let geometry = prism_geometry();
    let params = Params::default();
    // The samples as the WAV holds them (read by hound), as f32: 16-bit PCM / 32768.
    let interleaved: Vec<f32> = hound::WavReader::open(&wav)
        .unwrap()
        .samples::<i16>()
        .map(|s| s.unwrap() as f32 / 32768.0)
        .collect();
    let channels: Vec<Vec<f32>> = (0..8)
        .map(|c| interleaved.iter().skip(c).step_by(8).copied().collect())
        .collect();

    let (reference, summary) = on_threads(1, || {
        collect(Analysis::open(name, &geometry, &params).unwrap())
    });
    let detected = reference.len() as u64;
    assert!(detected > 50, "{detected} detections");
    assert!(summary.stats.frames > 3 * 128, "several blocks");
    let stats: FrameStats = summary.stats;
    for threads in [1, 2, 3] {
        let runs = on_threads(threads, || {
            [
                collect(Analysis::open(name, &geometry, &params).unwrap()),
                collect(
                    Analysis::from_reader("bytes", Cursor::new(bytes.clone()), &geometry, &params)
                        .unwrap(),
                ),
                collect(
                    Analysis::from_channels(
                        "memory",
                        channels.iter().map(|c| &c[..]).collect(),
                        48000,
                        &geometry,
                        &params,
                    )
                    .unwrap(),
                ),
            ]
        });
        for (entry, (detections, summary)) in ["file", "reader", "channels"].iter().zip(runs) {
            let same = detections == reference;
            assert!(same, "{entry} on {threads} thread(s): other detections");
            assert_eq!(summary.stats, stats, "{entry} on {threads} thread(s)");
        }
    }

    // The binary: a file and standard input, one thread and two, the same rows (without
    // the tracker, which is not part of the library's analysis).
    let geo = testdata("prism.toml");
    let run_binary = |input: &str, threads: &str| {
        let mut child = ssl()
            .args([
                "analyze",
                input,
                "-g",
                geo.to_str().unwrap(),
                "-j",
                threads,
                "--no-track",
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let mut stdin = child.stdin.take().unwrap();
        let feed = bytes.clone();
        let writer = std::thread::spawn(move || {
            use std::io::Write;
            let _ = stdin.write_all(&feed);
        });
        let out = child.wait_with_output().unwrap();
        writer.join().unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        parse_csv(&String::from_utf8(out.stdout).unwrap())
    };
    for (input, threads) in [(name, "1"), (name, "2"), ("-", "1"), ("-", "2")] {
        let rows = run_binary(input, threads);
        assert_eq!(
            rows.len(),
            reference.len(),
            "{input} on {threads} thread(s)"
        );
        for (row, d) in rows.iter().zip(&reference) {
            assert_eq!(row.frame, d.frame);
            assert!((row.azimuth_deg - d.azimuth_deg).abs() <= 0.0005 + 1e-9);
            assert!((row.elevation_deg - d.elevation_deg).abs() <= 0.0005 + 1e-9);
            assert!((row.score - d.score).abs() <= 0.00005 + 1e-9);
        }
    }
    // With the tracker (the default: the steered response, a second source a frame and
    // candidates), the same bytes on one thread and two.
    let tracked = |threads: &str| {
        let out = ssl()
            .args(["analyze", name, "-g", geo.to_str().unwrap(), "-j", threads])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        out.stdout
    };
    let one = tracked("1");
    assert!(parse_csv(&String::from_utf8(one.clone()).unwrap()).len() > 10);
    assert_eq!(one, tracked("2"));
}

#[path = "../../examples/rows.rs"]
mod example;

#[test]
fn the_library_example_gives_the_rows_of_the_binary() {
    let root = env!("CARGO_MANIFEST_DIR");
    let (wav, toml) = (
        format!("{root}/testdata/example.wav"),
        format!("{root}/testdata/prism.toml"),
    );
    let out = ssl()
        .args(["analyze", &wav, "-g", &toml, "-f", "json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let binary = ssl::record::parse_detections(&String::from_utf8(out.stdout).unwrap()).unwrap();
    let library = example::rows(&wav, &toml).unwrap();
    assert!(binary.len() > 50, "{} rows", binary.len());
    assert!(binary.iter().all(|r| r.source.is_some()));
    assert_eq!(library, binary);
}
