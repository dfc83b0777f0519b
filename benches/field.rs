//! Field conditions: real speech (the CMU ARCTIC clips in testdata/speech) in the paper's
//! reverberant room with its fan, on the paper's prism and on small arrays, at 48, 16
//! and 8 kHz, with a minute of background alone per array and rate. Prints a markdown table.
//!
//! `cargo bench --bench field` (about two minutes). Arguments choose other parameters (see
//! `support::harness::params_from`): `paper`, `fixed`, `bg=S`, `avg=N`, a tolerance and a
//! gate in us; `track` passes the detections through the tracker, as `ssl analyze` does.
//!
//! Each scene holds 8 speech events (the two clips alternating), one per horizontal
//! angle, 3 m away at elevation -7 deg for the prism (the paper's first condition), 1.5 m
//! away at elevation +15 deg for the small arrays (a seated talker's mouth seen from an
//! array on a table: on the side of a planar array's plane it reports), 0.5 s apart,
//! after 1 s of background. Cells: events detected within 10 deg / mean error of every
//! detection inside the events, nearest source (deg) / mean azimuth error of the same /
//! "confidently wrong" detections (more than 10 deg off with a score above the median
//! score) / false detections per minute of background alone / the same with the fan
//! 0.9 m from the array in a drier room (RT60 0.2 s). A linear array only knows
//! the angle between a source and its axis: its azimuth column is the error in that
//! angle, and its events and 3-D errors count the mirror directions it cannot tell apart
//! as misses.

#[path = "../tests/support/mod.rs"]
mod support;

use nalgebra::Vector3;
use ssl::evaluate::evaluate;
use ssl::geometry::angle_between_deg;
use ssl::sim::scene::{SceneFile, SignalKind, SourceSpec};
use ssl::track::TrackParams;
use ssl::{DetectionRecord, Geometry, Params, Truth};
use std::error::Error;
use std::path::Path;
use support::bench::{azimuth_error, azimuths, speech_room};
use support::harness::analyse_scene;

use support::{circle, SPEECH as CLIPS};

/// An array: its name, positions, and the distance and elevation of its sources.
struct Array {
    name: &'static str,
    mics: Vec<Vector3<f64>>,
    distance: f64,
    elevation: f64,
    /// For a linear array, its axis: the "azimuth" column is then the error in the one
    /// angle such an array measures, between the source and its axis.
    axis: Option<Vector3<f64>>,
}

fn arrays() -> Vec<Array> {
    vec![
        Array {
            name: "prism (8 mics, 50 x 40 x 36 cm)",
            mics: support::prism(),
            distance: 3.0,
            elevation: -7.0,
            axis: None,
        },
        Array {
            name: "circle (6 mics, r 4.63 cm)",
            mics: circle(6, 0.0463),
            distance: 1.5,
            elevation: 15.0,
            axis: None,
        },
        Array {
            name: "tetrahedron (4 mics, 6.5 cm edge)",
            mics: support::tetrahedron(0.065),
            distance: 1.5,
            elevation: 15.0,
            axis: None,
        },
        Array {
            name: "square (4 mics, 45.7 mm side)",
            mics: circle(4, 0.0457 / 2f64.sqrt()),
            distance: 1.5,
            elevation: 15.0,
            axis: None,
        },
        Array {
            name: "circle (6 + 1 mics, r 4.3 cm)",
            mics: [circle(6, 0.043), vec![Vector3::zeros()]].concat(),
            distance: 1.5,
            elevation: 15.0,
            axis: None,
        },
        Array {
            name: "circle (8 mics, r 4.9 cm)",
            mics: circle(8, 0.049),
            distance: 1.5,
            elevation: 15.0,
            axis: None,
        },
        Array {
            name: "line (4 mics, 4.57 cm apart)",
            mics: (0..4)
                .map(|i| Vector3::new(0.0457 * (i as f64 - 1.5), 0.0, 0.0))
                .collect(),
            distance: 1.5,
            elevation: 15.0,
            axis: Some(Vector3::x()),
        },
    ]
}

