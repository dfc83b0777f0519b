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

/// The files in `dir` whose names end in `.tmp`.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

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
    for signal in ["INT", "TERM", "HUP"] {
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
            Some(130),
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
