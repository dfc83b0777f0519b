//! How `ssl analyze` scales beyond 8 channels at 48 kHz: 16 and 32 microphones, 16 and
//! 96 kHz, and many small files in one call.
//!
//! `cargo bench --bench scaling -- [SECONDS]` (default 30). For each case it writes a scene with `ssl simulate`
//! (free field: white noise events of 0.8 s every 1.5 s from changing directions at 3 m,
//! -26 dBFS, sensor noise at -50 dBFS; room: the CMU ARCTIC clips of testdata/speech
//! taking turns from changing directions 1.5-3 m away in an 8 x 7 x 3 m room with RT60
//! 0.35 s, a fan and diffuse noise 10 dB below, at the defaults, whose calibrated
//! threshold searches far more candidate sets, and with the fixed threshold), analyses it with `--threads 1` and with all cores (wall time,
//! x real time, peak memory), checks that both outputs are identical byte for byte,
//! and scores the result with `ssl evaluate`. The 16- and 32-microphone arrays are
//! Fibonacci lattices on a sphere of radius 0.25 m; the others are the paper's prism.

#[path = "../tests/support/mod.rs"]
mod support;

use nalgebra::Vector3;
use ssl::evaluate::{evaluate, Report};
use ssl::record::read_detections;
use ssl::Truth;
use std::error::Error;
use std::path::Path;
use support::harness::{binary, cores, run_measured, seconds_arg};
use support::scenes::{scene_toml, speech_scene_toml};
use support::{circle, geometry_toml, prism, sphere_lattice};

struct Case {
    name: String,
    /// Reverberant speech rather than free-field noise events.
    speech: bool,
    /// Options added to `ssl analyze`.
    options: &'static [&'static str],
    mics: Vec<Vector3<f64>>,
    rate: u32,
    seconds: f64,
    /// Analyse this many copies of the recording in one call.
    copies: usize,
}

