//! Shared by the benchmark examples: running the `ssl` binary while watching its memory.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// The first argument, a length of audio in seconds, or `default`.
pub fn seconds_arg(default: f64) -> anyhow::Result<f64> {
    Ok(std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(default))
}

/// The cores the benchmarks run "all cores" on.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `target/release/ssl`, which the benchmarks time (build it first).
pub fn release_binary() -> anyhow::Result<PathBuf> {
    let exe = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/release/ssl");
    anyhow::ensure!(
        exe.exists(),
        "build the binary first: cargo build --release"
    );
    Ok(exe)
}

/// Runs `exe args`, polling its peak resident memory (VmHWM) from /proc every 5 ms.
/// Returns the wall time in seconds and the peak in MB; fails if the command fails.
pub fn run_measured(exe: &Path, args: &[&str]) -> anyhow::Result<(f64, f64)> {
    let start = Instant::now();
    let mut child = Command::new(exe).args(args).spawn()?;
    let mut peak_kb = 0u64;
    let status = loop {
        if let Ok(s) = std::fs::read_to_string(format!("/proc/{}/status", child.id())) {
            if let Some(v) = s.lines().find(|l| l.starts_with("VmHWM:")) {
                let kb = v.split_whitespace().nth(1).and_then(|x| x.parse().ok());
                peak_kb = peak_kb.max(kb.unwrap_or(0));
            }
        }
        if let Some(status) = child.try_wait()? {
            break status;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    anyhow::ensure!(
        status.success(),
        "{} {} failed",
        exe.display(),
        args.join(" ")
    );
    Ok((start.elapsed().as_secs_f64(), peak_kb as f64 / 1024.0))
}

/// A geometry file's text for these microphone positions (metres).
pub fn geometry_toml(positions: &[[f64; 3]]) -> String {
    positions
        .iter()
        .map(|p| format!("[[mic]]\nposition = [{}, {}, {}]\n", p[0], p[1], p[2]))
        .collect()
}
