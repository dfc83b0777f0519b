//! Many machines on existing engines (docs/guide.md, "Many machines"): `--shard K/N`,
//! the Slurm array script (contrib/slurm/ssl-array.sh) run as Slurm runs it and on a
//! one-node Slurm, and GNU parallel's recipes (local slots, and ssh to this machine
//! through an sshd of the test's own on 127.0.0.1). Each ends with the results of a
//! one-machine run, byte for byte.
//!
//! Slurm, parallel and sshd are system tools: a test whose tool is missing says so and
//! passes, unless `SSL_REQUIRE_TOOLS=1` (set by CI, which installs them), when it fails.
//! A daemon that will not start where the test runs (a container without a resolvable
//! host name, say) is said and skipped either way: the issue asks for the engines "if
//! one can be started"; the script's own test above needs none.

use crate::batch::{contents, copy};
use crate::support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use support::*;

/// Asserts two result sets equal: the same names, each with the same bytes (naming
/// the files that differ rather than printing them).
fn same(got: &[(String, Vec<u8>)], want: &[(String, Vec<u8>)]) {
    let names = |r: &[(String, Vec<u8>)]| r.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(got), names(want));
    let differ: Vec<&String> = got
        .iter()
        .zip(want)
        .filter(|(a, b)| a.1 != b.1)
        .map(|(a, _)| &a.0)
        .collect();
    assert!(differ.is_empty(), "these results differ: {differ:?}");
}

/// Whether `tool` can run; when it cannot, says so, and fails if CI requires it.
fn have(tool: &str, why: &str) -> bool {
    let found = Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        unavailable(&format!("{tool} is not installed ({why})"));
    }
    found
}

fn unavailable(what: &str) {
    if std::env::var_os("SSL_REQUIRE_TOOLS").is_some_and(|v| v == "1") {
        panic!("{what}, and SSL_REQUIRE_TOOLS=1");
    }
    eprintln!("skipped: {what}");
}

/// An archive in nested folders: copies of the example and two other recordings, and
/// a broken file; with the geometry at `root/prism.toml`.
fn archive(root: &Path) -> PathBuf {
    let archive = root.join("archive");
    for i in 0..5 {
        copy(
            &testdata("example.wav"),
            &archive.join(format!("site{}/day{}/r{i}.wav", i % 2, i % 3)),
        );
    }
    for (i, seconds) in [(5, 0.7), (6, 1.3)] {
        let (_keep, wav, _) = recording(seconds);
        copy(&wav, &archive.join(format!("site1/r{i}.wav")));
    }
    let bytes = std::fs::read(testdata("example.wav")).unwrap();
    write(&archive.join("site0"), "broken.wav", &bytes[..4000]);
    copy(&testdata("prism.toml"), &root.join("prism.toml"));
    archive
}

/// `ssl analyze archive -g prism.toml --out-dir OUT -f json` in `root`, with `extra`.
fn whole(root: &Path, out: &str, extra: &[&str]) -> std::process::Output {
    ssl()
        .current_dir(root)
        .args(["analyze", "archive", "-g", "prism.toml", "--out-dir", out])
        .args(["-f", "json", "-j", "1"])
        .args(extra)
        .output()
        .unwrap()
}

