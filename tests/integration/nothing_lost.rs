//! Nothing lost in an archive (issue 48): a batch under options that fail every input,
//! links, FIFOs, renames, look-alike recordings, long names and reruns of another kind
//! never loses a result, never writes outside `--out-dir`, never skips what changed, and
//! always ends. Each test names the point of the issue it covers.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::*;

/// Every file under `d` (stamps included), relative, with its bytes.
fn snapshot(d: &Path) -> Vec<(String, Vec<u8>)> {
    fn go(root: &Path, d: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            let name = p.strip_prefix(root).unwrap().display().to_string();
            if meta.is_dir() {
                go(root, &p, out);
            } else if meta.file_type().is_symlink() {
                out.push((name, b"-> link".to_vec()));
            } else if meta.is_file() {
                out.push((name, std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    go(d, d, &mut out);
    out.sort();
    out
}

fn copy(from: &Path, to: &Path) {
    std::fs::create_dir_all(to.parent().unwrap()).unwrap();
    std::fs::copy(from, to).unwrap();
}

/// An archive of two copies of the example (and the geometry).
fn archive(root: &Path) -> PathBuf {
    let a = root.join("in");
    copy(&testdata("example.wav"), &a.join("a.wav"));
    copy(&testdata("example.wav"), &a.join("d/b.wav"));
    a
}

fn batch(inputs: &[&Path], out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["analyze"];
    args.extend(inputs.iter().map(|p| s(p)));
    let g = testdata("prism.toml");
    args.extend(["-g", s(&g), "--out-dir", s(out)]);
    args.extend(extra);
    run(&args)
}

/// Runs `cmd`, killing it after `limit`: `None` when it had to be killed.
fn within(mut cmd: Command, limit: Duration) -> Option<std::process::Output> {
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while start.elapsed() < limit {
        if child.try_wait().unwrap().is_some() {
            return Some(child.wait_with_output().unwrap());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

#[test]
fn point_1_a_rerun_whose_options_fail_every_input_withdraws_nothing() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    for format in ["csv", "json"] {
        let o = batch(&[&inputs], &out, &["-f", format]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let before = snapshot(&out);
    assert!(before.iter().any(|(n, _)| n == ".ssl/d/b.csv.json"));
    for extra in [
        &["--start", "1000"][..],
        &["--end", "0.01"],
        &["--frame-ms", "2000"],
        &["--clock"],
    ] {
        let o = batch(&[&inputs], &out, &[&["--resume"][..], extra].concat());
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("2 input(s): 0 done, 0 skipped, 2 failed; nothing analysed"),
            "{extra:?}: {}",
            stderr(&o)
        );
        // Every result and stamp as it was (the CSV run writes no summary).
        assert_eq!(snapshot(&out), before, "{extra:?} changed the results");
    }
    // A recording that did change and now fails still loses its result.
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    std::fs::write(inputs.join("a.wav"), &bytes[..3000]).unwrap();
    let o = batch(&[&inputs], &out, &["--resume"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!out.join("a.csv").exists() && !out.join(".ssl/a.csv.json").exists());
    assert!(out.join("d/b.csv").is_file());
}

#[test]
fn point_2_a_recording_named_like_a_summary_keeps_its_result_and_the_summary_its_name() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = root.join("in");
    copy(&testdata("example.wav"), &inputs.join("batch.wav"));
    copy(&testdata("example.wav"), &inputs.join("batch.1-of-2.wav"));
    copy(&testdata("example.wav"), &inputs.join("x.wav"));
    let out = root.join("out");
    for extra in [&["-f", "json"][..], &["-f", "json", "--shard", "1/2"]] {
        let o = batch(&[&inputs], &out, extra);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("the name of the batch's summary"), "{e}");
        let name = if extra.len() == 2 {
            "batch.json"
        } else {
            "batch.1-of-2.json"
        };
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join(name)).unwrap()).unwrap();
        assert!(summary["files"].is_array(), "{name} is not the summary");
        for f in summary["files"].as_array().unwrap() {
            assert_ne!(f["result"].as_str(), Some(s(&out.join(name))));
        }
    }
    // In CSV nothing collides: all three are analysed.
    let o = batch(&[&inputs], &root.join("csv"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(root.join("csv/batch.csv").is_file());
}

#[test]
fn point_3_links_inside_the_results_folder_are_never_followed() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    let outside = root.join("outside");
    std::fs::create_dir_all(out.join(".ssl")).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    let secret = write(&outside, "secret.csv", "keep me");
    let recording = std::fs::read(inputs.join("a.wav")).unwrap();
    // A result that is a link to a recording, a link to a file outside, a folder that
    // is a link outside.
    std::os::unix::fs::symlink(inputs.join("a.wav"), out.join("a.csv")).unwrap();
    std::os::unix::fs::symlink(&outside, out.join("d")).unwrap();
    let o = batch(&[&inputs], &out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("is a symbolic link") && e.contains("never"),
        "{e}"
    );
    assert_eq!(std::fs::read(inputs.join("a.wav")).unwrap(), recording);
    assert_eq!(std::fs::read(&secret).unwrap(), b"keep me");
    assert_eq!(std::fs::read_dir(&outside).unwrap().count(), 1);
    // The stamps' folder as a link outside, and a result linked to a file outside.
    let o2 = root.join("out2");
    std::fs::create_dir_all(&o2).unwrap();
    std::os::unix::fs::symlink(&outside, o2.join(".ssl")).unwrap();
    std::os::unix::fs::symlink(&secret, o2.join("a.csv")).unwrap();
    let o = batch(&[&inputs], &o2, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(&secret).unwrap(), b"keep me");
    assert_eq!(
        std::fs::read_dir(&outside).unwrap().count(),
        1,
        "written outside"
    );
    // Every input fails before its analysis, naming the link.
    assert!(
        stderr(&o).contains(".ssl: is a symbolic link"),
        "{}",
        stderr(&o)
    );
    assert!(!o2.join("d").exists());
}

#[test]
fn point_4_a_failing_recording_keeps_the_result_of_another_with_the_same_name() {
    let dir = tempdir();
    let root = dir.path();
    let d1 = root.join("card1/ZOOM0001.WAV");
    let d2 = root.join("card2/ZOOM0001.WAV");
    copy(&testdata("example.wav"), &d1);
    let (_keep, other, _) = recording(0.6);
    copy(&other, &d2);
    let out = root.join("out");
    let o = batch(&[&d1], &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let first = std::fs::read(out.join("ZOOM0001.csv")).unwrap();
    // Another recording of the same name: refused, the first result kept.
    let o = batch(&[&d2], &out, &["--resume"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("another recording"), "{}", stderr(&o));
    assert_eq!(std::fs::read(out.join("ZOOM0001.csv")).unwrap(), first);
    // The same, failing: nothing withdrawn.
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    std::fs::write(&d2, &bytes[..3000]).unwrap();
    let o = batch(&[&d2], &out, &["--resume"]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(std::fs::read(out.join("ZOOM0001.csv")).unwrap(), first);
    assert!(out.join(".ssl/ZOOM0001.csv.json").is_file());
    // The first card's recording, moved elsewhere: still its own result, skipped.
    let moved = root.join("archive/ZOOM0001.WAV");
    std::fs::create_dir_all(moved.parent().unwrap()).unwrap();
    std::fs::rename(&d1, &moved).unwrap();
    let o = batch(&[&moved], &out, &["--resume"]);
    assert!(stderr(&o).contains("0 done, 1 skipped"), "{}", stderr(&o));
}

/// Sets the modification time of `path` to 1980-01-01, as a recorder without a clock.
fn set_1980(path: &Path) {
    let t = std::time::UNIX_EPOCH + Duration::from_secs(315_532_800);
    std::fs::File::options()
        .write(true)
        .open(path)
        .unwrap()
        .set_modified(t)
        .unwrap();
}

#[test]
fn point_5_resume_redoes_a_recording_of_the_same_name_size_and_time_or_a_new_build() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = root.join("in");
    let a = inputs.join("a.wav");
    copy(&testdata("example.wav"), &a);
    set_1980(&a);
    let out = root.join("out");
    assert!(batch(&[&inputs], &out, &[]).status.success());
    let first = std::fs::read(out.join("a.csv")).unwrap();
    // Another take of the same length at the same time: other samples throughout
    // (here the same ones in the other polarity; the header is untouched).
    let mut bytes = std::fs::read(&a).unwrap();
    for pair in bytes[1024..].chunks_exact_mut(2) {
        let x = i16::from_le_bytes([pair[0], pair[1]]);
        pair.copy_from_slice(&x.saturating_neg().to_le_bytes());
    }
    std::fs::write(&a, &bytes).unwrap();
    set_1980(&a);
    let o = batch(&[&inputs], &out, &["--resume"]);
    assert!(stderr(&o).contains("1 done, 0 skipped"), "{}", stderr(&o));
    assert_ne!(std::fs::read(out.join("a.csv")).unwrap(), first);
    // Another build of the tool (the same version string): redone.
    let exe = root.join("ssl-other-build");
    let mut build = std::fs::read(env!("CARGO_BIN_EXE_ssl")).unwrap();
    build.extend_from_slice(b"another build");
    std::fs::write(&exe, &build).unwrap();
    std::fs::set_permissions(&exe, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let g = testdata("prism.toml");
    let again = |exe: &Path| {
        Command::new(exe)
            .args([
                "analyze",
                s(&inputs),
                "-g",
                s(&g),
                "--out-dir",
                s(&out),
                "--resume",
            ])
            .output()
            .unwrap()
    };
    assert!(stderr(&again(Path::new(env!("CARGO_BIN_EXE_ssl")))).contains("0 done, 1 skipped"));
    assert!(stderr(&again(&exe)).contains("1 done, 0 skipped"));
}

#[test]
fn point_5_a_recording_replaced_by_a_rename_during_the_run_is_redone() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = root.join("in");
    std::fs::create_dir_all(&inputs).unwrap();
    // Long enough to be caught in the middle of its analysis.
    let (_keep, long, _) = recording(40.0);
    let a = inputs.join("a.wav");
    copy(&long, &a);
    let (_keep2, other, _) = recording(0.7);
    let out = root.join("out");
    let g = testdata("prism.toml");
    let child = ssl()
        .args([
            "analyze",
            s(&inputs),
            "-g",
            s(&g),
            "--out-dir",
            s(&out),
            "-j",
            "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The temporary appears once the recording is open and its analysis starts.
    let start = Instant::now();
    while !out.exists() || temporaries(&out).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(60), "no temporary");
        std::thread::sleep(Duration::from_millis(2));
    }
    let staged = inputs.join(".a.wav.new");
    copy(&other, &staged);
    std::fs::rename(&staged, &a).unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // The result is the long recording's; --resume sees another file now, and redoes it.
    let o = batch(&[&inputs], &out, &["--resume"]);
    assert!(stderr(&o).contains("1 done, 0 skipped"), "{}", stderr(&o));
    let o = batch(&[&inputs], &out, &["--resume"]);
    assert!(stderr(&o).contains("0 done, 1 skipped"), "{}", stderr(&o));
}

#[test]
fn point_6_resume_with_another_record_kind_redoes_every_input() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    assert!(batch(&[&inputs], &out, &["-f", "json"]).status.success());
    for kind in ["--events", "--sources"] {
        let o = batch(&[&inputs], &out, &["-f", "json", "--resume", kind]);
        assert!(
            stderr(&o).contains("2 done, 0 skipped"),
            "{kind}: {}",
            stderr(&o)
        );
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("a.json")).unwrap()).unwrap();
        let key = kind.trim_start_matches("--");
        assert!(v.get(key).is_some(), "{kind}: {v}");
        let o = batch(&[&inputs], &out, &["-f", "json", "--resume", kind]);
        assert!(stderr(&o).contains("0 done, 2 skipped"), "{}", stderr(&o));
    }
}

#[test]
fn point_8_a_huge_shard_count_costs_what_a_small_one_does() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    for (n, k) in [
        ("18446744073709551615", "1"),
        ("100000000", "2"),
        ("100000000", "3"),
    ] {
        let out = root.join(format!("out{k}"));
        let shard = format!("{k}/{n}");
        let g = testdata("prism.toml");
        // Under 1 GiB of address space: the 2^64 - 1 shares once aborted or panicked.
        let limited = Command::new("sh")
            .arg("-c")
            .arg("ulimit -v 1048576; exec \"$0\" \"$@\"")
            .arg(env!("CARGO_BIN_EXE_ssl"))
            .args(["analyze", s(&inputs), "-g", s(&g), "--out-dir", s(&out)])
            .args(["--shard", &shard])
            .output()
            .unwrap();
        assert!(limited.status.success(), "{shard}: {}", stderr(&limited));
        let analysed = if k == "3" { 0 } else { 1 };
        assert!(
            stderr(&limited).contains(&format!("{analysed} done")),
            "{shard}: {}",
            stderr(&limited)
        );
    }
}

#[test]
fn point_10_a_fifo_at_a_result_or_in_a_list_never_blocks_the_batch() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let fifo = |p: &Path| {
        assert!(Command::new("mkfifo").arg(p).status().unwrap().success());
    };
    fifo(&out.join("a.csv"));
    let listed = root.join("listed.fifo");
    fifo(&listed);
    let list = write(root, "list.txt", format!("{}\n", listed.display()));
    let g = testdata("prism.toml");
    let mut cmd = ssl();
    cmd.args([
        "analyze",
        s(&inputs),
        "--files-from",
        s(&list),
        "-g",
        s(&g),
        "--out-dir",
        s(&out),
    ]);
    let o = within(cmd, Duration::from_secs(120)).expect("the batch blocked");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("a.csv: is a FIFO"), "{e}");
    assert!(
        e.contains("listed.fifo: is a FIFO, not a recording file"),
        "{e}"
    );
    assert!(e.contains("3 input(s): 1 done"), "{e}");
}

#[test]
fn point_11_a_long_recording_name_gets_its_result_and_resumes() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = root.join("in");
    let long = "r".repeat(249) + ".wav";
    copy(&testdata("example.wav"), &inputs.join(&long));
    copy(&testdata("example.wav"), &inputs.join("z.wav"));
    let out = root.join("out");
    let o = batch(&[&inputs], &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("r".repeat(249) + ".csv").is_file());
    let o = batch(&[&inputs], &out, &["--resume"]);
    assert!(stderr(&o).contains("0 done, 2 skipped"), "{}", stderr(&o));
    // A result name past 255 bytes fails alone; the batch goes on.
    let o = batch(&[&inputs], &root.join("nd"), &["-f", "ndjson"]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("more than the 255"), "{e}");
    assert!(e.contains("2 input(s): 1 done, 0 skipped, 1 failed"), "{e}");
}

