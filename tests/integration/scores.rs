//! `ssl evaluate` scores what was written, and its figures are what an independent scorer
//! gives: nine bursts that `--events` writes as nine events score as nine, from the
//! run's own events or read off its rows; no row just after a burst is false; and a few
//! lines of Python (scores/rederive.py) re-derive the per-source errors, the false
//! detections and the events recalled from the truth and the JSON result.

use crate::support;

use support::*;

/// The prism in a room of RT60 0.3 s at 16 kHz, with `sources` (TOML `[[source]]`
/// tables), simulated and analysed with `--events --format json`; also the rows as CSV.
fn scene(d: &std::path::Path, duration: f64, sources: &str) -> [std::path::PathBuf; 3] {
    write(d, "prism.toml", geometry_toml(&prism(), ""));
    let scene = format!(
        "sample_rate = 16000\nduration = {duration}\nseed = 21\n[room]\ndimensions = [7.0, 5.5, 3.2]\n\
         rt60 = 0.3\n[array]\ngeometry = \"prism.toml\"\nposition = [3.5, 2.75, 1.1]\n{sources}\
         [noise]\nsnr_db = 15\nsensor_db = -70\n"
    );
    let toml = write(d, "scene.toml", scene);
    let wav = d.join("r.wav");
    let o = run(&["simulate", s(&toml), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let geometry = d.join("prism.toml");
    let o = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&geometry),
        "--events",
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = write(d, "r.json", &o.stdout);
    let o = run(&["analyze", s(&wav), "-g", s(&geometry)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = write(d, "rows.csv", &o.stdout);
    [d.join("r.truth.json"), json, csv]
}

fn evaluate(truth: &std::path::Path, result: &std::path::Path) -> serde_json::Value {
    let o = run(&["evaluate", "--truth", s(truth), s(result), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// `n` bursts of `len` seconds every `every` seconds from `from`.
fn bursts(n: usize, from: f64, every: f64, len: f64) -> String {
    let spans: Vec<String> = (0..n)
        .map(|i| {
            format!(
                "[{:.3}, {:.3}]",
                from + every * i as f64,
                from + every * i as f64 + len
            )
        })
        .collect();
    format!("[{}]", spans.join(", "))
}

#[test]
fn nine_bursts_written_as_nine_events_score_as_nine() {
    let dir = tempdir();
    let source = format!(
        "[[source]]\nazimuth_deg = 30.0\ndistance = 2.0\nsignal = \"white\"\nlevel_db = -26\nactive = {}\n",
        bursts(9, 0.5, 0.6, 0.15)
    );
    let [truth, json, csv] = scene(dir.path(), 6.5, &source);
    let result: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(result["events"].as_array().unwrap().len(), 9, "{result}");
    // One analysis frame: 512 samples at 16 kHz.
    let frame = 512.0 / 16000.0;
    for (path, from) in [(&json, "written"), (&csv, "rows")] {
        let r = evaluate(&truth, path);
        let t = &r["tracking"];
        assert_eq!(t["events_from"], from, "{r}");
        assert_eq!(t["events"], 9, "{r}");
        assert_eq!(t["events_recalled"], 9, "{r}");
        assert_eq!(t["false_events"], 0, "{r}");
        assert!(t["onset_error_s"].as_f64().unwrap() < frame, "{r}");
        assert!(t["event_coverage"].as_f64().unwrap() > 0.9, "{r}");
        // The rows just after each burst (its frame, its reverberation) are its own.
        assert_eq!(r["false_detections"], 0, "{r}");
        assert!(
            r["tail_rule"].as_str().unwrap().starts_with("one frame"),
            "{r}"
        );
    }
}

#[test]
fn an_independent_scorer_re_derives_the_figures() {
    let dir = tempdir();
    // A talker throughout and nine bursts at another place while he talks: rows in
    // frames that straddle a burst's ends are charged to the nearer source heard then.
    let sources = format!(
        "[[source]]\nazimuth_deg = -40.0\ndistance = 2.0\nsignal = \"speech\"\nlevel_db = -26\nactive = [[0.4, 6.2]]\n\
         [[source]]\nazimuth_deg = 50.0\nelevation_deg = 10.0\ndistance = 1.5\nsignal = \"white\"\nlevel_db = -24\nactive = {}\n",
        bursts(9, 0.8, 0.6, 0.15)
    );
    let [truth, json, _] = scene(dir.path(), 6.5, &sources);
    let r = evaluate(&truth, &json);
    let script = write(
        dir.path(),
        "rederive.py",
        include_str!("scores/rederive.py"),
    );
    let tail = r["tail_s"].as_f64().unwrap().to_string();
    let o = std::process::Command::new("python3")
        .args([s(&script), s(&truth), s(&json), &tail])
        .output()
        .expect("python3 (on every machine this project runs on)");
    assert!(o.status.success(), "{}", stderr(&o));
    let py: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sources = r["sources"].as_array().unwrap();
    for (i, s) in sources.iter().enumerate() {
        let (ours, theirs) = (
            s["mean_error_deg"].as_f64().unwrap(),
            py["mean_error_deg"][i].as_f64().unwrap(),
        );
        assert!(
            (ours - theirs).abs() < 1e-6,
            "source {i}: {ours} vs {theirs}"
        );
    }
    assert_eq!(r["false_detections"], py["false_detections"]);
    let t = &r["tracking"];
    assert_eq!(t["events_from"], "written");
    assert_eq!(t["events"], py["events"]);
    assert_eq!(t["events_recalled"], py["recalled"]);
    let onset =
        (t["onset_error_s"].as_f64().unwrap() - py["onset_error_s"].as_f64().unwrap()).abs();
    assert!(onset < 1e-6, "{r} {py}");
    // Every burst is recalled and the bursts are placed within a degree.
    assert_eq!(sources[1]["events_detected"], 9);
    assert!(sources[1]["mean_error_deg"].as_f64().unwrap() < 1.0, "{r}");
}
