//! `ssl evaluate` and `ssl plot` over many results: folders of results as `--out-dir`
//! writes them, or results concatenated on standard input. Each recording is scored
//! against its own truth (found at its relative path in a folder of truths), then
//! pooled; the pairing is checked by giving every recording a source in another
//! direction, so a wrong pairing shows as an error of tens of degrees.

use crate::support;

use std::path::Path;
use support::*;

/// Simulates a talker at `azimuth` into `dir/name.wav`, its truth beside it.
fn simulated(dir: &Path, name: &str, azimuth: f64, seed: u64) {
    std::fs::create_dir_all(dir).unwrap();
    let scene = format!(
        "sample_rate = 48000\nduration = 2.0\nseed = {seed}\n\
         [array]\ngeometry = \"{}\"\nposition = [0.0, 0.0, 0.0]\n\
         [[source]]\nazimuth_deg = {azimuth}\nelevation_deg = 10.0\ndistance = 3.0\n\
         signal = \"white\"\nlevel_db = -26\nactive = [[0.4, 1.6]]\n\
         [noise]\nsensor_db = -60\n",
        s(&testdata("prism.toml"))
    );
    let toml = write(dir, &format!("{name}.toml"), scene);
    let wav = dir.join(format!("{name}.wav"));
    let o = run(&["simulate", s(&toml), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::remove_file(toml).unwrap();
}

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn a_folder_of_results_is_scored_recording_by_recording_and_pooled() {
    let dir = tempdir();
    let root = dir.path();
    let archive = root.join("archive");
    simulated(&archive.join("d1"), "a", 30.0, 1);
    simulated(&archive.join("d1"), "b", 120.0, 2);
    simulated(&archive.join("d2/deep"), "c", -100.0, 3);
    // A recording without a truth: listed, not scored.
    std::fs::copy(testdata("example.wav"), archive.join("d2/extra.wav")).unwrap();
    let geometry = testdata("prism.toml");
    let results = root.join("results");
    let o = run(&[
        "analyze",
        s(&archive),
        "-g",
        s(&geometry),
        "--out-dir",
        s(&results),
        "-f",
        "ndjson",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    let o = run(&["evaluate", "--truth", s(&archive), s(&results), "--json"]);
    let many = json(&o);
    let scored = many["recordings"].as_array().unwrap();
    assert_eq!(scored.len(), 3, "{many}");
    assert_eq!(many["without_truth"].as_array().unwrap().len(), 1);
    assert!(many["without_truth"][0]
        .as_str()
        .unwrap()
        .ends_with("d2/extra.wav"));
    // Each recording's report is the one `ssl evaluate` gives it alone, and its errors
    // are small: it was paired with its own truth.
    let mut detections = 0;
    for (x, (result, truth)) in scored.iter().zip([
        ("d1/a.ndjson", "d1/a.truth.json"),
        ("d1/b.ndjson", "d1/b.truth.json"),
        ("d2/deep/c.ndjson", "d2/deep/c.truth.json"),
    ]) {
        let alone = json(&run(&[
            "evaluate",
            "--truth",
            s(&archive.join(truth)),
            s(&results.join(result)),
            "--json",
        ]));
        assert_eq!(x["report"], alone, "{result}");
        assert!(x["truth"].as_str().unwrap().ends_with(truth));
        assert!(alone["mean_error_deg"].as_f64().unwrap() < 5.0, "{alone}");
        detections += alone["detections"].as_u64().unwrap();
    }
    let pooled = &many["pooled"];
    assert_eq!(pooled["recordings"], 3);
    assert_eq!(pooled["detections"].as_u64().unwrap(), detections);
    assert!(pooled["frame_detection_rate"].as_f64().unwrap() > 0.5);

    // The table: one line per recording, then the pooled line and the one left out.
    let o = run(&["evaluate", "--truth", s(&archive), s(&results)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let table = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(table.contains("pooled: 3 recordings"), "{table}");
    assert!(
        table.contains("without a truth (not scored): 1 recording(s)"),
        "{table}"
    );

    // The results concatenated on standard input: the same report.
    let mut cat = Vec::new();
    for r in [
        "d1/a.ndjson",
        "d1/b.ndjson",
        "d2/deep/c.ndjson",
        "d2/extra.ndjson",
    ] {
        cat.extend(std::fs::read(results.join(r)).unwrap());
    }
    let o = run_with_stdin(&["evaluate", "--truth", s(&archive), "-", "--json"], cat);
    assert_eq!(json(&o), many);

    // One truth for several recordings: refused, pointing to a folder of truths.
    let o = run(&[
        "evaluate",
        "--truth",
        s(&archive.join("d1/a.truth.json")),
        s(&results),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("give --truth a folder"),
        "{}",
        stderr(&o)
    );

    // No truth at all under the folder: one error.
    let o = run(&["evaluate", "--truth", s(&root.join("results")), s(&results)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("no truth for any of the 4 recording(s)"),
        "{}",
        stderr(&o)
    );

    // The plot of the folder draws each recording.
    let svg = root.join("all.svg");
    let o = run(&[
        "plot",
        s(&results),
        "--file",
        &format!("{}", archive.join("d1/b.wav").display()),
        "-o",
        s(&svg),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["plot", s(&results.join("d1")), "-o", s(&svg)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("d1/a.wav") && text.contains("d1/b.wav"));
}

#[test]
fn concatenated_csv_results_are_read_as_one() {
    let dir = tempdir();
    let root = dir.path();
    let archive = root.join("archive");
    simulated(&archive, "r0", 60.0, 4);
    simulated(&archive, "r1", -30.0, 5);
    let geometry = testdata("prism.toml");
    let mut cat = Vec::new();
    let mut detections = 0;
    for name in ["r0", "r1"] {
        let wav = archive.join(format!("{name}.wav"));
        let o = run(&["analyze", s(&wav), "-g", s(&geometry)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let csv = write(root, &format!("{name}.csv"), &o.stdout);
        let alone = json(&run(&[
            "evaluate",
            "--truth",
            s(&archive.join(format!("{name}.truth.json"))),
            s(&csv),
            "--json",
        ]));
        detections += alone["detections"].as_u64().unwrap();
        cat.extend(o.stdout);
    }
    // Both headers and every row of both: the pooled count is the sum.
    let o = run_with_stdin(
        &["evaluate", "--truth", s(&archive), "-", "--json"],
        cat.clone(),
    );
    let many = json(&o);
    assert_eq!(many["pooled"]["recordings"], 2);
    assert_eq!(many["pooled"]["detections"].as_u64().unwrap(), detections);
    assert!(detections > 20, "{detections}");
    let svg = root.join("p.svg");
    let o = run_with_stdin(&["plot", "-", "-o", s(&svg)], cat);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.contains("r0.wav") && text.contains("r1.wav"));
}

/// A folder of CSV results from `--out-dir` names its array through the batch's stamps:
/// a planar circle's results are scored in azimuth with no `-g`, as its JSON results
/// are; the same CSV copied out of the folder is scored by the 3-D angle, with the
/// warning that says how to fix it.
#[test]
fn csv_results_of_a_batch_name_their_array() {
    let dir = tempdir();
    let root = dir.path();
    let circle = write(root, "circle.toml", geometry_toml(&circle(6, 0.05), ""));
    let archive = root.join("archive");
    std::fs::create_dir_all(&archive).unwrap();
    let scene = format!(
        "sample_rate = 16000\nduration = 2.0\nseed = 4\n\
         [array]\ngeometry = \"{}\"\nposition = [0.0, 0.0, 0.0]\n\
         [[source]]\nazimuth_deg = 70\nelevation_deg = 25.0\ndistance = 3.0\n\
         signal = \"white\"\nlevel_db = -26\nactive = [[0.4, 1.6]]\n\
         [noise]\nsensor_db = -60\n",
        s(&circle)
    );
    let toml = write(root, "a.toml", scene);
    let wav = archive.join("a.wav");
    let o = run(&["simulate", s(&toml), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let results = root.join("results");
    let o = run(&[
        "analyze",
        s(&archive),
        "-g",
        s(&circle),
        "--out-dir",
        s(&results),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let truth = archive.join("a.truth.json");
    let csv = results.join("a.csv");
    let o = run(&["evaluate", "--truth", s(&truth), s(&csv), "--json"]);
    let stamped = json(&o);
    assert_eq!(stamped["metric"], "azimuth", "{stamped}");
    assert!(
        !stderr(&o).contains("scored by the 3-D angle"),
        "{}",
        stderr(&o)
    );
    // As -g gives it.
    let o = run(&[
        "evaluate",
        "--truth",
        s(&truth),
        s(&csv),
        "-g",
        s(&circle),
        "--json",
    ]);
    assert_eq!(json(&o), stamped);
    // The folder of results against the folder of truths: the same.
    let o = run(&["evaluate", "--truth", s(&archive), s(&results), "--json"]);
    assert_eq!(json(&o)["recordings"][0]["report"], stamped);
    // Out of its folder, the CSV cannot say its array.
    let copy = root.join("a.csv");
    std::fs::copy(&csv, &copy).unwrap();
    let o = run(&["evaluate", "--truth", s(&truth), s(&copy), "--json"]);
    assert_eq!(json(&o)["metric"], "3-D angle");
    assert!(
        stderr(&o).contains("scored by the 3-D angle"),
        "{}",
        stderr(&o)
    );
    // ssl plot scores as ssl evaluate does.
    let svg = root.join("a.svg");
    let o = run(&["plot", s(&csv), "--truth", s(&truth), "-o", s(&svg)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&svg).unwrap();
    let said = format!(
        "mean error {:.2} deg (azimuth)",
        stamped["mean_error_deg"].as_f64().unwrap()
    );
    assert!(text.contains(&said), "{said}: {text}");
}
