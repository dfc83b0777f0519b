//! Bounded work for any input: nothing the user gives can make `ssl` allocate without
//! bound, run for hours, panic, or print NaN; what cannot be meant is refused with the
//! limit in the message.

use crate::support;

use std::path::Path;
use std::time::{Duration, Instant};
use support::*;

/// Runs `ssl args` in `dir`, expecting a one-line error containing `needle`, promptly.
fn refused(dir: &Path, args: &[&str], needle: &str) {
    let start = Instant::now();
    let out = ssl().current_dir(dir).args(args).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(err.contains(needle), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "{args:?} took {:?}",
        start.elapsed()
    );
}

const ARRAY: &str = "[[mic]]\nposition = [0.1, 0.0, 0.0]\n[[mic]]\nposition = [-0.1, 0.0, 0.0]\n[[mic]]\nposition = [0.0, 0.1, 0.05]\n[[mic]]\nposition = [0.0, -0.1, -0.05]\n";

/// A scene file around `body` (a free-field 4-mic array at 16 kHz unless `body` says
/// otherwise), written as `scene.toml`.
fn scene_file(dir: &Path, head: &str, body: &str) -> String {
    write(dir, "array.toml", ARRAY);
    let text = format!(
        "sample_rate = 16000\nduration = 1.0\n{head}\n[array]\ngeometry = \"array.toml\"\nposition = [2.0, 2.0, 1.0]\n{body}"
    );
    write(dir, "scene.toml", text);
    "scene.toml".into()
}

/// Simulates the default scene into `sim.wav` and `sim.truth.json`, analysed into
/// `r.csv`.
fn simulate_and_analyze(d: &Path) {
    let sim = scene_file(d, "", SOURCE);
    for args in [
        vec!["simulate", &sim, "-o", "sim.wav"],
        vec!["analyze", "sim.wav", "-g", "array.toml", "-o", "r.csv"],
    ] {
        let out = ssl().current_dir(d).args(&args).output().unwrap();
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    }
}

const SOURCE: &str =
    "[[source]]\nazimuth_deg = 30.0\ndistance = 1.0\nsignal = \"white\"\nactive = [[0.4, 0.9]]\n";

#[test]
fn endless_and_absurd_inputs_are_refused_promptly() {
    let dir = tempdir();
    let d = dir.path();
    let sc = scene(
        prism(),
        48000,
        &[(30.0, 10.0, ssl::sim::signals::Signal::WhiteNoise)],
        0.3,
        0.005,
        1,
    );
    let wav = render_wav(d, "rec.wav", &sc, ssl::sim::Encoding::Int16);
    let geo = write(d, "prism.toml", geometry_toml(&prism(), ""));
    // /dev/zero as geometry, scene, truth and result: read up to a limit, then refused.
    refused(
        d,
        &["analyze", s(&wav), "-g", "/dev/zero"],
        "longer than 1048576 bytes",
    );
    refused(d, &["simulate", "/dev/zero", "-o", "x.wav"], "longer than");
    simulate_and_analyze(d);
    refused(
        d,
        &["evaluate", "--truth", "/dev/zero", "r.csv"],
        "longer than",
    );
    refused(
        d,
        &["evaluate", "--truth", "sim.truth.json", "/dev/zero"],
        "longer than",
    );
    // A frame size that cannot be meant.
    refused(
        d,
        &[
            "analyze",
            s(&wav),
            "-g",
            s(&geo),
            "-n",
            "18446744073709551614",
        ],
        "from 16 to 65536",
    );
    // Microphones 1e150 m apart, or in millimetres.
    let far = write(
        d,
        "far.toml",
        "[[mic]]\nposition = [1e150, 0, 0]\n[[mic]]\nposition = [-1e150, 0, 0]\n",
    );
    refused(
        d,
        &["analyze", s(&wav), "-g", s(&far)],
        "arrays up to 5 m wide are supported",
    );
    let mm: Vec<_> = prism().iter().map(|p| p * 1000.0).collect();
    let mm = write(d, "mm.toml", geometry_toml(&mm, ""));
    let advice =
        "they look like millimetres (divide them by 1000: the array is then 73.5 cm across)";
    refused(d, &["analyze", s(&wav), "-g", s(&mm)], advice);
    refused(d, &["geometry", s(&mm)], advice);
    // A 3 cm square in centimetres is a 4.2 m array: it runs, but a warning names the
    // unit first.
    let cm = write(
        d,
        "cm.toml",
        "[[mic]]\nposition = [1.5, 1.5, 0]\n[[mic]]\nposition = [-1.5, 1.5, 0]\n\
         [[mic]]\nposition = [-1.5, -1.5, 0]\n[[mic]]\nposition = [1.5, -1.5, 0]\n",
    );
    let out = run(&["geometry", s(&cm)]);
    assert!(
        stderr(&out).contains(
            "they look like centimetres (divide them by 100: the array is then 4.2 cm across)"
        ),
        "{}",
        stderr(&out)
    );
}

