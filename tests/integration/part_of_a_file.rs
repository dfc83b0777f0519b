//! `--start` and `--end`: part of a file is analysed, with the file's own times and frame
//! indices, the same from a file and from a pipe.

use crate::support;

use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use support::*;

#[test]
fn start_and_end_analyse_part_of_a_file_in_its_own_times() {
    let dir = tempdir();
    let mics = prism();
    // Noise from 30 deg for 0.1-0.7 s, then from -120 deg for 0.8-1.4 s.
    let dirs = [
        (30.0, 0.0, Signal::WhiteNoise),
        (-120.0, 0.0, Signal::WhiteNoise),
    ];
    let scene = scene(mics.clone(), 48000, &dirs, 0.6, 0.002, 5);
    let wav = render_wav(dir.path(), "rec.wav", &scene, Encoding::Int16);
    let geometry = write(dir.path(), "prism.toml", geometry_toml(&mics, ""));
    let rows = |extra: &[&str]| {
        let mut args = vec!["analyze", s(&wav), "-g", s(&geometry), "--no-track"];
        args.extend_from_slice(extra);
        let out = run(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        parse_csv(&String::from_utf8(out.stdout).unwrap())
    };
    let all = rows(&[]);
    let part = rows(&["--start", "0.75", "--end", "1.3"]);
    assert!(part.len() > 20);
    for r in &part {
        // The file's times and frames: frame i starts at sample i * 512.
        assert!(
            r.time_s >= 0.75 - 512.0 / 48000.0 && r.time_s <= 1.3,
            "{}",
            r.time_s
        );
        assert!((r.time_s - (r.frame as f64 * 512.0 + 512.0) / 48000.0).abs() < 1e-5);
        assert!((r.azimuth_deg + 120.0).abs() < 2.0, "{}", r.azimuth_deg);
    }
    // The same frames as the whole file gives there, once the noise estimate has
    // settled (the first frames of a part learn it afresh).
    let later: Vec<_> = all
        .iter()
        .filter(|r| r.time_s > 1.0 && r.time_s < 1.25)
        .collect();
    let same: Vec<_> = part
        .iter()
        .filter(|r| r.time_s > 1.0 && r.time_s < 1.25)
        .collect();
    assert_eq!(later.len(), same.len());
    // From a pipe, the same bytes.
    let piped = run_with_stdin(
        &[
            "analyze",
            "-",
            "-g",
            s(&geometry),
            "--no-track",
            "--start",
            "0.75",
            "--end",
            "1.3",
        ],
        std::fs::read(&wav).unwrap(),
    );
    let from_file = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "--no-track",
        "--start",
        "0.75",
        "--end",
        "1.3",
    ]);
    assert_eq!(
        String::from_utf8_lossy(&piped.stdout).replace("<stdin>", "F"),
        String::from_utf8_lossy(&from_file.stdout).replace(s(&wav), "F")
    );
    // The JSON metadata records the span; a span past the end is one clear error.
    let json = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "-f",
        "json",
        "--start",
        "0.75",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(doc["parameters"]["framing"]["start_s"], 0.75);
    let out = run(&["analyze", s(&wav), "-g", s(&geometry), "--start", "9"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("--start 9 s leaves 0.0 ms of this"),
        "{}",
        stderr(&out)
    );
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "--start",
        "1",
        "--end",
        "0.5",
    ]);
    assert_ne!(out.status.code(), Some(0));
    assert!(stderr(&out).contains("--end after it"), "{}", stderr(&out));
}
