//! Measures the method's open choices (window, tolerance, sub-sample interpolation,
//! spectral weighting, peaks per pair) on free-field scenes with known truth, and prints
//! a markdown table. docs/method.md, "Choices and evidence", quotes its output.
//!
//! `cargo bench --bench measure` (the parameter table),
//! `cargo bench --bench measure -- --scores` (score distributions behind the default
//! threshold), `cargo bench --bench measure -- --estimator` (the noise estimator's
//! settings against a steady source).
//!
//! Scenes: the paper's 50 x 40 x 36 cm prism at 48 kHz; 16 target directions (8 azimuths
//! x elevations -20 and +25 deg), each active for 0.5 s with 0.3 s gaps, after 1 s of
//! background alone. Sources are at -26 dBFS RMS (clicks, 2 ms transients, at -14 dBFS
//! RMS during each click). Background: independent sensor noise, plus in the "fan" scenes
//! a continuous pink-noise point source (azimuth -100, elevation -30, 1.5 m away) at
//! -26 dBFS (0 dB) or -20 dBFS (+6 dB).

#[path = "../tests/support/mod.rs"]
mod support;

use nalgebra::Vector3;
use ssl::geometry::{angle_between_deg, unit_from_angles};
use ssl::method::weighting::NoiseSettings;
use ssl::method::{Interpolation, Window};
use ssl::sim::freefield::{render as render_scene, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::{Geometry, Params};
use support::frame_detections;

struct Condition {
    name: &'static str,
    signal: Signal,
    /// Fan level relative to the target (dB), or `None` for no fan.
    fan_db: Option<f64>,
    sensor_noise: f64,
}

struct Rendered {
    channels: Vec<Vec<f32>>,
    /// (start, end, direction) of each target burst.
    targets: Vec<(f64, f64, Vector3<f64>)>,
    duration_s: f64,
}

fn render(c: &Condition, seed: u64) -> Rendered {
    let level = 0.05;
    let mut sources = Vec::new();
    let mut targets = Vec::new();
    let mut t = 1.0;
    for (i, el) in [-20.0, 25.0].iter().enumerate() {
        for k in 0..8 {
            let az = -157.5 + 45.0 * k as f64 + 10.0 * i as f64;
            let u = unit_from_angles(az, *el);
            sources.push(Source {
                place: Place::Direction(u),
                signal: c.signal.clone(),
                start_s: t,
                end_s: t + 0.5,
                // Clicks are 2 ms transients: -14 dBFS RMS during each click.
                level: if matches!(c.signal, Signal::Clicks { .. }) {
                    0.2
                } else {
                    level
                },
            });
            targets.push((t, t + 0.5, u));
            t += 0.8;
        }
    }
    let duration_s = t;
    if let Some(db) = c.fan_db {
        sources.push(Source {
            place: Place::Position(unit_from_angles(-100.0, -30.0) * 1.5),
            signal: Signal::PinkNoise,
            start_s: 0.0,
            end_s: duration_s,
            level: level * 10f64.powf(db / 20.0),
        });
    }
    let scene = Scene {
        sample_rate: 48000,
        duration_s,
        mics: support::prism(),
        speed_of_sound: 343.0,
        sources,
        sensor_noise: c.sensor_noise,
        seed,
    };
    Rendered {
        channels: render_scene(&scene),
        targets,
        duration_s,
    }
}

#[derive(Default)]
struct Score {
    /// Per-pair scores of background-only detections and of correct detections.
    background_scores: Vec<f64>,
    target_scores: Vec<f64>,
    inside_frames: usize,
    hits: usize,
    detections_inside: usize,
    error_sum: f64,
    false_detections: usize,
    outside_s: f64,
}

/// Scores every frame's detection against the targets: per-pair scores of correct and of
/// background-only detections (the evidence for the threshold), and the errors. The
/// frame-level view `ssl evaluate` does not give.
fn score(r: &Rendered, geometry: &Geometry, params: &Params) -> Score {
    let (n, detections) = frame_detections(&r.channels, 48000, geometry, params);
    let hop = n / 2;
    let mut s = Score::default();
    let half = n as f64 / 2.0 / 48000.0;
    let mut outside_frames = 0;
    for (index, det) in detections.iter().enumerate() {
        let start = index * hop;
        let t = (start as f64 + n as f64 / 2.0) / 48000.0;
        let inside = r
            .targets
            .iter()
            .find(|(a, b, _)| t - half >= *a && t + half <= *b);
        let overlaps = r
            .targets
            .iter()
            .any(|(a, b, _)| t + half > *a && t - half < *b);
        if let Some((_, _, u)) = inside {
            s.inside_frames += 1;
            if let Some(d) = &det {
                let e = angle_between_deg(&d.direction, u);
                s.detections_inside += 1;
                s.error_sum += e;
                if e < 10.0 {
                    s.hits += 1;
                    s.target_scores.push(d.score / 28.0);
                }
            }
        } else if !overlaps && t > 1.0 {
            // Background alone (after the first second the noise estimate has settled).
            outside_frames += 1;
            if let Some(d) = &det {
                s.false_detections += 1;
                s.background_scores.push(d.score / 28.0);
            }
        }
    }
    s.outside_s = outside_frames as f64 * hop as f64 / 48000.0;
    let _ = r.duration_s;
    s
}

fn main() {
    let geometry = support::prism_geometry();
    let conditions = [
        Condition {
            name: "white, sensor noise 20 dB",
            signal: Signal::WhiteNoise,
            fan_db: None,
            sensor_noise: 0.005,
        },
        Condition {
            name: "white + fan 0 dB",
            signal: Signal::WhiteNoise,
            fan_db: Some(0.0),
            sensor_noise: 0.0016,
        },
        Condition {
            name: "speech-like + fan 0 dB",
            signal: Signal::SpeechLike,
            fan_db: Some(0.0),
            sensor_noise: 0.0016,
        },
        Condition {
            name: "clicks + fan 0 dB",
            signal: Signal::Clicks { per_second: 8.0 },
            fan_db: Some(0.0),
            sensor_noise: 0.0016,
        },
        Condition {
            name: "speech-like + fan +6 dB",
            signal: Signal::SpeechLike,
            fan_db: Some(6.0),
            sensor_noise: 0.0016,
        },
    ];
    let base = Params::default();
    let variants: Vec<(&str, Params)> = vec![
        (
            "default (Hann, cosine peaks, tol 50 us, gate 100 us, weighted, M 8, calibrated threshold)",
            base.clone(),
        ),
        (
            "parabolic peaks",
            {
                let mut p = base.clone();
                p.peaks.interpolation = Some(Interpolation::Parabolic);
                p
            },
        ),
        (
            "window: Hamming",
            {
                let mut p = base.clone();
                p.framing.window = Window::Hamming;
                p
            },
        ),
        (
            "window: rectangular",
            {
                let mut p = base.clone();
                p.framing.window = Window::Rectangular;
                p
            },
        ),
        (
            "integer lags (no interpolation)",
            {
                let mut p = base.clone();
                p.peaks.interpolation = Some(Interpolation::None);
                p
            },
        ),
        (
            "tolerance 0.5",
            {
                let mut p = base.clone();
                p.tolerance = ssl::method::Tolerance::Samples(0.5);
                p
            },
        ),
        (
            "tolerance 1",
            {
                let mut p = base.clone();
                p.tolerance = ssl::method::Tolerance::Samples(1.0);
                p
            },
        ),
        (
            "tolerance 3",
            {
                let mut p = base.clone();
                p.tolerance = ssl::method::Tolerance::Samples(3.0);
                p
            },
        ),
        (
            "tolerance 4",
            {
                let mut p = base.clone();
                p.tolerance = ssl::method::Tolerance::Samples(4.0);
                p
            },
        ),
        (
            "plain PHAT (no weighting)",
            {
                let mut p = base.clone();
                p.weighting.on = false;
                p
            },
        ),
        (
            "M = 1 peak per pair",
            {
                let mut p = base.clone();
                p.peaks.count = 1;
                p
            },
        ),
        (
            "M = 4 peaks per pair",
            {
                let mut p = base.clone();
                p.peaks.count = 4;
                p
            },
        ),
        (
            "threshold 0.4 per pair",
            {
                let mut p = base.clone();
                p.threshold = ssl::method::Threshold::Fixed { per_pair: 0.4 };
                p
            },
        ),
        (
            "threshold 0.6 per pair",
            {
                let mut p = base.clone();
                p.threshold = ssl::method::Threshold::Fixed { per_pair: 0.6 };
                p
            },
        ),
        (
            "no threshold",
            {
                let mut p = base.clone();
                p.threshold = ssl::method::Threshold::Fixed { per_pair: f64::NEG_INFINITY };
                p
            },
        ),
    ];
    if std::env::args().any(|a| a == "--estimator") {
        estimator_table(&geometry);
        return;
    }
    let rendered: Vec<Rendered> = conditions
        .iter()
        .enumerate()
        .map(|(i, c)| render(c, 100 + i as u64))
        .collect();
    if std::env::args().any(|a| a == "--scores") {
        // Score distributions without a threshold, to choose the default threshold.
        let open = {
            let mut p = Params::default();
            p.threshold = ssl::method::Threshold::Fixed {
                per_pair: f64::NEG_INFINITY,
            };
            p
        };
        let pct = |v: &mut Vec<f64>, p: f64| {
            v.sort_by(f64::total_cmp);
            if v.is_empty() {
                f64::NAN
            } else {
                v[((v.len() - 1) as f64 * p).round() as usize]
            }
        };
        println!("| scene | background per-pair score p50 / p99 / max | correct detections per-pair score p1 / p10 / p50 |");
        println!("|---|---|---|");
        for (c, r) in conditions.iter().zip(&rendered) {
            let mut s = score(r, &geometry, &open);
            let b = [
                pct(&mut s.background_scores, 0.5),
                pct(&mut s.background_scores, 0.99),
                pct(&mut s.background_scores, 1.0),
            ];
            let t = [
                pct(&mut s.target_scores, 0.01),
                pct(&mut s.target_scores, 0.1),
                pct(&mut s.target_scores, 0.5),
            ];
            // No detections at all (no background frames detected, or no source).
            let show = |x: [f64; 3]| {
                if x[0].is_nan() {
                    "none".to_string()
                } else {
                    format!("{:.2} / {:.2} / {:.2}", x[0], x[1], x[2])
                }
            };
            println!("| {} | {} | {} |", c.name, show(b), show(t));
        }
        return;
    }
    println!("Cells: mean angular error of detections inside active intervals (deg) / frames detected within 10 deg (%) / false detections per minute of background alone.\n");
    print!("| variant |");
    for c in &conditions {
        print!(" {} |", c.name);
    }
    println!();
    print!("|---|");
    for _ in &conditions {
        print!("---|");
    }
    println!();
    for (name, params) in &variants {
        print!("| {name} |");
        for r in &rendered {
            let s = score(r, &geometry, params);
            let mean = s.error_sum / s.detections_inside.max(1) as f64;
            let rate = 100.0 * s.hits as f64 / s.inside_frames.max(1) as f64;
            let fpm = s.false_detections as f64 / (s.outside_s / 60.0);
            print!(" {mean:.2} / {rate:.0}% / {fpm:.0} |");
        }
        println!();
    }
}

/// A source that stays on for 5 s (from 1 s to 6 s) must not be erased by the noise
/// estimate; stationary background must not be detected. Prints correct detections per
/// second of the source (of about 93 frames) and stray detections (frames that do not
/// overlap the source, or point more than 10 deg away from it).
fn estimator_table(geometry: &Geometry) {
    let u = unit_from_angles(40.0, 10.0);
    let scenes: Vec<(&str, Vec<Vec<f32>>)> = [
        (
            "white, sensor noise 3 dB below",
            0.035,
            None,
            Signal::WhiteNoise,
        ),
        (
            "white, sensor noise 6 dB below",
            0.025,
            None,
            Signal::WhiteNoise,
        ),
        (
            "white, fan 10 dB below",
            0.0005,
            Some(-10.0),
            Signal::WhiteNoise,
        ),
        (
            "speech-like, fan 10 dB below",
            0.0005,
            Some(-10.0),
            Signal::SpeechLike,
        ),
    ]
    .into_iter()
    .map(|(name, sensor, fan, signal)| {
        let mut sources = vec![Source {
            place: Place::Direction(u),
            signal,
            start_s: 1.0,
            end_s: 6.0,
            level: 0.05,
        }];
        if let Some(db) = fan {
            sources.push(Source {
                place: Place::Position(unit_from_angles(-100.0, -30.0) * 1.5),
                signal: Signal::PinkNoise,
                start_s: 0.0,
                end_s: 8.0,
                level: 0.05 * 10f64.powf(db / 20.0),
            });
        }
        let scene = Scene {
            sample_rate: 48000,
            duration_s: 8.0,
            mics: geometry.positions(),
            speed_of_sound: 343.0,
            sources,
            sensor_noise: sensor,
            seed: 3,
        };
        (name, render_scene(&scene))
    })
    .collect();
    println!("Correct detections in each second 1-6 of a 5 s steady source (of ~93 frames) / detections elsewhere.\n");
    print!("| presence ratio, noise time constant |");
    for (name, _) in &scenes {
        print!(" {name} |");
    }
    println!("\n|---|---|---|---|---|");
    for (ratio, tau) in [
        (5.0, 0.5),
        (3.0, 0.5),
        (3.0, 2.0),
        (2.0, 0.5),
        (2.0, 2.0),
        (2.0, 5.0),
    ] {
        let noise = NoiseSettings {
            presence_ratio: ratio,
            noise_tau_s: tau,
            ..NoiseSettings::default()
        };
        let default = noise == NoiseSettings::default();
        print!(
            "| {ratio}, {tau} s{} |",
            if default { " (default)" } else { "" }
        );
        for (_, ch) in &scenes {
            let params = {
                let mut p = Params::default();
                p.noise = noise;
                p
            };
            let (n, detections) = frame_detections(ch, 48000, geometry, &params);
            let mut per_s = [0usize; 5];
            let mut stray = 0;
            for (i, det) in detections.iter().enumerate() {
                let st = i * n / 2;
                let t = (st + n / 2) as f64 / 48000.0;
                let half = n as f64 / 2.0 / 48000.0;
                if let Some(d) = det {
                    let overlaps = t + half > 1.0 && t - half < 6.0;
                    if (1.0..6.0).contains(&t) && angle_between_deg(&d.direction, &u) < 10.0 {
                        per_s[t as usize - 1] += 1;
                    } else if !overlaps || angle_between_deg(&d.direction, &u) >= 10.0 {
                        stray += 1;
                        if std::env::var_os("SSL_DEBUG").is_some() {
                            eprintln!(
                                "stray at {t:.3} s: az {:.1} el {:.1} score {:.1}",
                                d.azimuth_deg, d.elevation_deg, d.score
                            );
                        }
                    }
                }
            }
            let cells: Vec<String> = per_s.iter().map(|c| c.to_string()).collect();
            print!(" {} / {stray} |", cells.join(" "));
        }
        println!();
    }
}