#[test]
fn simulate_validates_its_scene_and_its_cost_before_rendering() {
    let dir = tempdir();
    let d = dir.path();
    let room = "[room]\ndimensions = [5.0, 4.0, 3.0]\nrt60 = 0.3\n";
    let cases: Vec<(String, String, &str)> = vec![
        // Numbers that cannot be meant.
        ("".into(), SOURCE.replace("30.0", "nan"), "must be finite"),
        (
            "".into(),
            format!("{SOURCE}level_db = inf\n"),
            "level_db must be between",
        ),
        (
            "".into(),
            format!("{SOURCE}level_db = 1000\n"),
            "level_db must be between",
        ),
        (
            "".into(),
            SOURCE.replace("\"white\"", "\"clicks\"\nrate = 0"),
            "rate must be between",
        ),
        (
            "".into(),
            SOURCE.replace("\"white\"", "\"clicks\"\nrate = nan"),
            "must be finite",
        ),
        (
            "".into(),
            SOURCE.replace("\"white\"", "\"tone\"\nfrequency = 9000"),
            "frequency must be between",
        ),
        (
            "".into(),
            "[[source]]\nposition = [nan, 1.0, 1.0]\nsignal = \"white\"\n".into(),
            "must be finite",
        ),
        (
            "".into(),
            SOURCE.replace("distance = 1.0", "distance = 1e7"),
            "distance must be between",
        ),
        (
            "".into(),
            "[[source]]\nposition = [1e7, 1.0, 1.0]\nsignal = \"white\"\n".into(),
            "at most 1000 m",
        ),
        (
            "duration = 0.00001".into(),
            SOURCE.into(),
            "less than one sample",
        ),
        (
            "speed_of_sound = 1e12".into(),
            SOURCE.into(),
            "speed_of_sound must be between",
        ),
        // Costs: a long recording, an absurd reverberation, a room too small for its echoes.
        (
            "duration = 3600\nsample_rate = 48000".into(),
            SOURCE.into(),
            "samples; at most",
        ),
        (
            room.replace("0.3", "100"),
            SOURCE.into(),
            "image sources per response",
        ),
        (
            "[room]\ndimensions = [0.3, 0.3, 0.3]\nrt60 = 0.5".into(),
            SOURCE.into(),
            "image sources",
        ),
        ("".into(), SOURCE.repeat(1001), "at most 1000 are supported"),
        // Issue 31, item 20: "does not decay as requested" said nothing more.
        (
            "[room]\ndimensions = [50.0, 50.0, 50.0]\nrt60 = 0.05".into(),
            SOURCE.into(),
            "sound travels 97 ms between walls on average, too long for its echoes to decay 25 dB within 1.5 x rt60; a longer rt60 or a smaller room",
        ),
        // Issue 31, item 12: what the cost check ignored. 100,000 free-field fans ran
        // past 120 s; 8,000 active intervals at RT60 2.5 s took 99 s.
        (
            "duration = 5.0".into(),
            format!(
                "{SOURCE}[noise]\nsnr_db = 10\n{}",
                "[[noise.fan]]\nposition = [3.0, 3.0, 1.0]\nsignal = \"pink\"\n".repeat(100_000)
            ),
            "100000 fans",
        ),
        (
            "duration = 20.0\n[room]\ndimensions = [10.0, 8.0, 4.0]\nrt60 = 1.0".into(),
            SOURCE.replace(
                "active = [[0.4, 0.9]]",
                &format!(
                    "active = [{}]",
                    (0..20000)
                        .map(|i| format!("[{:.4}, {:.4}]", i as f64 * 0.001, i as f64 * 0.001 + 0.0005))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            "20000 active intervals",
        ),
    ];
    for (head, body, needle) in cases {
        // A head that sets sample_rate or duration replaces the default lines.
        write(d, "array.toml", ARRAY);
        let mut text = String::new();
        if !head.contains("sample_rate") {
            text += "sample_rate = 16000\n";
        }
        if !head.contains("duration") {
            text += "duration = 1.0\n";
        }
        let (top, room_part) = match head.find("[room]") {
            Some(i) => (&head[..i], &head[i..]),
            None => (&head[..], ""),
        };
        text += &format!(
            "{top}\n[array]\ngeometry = \"array.toml\"\nposition = [2.0, 2.0, 1.0]\n{room_part}\n{body}"
        );
        write(d, "scene.toml", text);
        refused(d, &["simulate", "scene.toml", "-o", "out.wav"], needle);
        assert!(!d.join("out.wav").exists());
    }
}

#[test]
fn evaluate_refuses_values_that_cannot_be_meant() {
    let dir = tempdir();
    let d = dir.path();
    simulate_and_analyze(d);
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("sim.truth.json")).unwrap()).unwrap();
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut t = truth.clone();
        f(&mut t);
        write(d, "t.json", serde_json::to_string(&t).unwrap());
    };
    type Change<'a> = &'a dyn Fn(&mut serde_json::Value);
    let cases: [(Change, &str); 5] = [
        (&|t| t["duration_s"] = 1e12.into(), "duration_s"),
        (&|t| t["duration_s"] = (-1.0).into(), "duration_s"),
        (
            &|t| t["sources"][0]["active"] = serde_json::json!([[0.8, 0.2]]),
            "reversed",
        ),
        (&|t| t["sample_rate"] = 0.into(), "sample_rate"),
        (
            &|t| {
                t["sources"][0]["x"] = 0.0.into();
                t["sources"][0]["y"] = 0.0.into();
                t["sources"][0]["z"] = 0.0.into();
            },
            "not a finite non-zero vector",
        ),
    ];
    for (change, needle) in cases {
        edit(change);
        refused(d, &["evaluate", "--truth", "t.json", "r.csv"], needle);
    }
    // NaN in a result (as text: JSON has no NaN), and a zero vector.
    let csv = std::fs::read_to_string(d.join("r.csv")).unwrap();
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[1].split(',').map(String::from).collect();
    fields[3] = "NaN".into();
    lines[1] = fields.join(",");
    write(d, "nan.csv", lines.join("\n") + "\n");
    refused(
        d,
        &["evaluate", "--truth", "sim.truth.json", "nan.csv"],
        "not a finite number",
    );
    fields[3] = "0".into();
    fields[4] = "0".into();
    fields[5] = "0".into();
    lines[1] = fields.join(",");
    write(d, "zero.csv", lines.join("\n") + "\n");
    refused(
        d,
        &["evaluate", "--truth", "sim.truth.json", "zero.csv"],
        "vector is zero",
    );
    // The truth file the project ships is read.
    let example = ssl()
        .args(["evaluate", "--truth"])
        .arg(testdata("example.truth.json"))
        .arg(write(
            d,
            "none.csv",
            "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics\n",
        ))
        .output()
        .unwrap();
    assert!(example.status.success(), "{}", stderr(&example));
}

