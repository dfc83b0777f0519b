//! `ssl plot`: the picture's structure (not its pixels), its size on large results, and
//! the README's example picture kept current.

use crate::support;

use std::path::Path;
use support::*;

/// The example analysed with events as JSON (in `dir`), as the README shows.
fn example_json(dir: &Path) -> std::path::PathBuf {
    let out = dir.join("r.json");
    let o = ssl()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "analyze",
            "testdata/example.wav",
            "-g",
            "testdata/prism.toml",
        ])
        .args(["-f", "json", "--events", "-o", s(&out)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    out
}

fn plot(args: &[&str]) -> std::process::Output {
    ssl()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .arg("plot")
        .args(args)
        .output()
        .unwrap()
}

/// Every `<circle>` of the SVG, and all its text.
/// The marks (circles of radius 2; the legend's are 3) and the text of an SVG.
fn circles_and_text(svg: &str) -> (usize, String) {
    let doc = roxmltree::Document::parse(svg).expect("the SVG parses as XML");
    let circles = doc
        .descendants()
        .filter(|n| n.has_tag_name("circle") && n.attribute("r") == Some("2"))
        .count();
    let text = doc
        .descendants()
        .filter_map(|n| n.text())
        .collect::<Vec<_>>()
        .join("\n");
    (circles, text)
}

#[test]
fn the_example_plot_has_one_mark_per_detection_per_panel_and_its_labels() {
    let dir = tempdir();
    let json = example_json(dir.path());
    let o = plot(&[s(&json), "--truth", "testdata/example.truth.json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = String::from_utf8(o.stdout).unwrap();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = doc["detections"].as_array().unwrap().len();
    let (circles, text) = circles_and_text(&svg);
    // Azimuth, elevation and sky map: three marks per detection.
    assert_eq!(circles, 3 * rows);
    for label in [
        "time (s)",
        "azimuth (deg)",
        "elevation (deg)",
        "testdata/example.wav",
        "prism-8 (8 mics)",
        "calibrated per frame",
        "3 events",
        "events detected 100%",
        // The legend.
        "source 1",
        "truth (black",
        "event (mean direction",
    ] {
        assert!(text.contains(label), "{label} missing from:\n{text}");
    }
    // The same bytes every time, and the same picture through standard input.
    let again = plot(&[s(&json), "--truth", "testdata/example.truth.json"]);
    assert_eq!(again.stdout, svg.as_bytes());
    let piped = run_with_stdin(
        &[
            "plot",
            "-",
            "--truth",
            &format!("{}/testdata/example.truth.json", env!("CARGO_MANIFEST_DIR")),
        ],
        std::fs::read(&json).unwrap(),
    );
    assert_eq!(piped.stdout, svg.as_bytes(), "{}", stderr(&piped));
}

#[test]
fn several_files_get_one_row_each_and_file_picks_one() {
    let dir = tempdir();
    let csv = dir.path().join("two.csv");
    let o = ssl()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "analyze",
            "testdata/example.wav",
            "-",
            "-g",
            "testdata/prism.toml",
        ])
        .args(["--no-track", "-o", s(&csv)])
        .stdin(std::fs::File::open(testdata("example.wav")).unwrap())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = parse_csv(&std::fs::read_to_string(&csv).unwrap()).len();
    let o = plot(&[s(&csv)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (circles, text) = circles_and_text(&String::from_utf8(o.stdout).unwrap());
    assert_eq!(circles, 3 * rows);
    assert!(text.contains("testdata/example.wav") && text.contains("<stdin>"));
    // Without tracks the marks are coloured by score, and the title and legend say so.
    assert!(text.contains("colour: score") && text.contains("detection (colour: score"));
    let o = plot(&[s(&csv), "--file", "<stdin>"]);
    let (circles, text) = circles_and_text(&String::from_utf8(o.stdout).unwrap());
    assert_eq!(circles, 3 * rows / 2);
    assert!(!text.contains("testdata/example.wav"));
    let o = plot(&[s(&csv), "--file", "nope.wav"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(
        e.contains("no file \"nope.wav\"") && e.lines().count() == 1,
        "{e}"
    );
}

#[test]
fn an_hour_of_detections_is_binned_into_a_bounded_picture() {
    let dir = tempdir();
    // An hour at 100 detections a second: three sources turning slowly, plus noise.
    let mut text =
        String::from("time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source\n");
    let mut seed = 7u64;
    for i in 0..360_000u64 {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let jitter = (seed >> 40) as f64 / (1u64 << 24) as f64 - 0.5;
        let source = i % 3 + 1;
        let t = i as f64 * 0.01;
        let az =
            ((source as f64 * 120.0 + t * 0.1 + 20.0 * jitter + 180.0).rem_euclid(360.0)) - 180.0;
        let el = 10.0 * jitter;
        let (a, e) = (az.to_radians(), el.to_radians());
        text += &format!(
            "{t:.6},{az:.3},{el:.3},{:.6},{:.6},{:.6},{:.4},hour.wav,{i},8,{source}\n",
            e.cos() * a.cos(),
            e.cos() * a.sin(),
            e.sin(),
            5.0 + jitter
        );
    }
    let csv = write(dir.path(), "hour.csv", text);
    let started = std::time::Instant::now();
    let out = dir.path().join("hour.svg");
    let o = plot(&[s(&csv), "-o", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    eprintln!(
        "an hour's result plotted in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    let svg = std::fs::read_to_string(&out).unwrap();
    let (circles, text) = circles_and_text(&svg);
    assert!(circles <= 3 * ssl::plot::MAX_MARKS, "{circles}");
    assert!(circles > 3 * ssl::plot::MAX_MARKS / 4, "{circles}");
    assert!(svg.len() < 8 << 20, "{} bytes", svg.len());
    assert!(
        text.contains("360000 detections") && text.contains("binned"),
        "{text}"
    );
}

#[test]
fn what_is_not_a_result_is_refused_in_one_line() {
    let dir = tempdir();
    let bad = write(dir.path(), "bad.json", "{\"detections\": 3}");
    let o = plot(&[s(&bad)]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("bad.json") && e.lines().count() == 1, "{e}");
    let text = write(dir.path(), "notes.txt", "garbage\n");
    let o = plot(&[s(&text)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("not a result of ssl analyze"),
        "{}",
        stderr(&o)
    );
    let empty = write(
        dir.path(),
        "empty.csv",
        "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source\n",
    );
    let o = plot(&[s(&empty)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no detections"), "{}", stderr(&o));
}

/// The README shows `docs/example.svg`, made by the commands it quotes; this keeps it
/// current (`SSL_UPDATE_PLOTS=1 cargo test --test integration plot::` rewrites it).
#[test]
fn the_readme_picture_is_current() {
    let dir = tempdir();
    let json = example_json(dir.path());
    let o = plot(&[s(&json), "--truth", "testdata/example.truth.json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/example.svg");
    if std::env::var_os("SSL_UPDATE_PLOTS").is_some() {
        std::fs::write(&path, &o.stdout).unwrap();
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == o.stdout,
        "docs/example.svg is stale: SSL_UPDATE_PLOTS=1 cargo test --release --test integration plot::"
    );
}

#[test]
fn one_picture_draws_a_bounded_number_of_files() {
    // Issue 31, item 16: the SVG grew with the number of files (40,000 one-row files:
    // 629 MB). At most ssl::plot::MAX_FILES rows; more is an error naming --file.
    let dir = tempdir();
    let d = dir.path();
    let header = "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source\n";
    let rows = |n: usize| {
        (0..n)
            .map(|i| format!("0.1,0,0,1,0,0,3,f{i}.wav,9,8,1\n"))
            .collect::<String>()
    };
    let max = ssl::plot::MAX_FILES;
    write(d, "many.csv", format!("{header}{}", rows(max + 1)));
    write(d, "most.csv", format!("{header}{}", rows(max)));
    let out = run(&["plot", s(&d.join("many.csv")), "-o", s(&d.join("many.svg"))]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains(&format!(
            "the result holds {} files; one picture draws at most {max}: pick one with --file NAME",
            max + 1
        )),
        "{}",
        stderr(&out)
    );
    assert!(!d.join("many.svg").exists());
    let out = run(&["plot", s(&d.join("most.csv")), "-o", s(&d.join("most.svg"))]);
    assert!(out.status.success(), "{}", stderr(&out));
    let size = std::fs::metadata(d.join("most.svg")).unwrap().len();
    assert!(size < 2 << 20, "{size} bytes");
}

#[test]
fn an_events_only_result_fills_the_sky_map_and_the_picture_fits_a_window() {
    let dir = tempdir();
    let events = dir.path().join("events.csv");
    let o = ssl()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "analyze",
            "testdata/example.wav",
            "-g",
            "testdata/prism.toml",
        ])
        .args(["--events", "-o", s(&events)])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = plot(&[s(&events)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = String::from_utf8(o.stdout).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let root = doc.root_element();
    // A 1400-pixel window shows it whole.
    let width: f64 = root.attribute("width").unwrap().parse().unwrap();
    assert!(width <= 1380.0, "{width}");
    // Each event is a bar in both time panels and a square (drawn at 0.6 opacity) on the
    // sky map, the third panel, right of two thirds of the width.
    let squares: Vec<f64> = doc
        .descendants()
        .filter(|n| n.has_tag_name("rect") && n.attribute("opacity") == Some("0.6"))
        .filter_map(|n| n.attribute("x")?.parse().ok())
        .collect();
    let events_written = std::fs::read_to_string(&events).unwrap().lines().count() - 1;
    assert!(events_written > 0);
    assert_eq!(squares.len(), events_written);
    assert!(
        squares.iter().all(|&x| x > width * 2.0 / 3.0),
        "{squares:?}"
    );
    // Ticks in plain numbers: 1, 2.5, never 1.0.
    let (_, text) = circles_and_text(&svg);
    for line in text.lines() {
        let t = line.trim();
        if t.parse::<f64>().is_ok() {
            assert!(!t.ends_with(".0"), "tick {t}");
        }
    }
}

/// A moving source's event is drawn along its path in the azimuth panel, from its first
/// detection's azimuth to its last's, not as a flat bar at its mean; a still source's
/// event stays a bar.
#[test]
fn a_moving_events_band_follows_its_path() {
    let dir = tempdir();
    // A walker from -60 to 57 deg over 1.0-4.9 s (mean 0 deg), and a still source at
    // 120 deg over 5-6 s.
    let events = write(
        dir.path(),
        "events.csv",
        "file,source,start_s,end_s,azimuth_deg,elevation_deg,x,y,z,spread_deg,detections,score,\
         start_azimuth_deg,start_elevation_deg,end_azimuth_deg,end_elevation_deg,uncertainty_deg\n\
         w.wav,1,1.000000,4.900000,0.000,-7.000,0.992546,0.000000,-0.121869,30.000,100,5.0000,-60.000,-7.000,57.000,-7.000,3.00\n\
         w.wav,2,5.000000,6.000000,120.000,0.000,-0.500000,0.866025,0.000000,1.000,30,5.0000,119.000,0.000,121.000,0.000,3.00\n",
    );
    let o = plot(&[s(&events)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let svg = String::from_utf8(o.stdout).unwrap();
    let doc = roxmltree::Document::parse(&svg).unwrap();
    let bands: Vec<Vec<(f64, f64)>> = doc
        .descendants()
        .filter(|n| n.has_tag_name("polygon") && n.attribute("opacity") == Some("0.35"))
        .map(|n| {
            n.attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect();
    // The walker only, in the azimuth and the elevation panel.
    assert_eq!(bands.len(), 2, "{svg}");
    // In the azimuth panel (the first), its band rises (y falls on screen) by 117 deg
    // of the panel's 360 from its start to its end.
    let az = &bands[0];
    let (start, end) = (az[0], az[1]);
    assert!(end.0 > start.0 && start.1 - end.1 > 50.0, "{az:?}");
    // In the elevation panel it is flat: -7 deg throughout.
    let el = &bands[1];
    assert!((el[0].1 - el[1].1).abs() < 1.0, "{el:?}");
}
