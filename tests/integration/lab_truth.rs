//! A lab's own ground truth (docs/interface.md, "Ground truth of a measured setup"): a
//! hand-written truth in the minimal JSON or the CSV form scores exactly as the one
//! `ssl simulate` writes; its problems are listed at once; scores measure what the array
//! observes (azimuth for a planar array) unless `--metric` says otherwise.

use crate::support;

use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use support::*;

/// `ssl evaluate --json` of `result` against `truth` with `extra` flags: the report.
fn report(truth: &std::path::Path, result: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["evaluate", "--truth", s(truth), s(result), "--json"];
    args.extend_from_slice(extra);
    let out = run(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The shipped example's rows, as CSV in `d`.
fn example_rows(d: &std::path::Path) -> std::path::PathBuf {
    let out = run(&[
        "analyze",
        s(&testdata("example.wav")),
        "-g",
        s(&testdata("prism.toml")),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    write(d, "rows.csv", &out.stdout)
}

#[test]
fn a_hand_written_truth_in_json_or_csv_scores_as_the_simulated_one() {
    let dir = tempdir();
    let d = dir.path();
    let result = example_rows(d);
    let truth = ssl::Truth::from_file(&testdata("example.truth.json")).unwrap();
    let mut json = Vec::new();
    let mut csv = String::from("source,start_s,end_s,azimuth_deg,elevation_deg\n");
    for src in &truth.sources {
        json.push(serde_json::json!({
            "name": src.signal, "azimuth_deg": src.azimuth_deg, "elevation_deg": src.elevation_deg,
            "intervals": src.active,
        }));
        for [a, b] in &src.active {
            csv += &format!(
                "{},{a},{b},{},{}\n",
                src.index, src.azimuth_deg, src.elevation_deg
            );
        }
    }
    let json = write(
        d,
        "truth.json",
        serde_json::json!({ "sources": json, "duration_s": truth.duration_s }).to_string(),
    );
    let csv = write(d, "truth.csv", csv);
    let simulated = report(&testdata("example.truth.json"), &result, &[]);
    for hand in [&json, &csv] {
        let r = report(hand, &result, &[]);
        for key in [
            "detections",
            "mean_error_deg",
            "event_detection_rate",
            "frame_detection_rate",
        ] {
            let (a, b) = (&r[key], &simulated[key]);
            let close = match (a.as_f64(), b.as_f64()) {
                (Some(x), Some(y)) => (x - y).abs() < 1e-6 * y.abs().max(1.0),
                _ => a == b,
            };
            assert!(close, "{}: {key} {a} against {b}", hand.display());
        }
        assert!(simulated["detections"].as_u64().unwrap() > 50);
    }
}

#[test]
fn a_hand_written_truth_lists_every_problem_at_once() {
    let dir = tempdir();
    let d = dir.path();
    let result = example_rows(d);
    let truth = write(
        d,
        "truth.json",
        r#"{"sources": [{"elevation_deg": 30}, {"azimuth_deg": 10, "elevation_deg": 0, "intervals": [[3, 1]]}]}"#,
    );
    let out = run(&["evaluate", "--truth", s(&truth), s(&result)]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert_eq!(err.lines().count(), 1, "{err}");
    for needle in [
        "truth.json",
        "source 1: give azimuth_deg and elevation_deg",
        "source 1: missing intervals",
        "source 2: intervals must be",
    ] {
        assert!(err.contains(needle), "{needle}: {err}");
    }
}

#[test]
fn a_planar_array_is_scored_by_its_azimuth_unless_asked_otherwise() {
    let dir = tempdir();
    let d = dir.path();
    // A 6-mic circle of 5 cm on a table: one source 30 deg below its plane (reported
    // above it, 60 deg off in 3-D), one 20 deg above.
    let mics = circle(6, 0.05);
    let dirs = [
        (40.0, -30.0, Signal::WhiteNoise),
        (-100.0, 20.0, Signal::WhiteNoise),
    ];
    let scene = scene(mics.clone(), 16000, &dirs, 0.5, 0.002, 9);
    let wav = render_wav(d, "rec.wav", &scene, Encoding::Float32);
    let geometry = write(d, "circle.toml", geometry_toml(&mics, ""));
    let truth = write(
        d,
        "truth.json",
        r#"{"sources": [{"azimuth_deg": 40, "elevation_deg": -30, "intervals": [[0.1, 0.6]]},
                        {"azimuth_deg": -100, "elevation_deg": 20, "intervals": [[0.7, 1.2]]}]}"#,
    );
    let json = {
        let out = run(&[
            "analyze",
            s(&wav),
            "-g",
            s(&geometry),
            "-f",
            "json",
            "--no-track",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        write(d, "rows.json", &out.stdout)
    };
    let csv = {
        let out = run(&["analyze", s(&wav), "-g", s(&geometry), "--no-track"]);
        write(d, "rows.csv", &out.stdout)
    };
    let mean = |r: &serde_json::Value| r["mean_error_deg"].as_f64().unwrap();
    // The JSON result carries its geometry: azimuth by default.
    let by_default = report(&truth, &json, &[]);
    assert_eq!(by_default["metric"], "azimuth");
    assert!(mean(&by_default) < 2.0, "{by_default}");
    // A CSV result does not: with --geometry the same; without, the 3-D angle.
    assert_eq!(
        report(&truth, &csv, &["-g", s(&geometry)])["metric"],
        "azimuth"
    );
    let three_d = report(&truth, &csv, &[]);
    assert_eq!(three_d["metric"], "3-D angle");
    assert!(mean(&three_d) > 15.0, "{three_d}");
    assert_eq!(
        report(&truth, &json, &["--metric", "3d"])["metric"],
        "3-D angle"
    );
    // A truth of azimuths only, all a lab with a planar array may know, is scored in
    // azimuth whatever the result carries, even asked for 3-D.
    let azimuths = write(
        d,
        "azimuths.csv",
        "start,end,azimuth\n0.1,0.6,40\n0.7,1.2,-100\n",
    );
    for extra in [&[][..], &["--metric", "3d"][..]] {
        let r = report(&azimuths, &csv, extra);
        assert_eq!(r["metric"], "azimuth", "{r}");
        assert!((mean(&r) - mean(&by_default)).abs() < 1e-6, "{r}");
    }
    // `ssl plot` scores by the same rules: the same geometry flag, the same figure in
    // its title, and the same warning when nothing names the array.
    let title_error = |extra: &[&str]| {
        let mut args = vec!["plot", s(&csv), "--truth", s(&truth)];
        args.extend_from_slice(extra);
        let out = run(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        let svg = String::from_utf8(out.stdout.clone()).unwrap();
        let at = svg.find("mean error ").expect("a score in the title") + "mean error ".len();
        (
            svg[at..].split(' ').next().unwrap().parse::<f64>().unwrap(),
            stderr(&out),
        )
    };
    let with_g = report(&truth, &csv, &["-g", s(&geometry)]);
    let (plotted, said) = title_error(&["-g", s(&geometry)]);
    assert!(
        (plotted - mean(&with_g)).abs() < 0.006,
        "{plotted} against {with_g}"
    );
    assert!(said.is_empty(), "{said}");
    let (plotted, said) = title_error(&[]);
    assert!(
        (plotted - mean(&three_d)).abs() < 0.006,
        "{plotted} against {three_d}"
    );
    assert!(
        said.contains("scored by the 3-D angle") && said.contains("-g ARRAY.toml"),
        "{said}"
    );
    let out = run(&["evaluate", "--truth", s(&truth), s(&csv)]);
    assert!(stderr(&out).contains("scored by the 3-D angle"));
    // A folder of truths, as `ssl evaluate` takes it: the recording's own.
    let truths = d.join("truths");
    std::fs::create_dir_all(&truths).unwrap();
    std::fs::copy(&truth, truths.join("rec.truth.json")).unwrap();
    let (plotted, _) = title_error(&["-g", s(&geometry)]);
    let out = run(&["plot", s(&csv), "--truth", s(&truths), "-g", s(&geometry)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8(out.stdout)
        .unwrap()
        .contains(&format!("mean error {plotted:.2} deg")));
    // The table says what it measured.
    let out = run(&["evaluate", "--truth", s(&truth), s(&json)]);
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("errors: azimuth"));
    // A planar array has no axis.
    let out = run(&[
        "evaluate",
        "--truth",
        s(&truth),
        s(&json),
        "--metric",
        "axis",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("--metric axis needs a linear array's geometry"));
}
