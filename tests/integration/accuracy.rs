//! End-to-end accuracy: the `ssl` binary on synthetic recordings whose source directions
//! are known (fractional delays, independent sensor noise), for 3-D, planar and linear
//! arrays, several sample rates and every sample encoding.

use crate::support;

use nalgebra::Vector3;
use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use support::*;

fn analyze_scene(
    scene: &ssl::sim::freefield::Scene,
    positions: &[Vector3<f64>],
    extra_toml: &str,
    encoding: Encoding,
    extra_args: &[&str],
) -> Vec<Row> {
    let dir = tempdir();
    let wav = render_wav(dir.path(), "rec.wav", scene, encoding);
    let geo = write(
        dir.path(),
        "array.toml",
        geometry_toml(positions, extra_toml),
    );
    let mut args = vec![
        "analyze",
        wav.to_str().unwrap(),
        "--geometry",
        geo.to_str().unwrap(),
    ];
    args.extend_from_slice(extra_args);
    let out = run(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    parse_csv(&String::from_utf8(out.stdout).unwrap())
}

/// Ten directions over the sphere, alternating broadband noise and clicks.
fn sphere_directions() -> Vec<(f64, f64, Signal)> {
    let [noise, clicks] = signals();
    [
        (0.0, 0.0),
        (45.0, 10.0),
        (90.0, -15.0),
        (135.0, 30.0),
        (180.0, 0.0),
        (-135.0, -30.0),
        (-90.0, 45.0),
        (-45.0, -60.0),
        (20.0, 75.0),
        (110.0, -80.0),
    ]
    .iter()
    .enumerate()
    .map(|(i, &(az, el))| {
        (
            az,
            el,
            if i % 2 == 0 {
                noise.clone()
            } else {
                clicks.clone()
            },
        )
    })
    .collect()
}

#[test]
fn prism_localizes_noise_and_clicks_in_every_direction_within_2_degrees() {
    let dirs = sphere_directions();
    // Sensor noise 20 dB below the sources.
    let scene = scene(prism(), 48000, &dirs, 0.3, 0.005, 11);
    let rows = analyze_scene(&scene, &prism(), "", Encoding::Int16, &[]);
    for (i, (found, frames, mean, max)) in score_sources(&scene, &rows, 1024, |u| *u)
        .into_iter()
        .enumerate()
    {
        let (az, el, sig) = &dirs[i];
        eprintln!(
            "az {az} el {el} {sig:?}: {found}/{frames} frames, mean {mean:.3} max {max:.3} deg"
        );
        assert!(
            mean < 2.0 && max < 5.0,
            "az {az} el {el}: mean {mean} max {max}"
        );
        // Noise fills every frame; clicks (25/s) fill a part of them.
        let needed = if matches!(sig, Signal::WhiteNoise) {
            frames * 9 / 10
        } else {
            frames / 4
        };
        assert!(
            found >= needed,
            "az {az} el {el}: {found} of {frames} frames"
        );
    }
    // Nothing is reported in the silent gaps between the sources.
    // (A frame overlaps a source when its centre is within half a frame of the interval.)
    let stray = rows.iter().filter(|r| {
        !scene
            .sources
            .iter()
            .any(|s| r.time_s + 0.011 >= s.start_s && r.time_s - 0.011 <= s.end_s)
    });
    assert_eq!(stray.count(), 0);
}

#[test]
fn low_snr_still_localizes_broadband_noise() {
    let dirs: Vec<_> = [(60.0, 20.0), (-150.0, -10.0)]
        .iter()
        .map(|&(a, e)| (a, e, Signal::WhiteNoise))
        .collect();
    // Independent sensor noise 3 dB below the source in every channel: default settings.
    let scene3 = scene(prism(), 48000, &dirs, 0.5, 0.035, 5);
    let rows = analyze_scene(&scene3, &prism(), "", Encoding::Float32, &[]);
    for (found, frames, mean, _) in score_sources(&scene3, &rows, 1024, |u| *u) {
        assert!(mean < 2.0, "3 dB: mean {mean}");
        assert!(found * 10 >= frames * 9, "3 dB: {found} of {frames}");
    }
    // At 0 dB a source scores about 0.48 per pair, under the default threshold (0.5,
    // chosen to reject stationary background); without the threshold it is still found.
    let scene0 = scene(prism(), 48000, &dirs, 0.5, 0.05, 5);
    let rows = analyze_scene(
        &scene0,
        &prism(),
        "",
        Encoding::Float32,
        &["--min-score", "0"],
    );
    for (found, frames, mean, _) in score_sources(&scene0, &rows, 1024, |u| *u) {
        assert!(mean < 2.0, "0 dB: mean {mean}");
        assert!(found * 2 >= frames, "0 dB: {found} of {frames}");
    }
}

#[test]
fn planar_array_reports_the_upper_mirror_image() {
    // 8 mics on a circle of radius 0.1 m in the horizontal plane.
    let mics: Vec<Vector3<f64>> = (0..8)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 8.0;
            Vector3::new(0.1 * a.cos(), 0.1 * a.sin(), 0.0)
        })
        .collect();
    let dirs: Vec<_> = [
        (10.0, 30.0),
        (100.0, -45.0),
        (-80.0, 60.0),
        (-170.0, 20.0),
        (150.0, -25.0),
        (45.0, 50.0),
        (-30.0, -35.0),
        (-120.0, 40.0),
    ]
    .iter()
    .map(|&(a, e)| (a, e, Signal::WhiteNoise))
    .collect();
    let scene = scene(mics.clone(), 48000, &dirs, 0.3, 0.002, 3);
    let rows = analyze_scene(&scene, &mics, "", Encoding::Int24, &[]);
    let mirrored = |u: &Vector3<f64>| Vector3::new(u.x, u.y, u.z.abs());
    // Free field has no diffuse part to remove: the default's directions are those
    // without the removal, to within a tenth of a degree per source.
    let kept = analyze_scene(&scene, &mics, "", Encoding::Int24, &["--dereverb", "off"]);
    let without = score_sources(&scene, &kept, 1024, mirrored);
    for (i, (found, frames, mean, _)) in score_sources(&scene, &rows, 1024, mirrored)
        .into_iter()
        .enumerate()
    {
        eprintln!(
            "{:?}: {found}/{frames} mean {mean:.3} ({:.3} without the removal)",
            dirs[i], without[i].2
        );
        assert!(mean < 2.0, "{:?}: mean {mean}", dirs[i]);
        assert!(found * 10 >= frames * 9, "{found} of {frames}");
        assert!(
            (mean - without[i].2).abs() < 0.1,
            "{mean} against {}",
            without[i].2
        );
    }
    assert!(rows.iter().all(|r| r.u.z >= 0.0));
}