/// Builds the archive in `root` and analyses it on one machine into `root/whole`:
/// the results every other run must equal (the broken input failing, exit status 1).
fn reference(root: &Path) -> Vec<(String, Vec<u8>)> {
    archive(root);
    let o = whole(root, "whole", &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let reference = contents(&root.join("whole"));
    assert_eq!(reference.len(), 7);
    reference
}

#[test]
fn shards_write_the_whole_batch_bytes_and_their_own_summaries() {
    let dir = tempdir();
    let root = dir.path();
    let reference = reference(root);
    // Every input falls to exactly one share, and the shares hold about equal audio:
    // their sizes differ by at most the largest input (inputs dealt largest first, each
    // to the share with the fewest bytes).
    let mut seen = Vec::new();
    let mut bytes = Vec::new();
    for k in 1..=3 {
        let o = whole(root, "sharded", &["--shard", &format!("{k}/3")]);
        let e = stderr(&o);
        assert!(e.contains(&format!("(share {k}/3 of 8)")), "{e}");
        let summary: serde_json::Value = serde_json::from_slice(
            &std::fs::read(root.join(format!("sharded/batch.{k}-of-3.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(summary["shard"], format!("{k}/3"));
        let mut share = 0;
        for f in summary["files"].as_array().unwrap() {
            let input = f["input"].as_str().unwrap().to_string();
            share += std::fs::metadata(root.join(&input)).unwrap().len();
            seen.push(input);
        }
        bytes.push(share);
    }
    seen.sort();
    let mut all: Vec<String> = reference
        .iter()
        .map(|(n, _)| format!("archive/{}", n.replace(".json", ".wav")))
        .collect();
    all.push("archive/site0/broken.wav".into());
    all.sort();
    assert_eq!(seen, all);
    let largest = std::fs::metadata(testdata("example.wav")).unwrap().len();
    assert!(
        bytes.iter().max().unwrap() - bytes.iter().min().unwrap() <= largest,
        "{bytes:?}"
    );
    same(&contents(&root.join("sharded")), &reference);
    assert!(!root.join("sharded/batch.json").exists());
    // A share that cannot be, and a share without a directory, are refused.
    for (args, says) in [
        (&["--shard", "0/3"][..], "`0/3` is not K/N"),
        (&["--shard", "4/3"], "`4/3` is not K/N"),
        (&["--shard", "two"], "`two` is not K/N"),
    ] {
        let o = whole(root, "bad", args);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(says), "{}", stderr(&o));
    }
    let o = run(&["analyze", "x.wav", "-g", "y.toml", "--shard", "1/2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--out-dir"), "{}", stderr(&o));
}

/// A manifest of the archive's recordings, relative to its folder: those of the
/// `reference` results, and the broken one.
fn manifest(reference: &[(String, Vec<u8>)]) -> String {
    let mut list: Vec<String> = reference
        .iter()
        .map(|(n, _)| n.replace(".json", ".wav"))
        .collect();
    list.push("site0/broken.wav".into());
    list.join("\n") + "\n"
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("contrib/slurm/ssl-array.sh")
}

/// The Slurm script as Slurm runs task `id` of the array `min..=max`.
fn slurm_task(root: &Path, id: u32, min: u32, max: u32, args: &[&str]) -> Command {
    let mut c = Command::new("bash");
    c.current_dir(root)
        .arg(script())
        .args(args)
        .env("SSL", env!("CARGO_BIN_EXE_ssl"))
        .env("SLURM_ARRAY_JOB_ID", "77")
        .env("SLURM_ARRAY_TASK_ID", id.to_string())
        .env("SLURM_ARRAY_TASK_MIN", min.to_string())
        .env("SLURM_ARRAY_TASK_MAX", max.to_string())
        .env("SLURM_ARRAY_TASK_COUNT", (max - min + 1).to_string())
        .env("SLURM_ARRAY_TASK_STEP", "1")
        .env("SLURM_CPUS_PER_TASK", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

#[test]
fn the_slurm_script_run_as_slurm_runs_its_tasks_gives_the_one_machine_results() {
    let dir = tempdir();
    let root = dir.path();
    let reference = reference(root);
    // Four tasks at once (IDs 10-13), on a directory and then on a manifest.
    let children: Vec<_> = (10..=13)
        .map(|id| {
            slurm_task(
                root,
                id,
                10,
                13,
                &["archive", "dir", "prism.toml", "-f", "json"],
            )
            .spawn()
            .unwrap()
        })
        .collect();
    let codes: Vec<Option<i32>> = children
        .into_iter()
        .map(|c| c.wait_with_output().unwrap().status.code())
        .collect();
    // One task holds the broken file and says so; the others succeed.
    assert_eq!(
        codes.iter().filter(|c| **c == Some(1)).count(),
        1,
        "{codes:?}"
    );
    assert_eq!(
        codes.iter().filter(|c| **c == Some(0)).count(),
        3,
        "{codes:?}"
    );
    same(&contents(&root.join("dir")), &reference);
    for k in 1..=4 {
        assert!(root.join(format!("dir/batch.{k}-of-4.json")).is_file());
    }
    // A manifest of relative paths, from the archive's folder.
    write(&root.join("archive"), "list.txt", manifest(&reference));
    for id in 1..=2 {
        let o = slurm_task(
            &root.join("archive"),
            id,
            1,
            2,
            &["list.txt", "../listed", "../prism.toml", "-f", "json"],
        )
        .output()
        .unwrap();
        assert!(o.status.code().is_some_and(|c| c <= 1), "{}", stderr(&o));
    }
    let listed = contents(&root.join("listed"));
    assert_eq!(
        listed.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        reference.iter().map(|(n, _)| n).collect::<Vec<_>>()
    );
    // A second submission finds everything done.
    let o = slurm_task(
        root,
        10,
        10,
        13,
        &["archive", "dir", "prism.toml", "-f", "json"],
    )
    .output()
    .unwrap();
    assert!(stderr(&o).contains(": 0 done, 2 skipped"), "{}", stderr(&o));
    // IDs that are not one range, and a job that is not an array, are refused.
    let o = slurm_task(root, 3, 1, 5, &["archive", "gaps", "prism.toml"])
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("one contiguous range"),
        "{}",
        stderr(&o)
    );
    let o = slurm_task(root, 1, 1, 1, &["archive", "none", "prism.toml"])
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("not an array task"), "{}", stderr(&o));
}

/// A free TCP port on 127.0.0.1 (free when asked; the daemon binds it soon after).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Daemons started by a test, stopped when it ends: their pid files.
struct Daemons(Vec<PathBuf>);

impl Drop for Daemons {
    fn drop(&mut self) {
        for pid in &self.0 {
            if let Ok(p) = std::fs::read_to_string(pid) {
                let _ = Command::new("kill").arg(p.trim()).status();
            }
        }
    }
}

fn short_hostname() -> String {
    let o = Command::new("hostname").arg("-s").output().unwrap();
    String::from_utf8_lossy(&o.stdout).trim().to_string()
}

#[test]
fn a_one_node_slurm_runs_the_array_to_the_one_machine_results() {
    if !(have("slurmctld", "slurm-wlm")
        && have("slurmd", "slurm-wlm")
        && have("sbatch", "slurm-wlm"))
    {
        return;
    }
    let dir = tempdir();
    let root = dir.path();
    let reference = reference(root);
    let slurm = root.join("slurm");
    for d in ["state", "spool"] {
        std::fs::create_dir_all(slurm.join(d)).unwrap();
    }
    let host = short_hostname();
    let user = String::from_utf8_lossy(&Command::new("id").arg("-un").output().unwrap().stdout)
        .trim()
        .to_string();
    let p = |name: &str| slurm.join(name).display().to_string();
    let conf = format!(
        "ClusterName=ssltest\nSlurmctldHost={host}\nAuthType=auth/none\nCredType=cred/none\n\
         SlurmUser={user}\nSlurmdUser={user}\nStateSaveLocation={}\nSlurmdSpoolDir={}\n\
         SlurmctldPidFile={}\nSlurmdPidFile={}\nSlurmctldPort={}\nSlurmdPort={}\n\
         ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSchedulerType=sched/builtin\n\
         SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\nReturnToService=2\n\
         MpiDefault=none\nJobCompType=jobcomp/none\nAccountingStorageType=accounting_storage/none\n\
         SlurmctldLogFile={}\nSlurmdLogFile={}\n\
         NodeName={host} CPUs=2 State=UNKNOWN\n\
         PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP\n",
        p("state"),
        p("spool"),
        p("ctld.pid"),
        p("d.pid"),
        free_port(),
        free_port(),
        p("ctld.log"),
        p("d.log"),
    );
    let conf_path = write(&slurm, "slurm.conf", conf);
    let _daemons = Daemons(vec![slurm.join("ctld.pid"), slurm.join("d.pid")]);
    let started = Command::new("slurmctld")
        .args(["-c"])
        .env("SLURM_CONF", &conf_path)
        .status()
        .is_ok_and(|s| s.success())
        && Command::new("slurmd")
            .env("SLURM_CONF", &conf_path)
            .status()
            .is_ok_and(|s| s.success());
    let log = || {
        ["ctld.log", "d.log"]
            .iter()
            .map(|l| std::fs::read_to_string(slurm.join(l)).unwrap_or_default())
            .collect::<Vec<_>>()
            .join("\n")
    };
    if !started {
        eprintln!("skipped: a one-node Slurm did not start:\n{}", log());
        return;
    }
    // The node registers within seconds.
    let mut idle = false;
    for _ in 0..100 {
        let o = Command::new("sinfo")
            .args(["-h", "-o", "%t"])
            .env("SLURM_CONF", &conf_path)
            .output()
            .unwrap();
        if String::from_utf8_lossy(&o.stdout).trim() == "idle" {
            idle = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    if !idle {
        eprintln!("skipped: the one-node Slurm's node is not idle:\n{}", log());
        return;
    }
    let o = Command::new("sbatch")
        .current_dir(root)
        .args(["--wait", "--array=1-3", "--cpus-per-task=1", "-o"])
        .arg(slurm.join("task-%a.log"))
        .arg(script())
        .args(["archive", "cluster", "prism.toml", "-f", "json"])
        .env("SLURM_CONF", &conf_path)
        .env("SSL", env!("CARGO_BIN_EXE_ssl"))
        .output()
        .unwrap();
    // One task held the broken file: sbatch --wait reports the array's failure.
    let tasks: String = (1..=3)
        .map(|a| std::fs::read_to_string(slurm.join(format!("task-{a}.log"))).unwrap_or_default())
        .collect();
    assert!(
        tasks.contains("(share 1/3 of 8)") && tasks.contains("(share 3/3 of 8)"),
        "{}\n{tasks}\n{}",
        stderr(&o),
        log()
    );
    assert!(tasks.contains("broken.wav"), "{tasks}");
    same(&contents(&root.join("cluster")), &reference);
}

/// An sshd of the test's own on 127.0.0.1, accepting a fresh key: the ssh command that
/// reaches it, or `None` when it cannot start.
fn local_sshd(dir: &Path, daemons: &mut Daemons) -> Option<String> {
    let sshd = ["/usr/sbin/sshd", "/usr/bin/sshd"]
        .into_iter()
        .find(|p| Path::new(p).is_file())?;
    for key in ["host", "user"] {
        let ok = Command::new("ssh-keygen")
            .args(["-q", "-t", "ed25519", "-N", "", "-f"])
            .arg(dir.join(key))
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            return None;
        }
    }
    std::fs::copy(dir.join("user.pub"), dir.join("authorized_keys")).ok()?;
    let port = free_port();
    let d = |n: &str| dir.join(n).display().to_string();
    let config = format!(
        "ListenAddress 127.0.0.1\nPort {port}\nHostKey {}\nAuthorizedKeysFile {}\nPidFile {}\n\
         StrictModes no\nUsePAM no\nPasswordAuthentication no\nKbdInteractiveAuthentication no\n\
         PermitRootLogin prohibit-password\n",
        d("host"),
        d("authorized_keys"),
        d("sshd.pid"),
    );
    write(dir, "sshd_config", config);
    // Privilege separation wants its empty directory when sshd runs as root.
    let _ = std::fs::create_dir_all("/run/sshd");
    daemons.0.push(dir.join("sshd.pid"));
    let ok = Command::new(sshd)
        .args(["-f", &d("sshd_config"), "-E", &d("sshd.log")])
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        return None;
    }
    let ssh = format!(
        "ssh -p {port} -i {} -o StrictHostKeyChecking=no -o UserKnownHostsFile=/dev/null \
         -o BatchMode=yes -o LogLevel=ERROR",
        d("user")
    );
    // Wait until it answers.
    for _ in 0..50 {
        let ok = Command::new("sh")
            .args(["-c", &format!("{ssh} 127.0.0.1 true")])
            .stdin(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Some(ssh);
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    eprintln!(
        "{}",
        std::fs::read_to_string(dir.join("sshd.log")).unwrap_or_default()
    );
    None
}

/// GNU parallel's shared-folder recipe: N shares over its slots (`--sshlogin` given).
fn parallel_shares(root: &Path, out: &str, logins: &[&str]) -> std::process::Output {
    let shares: Vec<String> = (1..=4).map(|k| k.to_string()).collect();
    Command::new("parallel")
        .current_dir(root)
        .arg("--will-cite")
        .args(logins)
        .args([
            env!("CARGO_BIN_EXE_ssl"),
            "analyze",
            "archive",
            "-g",
            "prism.toml",
        ])
        .args([
            "--out-dir",
            out,
            "--resume",
            "-f",
            "json",
            "-j",
            "1",
            "--shard",
            "{}/4",
        ])
        .arg(":::")
        .args(&shares)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

#[test]
fn gnu_parallel_on_local_slots_and_over_ssh_gives_the_one_machine_results() {
    if !have("parallel", "GNU parallel") {
        return;
    }
    let dir = tempdir();
    let root = dir.path();
    let reference = reference(root);
    // Local slots, sharing the folder.
    let o = parallel_shares(root, "slots", &["-j", "2"]);
    // parallel's status counts the jobs that failed: the one holding the broken file.
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    same(&contents(&root.join("slots")), &reference);

    // Over ssh to this machine, sharing the folder.
    let mut daemons = Daemons(Vec::new());
    let keys = root.join("keys");
    std::fs::create_dir_all(&keys).unwrap();
    let Some(ssh) = have("ssh", "openssh-client")
        .then(|| local_sshd(&keys, &mut daemons))
        .flatten()
    else {
        eprintln!("skipped: an sshd on 127.0.0.1 did not start (openssh-server)");
        return;
    };
    let o = parallel_shares(
        root,
        "ssh",
        &["--ssh", &ssh, "-S", "2/127.0.0.1", "--workdir", "."],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    same(&contents(&root.join("ssh")), &reference);

    // Over ssh without a shared folder: each recording and the geometry sent, the
    // result brought back. The one-machine run reads the same list from the archive.
    if !have("rsync", "parallel sends files with it") {
        return;
    }
    let archive = root.join("archive");
    copy(&root.join("prism.toml"), &archive.join("prism.toml"));
    write(root, "list.txt", manifest(&reference));
    let o = ssl()
        .current_dir(&archive)
        .args(["analyze", "--files-from", "../list.txt", "-g", "prism.toml"])
        .args(["--out-dir", "../listed", "-f", "ndjson", "-j", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let listed = contents(&root.join("listed"));
    assert_eq!(listed.len(), 7);
    let o = Command::new("parallel")
        .current_dir(&archive)
        .args([
            "--will-cite",
            "--ssh",
            &ssh,
            "-S",
            "2/127.0.0.1",
            "--workdir",
            "...",
        ])
        .args(["--transferfile", "prism.toml", "--transferfile", "{}"])
        .args(["--return", "sent/{.}.ndjson", "--cleanup"])
        .arg(format!(
            "echo {{}} | {} analyze --files-from - -g prism.toml -f ndjson -j 1 --out-dir sent",
            env!("CARGO_BIN_EXE_ssl")
        ))
        .args(["::::", "../list.txt"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    same(&contents(&archive.join("sent")), &listed);
}
