//! Many files (docs/interface.md, "Many files"): directories searched recursively,
//! `--glob`, `--files-from`, and `--out-dir` with one result per input at its relative
//! path, each the bytes a run on that input alone writes; failures listed, never
//! stopping the batch; a summary, and DIR/batch.json with `--format json`.

use crate::support;

use std::path::Path;
use support::*;

/// The files under `d` but its stamps (`.ssl/`), relative to `base`.
fn results(d: &Path, base: &Path, out: &mut Vec<String>) {
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.file_name() == Some(std::ffi::OsStr::new(".ssl")) {
            continue;
        }
        if p.is_dir() {
            results(&p, base, out)
        } else {
            out.push(p.strip_prefix(base).unwrap().display().to_string());
        }
    }
}

pub(crate) fn copy(from: &Path, to: &Path) {
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(from, to).unwrap();
}

#[test]
fn a_directory_gives_one_result_per_recording_at_its_relative_path() {
    let dir = tempdir();
    let root = dir.path();
    let example = testdata("example.wav");
    let archive = root.join("archive");
    copy(&example, &archive.join("day1/a/x1.wav"));
    copy(&example, &archive.join("day1/x2.WAV"));
    let (_keep, other, _) = recording(0.5);
    copy(&other, &archive.join("day2/x3.wav"));
    let bytes = std::fs::read(&example).unwrap();
    write(&archive.join("day2"), "broken.wav", &bytes[..3000]);
    write(&archive.join("day2"), "notes.txt", "not audio");
    let geometry = testdata("prism.toml");
    let out = root.join("out");
    let o = run(&[
        "analyze",
        s(&archive),
        "-g",
        s(&geometry),
        "--out-dir",
        s(&out),
        "--format",
        "json",
    ]);
    // One input failed: the status says so, the others have their results.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("4 input(s): 3 done, 0 skipped, 1 failed"), "{e}");
    assert!(
        e.contains("failed: ") && e.contains("broken.wav: truncated WAV"),
        "{e}"
    );
    let mut written: Vec<String> = Vec::new();
    results(&out, &out, &mut written);
    written.sort();
    assert_eq!(
        written,
        [
            "batch.json",
            "day1/a/x1.json",
            "day1/x2.json",
            "day2/x3.json"
        ]
    );
    // Each result is what a run on that input alone writes.
    for (input, result) in [
        ("day1/a/x1.wav", "day1/a/x1.json"),
        ("day2/x3.wav", "day2/x3.json"),
    ] {
        let alone = root.join("alone.json");
        let input = archive.join(input);
        let o = run(&[
            "analyze",
            s(&input),
            "-g",
            s(&geometry),
            "--format",
            "json",
            "-o",
            s(&alone),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read(out.join(result)).unwrap(),
            std::fs::read(&alone).unwrap(),
            "{result}"
        );
    }
    let batch: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("batch.json")).unwrap()).unwrap();
    assert_eq!(batch["done"], 3);
    assert_eq!(batch["failed"], 1);
    assert!(batch["audio_s"].as_f64().unwrap() > 4.4);
    let files = batch["files"].as_array().unwrap();
    assert_eq!(files.len(), 4);
    assert!(files
        .iter()
        .any(|f| f["result"].is_null() && f["error"].as_str().unwrap().contains("truncated")));
    // --glob chooses; a name two inputs would share is refused before anything runs.
    let only = root.join("only");
    let o = run(&[
        "analyze",
        s(&archive),
        "-g",
        s(&geometry),
        "--out-dir",
        s(&only),
        "--glob",
        "day1/**",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(only.join("day1/a/x1.csv").is_file() && only.join("day1/x2.csv").is_file());
    assert!(!only.join("day2").exists());
    copy(&example, &archive.join("day1/x2.flac"));
    let clash = root.join("clash");
    let o = run(&[
        "analyze",
        s(&archive),
        "-g",
        s(&geometry),
        "--out-dir",
        s(&clash),
        "--glob",
        "*.wav",
        "--glob",
        "*.flac",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("would both write"), "{}", stderr(&o));
    assert!(!clash.join("day1").exists());
}

#[test]
fn files_from_a_list_keep_the_lists_relative_paths() {
    let dir = tempdir();
    let root = dir.path();
    copy(&testdata("example.wav"), &root.join("site/mic/a.wav"));
    copy(&testdata("example.wav"), &root.join("b.wav"));
    let geometry = testdata("prism.toml");
    let o = ssl()
        .current_dir(root)
        .args([
            "analyze",
            "--files-from",
            "-",
            "-g",
            s(&geometry),
            "--out-dir",
            "res",
            "-f",
            "ndjson",
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .and_then(|mut c| {
            use std::io::Write;
            c.stdin
                .take()
                .unwrap()
                .write_all(b"site/mic/a.wav\n\nb.wav\n")?;
            c.wait_with_output()
        })
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(root.join("res/site/mic/a.ndjson").is_file());
    assert!(root.join("res/b.ndjson").is_file());
    assert!(
        stderr(&o).contains("2 input(s): 2 done, 0 skipped, 0 failed"),
        "{}",
        stderr(&o)
    );
}

/// Every result under `dir` with its bytes: not the summaries (`batch.json`,
/// `batch.K-of-N.json`), not the stamps, and not the temporaries a killed run leaves
/// (`.ssl-*.tmp`, never a result's name).
pub(crate) fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut names = Vec::new();
    results(dir, dir, &mut names);
    names.sort();
    names
        .into_iter()
        .filter(|n| !(n.starts_with("batch.") && n.ends_with(".json") && !n.contains('/')))
        .filter(|n| {
            let name = Path::new(n).file_name().unwrap().to_string_lossy();
            !(name.starts_with(".ssl-") && name.ends_with(".tmp"))
        })
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap();
            (n, bytes)
        })
        .collect()
}

#[test]
fn a_batch_killed_anywhere_and_resumed_ends_with_the_uninterrupted_results() {
    use rand::{Rng, SeedableRng};
    let dir = tempdir();
    let root = dir.path();
    let archive = root.join("archive");
    for i in 0..12 {
        copy(
            &testdata("example.wav"),
            &archive.join(format!("d{}/r{i:02}.wav", i % 3)),
        );
    }
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    write(&archive.join("d0"), "broken.wav", &bytes[..5000]);
    let geometry = testdata("prism.toml");
    let batch = |out: &Path, extra: &[&str]| {
        let mut c = ssl();
        c.args([
            "analyze",
            s(&archive),
            "-g",
            s(&geometry),
            "--out-dir",
            s(out),
            "-j",
            "1",
        ])
        .args(extra)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
        c
    };
    let whole = root.join("whole");
    let o = batch(&whole, &[]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let reference = contents(&whole);
    assert_eq!(reference.len(), 12);
    // Killed at random moments, then resumed to the end.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let resumed = root.join("resumed");
    for _ in 0..5 {
        let mut child = batch(&resumed, &["--resume"]).spawn().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(rng.random_range(5..400)));
        let _ = child.kill();
        let _ = child.wait();
    }
    let o = batch(&resumed, &["--resume"]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(contents(&resumed), reference);
    // Resuming a finished batch redoes only the input that failed.
    let o = batch(&resumed, &["--resume"]).output().unwrap();
    let e = stderr(&o);
    assert!(
        e.contains("13 input(s): 0 done, 12 skipped, 1 failed"),
        "{e}"
    );
    // Another parameter: everything is redone.
    let o = batch(&resumed, &["--resume", "--alpha", "0.5"])
        .output()
        .unwrap();
    assert!(stderr(&o).contains("12 done, 0 skipped"), "{}", stderr(&o));
    // A rewritten input: that one again (the others now match --alpha 0.5's stamps).
    let again = archive.join("d1/r01.wav");
    std::fs::write(&again, &bytes).unwrap();
    let o = batch(&resumed, &["--resume", "--alpha", "0.5"])
        .output()
        .unwrap();
    assert!(stderr(&o).contains("1 done, 11 skipped"), "{}", stderr(&o));
    // Two batches at once on one directory: neither corrupts a result.
    let shared = root.join("shared");
    let (mut a, mut b) = (
        batch(&shared, &[]).spawn().unwrap(),
        batch(&shared, &[]).spawn().unwrap(),
    );
    // Each fails only for the broken input: a rename race costs neither a result.
    let (a, b) = (a.wait().unwrap(), b.wait().unwrap());
    assert_eq!((a.code(), b.code()), (Some(1), Some(1)));
    assert_eq!(contents(&shared), reference);
}

#[test]
fn an_input_that_now_fails_loses_the_result_of_its_older_version() {
    let dir = tempdir();
    let root = dir.path();
    let archive = root.join("archive");
    copy(&testdata("example.wav"), &archive.join("a.wav"));
    copy(&testdata("example.wav"), &archive.join("b.wav"));
    let geometry = testdata("prism.toml");
    let out = root.join("out");
    let batch = || {
        run(&[
            "analyze",
            s(&archive),
            "-g",
            s(&geometry),
            "--out-dir",
            s(&out),
            "--resume",
        ])
    };
    assert!(batch().status.success());
    assert!(out.join("a.csv").is_file() && out.join(".ssl/a.csv.json").is_file());
    // a.wav is damaged: its old result and stamp go; b's stay.
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    std::fs::write(archive.join("a.wav"), &bytes[..3000]).unwrap();
    let o = batch();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!out.join("a.csv").exists() && !out.join(".ssl/a.csv.json").exists());
    assert!(out.join("b.csv").is_file());
    assert!(
        stderr(&o).contains("0 done, 1 skipped, 1 failed"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn one_input_per_thread_writes_the_bytes_of_one_thread() {
    let dir = tempdir();
    let root = dir.path();
    let archive = root.join("archive");
    for i in 0..7 {
        copy(
            &testdata("example.wav"),
            &archive.join(format!("d{}/r{i}.wav", i % 2)),
        );
    }
    let (_keep, other, _) = recording(0.8);
    copy(&other, &archive.join("d1/other.wav"));
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    write(&archive.join("d0"), "broken.wav", &bytes[..5000]);
    let geometry = testdata("prism.toml");
    let mut outputs = Vec::new();
    for threads in ["1", "3"] {
        let out = root.join(format!("j{threads}"));
        let o = run(&[
            "analyze",
            s(&archive),
            "-g",
            s(&geometry),
            "--out-dir",
            s(&out),
            "-f",
            "json",
            "-j",
            threads,
        ]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("9 input(s): 8 done, 0 skipped, 1 failed"),
            "{}",
            stderr(&o)
        );
        // The summary lists the inputs in their order whatever finished first.
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("batch.json")).unwrap()).unwrap();
        let listed: Vec<&str> = summary["files"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["input"].as_str().unwrap())
            .collect();
        let mut sorted = listed.clone();
        sorted.sort();
        assert_eq!(listed, sorted);
        outputs.push(contents(&out));
    }
    assert_eq!(outputs[0].len(), 8);
    assert!(outputs[0] == outputs[1], "-j 3 wrote other bytes than -j 1");
}
