//! The shipped example recording and its truth are what the simulator makes of the
//! example scene; this test fails when they are stale. Regenerate with:
//! `SSL_UPDATE_TESTDATA=1 cargo test --test integration testdata::`.
//!
//! The scene: three sources (noise burst, clicks, noise burst) from known directions
//! around the paper's prism array, free field, independent sensor noise 20 dB below each
//! source (-46 dBFS), 48 kHz 16-bit.

use crate::support;

use ssl::geometry::{angles_deg, unit_from_angles};
use ssl::record::{TruthArray, TruthSource};
use ssl::sim::freefield::{render, Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::sim::{write_wav, Encoding};
use ssl::{Geometry, Truth};

fn scene(geometry: &Geometry) -> Scene {
    // Noise at -26 dBFS RMS; clicks (2 ms transients) at -14 dBFS RMS during each click.
    let src = |az: f64, el: f64, signal: Signal, start_s: f64, end_s: f64| Source {
        place: Place::Direction(unit_from_angles(az, el)),
        level: if matches!(signal, Signal::Clicks { .. }) {
            0.2
        } else {
            0.05
        },
        signal,
        start_s,
        end_s,
    };
    Scene {
        sample_rate: 48000,
        duration_s: 2.0,
        mics: geometry.positions(),
        speed_of_sound: geometry.speed_of_sound,
        sources: vec![
            src(30.0, 10.0, Signal::WhiteNoise, 0.10, 0.60),
            src(
                -120.0,
                -20.0,
                Signal::Clicks { per_second: 20.0 },
                0.75,
                1.25,
            ),
            src(150.0, 40.0, Signal::WhiteNoise, 1.40, 1.90),
        ],
        sensor_noise: 0.005,
        seed: 2003,
    }
}

fn truth(geometry: &Geometry, scene: &Scene) -> Truth {
    let sources = scene
        .sources
        .iter()
        .enumerate()
        .map(|(index, s)| {
            let u = s.direction_from(&geometry.centre);
            let (azimuth_deg, elevation_deg) = angles_deg(&u);
            TruthSource {
                index,
                signal: match s.signal {
                    Signal::Clicks { .. } => "clicks",
                    _ => "white",
                }
                .into(),
                level_db: 20.0 * s.level.log10(),
                position_room: [0.0; 3],
                x: u.x,
                y: u.y,
                z: u.z,
                azimuth_deg,
                elevation_deg,
                distance_m: None,
                active: vec![[s.start_s, s.end_s]],
                turn_deg_per_s: None,
                turn_from_s: None,
                waypoints: Vec::new(),
                azimuth_only: false,
            }
        })
        .collect();
    Truth {
        tool: Default::default(),
        sample_rate: scene.sample_rate,
        duration_s: scene.duration_s,
        seed: scene.seed,
        speed_of_sound: scene.speed_of_sound,
        room: None,
        array: TruthArray {
            geometry: "prism.toml".into(),
            position: [0.0; 3],
            yaw_deg: 0.0,
        },
        sources,
        noise: None,
        recording: Some("example.wav".into()),
    }
}

#[test]
fn example_recording_and_truth_are_what_the_simulator_makes() {
    let geometry = support::prism_geometry();
    let scene = scene(&geometry);
    let dir = support::tempdir();
    let wav = dir.path().join("example.wav");
    write_wav(&wav, &render(&scene), scene.sample_rate, Encoding::Int16).unwrap();
    let text = serde_json::to_string_pretty(&truth(&geometry, &scene)).unwrap() + "\n";
    let files = [
        ("example.wav", std::fs::read(&wav).unwrap()),
        ("example.truth.json", text.into_bytes()),
    ];
    let update = std::env::var_os("SSL_UPDATE_TESTDATA").is_some();
    for (name, bytes) in files {
        let path = support::testdata(name);
        if update {
            std::fs::write(&path, &bytes).unwrap();
        } else {
            assert!(
                std::fs::read(&path).unwrap_or_default() == bytes,
                "testdata/{name} is stale: regenerate with `SSL_UPDATE_TESTDATA=1 cargo test --test integration testdata::`"
            );
        }
    }
}