#[test]
fn planar_array_side_key_selects_the_lower_half() {
    let mics: Vec<Vector3<f64>> = (0..6)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 6.0;
            Vector3::new(0.08 * a.cos(), 0.08 * a.sin(), 0.0)
        })
        .collect();
    let dirs = vec![(70.0, -40.0, Signal::WhiteNoise)];
    let scene = scene(mics.clone(), 48000, &dirs, 0.4, 0.002, 4);
    let rows = analyze_scene(
        &scene,
        &mics,
        "side = [0.0, 0.0, -1.0]",
        Encoding::Int16,
        &[],
    );
    let (found, frames, mean, _) = score_sources(&scene, &rows, 1024, |u| *u)[0];
    assert!(
        mean < 2.0 && found * 10 >= frames * 9,
        "{found}/{frames} mean {mean}"
    );
}

#[test]
fn linear_array_reports_the_angle_to_its_axis() {
    // 4 mics along y (5 cm spacing); default side +x.
    let mics: Vec<Vector3<f64>> = (0..4)
        .map(|i| Vector3::new(0.0, -0.075 + 0.05 * i as f64, 0.0))
        .collect();
    let dirs: Vec<_> = [
        (0.0, 0.0),
        (30.0, 20.0),
        (-45.0, 0.0),
        (120.0, -30.0),
        (-100.0, 50.0),
        (60.0, -60.0),
        (160.0, 10.0),
        (-20.0, 40.0),
    ]
    .iter()
    .map(|&(a, e)| (a, e, Signal::WhiteNoise))
    .collect();
    let scene = scene(mics.clone(), 48000, &dirs, 0.3, 0.002, 8);
    let rows = analyze_scene(&scene, &mics, "", Encoding::Int16, &[]);
    let in_axis_plane = |u: &Vector3<f64>| {
        let c = u.y; // cosine of the angle to the +y axis
        Vector3::new((1.0 - c * c).sqrt(), c, 0.0)
    };
    for (i, (found, frames, mean, _)) in score_sources(&scene, &rows, 1024, in_axis_plane)
        .into_iter()
        .enumerate()
    {
        eprintln!("{:?}: {found}/{frames} mean {mean:.3}", dirs[i]);
        assert!(mean < 2.0, "{:?}: mean {mean}", dirs[i]);
        assert!(found * 10 >= frames * 9, "{found} of {frames}");
    }
}

