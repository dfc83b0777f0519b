//! `--band LOW-HIGH`: only those frequencies are analysed. Two sources sound at once,
//! one low (200-900 Hz) and one high (3-8 kHz), from directions 120 deg apart; each band
//! finds its own source and never the other.

use crate::support;

use rand::{Rng, SeedableRng};
use ssl::geometry::{angle_between_deg, unit_from_angles};
use ssl::sim::freefield::{Place, Scene, Source};
use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use support::*;

/// Noise made of 300 sines at random frequencies in `low..high` Hz with random phases,
/// faded in and out over 50 ms (an abrupt start or end is a click at every frequency).
fn band_noise(low: f64, high: f64, seconds: f64, rate: f64, seed: u64) -> Vec<f64> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut x = vec![0.0; (seconds * rate) as usize];
    for _ in 0..300 {
        let f = rng.random_range(low..high);
        let phase = rng.random_range(0.0..std::f64::consts::TAU);
        let w = std::f64::consts::TAU * f / rate;
        for (i, v) in x.iter_mut().enumerate() {
            *v += (w * i as f64 + phase).sin();
        }
    }
    let (len, fade) = (x.len(), (0.05 * rate) as usize);
    for i in 0..fade {
        let g = 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / fade as f64).cos();
        x[i] *= g;
        x[len - 1 - i] *= g;
    }
    x
}

#[test]
fn each_band_finds_the_source_that_sounds_in_it() {
    let dir = tempdir();
    let rate = 48000;
    let (low_dir, high_dir) = (unit_from_angles(-60.0, 0.0), unit_from_angles(60.0, 20.0));
    let source = |place, samples| Source {
        place: Place::Direction(place),
        signal: Signal::Recording(samples),
        start_s: 0.1,
        end_s: 1.4,
        level: 0.05,
    };
    let scene = Scene {
        sample_rate: rate,
        duration_s: 1.5,
        mics: prism(),
        speed_of_sound: 343.0,
        sources: vec![
            source(low_dir, band_noise(200.0, 900.0, 1.3, 48000.0, 1)),
            source(high_dir, band_noise(3000.0, 8000.0, 1.3, 48000.0, 2)),
        ],
        sensor_noise: 0.002,
        seed: 3,
    };
    let wav = render_wav(dir.path(), "rec.wav", &scene, Encoding::Int16);
    let geometry = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let near = |band: Option<&str>, frame: &str| {
        let mut args = vec![
            "analyze",
            s(&wav),
            "-g",
            s(&geometry),
            "--no-track",
            "--frame-size",
            frame,
        ];
        if let Some(b) = band {
            args.extend(["--band", b]);
        }
        let out = run(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        let rows = parse_csv(&String::from_utf8(out.stdout).unwrap());
        let count = |d| {
            rows.iter()
                .filter(|r| angle_between_deg(&r.u, d) < 5.0)
                .count()
        };
        (count(&low_dir), count(&high_dir), rows.len())
    };
    let (low, high, all) = near(Some("2k-20k"), "1024");
    assert!(high > 60 && low == 0 && high == all, "{low} {high} {all}");
    // 100-1000 Hz is 77 bins of a 4096-sample frame (19 of a 1024-sample one, which the
    // run warns about).
    let (low, high, all) = near(Some("100-1000"), "4096");
    assert!(low > 15 && high == 0 && low == all, "{low} {high} {all}");
    // The whole band hears the high source at least (the louder above the noise).
    let (_, high, _) = near(None, "1024");
    assert!(high > 30, "{high}");
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "--band",
        "100-1000",
        "-o",
        "/dev/null",
    ]);
    let e = stderr(&out);
    assert!(
        out.status.success() && e.contains("the band holds 19 frequency bins"),
        "{e}"
    );
}

#[test]
fn a_band_that_is_not_one_is_a_clear_error() {
    let (_dir, wav, geometry) = recording(0.3);
    for (band, says) in [
        ("3400-300", "not a band"),
        ("300", "LOW-HIGH"),
        ("30000-40000", "frequency bin"),
        ("1000-1100", "frequency bin"),
    ] {
        let out = run(&["analyze", s(&wav), "-g", s(&geometry), "--band", band]);
        assert!(
            matches!(out.status.code(), Some(1 | 2)),
            "{band}: {}",
            stderr(&out)
        );
        assert!(stderr(&out).contains(says), "{band}: {}", stderr(&out));
    }
    // The band is in the JSON metadata.
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "--band",
        "300-3400",
        "--format",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        doc["parameters"]["weighting"]["band_hz"],
        serde_json::json!([300.0, 3400.0])
    );
}