/// What a scene holds.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// 8 speech events around the array.
    Speech,
    /// The room's noise alone for a minute, with one event at the end.
    Background,
    /// As `Background`, with the fan on the table 0.9 m from the array in a drier room
    /// (RT60 0.2 s): a steady source heard mostly directly.
    NearFan,
}

/// The scene of `kind` for `array` at `rate`.
fn scene(array: &Array, rate: u32, kind: Kind, seed: u64) -> SceneFile {
    let background = kind != Kind::Speech;
    let az = azimuths(8);
    let mut t = 1.0;
    let mut sources = Vec::new();
    for (i, &a) in az.iter().enumerate() {
        let (clip, length) = CLIPS[i % 2];
        let start = if background { 60.5 } else { t };
        sources.push(SourceSpec {
            position: None,
            azimuth_deg: Some(a),
            elevation_deg: Some(array.elevation),
            distance: Some(array.distance),
            signal: SignalKind::File,
            level_db: -26.0,
            active: Some(vec![[start, start + length]]),
            rate: None,
            frequency: None,
            file: Some(clip.into()),
            turn_deg_per_s: None,
        });
        t += length + 0.5;
        if background {
            break;
        }
    }
    let duration = if background {
        60.5 + CLIPS[0].1 + 0.2
    } else {
        t
    };
    let near = kind == Kind::NearFan;
    let mut scene = speech_room(rate, duration, seed, if near { 0.2 } else { 0.35 }, near);
    scene.source = sources;
    scene
}

/// Simulates a scene and analyses it in memory, through the tracker with `track` on
/// the command line (as `ssl analyze` does by default): the records and the truth.
fn run(
    dir: &Path,
    scene: &SceneFile,
    geometry: &Geometry,
    params: &Params,
) -> Result<(Vec<DetectionRecord>, Truth), Box<dyn Error>> {
    analyse_scene(dir, scene, geometry, params, TRACK.get().cloned().flatten())
}

/// The tracker the detections go through: `track` on the command line for the
/// defaults, `track=HITS,SECONDS` for other confirmation settings.
static TRACK: std::sync::OnceLock<Option<TrackParams>> = std::sync::OnceLock::new();

/// Detections more than 10 deg from every active source, scoring above the median.
fn confidently_wrong(records: &[DetectionRecord], truth: &Truth) -> usize {
    let mut scores: Vec<f64> = records.iter().map(|r| r.score).collect();
    scores.sort_by(f64::total_cmp);
    let median = scores.get(scores.len() / 2).copied().unwrap_or(0.0);
    records
        .iter()
        .filter(|r| r.score > median)
        .filter(|r| {
            let u = Vector3::new(r.x, r.y, r.z);
            truth.sources.iter().all(|s| {
                let active = s
                    .active
                    .iter()
                    .any(|&[a, b]| r.time_s > a && r.time_s < b + 0.2);
                !active || angle_between_deg(&u, &s.direction()) > 10.0
            })
        })
        .filter(|r| {
            truth.sources.iter().any(|s| {
                s.active
                    .iter()
                    .any(|&[a, b]| r.time_s > a && r.time_s < b + 0.2)
            })
        })
        .count()
}