#[test]
fn sample_rates_from_8_to_192_khz() {
    let dirs: Vec<_> = [(40.0, 15.0), (-110.0, -25.0)]
        .iter()
        .map(|&(a, e)| (a, e, Signal::WhiteNoise))
        .collect();
    for (rate, n, bound) in [
        (8000, 128, 2.0),
        (16000, 256, 2.0),
        (96000, 2048, 2.0),
        (192000, 4096, 2.0),
    ] {
        let scene = scene(prism(), rate, &dirs, 0.3, 0.005, rate as u64);
        let rows = analyze_scene(&scene, &prism(), "", Encoding::Int16, &[]);
        for (found, frames, mean, _) in score_sources(&scene, &rows, n, |u| *u) {
            eprintln!("{rate} Hz: {found}/{frames} mean {mean:.3}");
            assert!(mean < bound, "{rate} Hz: mean {mean}");
            assert!(found * 10 >= frames * 8, "{rate} Hz: {found} of {frames}");
        }
    }
}

#[test]
fn every_sample_encoding_gives_the_same_directions() {
    let dirs = vec![(-60.0, 25.0, Signal::WhiteNoise)];
    let scene = scene(prism(), 48000, &dirs, 0.3, 0.005, 21);
    for enc in [
        Encoding::Int8,
        Encoding::Int16,
        Encoding::Int24,
        Encoding::Int32,
        Encoding::Float32,
    ] {
        let rows = analyze_scene(&scene, &prism(), "", enc, &[]);
        let (found, frames, mean, _) = score_sources(&scene, &rows, 1024, |u| *u)[0];
        assert!(
            mean < 2.0 && found * 10 >= frames * 9,
            "{enc:?}: {found}/{frames} mean {mean}"
        );
    }
}

#[test]
fn shipped_example_matches_its_truth() {
    // The README's first command.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = ssl()
        .current_dir(root)
        .args([
            "analyze",
            "testdata/example.wav",
            "--geometry",
            "testdata/prism.toml",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let rows = parse_csv(&String::from_utf8(out.stdout).unwrap());
    let truth = ssl::Truth::from_file(&root.join("testdata/example.truth.json")).unwrap();
    for s in &truth.sources {
        let u = s.direction();
        let [a, b] = s.active[0];
        let inside: Vec<&Row> = rows
            .iter()
            .filter(|r| r.time_s - 0.0107 >= a && r.time_s + 0.0107 <= b)
            .collect();
        assert!(
            inside.len() >= 10,
            "{} detections in {a}..{b}",
            inside.len()
        );
        for r in inside {
            assert!(
                ssl::geometry::angle_between_deg(&r.u, &u) < 1.0,
                "{r:?} vs {u:?}"
            );
        }
    }
}

#[test]
fn sphere_lattice_points_lie_on_the_sphere_and_are_spread() {
    for k in [4usize, 16, 32] {
        let p = support::sphere_lattice(k, 0.25);
        assert_eq!(p.len(), k);
        let mut closest = f64::INFINITY;
        for (i, a) in p.iter().enumerate() {
            assert!((a.norm() - 0.25).abs() < 1e-12, "{a:?}");
            for b in &p[i + 1..] {
                closest = closest.min((a - b).norm());
            }
        }
        // Evenly spread: no two points closer than half the spacing of k equal caps.
        let spacing = 0.25 * (4.0 * std::f64::consts::PI / k as f64).sqrt();
        assert!(closest > 0.5 * spacing, "k {k}: {closest} vs {spacing}");
    }
}