#[test]
fn a_speed_of_sound_outside_50_to_5000_m_s_is_refused_everywhere() {
    let dir = tempdir();
    let d = dir.path();
    let wav = testdata("example.wav");
    let prism = testdata("prism.toml");
    let (wav, prism) = (s(&wav), s(&prism));
    // On the command line: a usage error naming the range (1e-304 panicked the steered
    // search, 1e-16 to 1e-303 analysed nonsense, 0.01 advised an impossible frame).
    for c in ["1e-304", "1e-16", "0.01", "49", "5001", "1e300"] {
        for args in [
            vec!["analyze", wav, "-g", prism, "-c", c],
            vec!["geometry", prism, "-c", c],
        ] {
            let out = ssl().args(&args).output().unwrap();
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
            assert!(err.contains("50 to 5000 m/s"), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{args:?}: {err}");
        }
    }
    // In a geometry file: a data error naming the file and the range.
    let text = format!("speed_of_sound = 1e-308\n{ARRAY}");
    write(d, "slow.toml", text);
    refused(
        d,
        &["geometry", "slow.toml"],
        "speed_of_sound must be 50 to 5000 m/s",
    );
    // The range's ends are accepted.
    for c in ["50", "5000", "343"] {
        let out = ssl().args(["geometry", prism, "-c", c]).output().unwrap();
        assert!(out.status.success(), "-c {c}: {}", stderr(&out));
    }
}

#[test]
fn printing_to_a_full_disk_is_an_error_line_naming_standard_output() {
    let prism = testdata("prism.toml");
    let truth = testdata("example.truth.json");
    let dir = tempdir();
    let result = dir.path().join("r.csv");
    let wav = testdata("example.wav");
    let out = ssl()
        .args(["analyze", s(&wav), "-g", s(&prism), "-o", s(&result)])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    // completions panicked (clap_complete's writer); geometry and evaluate said only
    // "No space left on device".
    for args in [
        vec!["completions", "bash"],
        vec!["geometry", s(&prism)],
        vec!["evaluate", "--truth", s(&truth), s(&result)],
    ] {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = ssl().args(&args).stdout(full).output().unwrap();
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("cannot write standard output: No space left on device"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
}

#[test]
fn plot_refuses_a_result_with_a_number_that_is_not_finite() {
    let dir = tempdir();
    let d = dir.path();
    let header = "time_s,azimuth_deg,elevation_deg,x,y,z,score,file,frame,mics,source";
    write(
        d,
        "rows.csv",
        format!("{header}\ninf,30,10,0.85,0.49,0.17,5,a.wav,9,8,1\n"),
    );
    refused(
        d,
        &["plot", "rows.csv", "-o", "r.svg"],
        "row 1 (line 2): a detection's time_s is not a finite number",
    );
    let header =
        "file,source,start_s,end_s,azimuth_deg,elevation_deg,x,y,z,spread_deg,detections,score";
    write(
        d,
        "events.csv",
        format!("{header}\na.wav,1,0.1,Infinity,30,10,0.85,0.49,0.17,0.1,40,5\n"),
    );
    refused(
        d,
        &["plot", "events.csv", "-o", "e.svg"],
        "row 1 (line 2): an event's end_s is not a finite number",
    );
    assert!(!d.join("r.svg").exists() && !d.join("e.svg").exists());
}

#[test]
fn threads_are_bounded() {
    let wav = testdata("example.wav");
    let prism = testdata("prism.toml");
    let args = ["analyze", s(&wav), "-g", s(&prism), "-j", "10000"];
    let out = ssl().args(args).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--threads") && err.contains("1024"), "{err}");
}

#[test]
fn toml_arrays_with_extra_numbers_are_errors() {
    let dir = tempdir();
    let d = dir.path();
    // A geometry's position and side.
    let mic4 = ARRAY.replacen(
        "position = [0.1, 0.0, 0.0]",
        "position = [0.1, 0.0, 0.0, 1000]",
        1,
    );
    write(d, "mic4.toml", &mic4);
    refused(
        d,
        &["geometry", "mic4.toml"],
        "expected an array of 3 numbers",
    );
    write(
        d,
        "side4.toml",
        format!("side = [0.0, 0.0, 1.0, 5.0]\n{ARRAY}"),
    );
    refused(
        d,
        &["geometry", "side4.toml"],
        "expected an array of 3 numbers",
    );
    // A scene's room, its array's position, a source's position and intervals, a fan.
    let room = "[room]\ndimensions = [5.0, 4.0, 3.0, 9.0]\nrt60 = 0.3";
    let fan = "[noise]\nsnr_db = 10\n[[noise.fan]]\nposition = [1.0, 1.0, 1.0, 1.0]\n";
    let source_at = "[[source]]\nposition = [1.0, 1.0, 1.0, 1.0]\nsignal = \"white\"\n";
    let three = "[[source]]\nazimuth_deg = 30.0\ndistance = 1.0\nsignal = \"white\"\nactive = [[0.1, 0.5, 0.9]]\n";
    for (head, body, needle) in [
        (room, SOURCE.to_string(), "an array of 3 numbers"),
        ("", format!("{SOURCE}{fan}"), "an array of 3 numbers"),
        ("", source_at.to_string(), "an array of 3 numbers"),
        ("", three.to_string(), "an array of 2 numbers"),
    ] {
        let scene = scene_file(d, head, &body);
        refused(d, &["simulate", &scene, "-o", "x.wav"], needle);
    }
    // The array's position in the room.
    let scene = scene_file(d, "", SOURCE);
    let text = std::fs::read_to_string(d.join(&scene)).unwrap();
    let array4 = "position = [2.0, 2.0, 1.0, 7.0]";
    write(
        d,
        &scene,
        text.replace("position = [2.0, 2.0, 1.0]", array4),
    );
    refused(
        d,
        &["simulate", "scene.toml", "-o", "x.wav"],
        "an array of 3 numbers",
    );
    assert!(!d.join("x.wav").exists());
}

#[test]
fn evaluate_and_plot_read_results_with_one_reader() {
    // Issue 31, item 8: evaluate scored an empty file, garbage, `[1,2,3]` and `"hello"`
    // as an empty result; errors inside a JSON document were placed at "line 1"; plot
    // refused a CSV with a byte order mark that evaluate read.
    let dir = tempdir();
    let d = dir.path();
    simulate_and_analyze(d);
    let analysed = ssl()
        .current_dir(d)
        .args([
            "analyze",
            "sim.wav",
            "-g",
            "array.toml",
            "-f",
            "json",
            "-o",
            "r.json",
        ])
        .output()
        .unwrap();
    assert!(analysed.status.success());
    let csv = std::fs::read(d.join("r.csv")).unwrap();
    write(d, "bom.csv", [&b"\xEF\xBB\xBF"[..], &csv].concat());
    write(d, "empty", "");
    write(d, "blank", "\n \n");
    write(d, "garbage", [0u8, 159, 146, 150, 7, 27, b'[', b'2', b'J']);
    write(d, "array.json", "[1,2,3]\n");
    write(d, "hello.json", "\"hello\"\n");
    write(d, "object.json", "{\"a\": 1}\n");
    // A document with a bad value on its 5th line.
    let doc = std::fs::read_to_string(d.join("r.json")).unwrap();
    let mut lines: Vec<String> = doc.lines().map(String::from).collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with("{\"time_s\""))
        .unwrap();
    lines[at] = lines[at].replacen("\"score\":", "\"score\":\"high\",\"was\":", 1);
    write(d, "bad.json", lines.join("\n"));
    let cases: &[(&str, &str)] = &[
        ("empty", "empty: not a result of ssl analyze"),
        ("blank", "empty: not a result of ssl analyze"),
        ("garbage", "not a result of ssl analyze: its first line is"),
        (
            "array.json",
            "not a result of ssl analyze: its first line is \"[1,2,3]\"",
        ),
        ("hello.json", "not a result of ssl analyze"),
        (
            "object.json",
            "not a result of ssl analyze (no `detections`",
        ),
        (
            "bad.json",
            &format!(
                "invalid type: string \"high\", expected f64 at line {}",
                at + 1
            ),
        ),
    ];
    for (file, needle) in cases {
        let e = ssl()
            .current_dir(d)
            .args(["evaluate", "--truth", "sim.truth.json", file])
            .output()
            .unwrap();
        let p = ssl()
            .current_dir(d)
            .args(["plot", file, "-o", "p.svg"])
            .output()
            .unwrap();
        for out in [&e, &p] {
            assert_eq!(out.status.code(), Some(1), "{file}: {}", stderr(out));
            assert!(stderr(out).contains(needle), "{file}: {}", stderr(out));
            assert_eq!(stderr(out).lines().count(), 1, "{file}: {}", stderr(out));
            assert!(
                !stderr(out).contains('\u{1b}'),
                "{file}: an escape printed raw"
            );
        }
        assert_eq!(stderr(&e), stderr(&p), "{file}: one reader, one answer");
    }
    // A byte order mark is skipped by both, and changes nothing.
    for file in ["bom.csv", "r.csv", "r.json"] {
        let e = ssl()
            .current_dir(d)
            .args(["evaluate", "--truth", "sim.truth.json", file])
            .output()
            .unwrap();
        assert!(e.status.success(), "{file}: {}", stderr(&e));
        let p = ssl()
            .current_dir(d)
            .args(["plot", file, "-o", "p.svg"])
            .output()
            .unwrap();
        assert!(p.status.success(), "{file}: {}", stderr(&p));
    }
    let score = |f: &str| {
        ssl()
            .current_dir(d)
            .args([
                "evaluate",
                "--truth",
                "sim.truth.json",
                f,
                "-g",
                "array.toml",
            ])
            .output()
            .unwrap()
            .stdout
    };
    assert_eq!(score("bom.csv"), score("r.csv"));
    // A JSON result carries its geometry, which a CSV result is given here.
    assert_eq!(score("r.json"), score("r.csv"));
}

#[test]
fn a_json_result_is_read_in_the_memory_of_its_rows() {
    // Issue 31, item 13: a JSON result was parsed whole into a value and cloned (a
    // 200 MB result took 5.2 GB, NDJSON 0.39 GB). Now both stream: the same rows take
    // about the same memory in either format.
    let dir = tempdir();
    let d = dir.path();
    simulate_and_analyze(d);
    let row = "{\"time_s\":0.5,\"azimuth_deg\":30.0,\"elevation_deg\":0.0,\"x\":0.866025,\"y\":0.5,\"z\":0.0,\"score\":3.5,\"file\":\"sim.wav\",\"frame\":46,\"mics\":4,\"source\":1}";
    let n = 150_000;
    let mut ndjson = String::with_capacity(n * (row.len() + 1));
    for _ in 0..n {
        ndjson.push_str(row);
        ndjson.push('\n');
    }
    let json = format!(
        "{{\"tool\":{{\"name\":\"ssl\"}},\n\"detections\":[\n{}\n],\n\"files\":[]}}\n",
        ndjson.trim_end().replace('\n', ",\n")
    );
    write(d, "big.ndjson", &ndjson);
    write(d, "big.json", &json);
    let exe = support::harness::binary();
    let peak = |file: &str| {
        let (_, mb) = support::harness::run_measured(
            exe,
            &[
                "evaluate",
                "--truth",
                d.join("sim.truth.json").to_str().unwrap(),
                d.join(file).to_str().unwrap(),
            ],
        )
        .unwrap();
        mb
    };
    let (from_json, from_ndjson) = (peak("big.json"), peak("big.ndjson"));
    eprintln!(
        "{} MB of JSON: {from_json:.0} MB; NDJSON: {from_ndjson:.0} MB",
        json.len() >> 20
    );
    assert!(
        from_json < from_ndjson * 1.3 + 10.0,
        "JSON {from_json:.0} MB against NDJSON {from_ndjson:.0} MB"
    );
}

#[test]
fn a_long_file_source_is_read_only_as_far_as_it_is_played() {
    // Issue 31, item 15: a `file` source was read whole as f64 (a 300M-sample WAV
    // aborted at 2 GB). A sparse 50M-sample file (100 MB of zeros on disk, 400 MB as
    // f64) played for 1 s now takes a few MB.
    let dir = tempdir();
    let d = dir.path();
    let frames: u32 = 50_000_000;
    let mut header = Vec::new();
    header.extend_from_slice(b"RIFF");
    header.extend_from_slice(&(36 + 2 * frames).to_le_bytes());
    header.extend_from_slice(b"WAVEfmt ");
    header.extend_from_slice(&16u32.to_le_bytes());
    header.extend_from_slice(&1u16.to_le_bytes()); // PCM
    header.extend_from_slice(&1u16.to_le_bytes()); // mono
    header.extend_from_slice(&16000u32.to_le_bytes());
    header.extend_from_slice(&32000u32.to_le_bytes());
    header.extend_from_slice(&2u16.to_le_bytes());
    header.extend_from_slice(&16u16.to_le_bytes());
    header.extend_from_slice(b"data");
    header.extend_from_slice(&(2 * frames).to_le_bytes());
    let long = write(d, "long.wav", &header);
    std::fs::OpenOptions::new()
        .write(true)
        .open(&long)
        .unwrap()
        .set_len(header.len() as u64 + 2 * frames as u64)
        .unwrap();
    let sim = scene_file(
        d,
        "",
        "[[source]]\nazimuth_deg = 30.0\ndistance = 1.0\nsignal = \"file\"\nfile = \"long.wav\"\nactive = [[0.0, 1.0]]\n",
    );
    let (_, mb) = support::harness::run_measured(
        support::harness::binary(),
        &[
            "simulate",
            d.join(&sim).to_str().unwrap(),
            "-o",
            d.join("out.wav").to_str().unwrap(),
        ],
    )
    .unwrap();
    eprintln!("a 50M-sample file source, 1 s played: {mb:.0} MB");
    assert!(mb < 60.0, "{mb:.0} MB");
}

#[test]
fn dereverberation_takes_memory_as_samples_come_and_refuses_what_it_cannot_hold() {
    // Issue 31, item 17: --wpe reserved 2 s x rate x channels up front (a 1024-channel
    // 768 kHz header asked 6.29 GB). A streamed header promising that, with 2 MB of
    // data, now runs in a 1 GB address space.
    let dir = tempdir();
    let d = dir.path();
    let (channels, rate) = (1024u16, 768_000u32);
    let mut wav = Vec::new();
    wav.extend_from_slice(b"RIFF\xff\xff\xff\xffWAVEfmt ");
    wav.extend_from_slice(&16u32.to_le_bytes());
    wav.extend_from_slice(&1u16.to_le_bytes());
    wav.extend_from_slice(&channels.to_le_bytes());
    wav.extend_from_slice(&rate.to_le_bytes());
    wav.extend_from_slice(&(rate * 2 * channels as u32).to_le_bytes());
    wav.extend_from_slice(&(2 * channels).to_le_bytes());
    wav.extend_from_slice(&16u16.to_le_bytes());
    wav.extend_from_slice(b"data\xff\xff\xff\xff");
    wav.resize(wav.len() + 1000 * 2 * channels as usize, 0);
    write(d, "wide.wav", &wav);
    let four: String = ARRAY
        .split("[[mic]]\n")
        .skip(1)
        .enumerate()
        .map(|(i, m)| format!("[[mic]]\n{m}channel = {i}\n"))
        .collect();
    write(d, "array.toml", four);
    let script = format!(
        "ulimit -v 1000000 && exec {} analyze - -g array.toml --wpe -j 1 < wide.wav",
        env!("CARGO_BIN_EXE_ssl")
    );
    let out = std::process::Command::new("sh")
        .args(["-c", &script])
        .current_dir(d)
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(matches!(out.status.code(), Some(0 | 1)), "{err}");
    assert!(!err.contains("channel"), "the filter ran: {err}");
    assert!(!err.contains("memory allocation"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Filters that grow as the square of the microphones are refused beyond 32.
    let mics: String = (0..64)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 64.0;
            format!(
                "[[mic]]\nposition = [{:.4}, {:.4}, 0.0]\nchannel = {i}\n",
                0.1 * a.cos(),
                0.1 * a.sin()
            )
        })
        .collect();
    write(d, "ring64.toml", mics);
    refused(
        d,
        &["analyze", "wide.wav", "-g", "ring64.toml", "--wpe"],
        "dereverberating the input (wpe) with 64 microphones at 768000 Hz needs about",
    );
}

#[test]
fn messages_show_numbers_briefly_and_say_what_is_wrong() {
    // Issue 31, item 20 (and the NaN WAV of item 19).
    let dir = tempdir();
    let d = dir.path();
    simulate_and_analyze(d);
    let no_long_numbers = |err: &str| {
        let longest = err
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest < 20, "a number of {longest} digits: {err}");
    };
    // A warning's threshold, a truth's duration, a scene's duration.
    let out = ssl()
        .current_dir(d)
        .args([
            "analyze",
            "sim.wav",
            "-g",
            "array.toml",
            "--min-score",
            "1e300",
        ])
        .output()
        .unwrap();
    assert!(
        stderr(&out).contains("a threshold of 1e300 per pair"),
        "{}",
        stderr(&out)
    );
    no_long_numbers(&stderr(&out));
    let mut t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("sim.truth.json")).unwrap()).unwrap();
    t["duration_s"] = 1e300.into();
    write(d, "t.json", t.to_string());
    refused(
        d,
        &["evaluate", "--truth", "t.json", "r.csv"],
        "duration_s 1e300 is not",
    );
    let text = std::fs::read_to_string(d.join("scene.toml"))
        .unwrap()
        .replace("duration = 1.0", "duration = 1e300");
    write(d, "long.toml", text);
    refused(d, &["simulate", "long.toml", "-o", "x.wav"], "got 1e300");
    // An optional number is shown as a number, not `Some(...)`.
    let text = std::fs::read_to_string(d.join("scene.toml")).unwrap()
        + "[noise]\nsnr_db = 10\nsensor_db = 1e9\n";
    write(d, "sensor.toml", text);
    refused(
        d,
        &["simulate", "sensor.toml", "-o", "x.wav"],
        "dBFS, got 1e9",
    );
    let out = ssl()
        .current_dir(d)
        .args(["simulate", "sensor.toml", "-o", "x.wav"])
        .output()
        .unwrap();
    assert!(!stderr(&out).contains("Some("), "{}", stderr(&out));
    // A weight that leaves nothing to scale (it wrote an all-NaN float WAV).
    let text = std::fs::read_to_string(d.join("scene.toml"))
        .unwrap()
        .replace("sample_rate = 16000", "sample_rate = 16000\nformat = \"float32\"")
        + "[noise]\nsnr_db = 10\n[[noise.fan]]\nposition = [3.0, 3.0, 1.0]\nsignal = \"pink\"\nweight_db = -1e9\n";
    write(d, "weight.toml", text);
    refused(
        d,
        &["simulate", "weight.toml", "-o", "x.wav"],
        "weight_db between -100 and 100 dB",
    );
    // Microphones 10 um apart are not "the same position".
    write(
        d,
        "close.toml",
        "[[mic]]\nposition = [0.0, 0.0, 0.0]\n[[mic]]\nposition = [0.00001, 0.0, 0.0]\n",
    );
    refused(
        d,
        &["geometry", "close.toml"],
        "mics 1 and 2 are 10 um apart, closer than 100 um",
    );
    // A name with a terminal escape sequence is refused, not printed raw.
    write(
        d,
        "escape.toml",
        format!("name = \"a\\u001b[2Jb\"\n{ARRAY}"),
    );
    refused(
        d,
        &["geometry", "escape.toml"],
        "name holds a control character",
    );
    // --frame-ms out of range is an error, as -n is (it was clamped without a word).
    refused(
        d,
        &[
            "analyze",
            "sim.wav",
            "-g",
            "array.toml",
            "--frame-ms",
            "1e300",
        ],
        "a frame of 1e300 ms at 16000 Hz would be 1.6e301 samples; frames are 16 to 65536 samples",
    );
    // Two format chunks: which one describes the data cannot be told.
    let wav = std::fs::read(d.join("sim.wav")).unwrap();
    let fmt_at = wav.windows(4).position(|w| w == b"fmt ").unwrap();
    let fmt_len = u32::from_le_bytes(wav[fmt_at + 4..fmt_at + 8].try_into().unwrap()) as usize;
    let chunk = wav[fmt_at..fmt_at + 8 + fmt_len].to_vec();
    let doubled = [&wav[..fmt_at], &chunk, &wav[fmt_at..]].concat();
    write(d, "two.wav", doubled);
    refused(
        d,
        &["analyze", "two.wav", "-g", "array.toml"],
        "two format chunks",
    );
}

