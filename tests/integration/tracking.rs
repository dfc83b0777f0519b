//! Sources, not frames: tracks and events from the command line, on real speech in a
//! reverberant room with a fan (docs/interface.md, "Tracked sources" and "Events").

use crate::support;

use nalgebra::Vector3;
use ssl::geometry::{angle_between_deg, unit_from_angles};
use support::*;

/// Two talkers taking turns, A, B, then A again from the same place, on the prism at
/// 16 kHz in the paper's room (RT60 0.35 s, fan and diffuse noise 10 dB below): `wav`.
fn turns(dir: &std::path::Path) -> std::path::PathBuf {
    copy_speech(dir).unwrap();
    write(dir, "prism.toml", geometry_toml(&prism(), ""));
    let mut scene = String::from(
        "sample_rate = 16000\nduration = 12.5\nseed = 11\n[room]\ndimensions = [8.0, 7.0, 3.0]\n\
         rt60 = 0.35\n[array]\ngeometry = \"prism.toml\"\nposition = [4.0, 3.5, 0.8]\n",
    );
    for (az, start, clip, len) in [
        (40.0, 1.0, "aew_a0001", 3.9),
        (-80.0, 5.4, "axb_a0004", 2.8),
        (40.0, 8.7, "axb_a0004", 2.8),
    ] {
        scene += &format!(
            "[[source]]\nazimuth_deg = {az}\nelevation_deg = -7\ndistance = 2.0\n\
             signal = \"file\"\nfile = \"cmu_arctic_us_{clip}.wav\"\nactive = [[{start}, {}]]\n",
            start + len
        );
    }
    scene += "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
              [noise.diffuse]\nweight_db = -6\n";
    let path = write(dir, "turns.toml", &scene);
    let wav = dir.join("turns.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    wav
}

fn direction(v: &serde_json::Value) -> Vector3<f64> {
    Vector3::new(
        v["x"].as_f64().unwrap(),
        v["y"].as_f64().unwrap(),
        v["z"].as_f64().unwrap(),
    )
}

#[test]
fn two_talkers_taking_turns_are_two_tracks_and_three_events() {
    let dir = tempdir();
    let wav = turns(dir.path());
    let o = ssl()
        .current_dir(dir.path())
        .args([
            "analyze",
            s(&wav),
            "-g",
            "prism.toml",
            "--events",
            "-f",
            "json",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (a, b) = (unit_from_angles(40.0, -7.0), unit_from_angles(-80.0, -7.0));
    // Events: A, B, A, the last with A's id again, each where its talker is.
    let events = doc["events"].as_array().unwrap();
    let summary: Vec<(u64, f64, f64)> = events
        .iter()
        .map(|e| {
            (
                e["source"].as_u64().unwrap(),
                e["start_s"].as_f64().unwrap(),
                e["end_s"].as_f64().unwrap(),
            )
        })
        .collect();
    eprintln!("{summary:?}");
    assert_eq!(events.len(), 3, "{summary:?}");
    let ids: Vec<u64> = summary.iter().map(|e| e.0).collect();
    assert_eq!(ids[0], ids[2]);
    assert_ne!(ids[0], ids[1]);
    for (e, (truth, start, end)) in
        events
            .iter()
            .zip([(a, 1.0, 4.9), (b, 5.4, 8.2), (a, 8.7, 11.5)])
    {
        let error = angle_between_deg(&direction(e), &truth);
        assert!(error < 3.0, "{e}: {error} deg");
        // An event spans its detections: inside the talker's sentence (and its
        // reverberation), not necessarily all of it.
        let (s0, s1) = (e["start_s"].as_f64().unwrap(), e["end_s"].as_f64().unwrap());
        assert!(s0 >= start - 0.05 && s1 <= end + 0.4 && s0 < s1, "{e}");
        assert!(e["spread_deg"].as_f64().unwrap() < 5.0, "{e}");
    }
    // Every detection carries its track, and each track's rows are on its talker.
    let rows = doc["detections"].as_array().unwrap();
    assert!(rows.len() > 50, "{}", rows.len());
    let mut on_track = 0;
    for r in rows {
        let id = r["source"].as_u64().unwrap();
        let truth = if id == ids[0] { a } else { b };
        assert!(id == ids[0] || id == ids[1], "{r}");
        on_track += (angle_between_deg(&direction(r), &truth) < 10.0) as usize;
    }
    assert!(
        on_track * 100 >= rows.len() * 98,
        "{on_track} of {}",
        rows.len()
    );
    // The file's entry says what the tracker made of the detections.
    let stats = &doc["files"][0]["tracking"];
    assert_eq!(stats["rows"].as_u64(), Some(rows.len() as u64), "{stats}");
    let mut distinct: Vec<u64> = rows.iter().map(|r| r["source"].as_u64().unwrap()).collect();
    distinct.sort();
    distinct.dedup();
    assert_eq!(
        stats["tracks"].as_u64(),
        Some(distinct.len() as u64),
        "{stats}"
    );
    // The same events as CSV; without tracking, every frame's detection above the
    // threshold is there and no candidate under it (with tracking, the candidates its
    // tracks confirm add rows).
    let csv = |extra: &[&str]| {
        let mut args = vec!["analyze", s(&wav), "-g", "prism.toml"];
        args.extend_from_slice(extra);
        let o = ssl().current_dir(dir.path()).args(&args).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let text = csv(&["--events"]);
    assert!(text.starts_with(
        "file,source,start_s,end_s,azimuth_deg,elevation_deg,x,y,z,spread_deg,detections,score,\
         start_azimuth_deg,start_elevation_deg,end_azimuth_deg,end_elevation_deg,uncertainty_deg\n"
    ));
    assert_eq!(text.lines().count(), 4);
    // Talkers who stay put start and end where they are heard on average.
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line
            .split(',')
            .skip(4)
            .filter_map(|v| v.parse().ok())
            .collect();
        let (azimuth, start, end) = (f[0], f[8], f[10]);
        assert!(
            (start - azimuth).abs() < 5.0 && (end - azimuth).abs() < 5.0,
            "{line}"
        );
    }
    let untracked = parse_csv(&csv(&["--no-track"]));
    assert!(untracked.iter().all(|r| r.source.is_none()));
    eprintln!("{} rows untracked, {} tracked", untracked.len(), rows.len());
    assert!(untracked.len() > 50 && untracked.len() < rows.len());
    // --keep-unconfirmed: the same tracked rows, and the ones no track confirmed among
    // them without a source, in frame order.
    let tracked = parse_csv(&csv(&[]));
    let kept = parse_csv(&csv(&["--keep-unconfirmed"]));
    let confirmed: Vec<_> = kept
        .iter()
        .filter(|r| r.source.is_some())
        .cloned()
        .collect();
    assert_eq!(confirmed, tracked);
    let unconfirmed = kept.len() - confirmed.len();
    eprintln!("{unconfirmed} rows unconfirmed");
    assert!(unconfirmed > 0);
    // Counted the same with or without them written.
    assert_eq!(
        stats["unconfirmed"].as_u64(),
        Some(unconfirmed as u64),
        "{stats}"
    );
    assert!(stats["reflections"].as_u64().unwrap() <= unconfirmed as u64);
    assert!(kept.windows(2).all(|w| w[0].time_s <= w[1].time_s));
}

#[test]
fn background_alone_gives_no_track_and_no_event() {
    let dir = tempdir();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    // The room's fan and diffuse noise for 20 s, at the level they have under a talker.
    let scene =
        "sample_rate = 16000\nduration = 20.0\nseed = 12\n[room]\ndimensions = [8.0, 7.0, 3.0]\n\
                 rt60 = 0.35\n[array]\ngeometry = \"prism.toml\"\nposition = [4.0, 3.5, 0.8]\n\
                 [[source]]\nazimuth_deg = 40\ndistance = 2.0\nsignal = \"white\"\nlevel_db = -26\n\
                 active = [[19.5, 19.9]]\n\
                 [noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [4.7, 4.0, 0.9]\n\
                 [noise.diffuse]\nweight_db = -6\n";
    let path = write(dir.path(), "quiet.toml", scene);
    let wav = dir.path().join("quiet.wav");
    assert!(run(&["simulate", s(&path), "-o", s(&wav)]).status.success());
    let o = ssl()
        .current_dir(dir.path())
        .args(["analyze", s(&wav), "-g", "prism.toml", "--events"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    // Only the burst at the end: one event, at 40 deg.
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2, "{text}");
    assert!(lines[1].contains(",1,19."), "{text}");
}

/// Two talkers at once, 60 deg apart, on the prism at 16 kHz in the same room: each is
/// its own track, found in most 0.1 s windows in which both talk, each row on its talker.
/// Tracking's candidates under the threshold, confirmed by the tracks, are what find
/// them that often: with `--candidates 1` (none), far fewer windows.
#[test]
fn two_talkers_at_once_are_both_followed() {
    let dir = tempdir();
    copy_speech(dir.path()).unwrap();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let mut scene = String::from(
        "sample_rate = 16000\nduration = 5.0\nseed = 21\n[room]\ndimensions = [8.0, 7.0, 3.0]\n\
         rt60 = 0.35\n[array]\ngeometry = \"prism.toml\"\nposition = [4.0, 3.5, 0.8]\n",
    );
    for (az, clip) in [(20.0, "aew_a0001"), (-40.0, "axb_a0004")] {
        scene += &format!(
            "[[source]]\nazimuth_deg = {az}\nelevation_deg = -7\ndistance = 2.0\n\
             signal = \"file\"\nfile = \"cmu_arctic_us_{clip}.wav\"\nactive = [[1.0, 3.8]]\n"
        );
    }
    scene += "[noise]\nsnr_db = 10\nsensor_db = -70\n[[noise.fan]]\nposition = [7.6, 6.6, 2.7]\n\
              [noise.diffuse]\nweight_db = -6\n";
    let path = write(dir.path(), "both.toml", &scene);
    let wav = dir.path().join("both.wav");
    let o = run(&["simulate", s(&path), "-o", s(&wav)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let truth = ssl::Truth::from_file(&dir.path().join("both.truth.json")).unwrap();
    let windows = |extra: &[&str]| {
        let mut args = vec!["analyze", s(&wav), "-g", "prism.toml"];
        args.extend_from_slice(extra);
        let o = ssl().current_dir(dir.path()).args(&args).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let rows = ssl::record::parse_detections(&String::from_utf8(o.stdout).unwrap()).unwrap();
        let report = ssl::evaluate::evaluate(&truth, &rows, 0.175).unwrap();
        let t = report.tracking.clone().unwrap();
        (report, t.overlap_detected as f64 / t.overlap_pairs as f64)
    };
    let (report, share) = windows(&[]);
    let (_, without) = windows(&["--candidates", "1"]);
    let t = report.tracking.as_ref().unwrap();
    eprintln!(
        "both talkers: {:.0}% of windows ({:.0}% without candidates), {} tracks, mean error {:?}",
        100.0 * share,
        100.0 * without,
        t.tracks,
        report.mean_error_deg
    );
    assert_eq!(t.tracks, 2);
    assert!(t.sources.iter().all(|s| s.tracks == 1));
    assert!(share >= 0.5, "{share}");
    assert!(share > without + 0.2, "{share} vs {without}");
    assert!(report.mean_error_deg.unwrap() < 1.0);
    assert_eq!(report.false_detections, 0);
}

/// A talker turning at 45 deg/s around the prism at 16 kHz (free field, real speech):
/// one track, on the talker's direction at each row's time.
#[test]
fn a_moving_talker_is_one_track_on_its_trajectory() {
    let m = support::moving::moving_talker(&prism_geometry(), 16000, -7.0, 45.0, 5).unwrap();
    eprintln!("{m:?}");
    assert_eq!(m.tracks, 1);
    assert!(m.rows > 100, "{}", m.rows);
    assert!(m.mean_error_deg.unwrap() < 3.0, "{:?}", m.mean_error_deg);
    assert!(m.windows > 0.6, "{}", m.windows);
}

/// `--forget-s` bounds how long a silent source is remembered: a source that sounds
/// again from its place 3 s later keeps its id by default (120 s), and gets a new one
/// with `--forget-s 1` (what an array that moves between sounds wants).
#[test]
fn a_source_is_remembered_as_long_as_forget_s_says() {
    let dir = tempdir();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let scene =
        "sample_rate = 16000\nduration = 5.5\nseed = 5\n[room]\ndimensions = [7.0, 5.5, 3.2]\n\
                 rt60 = 0.3\n[array]\ngeometry = \"prism.toml\"\nposition = [3.5, 2.75, 1.1]\n\
                 [[source]]\nazimuth_deg = 30\ndistance = 2.0\nsignal = \"white\"\nlevel_db = -26\n\
                 active = [[0.5, 1.2], [4.2, 4.9]]\n[noise]\nsnr_db = 15\nsensor_db = -70\n";
    let path = write(dir.path(), "again.toml", scene);
    let wav = dir.path().join("again.wav");
    assert!(run(&["simulate", s(&path), "-o", s(&wav)]).status.success());
    let sources = |extra: &[&str]| -> Vec<u64> {
        let mut args = vec!["analyze", s(&wav), "-g", "prism.toml", "--events"];
        args.extend_from_slice(extra);
        let o = ssl().current_dir(dir.path()).args(&args).output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        text.lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect()
    };
    let remembered = sources(&[]);
    assert_eq!(remembered.len(), 2, "{remembered:?}");
    assert_eq!(remembered[0], remembered[1], "{remembered:?}");
    let forgotten = sources(&["--forget-s", "1"]);
    assert_eq!(forgotten.len(), 2, "{forgotten:?}");
    assert_ne!(forgotten[0], forgotten[1], "{forgotten:?}");
}
