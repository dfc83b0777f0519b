//! A moving source in a simulated room (`turn_deg_per_s` in a scene): rendered in
//! cross-faded blocks, scored by `ssl evaluate` against its trajectory, and tracked as
//! one source by `ssl analyze`.

use crate::support;

use ssl::sim::scene::SceneFile;
use support::*;

/// A scene on the prism at 16 kHz in the paper's room (RT60 0.35 s, fan and diffuse
/// noise 10 dB below): one source at azimuth -60 deg, elevation -7 deg, 2 m away, with
/// `source` (its signal lines and `turn_deg_per_s`, if any) from 1 s on.
fn scene(source: &str, duration: f64) -> String {
    format!(
        "sample_rate = 16000\nduration = {duration}\nseed = 21\nformat = \"float32\"\n\
         [room]\ndimensions = [8.0, 7.0, 3.0]\nrt60 = 0.35\n\
         [array]\ngeometry = \"prism.toml\"\nposition = [4.0, 3.5, 0.8]\n\
         [[source]]\nazimuth_deg = -60.0\nelevation_deg = -7.0\ndistance = 2.0\n{source}\n\
         [noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
         [noise.diffuse]\nweight_db = -6\n"
    )
}

/// A source that turns too slowly to move is rendered block by block, each block
/// through the responses of its own position, cross-faded: the blocks add up to the
/// recording rendered in one piece.
#[test]
fn a_still_source_rendered_in_blocks_is_the_source_rendered_whole() {
    let dir = tempdir();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let render = |turn: &str| {
        let text = scene(
            &format!("signal = \"white\"\nactive = [[0.2, 1.4]]\n{turn}"),
            1.5,
        );
        let scene: SceneFile = toml::from_str(&text).unwrap();
        ssl::sim::simulate(&scene, dir.path()).unwrap()
    };
    let (whole, blocks) = (render(""), render("turn_deg_per_s = 1e-9\n"));
    let peak = whole.channels[0].iter().fold(0.0f32, |m, v| m.max(v.abs()));
    for (a, b) in whole.channels.iter().zip(&blocks.channels) {
        let worst = a
            .iter()
            .zip(b)
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(worst < 1e-5 * peak, "{worst} of {peak}");
    }
    // The truth says it turns (however slowly).
    let truth = &blocks.truth.sources[0];
    assert_eq!(truth.turn_deg_per_s, Some(1e-9));
    assert!(whole.truth.sources[0].turn_deg_per_s.is_none());
}

/// Real speech turning at 30 deg/s through a reverberant room: one track, within 3 deg
/// of the trajectory; scored against where the talker started, the same rows are far
/// off (the evaluation follows the trajectory).
#[test]
fn a_talker_turning_in_a_room_is_one_track_on_its_trajectory() {
    let dir = tempdir();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    copy_speech(dir.path()).unwrap();
    let text = scene(
        "signal = \"file\"\nfile = \"cmu_arctic_us_aew_a0001.wav\"\nactive = [[1.0, 4.9]]\n\
         turn_deg_per_s = 30.0\n",
        5.5,
    );
    let path = write(dir.path(), "turning.toml", &text);
    let wav = dir.path().join("turning.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let truth_path = dir.path().join("turning.truth.json");
    let truth: ssl::Truth =
        serde_json::from_str(&std::fs::read_to_string(&truth_path).unwrap()).unwrap();
    let source = &truth.sources[0];
    assert_eq!(source.turn_deg_per_s, Some(30.0));
    // Heard from -60 deg once the direct sound reaches the array (2 m: 5.8 ms).
    let from = source.turn_from_s.unwrap();
    assert!((from - 1.0 - 2.0 / 343.0).abs() < 1e-5, "{from}");
    let o = ssl()
        .current_dir(dir.path())
        .args(["analyze", s(&wav), "-g", "prism.toml"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    let records = ssl::record::parse_detections(&text).unwrap();
    let report = ssl::evaluate::evaluate(&truth, &records, 0.175).unwrap();
    let tracking = report.tracking.clone().unwrap();
    eprintln!(
        "{} rows, mean error {:?}, {} tracks",
        records.len(),
        report.mean_error_deg,
        tracking.tracks
    );
    assert!(records.len() > 100);
    assert_eq!(tracking.tracks, 1);
    assert!(report.mean_error_deg.unwrap() < 3.0);
    // `ssl plot --truth` draws its path, not a line at its first direction: in the
    // azimuth and elevation panels and on the sky map, a polyline of one point every
    // 20 ms of its 3.9 s.
    let result = write(dir.path(), "turning.csv", &text);
    let o = ssl()
        .args(["plot", s(&result), "--truth", s(&truth_path)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = String::from_utf8(o.stdout).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let long = doc
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
        .filter(|n| {
            n.attribute("points")
                .unwrap_or("")
                .split_whitespace()
                .count()
                > 150
        })
        .count();
    assert_eq!(long, 3, "polylines of the path");
    // The same walk written by hand as a lab would: 0.5 s pieces with their start and
    // end directions in CSV, an Audacity label track, or its turn in JSON. Each is one
    // source of one event, scored as the simulator's exact truth.
    let [a, b] = source.active[0];
    let (mut csv, mut labels) = (
        String::from(
            "source,start_s,end_s,azimuth_deg,elevation_deg,end_azimuth_deg,end_elevation_deg\n",
        ),
        String::new(),
    );
    let mut t = a;
    while t < b - 1e-9 {
        let end = (t + 0.5).min(b);
        let (az0, el0) = ssl::geometry::angles_deg(&source.direction_at(t));
        let (az1, el1) = ssl::geometry::angles_deg(&source.direction_at(end));
        csv += &format!("walker,{t},{end},{az0},{el0},{az1},{el1}\n");
        labels += &format!("{t:.6}\t{end:.6}\twalker {az0}/{el0} -> {az1}/{el1}\n");
        t = end;
    }
    let json = serde_json::json!({"sources": [{
        "name": "walker", "azimuth_deg": source.azimuth_deg, "elevation_deg": source.elevation_deg,
        "intervals": source.active, "turn_deg_per_s": 30.0, "turn_from_s": from,
    }], "duration_s": truth.duration_s});
    for (name, text) in [
        ("pieces.csv", csv),
        ("labels.txt", labels),
        ("turn.json", json.to_string()),
    ] {
        let hand = ssl::Truth::from_file(&write(dir.path(), name, &text)).unwrap();
        assert_eq!(hand.sources.len(), 1, "{name}");
        assert_eq!(hand.sources[0].active.len(), 1, "{name}");
        let scored = ssl::evaluate::evaluate(&hand, &records, 0.175).unwrap();
        let (m, want) = (
            scored.mean_error_deg.unwrap(),
            report.mean_error_deg.unwrap(),
        );
        assert!((m - want).abs() < 0.02, "{name}: {m} against {want}");
        assert_eq!(scored.detections, report.detections, "{name}");
        assert_eq!(scored.tracking.unwrap().tracks, 1, "{name}");
    }
    let mut still = truth.clone();
    still.sources[0].turn_deg_per_s = None;
    let against_start = ssl::evaluate::evaluate(&still, &records, 0.175).unwrap();
    assert!(
        against_start.sources[0].detections == 0 || against_start.mean_error_deg.unwrap() > 20.0,
        "{:?}",
        against_start.mean_error_deg
    );
}