#[test]
fn point_12_an_unreadable_subfolder_is_named_and_the_rest_analysed() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let lost = inputs.join("lost+found");
    std::fs::create_dir_all(&lost).unwrap();
    copy(&testdata("example.wav"), &lost.join("hidden.wav"));
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&lost, std::fs::Permissions::from_mode(0o000)).unwrap();
    let out = root.join("out");
    let g = root.join("prism.toml");
    copy(&testdata("prism.toml"), &g);
    let mut cmd;
    // Root reads any folder: the batch runs as nobody, with its own copy of the binary
    // (the checkout may be in a folder nobody cannot enter).
    if is_root() {
        for p in [root, &inputs, &inputs.join("d")] {
            std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o777)).unwrap();
        }
        let exe = root.join("ssl");
        copy(Path::new(env!("CARGO_BIN_EXE_ssl")), &exe);
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        cmd = Command::new("setpriv");
        cmd.args(["--reuid=65534", "--regid=65534", "--clear-groups"]);
        cmd.arg(&exe);
    } else {
        cmd = ssl();
    }
    cmd.args(["analyze", s(&inputs), "-g", s(&g), "--out-dir", s(&out)]);
    let o = within(cmd, Duration::from_secs(120)).unwrap();
    std::fs::set_permissions(&lost, std::fs::Permissions::from_mode(0o755)).unwrap();
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("lost+found: cannot read the folder"), "{e}");
    assert!(e.contains("2 input(s): 2 done"), "{e}");
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Uid:"))
                .and_then(|l| l.split_whitespace().nth(1).map(|u| u == "0"))
        })
        .unwrap_or(false)
}