fn main() -> Result<(), Box<dyn Error>> {
    let started = std::time::Instant::now();
    let dir = tempfile::tempdir()?;
    support::copy_speech(dir.path())?;
    // Optional: other parameters (see `params_from`), and `grid` for the RT60 x SNR grid.
    let mut args = support::harness::args();
    let grid = args.iter().any(|a| a == "grid");
    let track = args.iter().find(|a| a.starts_with("track")).map(|a| {
        let mut p = support::harness::track_from(&args);
        if let Some((hits, seconds)) = a.strip_prefix("track=").and_then(|v| v.split_once(',')) {
            p.confirm_hits = hits.parse().expect("track=HITS,SECONDS");
            p.confirm_s = seconds.parse().expect("track=HITS,SECONDS");
        }
        p
    });
    TRACK.set(track).expect("set once");
    args.retain(|a| a != "grid" && !a.starts_with("track"));
    let params = support::harness::params_from(&args);
    if grid {
        return rt60_snr_grid(dir.path(), &params, started);
    }
    eprintln!(
        "tolerance {:?}, residual gate {:?} us, averaged over {} frames",
        params.tolerance, params.room.residual_gate_us, params.room.average_frames
    );
    println!(
        "| array | rate | events / mean error / azimuth error / confidently wrong / background false per min / near fan false per min |"
    );
    println!("|---|---|---|");
    for (k, array) in arrays().iter().enumerate() {
        std::fs::write(
            dir.path().join("array.toml"),
            support::geometry_toml(&array.mics, ""),
        )?;
        let geometry = Geometry::from_file(&dir.path().join("array.toml"))?;
        for rate in [48000, 16000, 8000] {
            let seed = 700 + 10 * k as u64 + (rate / 16000) as u64;
            let (records, truth) = run(
                dir.path(),
                &scene(array, rate, Kind::Speech, seed),
                &geometry,
                &params,
            )?;
            let report = evaluate(&truth, &records, 0.175)?;
            let wrong = confidently_wrong(&records, &truth);
            let mut false_per_minute = [0.0; 2];
            for (i, kind) in [Kind::Background, Kind::NearFan].into_iter().enumerate() {
                let (quiet, quiet_truth) = run(
                    dir.path(),
                    &scene(array, rate, kind, seed + 5 + i as u64),
                    &geometry,
                    &params,
                )?;
                let background = evaluate(&quiet_truth, &quiet, 0.175)?;
                false_per_minute[i] = background.false_per_minute.unwrap_or(0.0);
            }
            println!(
                "| {} | {} kHz | {:.0}% / {} / {} / {} of {} / {:.1} / {:.1} |",
                array.name,
                rate / 1000,
                100.0 * report.event_detection_rate.unwrap_or(0.0),
                report
                    .mean_error_deg
                    .map_or("-".to_string(), |e| format!("{e:.1} deg")),
                azimuth_error(&records, &truth, array.axis)
                    .map_or("-".to_string(), |e| format!("{e:.1} deg")),
                wrong,
                records.len(),
                false_per_minute[0],
                false_per_minute[1],
            );
        }
    }
    eprintln!(
        "field benchmark finished in {:.0} s",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The prism at 48 kHz with the scene above at RT60 0.2-0.8 s and 0-20 dB SNR: events
/// detected within 10 deg / mean error, per cell (`cargo bench --bench field -- grid`).
fn rt60_snr_grid(
    dir: &Path,
    params: &Params,
    started: std::time::Instant,
) -> Result<(), Box<dyn Error>> {
    let prism = &arrays()[0];
    std::fs::write(
        dir.join("array.toml"),
        support::geometry_toml(&prism.mics, ""),
    )?;
    let geometry = Geometry::from_file(&dir.join("array.toml"))?;
    let snrs = [20.0, 10.0, 0.0];
    println!("| RT60 | 20 dB | 10 dB | 0 dB |");
    println!("|---|---|---|---|");
    for (i, rt60) in [0.2, 0.35, 0.5, 0.8].into_iter().enumerate() {
        let mut row = format!("| {rt60} s |");
        for (j, snr) in snrs.into_iter().enumerate() {
            let mut scene = scene(prism, 48000, Kind::Speech, 900 + 10 * i as u64 + j as u64);
            if let Some(room) = scene.room.as_mut() {
                room.rt60 = Some(rt60);
            }
            if let Some(noise) = scene.noise.as_mut() {
                noise.snr_db = snr;
            }
            let (records, truth) = run(dir, &scene, &geometry, params)?;
            let report = evaluate(&truth, &records, 0.175)?;
            row += &format!(
                " {:.0}% / {} |",
                100.0 * report.event_detection_rate.unwrap_or(0.0),
                report
                    .mean_error_deg
                    .map_or("-".to_string(), |e| format!("{e:.1} deg")),
            );
        }
        println!("{row}");
    }
    eprintln!("grid finished in {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}