#[test]
fn every_subcommand_refuses_a_closed_standard_output_and_a_file_size_limit_is_an_error() {
    // Issue 31, item 19: ssl geometry, evaluate and completions exited 0 with standard
    // output closed; `ulimit -f` killed a run by SIGXFSZ without a message.
    let dir = tempdir();
    let d = dir.path();
    simulate_and_analyze(d);
    for args in [
        "geometry array.toml",
        "evaluate --truth sim.truth.json r.csv",
        "completions bash",
        "analyze sim.wav -g array.toml",
    ] {
        let out = std::process::Command::new("sh")
            .args([
                "-c",
                &format!("exec {} {args} >&-", env!("CARGO_BIN_EXE_ssl")),
            ])
            .current_dir(d)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("standard output"),
            "{args}: {}",
            stderr(&out)
        );
    }
    // A file size limit of 8 KB (ulimit -f counts 1024-byte blocks) on a long output.
    let out = std::process::Command::new("sh")
        .args([
            "-c",
            &format!(
                "ulimit -f 8 && exec {} analyze sim.wav -g array.toml --no-track -f json -o big.json",
                env!("CARGO_BIN_EXE_ssl")
            ),
        ])
        .current_dir(d)
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cannot write big.json: File too large"),
        "{err}"
    );
    assert!(!d.join("big.json").exists());
    assert!(temporaries(d).is_empty(), "{:?}", temporaries(d));
}