#[test]
fn point_14_a_list_never_makes_a_folder_outside_the_results_and_names_bad_lines() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let work = root.join("w/x/y");
    std::fs::create_dir_all(work.join("q")).unwrap();
    let list = write(
        root,
        "list.txt",
        format!(
            "q/../../escaped/..\n{}\nbad\0name.wav\n",
            inputs.join("a.wav").display()
        ),
    );
    let out = work.join("out");
    let g = testdata("prism.toml");
    let o = ssl()
        .current_dir(&work)
        .args([
            "analyze",
            "--files-from",
            s(&list),
            "-g",
            s(&g),
            "--out-dir",
            s(&out),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(!e.contains('\0'), "a raw NUL byte in the messages");
    assert!(e.contains("bad\\0name.wav: a NUL byte"), "{e}");
    assert!(e.contains("names a folder"), "{e}");
    assert!(e.contains("3 input(s): 1 done, 0 skipped, 2 failed"), "{e}");
    // Nothing beside the results folder.
    let mut beside: Vec<String> = std::fs::read_dir(&work)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    beside.sort();
    assert_eq!(beside, ["out", "q"]);
    assert!(!root.join("w/escaped").exists() && !root.join("w/x/escaped").exists());
}

#[test]
fn point_15_a_truncated_recording_keeps_its_rows_beside_and_a_resume_counts_only_what_it_did() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    std::fs::write(inputs.join("cut.wav"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = root.join("out");
    let o = batch(&[&inputs], &out, &["-f", "json"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(!out.join("cut.json").exists());
    let partial = out.join("cut.partial.json");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&partial).unwrap()).unwrap();
    assert!(!v["detections"].as_array().unwrap().is_empty());
    // What the recording gives alone, with -o.
    let alone = root.join("alone.json");
    let g = testdata("prism.toml");
    run(&[
        "analyze",
        s(&inputs.join("cut.wav")),
        "-g",
        s(&g),
        "-f",
        "json",
        "-o",
        s(&alone),
    ]);
    let a: serde_json::Value =
        serde_json::from_slice(&std::fs::read(root.join("alone.partial.json")).unwrap()).unwrap();
    assert_eq!(a["detections"], v["detections"]);
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("batch.json")).unwrap()).unwrap();
    let cut = summary["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["input"].as_str().unwrap().ends_with("cut.wav"))
        .unwrap();
    assert_eq!(cut["partial"].as_str(), Some(s(&partial)));
    // A resume that skips the rest says it analysed nothing, with no speed.
    let o = batch(&[&inputs], &out, &["-f", "json", "--resume"]);
    let e = stderr(&o);
    assert!(
        e.contains("0 done, 2 skipped, 1 failed; nothing analysed"),
        "{e}"
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("batch.json")).unwrap()).unwrap();
    assert_eq!(summary["speed"], 0.0);
    assert_eq!(summary["audio_s"], 0.0);
    // Once complete, the partial rows go.
    std::fs::write(inputs.join("cut.wav"), &bytes).unwrap();
    let o = batch(&[&inputs], &out, &["-f", "json", "--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!partial.exists() && out.join("cut.json").is_file());
}

#[test]
fn point_15_a_batch_on_a_terminal_shows_each_input() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    let g = testdata("prism.toml");
    let command = format!(
        "{} analyze {} -g {} --out-dir {} 2>&1",
        env!("CARGO_BIN_EXE_ssl"),
        s(&inputs),
        s(&g),
        s(&out)
    );
    // `script` gives the batch a terminal.
    let o = Command::new("script")
        .args(["-qec", &command, "/dev/null"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("[1/2]") && text.contains("[2/2]"), "{text}");
    assert!(text.contains("of audio -> a.csv"), "{text}");
}

#[test]
fn killed_batches_leave_temporaries_that_the_next_batch_on_the_host_sweeps() {
    let dir = tempdir();
    let root = dir.path();
    let inputs = archive(root);
    let out = root.join("out");
    assert!(batch(&[&inputs], &out, &[]).status.success());
    // A batch killed with SIGKILL in the middle of writing.
    let (_keep, long, _) = recording(30.0);
    copy(&long, &inputs.join("d/long.wav"));
    let g = testdata("prism.toml");
    let mut child = ssl()
        .args([
            "analyze",
            s(&inputs),
            "-g",
            s(&g),
            "--out-dir",
            s(&out),
            "-j",
            "1",
        ])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while temporaries(&out.join("d")).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(60), "no temporary");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(temporaries(&out.join("d")).len(), 1);
    // A temporary of another host is left alone.
    write(&out, ".ssl-otherhost-1-0.tmp", "");
    let o = batch(&[&inputs.join("a.wav")], &out, &["--resume"]);
    assert!(
        stderr(&o).contains("removed 1 temporary file"),
        "{}",
        stderr(&o)
    );
    assert!(temporaries(&out.join("d")).is_empty());
    assert_eq!(temporaries(&out), [".ssl-otherhost-1-0.tmp"]);
}

/// `ssl evaluate ARGS --json`, parsed.
fn evaluate_json(args: &[&str]) -> serde_json::Value {
    let o = run(&[&["evaluate"][..], args, &["--json"]].concat());
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn point_7_and_13_results_named_batch_and_results_beside_their_truths_are_scored() {
    let dir = tempdir();
    let root = dir.path();
    // The archive holds the recordings and their truths; the results go beside them.
    let archive = root.join("archive");
    for name in ["batch2", "take"] {
        copy(
            &testdata("example.wav"),
            &archive.join(format!("{name}.wav")),
        );
        copy(
            &testdata("example.truth.json"),
            &archive.join(format!("{name}.truth.json")),
        );
    }
    let o = batch(&[&archive], &archive, &["-f", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = evaluate_json(&["--truth", s(&archive), s(&archive)]);
    let scored: Vec<&str> = v["recordings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["recording"].as_str().unwrap())
        .collect();
    assert_eq!(scored.len(), 2, "{v}");
    assert!(scored.iter().any(|r| r.contains("batch2")), "{scored:?}");
    assert!(v["failed"].as_array().unwrap().is_empty(), "{v}");
    // The summary (batch.json) is not read as a result.
    let svg = root.join("plot.svg");
    let o = run(&["plot", s(&archive), "-o", s(&svg)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let drawn = std::fs::read_to_string(&svg).unwrap();
    assert!(
        drawn.contains("batch2"),
        "the result of batch2.wav is not drawn"
    );
}

#[test]
fn point_9_a_truth_of_a_hundred_thousand_intervals_is_scored_and_its_errors_are_one_short_line() {
    let dir = tempdir();
    let root = dir.path();
    let result = root.join("r.csv");
    let g = testdata("prism.toml");
    let o = run(&[
        "analyze",
        s(&testdata("example.wav")),
        "-g",
        s(&g),
        "-o",
        s(&result),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut truth = String::from("source,start_s,end_s,azimuth_deg,elevation_deg\n");
    for i in 0..100_000 {
        let t = i as f64 * 0.02;
        truth += &format!("s{},{t:.3},{:.3},30,10\n", i % 3, t + 0.01);
    }
    let truth_path = write(root, "t.csv", &truth);
    // n log n: seconds. Rows x intervals took 49 s here once; the bound is generous.
    let started = Instant::now();
    let o = run(&["evaluate", "--truth", s(&truth_path), s(&result)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        "plot",
        s(&result),
        "--truth",
        s(&truth_path),
        "-o",
        s(&root.join("p.svg")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        started.elapsed() < Duration::from_secs(30),
        "{:?}",
        started.elapsed()
    );
    // A truth with a mistake on every line: the first few named, the rest counted.
    let bad = truth.replace(",30,10", ",30,91");
    let bad = write(root, "bad.csv", &bad);
    let o = run(&["evaluate", "--truth", s(&bad), s(&result)]);
    assert_ne!(o.status.code(), Some(0));
    let e = stderr(&o);
    assert!(e.len() < 2000, "{} bytes", e.len());
    assert!(
        e.contains("elevation_deg must be within -90..90, got 91"),
        "{e}"
    );
    assert!(
        e.contains("lines 2-100001 (100000 lines): elevation_deg"),
        "{e}"
    );
    // Another value on every line: each message once, the first few named.
    let mut varied = String::from("source,start_s,end_s,azimuth_deg,elevation_deg\n");
    for i in 0..100_000 {
        varied += &format!("s,{i},{},30,{}\n", i + 1, 91 + i);
    }
    let varied = write(root, "varied.csv", &varied);
    let started = Instant::now();
    let o = run(&["evaluate", "--truth", s(&varied), s(&result)]);
    assert!(started.elapsed() < Duration::from_secs(10));
    let e = stderr(&o);
    assert!(e.len() < 2000, "{} bytes", e.len());
    assert!(e.contains("and 99990 more problems"), "{e}");
    // Angles out of range in the JSON form too.
    let far = write(
        root,
        "far.json",
        r#"{"sources": [{"azimuth_deg": 1e308, "elevation_deg": 0, "intervals": [[0, 1]]}]}"#,
    );
    let o = run(&["evaluate", "--truth", s(&far), s(&result)]);
    assert!(
        stderr(&o).contains("azimuth_deg must be within"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn concatenated_results_with_byte_order_marks_and_a_result_given_twice_are_read_once() {
    let dir = tempdir();
    let root = dir.path();
    let g = testdata("prism.toml");
    let o = run(&["analyze", s(&testdata("example.wav")), "-g", s(&g)]);
    assert!(o.status.success());
    let mut marked = b"\xEF\xBB\xBF".to_vec();
    marked.extend_from_slice(&o.stdout);
    let once = write(root, "once.csv", &marked);
    let twice = write(root, "twice.csv", [marked.clone(), marked].concat());
    let truth = testdata("example.truth.json");
    let one = evaluate_json(&["--truth", s(&truth), s(&once)]);
    let o = run(&["evaluate", "--truth", s(&truth), s(&twice), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("appear twice"), "{}", stderr(&o));
    let two: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(one["detections"], two["detections"]);
    assert_eq!(one["mean_error_deg"], two["mean_error_deg"]);
}

#[test]
fn standard_input_has_one_name_in_a_json_result() {
    let g = testdata("prism.toml");
    let o = run_with_stdin(
        &["analyze", "-", "-g", s(&g), "-f", "json"],
        std::fs::read(testdata("example.wav")).unwrap(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["files"][0]["file"], "<stdin>");
    assert_eq!(v["detections"][0]["file"], "<stdin>");
}
