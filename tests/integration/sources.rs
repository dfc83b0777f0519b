//! `--sources` (docs/interface.md, "Sources"): one record per tracked source of a file,
//! the sum of its events, checked against the events the same run writes.

use crate::support;

use support::*;

#[test]
fn each_tracked_source_is_one_record_summing_its_events() {
    let dir = tempdir();
    let d = dir.path();
    write(d, "prism.toml", geometry_toml(&prism(), ""));
    // A noise source heard twice from 40 deg, and clicks from -100 deg in between.
    let scene = write(
        d,
        "scene.toml",
        "sample_rate = 48000\nduration = 3.2\nseed = 3\n\
         [array]\ngeometry = \"prism.toml\"\nposition = [0, 0, 0]\n\
         [[source]]\nazimuth_deg = 40\nelevation_deg = 5\ndistance = 3\nsignal = \"white\"\n\
         level_db = -26\nactive = [[0.3, 0.9], [2.2, 2.9]]\n\
         [[source]]\nazimuth_deg = -100\nelevation_deg = 0\ndistance = 3\nsignal = \"white\"\n\
         level_db = -26\nactive = [[1.2, 1.8]]\n\
         [noise]\nsnr_db = 20\nsensor_db = -70\n",
    );
    let wav = d.join("rec.wav");
    let out = run(&["simulate", s(&scene), "-o", s(&wav)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json = |extra: &str| -> serde_json::Value {
        let out = run(&[
            "analyze",
            s(&wav),
            "-g",
            s(&d.join("prism.toml")),
            "-f",
            "json",
            extra,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let doc = json("--sources");
    let sources = doc["sources"].as_array().unwrap();
    let events = doc["events"].as_array().unwrap();
    assert_eq!(sources.len(), 2, "{sources:?}");
    for s in sources {
        let mine: Vec<_> = events
            .iter()
            .filter(|e| e["source"] == s["source"])
            .collect();
        let f = |v: &serde_json::Value| v.as_f64().unwrap();
        let first = mine
            .iter()
            .map(|e| f(&e["start_s"]))
            .fold(f64::INFINITY, f64::min);
        let last = mine.iter().map(|e| f(&e["end_s"])).fold(0.0, f64::max);
        let active: f64 = mine.iter().map(|e| f(&e["end_s"]) - f(&e["start_s"])).sum();
        let detections: u64 = mine.iter().map(|e| e["detections"].as_u64().unwrap()).sum();
        assert_eq!(s["events"].as_u64().unwrap(), mine.len() as u64);
        assert_eq!((f(&s["first_s"]), f(&s["last_s"])), (first, last));
        assert!((f(&s["active_s"]) - active).abs() < 1e-5);
        assert_eq!(s["detections"].as_u64().unwrap(), detections);
    }
    // The source heard twice is one record of two events, in its direction.
    let twice = sources
        .iter()
        .find(|s| s["events"] == 2)
        .expect("a source with 2 events");
    assert!(
        (twice["azimuth_deg"].as_f64().unwrap() - 40.0).abs() < 2.0,
        "{twice}"
    );
    // CSV: a header of the contract's fields, one row per source.
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&d.join("prism.toml")),
        "--sources",
    ]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.starts_with(
        "file,source,first_s,last_s,active_s,events,azimuth_deg,elevation_deg,x,y,z,spread_deg,detections\n"
    ));
    assert_eq!(text.lines().count(), 3);
    // Untracked, there are no sources.
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&d.join("prism.toml")),
        "--sources",
        "--no-track",
    ]);
    assert_eq!(out.status.code(), Some(2));
}