fn main() -> Result<(), Box<dyn Error>> {
    let seconds = seconds_arg(30.0)?;
    let exe = binary();
    let cores = cores();
    let prism = prism();
    // A planar array in the room, with and without the diffuse part's removal.
    let planar = |name: &str, mics: Vec<Vector3<f64>>, rate: u32| {
        [&[][..], &["--dereverb", "off"][..]].map(|options| Case {
            name: if options.is_empty() {
                name.into()
            } else {
                "the same, --dereverb off".into()
            },
            speech: true,
            options,
            mics: mics.clone(),
            rate,
            seconds,
            copies: 1,
        })
    };
    let mut cases = vec![
        Case {
            speech: false,
            options: &[],
            name: "prism (8 mics, 28 pairs), 48 kHz".into(),
            mics: prism.clone(),
            rate: 48000,
            seconds,
            copies: 1,
        },
        Case {
            speech: false,
            options: &[],
            name: "16 mics (120 pairs), 48 kHz".into(),
            mics: sphere_lattice(16, 0.25),
            rate: 48000,
            seconds,
            copies: 1,
        },
        Case {
            speech: false,
            options: &[],
            name: "32 mics (496 pairs), 48 kHz".into(),
            mics: sphere_lattice(32, 0.25),
            rate: 48000,
            seconds: seconds / 2.0,
            copies: 1,
        },
        Case {
            name: "32 mics, reverberant speech, 48 kHz".into(),
            speech: true,
            options: &[],
            mics: sphere_lattice(32, 0.25),
            rate: 48000,
            seconds: seconds / 2.0,
            copies: 1,
        },
        Case {
            name: "32 mics, reverberant speech, 48 kHz, --min-score 0.5".into(),
            speech: true,
            options: &["--min-score", "0.5"],
            mics: sphere_lattice(32, 0.25),
            rate: 48000,
            seconds: seconds / 2.0,
            copies: 1,
        },
        Case {
            speech: false,
            options: &[],
            name: "prism, 96 kHz (N = 2048)".into(),
            mics: prism.clone(),
            rate: 96000,
            seconds,
            copies: 1,
        },
        Case {
            speech: false,
            options: &[],
            name: "prism, 16 kHz (N = 256)".into(),
            mics: prism.clone(),
            rate: 16000,
            seconds,
            copies: 1,
        },
        Case {
            speech: false,
            options: &[],
            name: "200 files of 2 s (prism, 48 kHz), one call".into(),
            mics: prism,
            rate: 48000,
            seconds: 2.0,
            copies: 200,
        },
    ];
    let at = cases.len() - 3;
    let circles = [
        planar(
            "6-mic circle (r 4.63 cm), reverberant speech, 16 kHz",
            circle(6, 0.0463),
            16000,
        ),
        planar(
            "16-mic circle (r 10 cm), reverberant speech, 48 kHz",
            circle(16, 0.1),
            48000,
        ),
    ];
    cases.splice(at..at, circles.into_iter().flatten());
    println!(
        "| recording | audio | --threads 1 | --threads {cores} | peak memory | mean error | events found |"
    );
    println!("|---|---|---|---|---|---|---|");
    for case in &cases {
        let dir = tempfile::tempdir()?;
        let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
        let array = path("array.toml");
        std::fs::write(&array, geometry_toml(&case.mics, ""))?;
        let scene = if case.speech {
            support::copy_speech(dir.path())?;
            speech_scene_toml(
                case.rate,
                case.seconds,
                case.mics.iter().all(|m| m.z == 0.0),
                6,
            )
        } else {
            scene_toml(case.rate, case.seconds, 5)
        };
        std::fs::write(path("scene.toml"), scene)?;
        let wav = path("rec.wav");
        let truth = path("truth.json");
        let simulate = [
            "simulate",
            &path("scene.toml"),
            "-o",
            &wav,
            "--truth",
            &truth,
        ];
        run_measured(exe, &simulate)?;
        let mut inputs = vec![wav.clone()];
        for c in 1..case.copies {
            let copy = path(&format!("rec{c}.wav"));
            std::fs::hard_link(&wav, &copy)?;
            inputs.push(copy);
        }
        let mut cells = Vec::new();
        let mut peak = 0.0f64;
        for threads in [1, cores] {
            let out = path(&format!("out{threads}.csv"));
            let threads_arg = threads.to_string();
            let mut args = vec!["analyze", "-g", &array];
            args.extend(inputs.iter().map(String::as_str));
            args.extend(["-o", &out, "--threads", &threads_arg]);
            args.extend(case.options);
            let (wall, peak_mb) = run_measured(exe, &args)?;
            let audio = case.seconds * case.copies as f64;
            cells.push(format!("{wall:.2} s ({:.0}x)", audio / wall));
            peak = peak.max(peak_mb);
        }
        if std::fs::read(path("out1.csv"))? != std::fs::read(path(&format!("out{cores}.csv")))? {
            return Err(
                format!("{}: the output depends on the number of threads", case.name).into(),
            );
        }
        let report = score_first_file(Path::new(&truth), Path::new(&path("out1.csv")))?;
        let mean = report.mean_error_deg.unwrap_or(f64::NAN);
        let events = report.event_detection_rate.unwrap_or(f64::NAN);
        println!(
            "| {} | {} s | {} | {} | {peak:.1} MB | {mean:.2} deg | {:.0}% |",
            case.name,
            case.seconds * case.copies as f64,
            cells[0],
            cells[1],
            100.0 * events
        );
    }
    Ok(())
}

/// The evaluation of the first file's detections (for many identical files, the first
/// one's rows are what the truth describes; the result holds them all, in file order).
fn score_first_file(truth: &Path, result: &Path) -> Result<Report, Box<dyn Error>> {
    let truth = Truth::from_file(truth)?;
    let mut records = read_detections(result)?;
    let first = records.first().map(|r| r.file.clone()).unwrap_or_default();
    records.retain(|r| r.file == first);
    let tail = truth.rt60_s().map_or(0.0, |t| t / 2.0);
    Ok(evaluate(&truth, &records, tail)?)
}
