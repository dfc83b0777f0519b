//! Nothing lost: outputs never replace inputs, a run that analysed nothing replaces
//! nothing, files keep the user's umask and their mode, interrupted runs leave no
//! temporary files, write errors name the destination, `-` is standard output.

use crate::support;

use ssl::sim::signals::Signal;
use ssl::sim::Encoding;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::{Command, Stdio};
use support::*;

const SCENE: &str = "sample_rate = 16000\nduration = 1.0\n[array]\ngeometry = \"prism.toml\"\nposition = [0.0, 0.0, 0.0]\n[[source]]\nazimuth_deg = 30.0\ndistance = 2.0\nsignal = \"white\"\n";

#[test]
fn an_output_that_is_an_input_is_refused() {
    let (dir, wav, geo) = recording(0.5);
    let before = std::fs::read(&wav).unwrap();
    // The recording, the same file through another spelling, a hard link, and the geometry.
    let other_spelling = dir.path().join(".").join("rec.wav");
    let link = dir.path().join("hard.wav");
    std::fs::hard_link(&wav, &link).unwrap();
    for output in [&wav, &other_spelling, &link, &geo] {
        let out = run(&["analyze", s(&wav), "-g", s(&geo), "-o", s(output)]);
        assert_eq!(out.status.code(), Some(1), "{}", s(output));
        assert!(stderr(&out).contains("is the input"), "{}", stderr(&out));
    }
    assert_eq!(
        std::fs::read(&wav).unwrap(),
        before,
        "the recording is intact"
    );
    assert!(std::fs::read_to_string(&geo).unwrap().contains("[[mic]]"));
    // ssl simulate: the scene as the WAV, the scene or the WAV as the truth.
    let scene = write(dir.path(), "scene.toml", SCENE);
    for args in [
        vec!["simulate", s(&scene), "-o", s(&scene)],
        vec!["simulate", s(&scene), "-o", "out.wav", "--truth", s(&scene)],
        vec!["simulate", s(&scene), "-o", s(&wav), "--truth", s(&link)],
    ] {
        let out = ssl().current_dir(dir.path()).args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(
            stderr(&out).contains("is the input"),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    assert!(std::fs::read_to_string(&scene)
        .unwrap()
        .starts_with("sample_rate"));
    assert_eq!(std::fs::read(&wav).unwrap(), before);
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn a_run_that_analysed_nothing_replaces_nothing() {
    let (dir, _, geo) = recording(0.5);
    let out_path = write(dir.path(), "results.csv", "good results\n");
    let missing = dir.path().join("missing.wav");
    let out = run(&["analyze", s(&missing), "-g", s(&geo), "-o", s(&out_path)]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        std::fs::read_to_string(&out_path).unwrap(),
        "good results\n"
    );
    // Standard output gets nothing either, in every format.
    for format in ["csv", "json", "ndjson"] {
        let out = run(&["analyze", s(&missing), "-g", s(&geo), "-f", format]);
        assert_eq!(out.status.code(), Some(1));
        assert!(out.stdout.is_empty(), "{format}: {:?}", out.stdout);
    }
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn outputs_keep_the_umask_and_a_replaced_file_keeps_its_mode() {
    let (dir, wav, geo) = recording(0.5);
    let analyze = |output: &Path, umask: &str| {
        let cmd = format!(
            "umask {umask} && exec {} analyze {} -g {} -o {}",
            env!("CARGO_BIN_EXE_ssl"),
            s(&wav),
            s(&geo),
            s(output)
        );
        Command::new("sh").args(["-c", &cmd]).output().unwrap()
    };
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let fresh = dir.path().join("fresh.csv");
    assert!(analyze(&fresh, "022").status.success());
    assert_eq!(mode(&fresh), 0o644, "a new file: 0666 less the umask");
    let shared = dir.path().join("shared.csv");
    assert!(analyze(&shared, "002").status.success());
    assert_eq!(mode(&shared), 0o664);
    // A replaced file keeps its mode, whatever the umask.
    std::fs::set_permissions(&fresh, std::fs::Permissions::from_mode(0o640)).unwrap();
    assert!(analyze(&fresh, "077").status.success());
    assert_eq!(mode(&fresh), 0o640);
    // A read-only file is not replaced.
    std::fs::set_permissions(&fresh, std::fs::Permissions::from_mode(0o444)).unwrap();
    let before = std::fs::read(&fresh).unwrap();
    let out = analyze(&fresh, "022");
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("read-only"), "{}", stderr(&out));
    assert_eq!(std::fs::read(&fresh).unwrap(), before);
    // ssl simulate's outputs too.
    write(dir.path(), "scene.toml", SCENE);
    let cmd = format!(
        "umask 022 && exec {} simulate scene.toml -o sim.wav",
        env!("CARGO_BIN_EXE_ssl")
    );
    let out = Command::new("sh")
        .args(["-c", &cmd])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(mode(&dir.path().join("sim.wav")), 0o644);
    assert_eq!(mode(&dir.path().join("sim.truth.json")), 0o644);
}

#[test]
fn an_interrupted_run_leaves_no_temporary_file_and_the_old_output() {
    let dir = tempdir();
    // 40 s of audio: long enough to be interrupted while writing.
    let sc = scene(
        prism(),
        48000,
        &[(30.0, 10.0, Signal::WhiteNoise)],
        40.0,
        0.005,
        1,
    );
    let wav = render_wav(dir.path(), "long.wav", &sc, Encoding::Int16);
    let geo = write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    let out_path = write(dir.path(), "out.csv", "old\n");
    // Every signal whose default action ends the process (issue 31, item 19: SIGUSR1
    // and SIGALRM left the temporary file), with the shell's status 128 + its number.
    for (signal, number) in [
        ("INT", 2),
        ("TERM", 15),
        ("HUP", 1),
        ("QUIT", 3),
        ("USR1", 10),
        ("USR2", 12),
        ("ALRM", 14),
    ] {
        let child = ssl()
            .args([
                "analyze",
                s(&wav),
                "-g",
                s(&geo),
                "-o",
                s(&out_path),
                "-j",
                "1",
            ])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Wait until the temporary file exists, then interrupt.
        let start = std::time::Instant::now();
        while temporaries(dir.path()).is_empty() && start.elapsed().as_secs() < 10 {
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        assert!(
            !temporaries(dir.path()).is_empty(),
            "the run writes a temporary file"
        );
        let killed = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(killed.success());
        let out = child.wait_with_output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(128 + number),
            "SIG{signal}: {}",
            stderr(&out)
        );
        assert!(
            temporaries(dir.path()).is_empty(),
            "SIG{signal} left a temporary file"
        );
        assert_eq!(std::fs::read_to_string(&out_path).unwrap(), "old\n");
    }
}

#[test]
fn simulate_writes_the_wav_and_its_truth_both_or_neither() {
    let dir = tempdir();
    write(dir.path(), "prism.toml", geometry_toml(&prism(), ""));
    write(dir.path(), "scene.toml", SCENE);
    write(dir.path(), "sim.wav", "old wav");
    // The truth cannot be written (a full device): the WAV stays as it was.
    let out = ssl()
        .current_dir(dir.path())
        .args([
            "simulate",
            "scene.toml",
            "-o",
            "sim.wav",
            "--truth",
            "/dev/full",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("cannot write /dev/full: No space left on device"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("sim.wav")).unwrap(),
        "old wav"
    );
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn write_errors_name_the_destination_and_a_closed_stdout_is_an_error() {
    let (_dir, wav, geo) = recording(0.5);
    let out = run(&["analyze", s(&wav), "-g", s(&geo), "-o", "/dev/full"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("cannot write /dev/full: No space left on device"),
        "{err}"
    );
    assert!(!err.contains(".tmp"), "{err}");
    // Standard output closed (`>&-`): an error, not a silent success.
    let cmd = format!(
        "exec {} analyze {} -g {} >&-",
        env!("CARGO_BIN_EXE_ssl"),
        s(&wav),
        s(&geo)
    );
    let out = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("standard output"), "{}", stderr(&out));
}

#[test]
fn dash_is_standard_output_and_standard_input() {
    let (dir, wav, geo) = recording(0.5);
    let out = ssl()
        .current_dir(dir.path())
        .args(["analyze", s(&wav), "-g", s(&geo), "-o", "-"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("time_s,"));
    assert!(!dir.path().join("-").exists(), "no file named -");
    // ssl evaluate reads the result from standard input.
    write(dir.path(), "scene.toml", SCENE);
    let sim = ssl()
        .current_dir(dir.path())
        .args(["simulate", "scene.toml", "-o", "sim.wav"])
        .output()
        .unwrap();
    assert!(sim.status.success(), "{}", stderr(&sim));
    let analysed = ssl()
        .current_dir(dir.path())
        .args(["analyze", "sim.wav", "-g", s(&geo)])
        .output()
        .unwrap();
    let mut child = ssl()
        .current_dir(dir.path())
        .args(["evaluate", "--truth", "sim.truth.json", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    child
        .stdin
        .take()
        .unwrap()
        .write_all(&analysed.stdout)
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("overall:"));
}

#[test]
fn the_same_file_twice_draws_a_warning() {
    let (dir, wav, geo) = recording(0.5);
    let again = dir.path().join(".").join("rec.wav");
    let out = run(&["analyze", s(&wav), s(&again), "-g", s(&geo)]);
    assert!(out.status.success());
    assert!(
        stderr(&out).contains("the same file as"),
        "{}",
        stderr(&out)
    );
}

/// `sh -c script` in `dir`, with `$SSL` the binary.
fn shell(dir: &Path, script: &str) -> std::process::Output {
    Command::new("sh")
        .args(["-c", script])
        .env("SSL", env!("CARGO_BIN_EXE_ssl"))
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn standard_input_is_protected_as_the_file_behind_it() {
    // Issue 31, item 1: `-` (and /dev/stdin, /dev/fd/0, /proc/self/fd/0) read from a file
    // that is also the output replaced the recording with CSV.
    let (dir, wav, _geo) = recording(0.5);
    let d = dir.path();
    let before = std::fs::read(&wav).unwrap();
    for input in ["-", "/dev/stdin", "/dev/fd/0", "/proc/self/fd/0"] {
        let out = shell(
            d,
            &format!("$SSL analyze {input} -g prism.toml -o rec.wav < rec.wav"),
        );
        assert_eq!(out.status.code(), Some(1), "{input}: {}", stderr(&out));
        assert!(stderr(&out).contains("the output is"), "{}", stderr(&out));
        assert_eq!(std::fs::read(&wav).unwrap(), before, "{input}");
    }
    // Standard output appended to the recording is refused too.
    let out = shell(d, "$SSL analyze rec.wav -g prism.toml >> rec.wav");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("standard output: the output is the input rec.wav"),
        "{}",
        stderr(&out)
    );
    assert_eq!(std::fs::read(&wav).unwrap(), before);
    // ssl plot: the result and the truth, each read through standard input.
    let made = shell(
        d,
        "$SSL analyze rec.wav -g prism.toml -f json -o r.json && printf '%s' '{\"sources\":[]}' > t.json",
    );
    assert!(made.status.success(), "{}", stderr(&made));
    let result = std::fs::read(d.join("r.json")).unwrap();
    for script in [
        "$SSL plot - -o r.json < r.json",
        "$SSL plot r.json --truth - -o t.json < t.json",
    ] {
        let out = shell(d, script);
        assert_eq!(out.status.code(), Some(1), "{script}: {}", stderr(&out));
        assert!(stderr(&out).contains("the output is"), "{}", stderr(&out));
    }
    assert_eq!(std::fs::read(d.join("r.json")).unwrap(), result);
    assert_eq!(
        std::fs::read_to_string(d.join("t.json")).unwrap(),
        "{\"sources\":[]}"
    );
    // A pipe or a terminal is no file: reading standard input and writing
    // /dev/stdout stays allowed.
    let out = shell(
        d,
        "cat rec.wav | $SSL analyze - -g prism.toml -o /dev/stdout",
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("time_s,"));
}

#[test]
fn simulate_protects_every_file_the_scene_reads() {
    // Issue 31, item 2: the scene's geometry and a `file` source were overwritten.
    let dir = tempdir();
    let d = dir.path();
    let geo = write(d, "prism.toml", geometry_toml(&prism(), ""));
    let geo_text = std::fs::read(&geo).unwrap();
    let source = render_wav(
        d,
        "voice.wav",
        &scene(
            vec![nalgebra::Vector3::zeros()],
            16000,
            &[(0.0, 0.0, Signal::WhiteNoise)],
            0.3,
            0.0,
            1,
        ),
        Encoding::Int16,
    );
    let source_bytes = std::fs::read(&source).unwrap();
    write(
        d,
        "scene.toml",
        format!("{SCENE}[[source]]\nazimuth_deg = 90.0\ndistance = 2.0\nsignal = \"file\"\nfile = \"voice.wav\"\n"),
    );
    for args in [
        vec![
            "simulate",
            "scene.toml",
            "-o",
            "x.wav",
            "--truth",
            "prism.toml",
        ],
        vec!["simulate", "scene.toml", "-o", "prism.toml"],
        vec!["simulate", "scene.toml", "-o", "voice.wav"],
        vec![
            "simulate",
            "scene.toml",
            "-o",
            "x.wav",
            "--truth",
            "./voice.wav",
        ],
    ] {
        let out = ssl().current_dir(d).args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("is the input"),
            "{args:?}: {}",
            stderr(&out)
        );
    }
    assert_eq!(std::fs::read(&geo).unwrap(), geo_text);
    assert_eq!(std::fs::read(&source).unwrap(), source_bytes);
    assert!(!d.join("x.wav").exists());
    assert!(temporaries(d).is_empty());
}

#[test]
fn a_descriptor_named_as_output_is_written_through_it() {
    // Issue 31, item 3: `-o /dev/stdout >> log` replaced the log, and failed on a pipe.
    let (dir, _wav, _geo) = recording(0.5);
    let d = dir.path();
    let rows = shell(d, "$SSL analyze rec.wav -g prism.toml").stdout;
    assert!(!rows.is_empty());
    for output in ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"] {
        std::fs::write(d.join("log.txt"), "earlier line\n").unwrap();
        let out = shell(
            d,
            &format!("$SSL analyze rec.wav -g prism.toml -o {output} >> log.txt"),
        );
        assert!(out.status.success(), "{output}: {}", stderr(&out));
        let log = std::fs::read(d.join("log.txt")).unwrap();
        assert_eq!(log, [&b"earlier line\n"[..], &rows].concat(), "{output}");
        assert!(temporaries(d).is_empty());
        // Through a pipe.
        let out = shell(
            d,
            &format!("$SSL analyze rec.wav -g prism.toml -o {output} | cat"),
        );
        assert!(out.status.success(), "{output}: {}", stderr(&out));
        assert_eq!(out.stdout, rows, "{output}");
    }
    // Standard error, and another open descriptor.
    let out = shell(
        d,
        "$SSL analyze rec.wav -g prism.toml -o /dev/stderr 2>> err.txt",
    );
    assert!(out.status.success());
    assert_eq!(std::fs::read(d.join("err.txt")).unwrap(), rows);
    std::fs::write(d.join("fd7.txt"), "kept\n").unwrap();
    let out = shell(
        d,
        "$SSL analyze rec.wav -g prism.toml -o /dev/fd/7 7>> fd7.txt",
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(
        std::fs::read(d.join("fd7.txt")).unwrap(),
        [&b"kept\n"[..], &rows].concat()
    );
    // A descriptor that is not open is an error naming it.
    let out = shell(d, "$SSL analyze rec.wav -g prism.toml -o /dev/fd/9");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("cannot write /dev/fd/9"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn simulate_replaces_both_or_neither_even_when_signalled_between_the_renames() {
    // Issue 31, item 4: a SIGINT between the two renames deleted the old WAV. A test
    // seam pauses between them; the signal must wait for the commit to end.
    let dir = tempdir();
    let d = dir.path();
    write(d, "prism.toml", geometry_toml(&prism(), ""));
    write(d, "scene.toml", SCENE);
    write(
        d,
        "new.toml",
        SCENE.replace("duration = 1.0", "duration = 1.0\nseed = 7"),
    );
    assert!(ssl()
        .current_dir(d)
        .args(["simulate", "scene.toml", "-o", "sim.wav"])
        .status()
        .unwrap()
        .success());
    assert!(ssl()
        .current_dir(d)
        .args([
            "simulate",
            "new.toml",
            "-o",
            "expected.wav",
            "--truth",
            "expected.json"
        ])
        .status()
        .unwrap()
        .success());
    let inode =
        |p: &str| std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(d.join(p)).unwrap());
    let old_inode = inode("sim.wav");
    let child = ssl()
        .current_dir(d)
        .args(["simulate", "new.toml", "-o", "sim.wav"])
        .env("SSL_TEST_COMMIT_PAUSE_MS", "1500")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The first rename has happened when sim.wav is another file.
    let start = std::time::Instant::now();
    while inode("sim.wav") == old_inode && start.elapsed().as_secs() < 20 {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert_ne!(
        inode("sim.wav"),
        old_inode,
        "the WAV was renamed into place"
    );
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", stderr(&out));
    // Both are the new ones: the signal waited for the truth's rename.
    assert_eq!(
        std::fs::read(d.join("sim.wav")).unwrap(),
        std::fs::read(d.join("expected.wav")).unwrap()
    );
    let truth = |p: &str| -> serde_json::Value {
        let mut v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(p)).unwrap()).unwrap();
        v.as_object_mut().unwrap().remove("recording");
        v
    };
    assert_eq!(truth("sim.truth.json"), truth("expected.json"));
    assert!(temporaries(d).is_empty());
}

#[test]
fn a_failed_run_keeps_the_old_output_and_sets_its_results_aside() {
    // Issue 31, item 5: a run that exits 1 replaced an existing -o.
    let (dir, wav, _geo) = recording(1.0);
    let d = dir.path();
    let bytes = std::fs::read(&wav).unwrap();
    std::fs::write(d.join("cut.wav"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    write(d, "keep.csv", "precious\n");
    let out = shell(d, "$SSL analyze rec.wav cut.wav -g prism.toml -o keep.csv");
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.contains("cut.wav: truncated WAV"), "{err}");
    assert!(
        err.contains("keep.csv: left as it was, since a file failed; the results of what was read are in keep.partial.csv"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("keep.csv")).unwrap(),
        "precious\n"
    );
    let partial = std::fs::read_to_string(d.join("keep.partial.csv")).unwrap();
    assert!(
        partial.contains(",rec.wav,") && partial.contains(",cut.wav,"),
        "{partial}"
    );
    // A new output is not made either.
    let out = shell(d, "$SSL analyze cut.wav -g prism.toml -o new.json -f json");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("new.json: not written"),
        "{}",
        stderr(&out)
    );
    assert!(!d.join("new.json").exists());
    assert!(d.join("new.partial.json").exists());
    assert!(temporaries(d).is_empty());
}

#[test]
fn an_output_in_a_missing_directory_names_the_directory() {
    // Issue 31, item 19.
    let (dir, _wav, _geo) = recording(0.5);
    let d = dir.path();
    let out = shell(d, "$SSL analyze rec.wav -g prism.toml -o missing/dir/x.csv");
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out)
            .contains("cannot write missing/dir/x.csv: directory missing/dir: no such file"),
        "{}",
        stderr(&out)
    );
    let out = shell(d, "$SSL analyze rec.wav -g prism.toml -o rec.wav/x.csv");
    assert!(
        stderr(&out).contains("rec.wav is not a directory"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_files_entry_counts_its_rows_and_its_frames_with_a_detection() {
    // Two sources at once: frames with a detection are fewer than rows.
    let dir = tempdir();
    let mics = prism();
    let mut sc = scene(
        mics.clone(),
        48000,
        &[
            (40.0, 0.0, Signal::WhiteNoise),
            (-100.0, 10.0, Signal::WhiteNoise),
        ],
        1.2,
        0.002,
        4,
    );
    // Both on over the same interval.
    let first = (sc.sources[0].start_s, sc.sources[0].end_s);
    sc.sources[1].start_s = first.0;
    sc.sources[1].end_s = first.1;
    let wav = render_wav(dir.path(), "two.wav", &sc, Encoding::Int16);
    let geometry = write(dir.path(), "prism.toml", geometry_toml(&mics, ""));
    let out = run(&["analyze", s(&wav), "-g", s(&geometry), "--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = doc["detections"].as_array().unwrap().len() as u64;
    let entry = &doc["files"][0];
    assert_eq!(entry["rows"].as_u64(), Some(rows));
    let frames = entry["detections"].as_u64().unwrap();
    assert!(
        frames < rows,
        "{frames} frames with a detection, {rows} rows"
    );
}
